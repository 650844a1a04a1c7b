"""Mutation testing of the firmware core: how many injected bugs the crates' own tests catch.

cargo-mutants (installed by scripts/setup) copies the firmware workspace, applies one mutation at
a time (a function returning a default, an operator swapped, a condition negated) and runs the
mutated crate's tests. A mutant is *caught* if a test fails, *missed* if every test passes,
*timeout* if the tests hang, *unviable* if it does not build. The goal (docs/mutants.md) is
≥ 90 % of the viable mutants (caught + missed + timeout) detected in each crate; a timeout is
detected (the suite does not pass: a hang, usually a wait that never ends), as in PIT and
Stryker, and is shown in its own column. Mutants proved equivalent are excluded by name in firmware/.cargo/mutants.toml,
each with its reason there and in docs/mutants.md.

    scripts/mutants [CRATE ...] [--file GLOB] [--exclude GLOB] [--re REGEX] [--shard K/N] [--goal PCT]

`--shard K/N` runs every N-th mutant (round robin over the crate's list, so every file is
sampled): a quicker estimate of a crate's ratio, stated as a sample in the table.

Output per crate goes to .cache/mutants/CRATE (cargo-mutants' mutants.out: outcomes.json,
missed.txt, logs); the closing table is Markdown, ready for docs/mutants.md.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time

from . import ROOT

CARGO_MUTANTS = ROOT / ".tools" / "cargo-mutants" / "bin" / "cargo-mutants"
CRATES = ["r2p-management", "r2p-middleware", "rtcan", "r2p-node"]
# Crates mutated only when named, on a part (`--file`, `--re`): the gateway's Zenoh client and
# its application, whose whole runs are longer than their new lines need (docs/mutants.md).
NAMED_ONLY = ["r2p-zenoh", "r2p-app-gateway"]
# Packages whose tests exercise a crate beyond its own, run on its mutants too: the node's
# slot policy is tested on the bit-accurate virtual bus (r2p-vbus's node_slot_policy.rs: when
# frames start and end), which the node's own loopback test bus cannot show; rtcan's exact frame
# length (wire_bits: CRC-15 and stuffing) is checked against the virtual bus's own bit-level
# encoder (r2p-vbus's bxcan_timestamps.rs), an independent implementation.
TESTED_BY = {"r2p-node": ["r2p-vbus"], "rtcan": ["r2p-vbus"]}
CACHE = ROOT / ".cache" / "mutants"
GOAL_PCT = 90.0


def scratch_dir():
    """The temporary directory cargo-mutants copies the workspace into.

    The rtcan tests include the shared vectors as `../../../../tests/vectors/...` from their
    source file, i.e. `<copy>/../tests`: the copies are made in a directory beside a link to the
    repository's tests/ (and its modules.toml) so that the path resolves in them as it does in
    the checkout.
    """
    scratch = CACHE / "scratch"
    scratch.mkdir(parents=True, exist_ok=True)
    # tests/ for the vectors; modules.toml for the emulator's build script (r2p-world), which
    # crates tested through r2p-loadbench or the emulator build.
    for name in ("tests", "modules.toml"):
        link = scratch / name
        if not link.is_symlink():
            link.symlink_to(ROOT / name)
    return scratch


def run_crate(crate: str, extra: list[str]) -> tuple[dict, float]:
    out = CACHE / crate
    shutil.rmtree(out / "mutants.out", ignore_errors=True)
    out.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "TMPDIR": str(scratch_dir()),
           # One target dir per crate for all its mutants: dependencies build once, not once per
           # copy, and two crates can run side by side (one per core) without waiting on
           # each other's build lock.
           "CARGO_TARGET_DIR": str(CACHE / "target" / crate)}
    tests = [a for pkg in [crate, *TESTED_BY.get(crate, [])] for a in ("--test-package", pkg)]
    cmd = [str(CARGO_MUTANTS), "mutants", "--dir", str(ROOT / "firmware"), "-p", crate, *tests,
           "--jobs", "1", "--no-shuffle", "--output", str(out), *extra]
    t0 = time.monotonic()
    p = subprocess.run(cmd, cwd=ROOT / "firmware", env=env)
    seconds = time.monotonic() - t0
    outcomes = out / "mutants.out" / "outcomes.json"
    if not outcomes.exists():
        raise SystemExit(f"mutants: cargo-mutants wrote no {outcomes} for {crate} (exit {p.returncode})")
    return json.loads(outcomes.read_text()), seconds


def counts(report: dict) -> dict[str, int]:
    c = {k: int(report.get(k, 0)) for k in ("caught", "missed", "timeout", "unviable")}
    c["viable"] = c["caught"] + c["missed"] + c["timeout"]
    return c


def survivors(report: dict) -> list[str]:
    out = []
    for o in report.get("outcomes", []):
        if o.get("summary") == "MissedMutant" and isinstance(o.get("scenario"), dict):
            m = o["scenario"].get("Mutant", {})
            span = m.get("span", {}).get("start", {})
            name = m.get("name") or f"{m.get('file')}:{span.get('line')}: {m.get('replacement')}"
            out.append(name)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="mutants", description=__doc__.splitlines()[0])
    ap.add_argument("crates", nargs="*", help=f"crates (default: {' '.join(CRATES)})")
    ap.add_argument("--file", action="append", default=[], help="only mutate files matching this glob")
    ap.add_argument("--exclude", action="append", default=[],
                    help="skip files matching this glob (e.g. one measured whole before)")
    ap.add_argument("--re", action="append", default=[], help="only mutants whose name matches")
    ap.add_argument("--shard", help="K/N: only mutants i with i %% N == K (a sample)")
    ap.add_argument("--goal", type=float, default=GOAL_PCT, help="caught/viable %% each crate must reach")
    args = ap.parse_args(argv)
    if not CARGO_MUTANTS.exists():
        print(f"mutants: {CARGO_MUTANTS.relative_to(ROOT)} is missing: run scripts/setup", file=sys.stderr)
        return 2
    unknown = [c for c in args.crates if c not in CRATES + NAMED_ONLY]
    if unknown:
        print(f"mutants: not a core crate: {', '.join(unknown)}; crates are: {', '.join(CRATES)} "
              f"(and, when named: {', '.join(NAMED_ONLY)})", file=sys.stderr)
        return 2
    extra = [a for f in args.file for a in ("--file", f)] + [a for r in args.re for a in ("--re", r)]
    extra += [a for f in args.exclude for a in ("--exclude", f)]
    if args.shard:
        extra += ["--shard", args.shard, "--sharding", "round-robin"]
    rows, below = [], []
    for crate in args.crates or CRATES:
        report, seconds = run_crate(crate, extra)
        c = counts(report)
        pct = 100.0 * (c["caught"] + c["timeout"]) / c["viable"] if c["viable"] else 100.0
        name = f"{crate} (sample {args.shard})" if args.shard else crate
        rows.append((name, c, pct, seconds, survivors(report)))
        if pct < args.goal:
            below.append(crate)
    print("\n| crate | caught | timeout | missed | unviable | detected / viable | run time |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for crate, c, pct, seconds, _ in rows:
        print(f"| {crate} | {c['caught']} | {c['timeout']} | {c['missed']} | {c['unviable']} "
              f"| {pct:.1f} % | {seconds / 60:.1f} min |")
    for crate, _, _, _, left in rows:
        if left:
            print(f"\n{crate}: {len(left)} missed")
            for s in left:
                print(f"- {s}")
    if below:
        print(f"\nmutants: below the {args.goal:.0f} % goal: {', '.join(below)} "
              f"(the survivors are listed above; .cache/mutants/CRATE/mutants.out has the diffs)")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
