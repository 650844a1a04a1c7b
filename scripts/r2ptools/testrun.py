"""`make test`: every test stage, one summary at the end.

Stages run in order and each is counted from its runner's own closing lines; a failing stage
does not stop the others, so one run shows everything that is wrong. The run fails if any stage
fails, or if no test ran at all.

    scripts/run-tests [--only STAGE,...] [--firmware-dir D] [--pytest-path P] [--qemu-images I ...]

The path options point a stage at other code; tests/test_run_tests.py uses them to prove that a
failing Rust, QEMU or pytest test fails the run.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from . import ROOT, results
from .results import Counts


@dataclass
class Stage:
    name: str
    what: str
    cmd: list[str]
    cwd: Path
    parse: Callable[[str], Counts]
    env: dict[str, str] = field(default_factory=dict)


@dataclass
class Outcome:
    stage: Stage
    rc: int
    counts: Counts
    seconds: float

    @property
    def ok(self) -> bool:
        return self.rc == 0 and self.counts.failed == 0


def no_counts(_: str) -> Counts:
    return Counts()


def stages(args: argparse.Namespace) -> list[Stage]:
    py = str(ROOT / ".venv" / "bin" / "python")
    scripts = str(ROOT / "scripts")
    firmware = args.firmware_dir.resolve()
    return [
        # Property tests draw from a fixed seed so a run is repeatable; explore other inputs with
        # PROPTEST_RNG_SEED=<n> cargo test.
        Stage("rust", "host unit, property and doc tests (cargo test)",
              ["cargo", "test", "--workspace", "--locked", "--color", "never"], firmware, results.libtest,
              {"PROPTEST_RNG_SEED": os.environ.get("PROPTEST_RNG_SEED", "20261122")}),
        Stage("lint", "rustfmt and clippy in every Rust workspace, warnings denied",
              [str(ROOT / "scripts" / "lint")], ROOT, no_counts),
        Stage("qemu", "core suites on an emulated Cortex-M3",
              [py, "-m", "r2ptools.qemu", *args.qemu_images], ROOT, results.libtest,
              {"PYTHONPATH": scripts}),
        Stage("fuzz", "fuzz targets, bounded runs with a fixed seed (arbitrary input never panics)",
              [py, "-m", "r2ptools.fuzz"], ROOT, results.libtest, {"PYTHONPATH": scripts}),
        Stage("pytest", "scripts, checks and end-to-end tests",
              [py, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider", str(args.pytest_path)], ROOT,
              results.pytest, {"PYTHONPATH": scripts}),
    ]


def run(stage: Stage) -> Outcome:
    print(f"\n=== {stage.name}: {stage.what}\n$ {' '.join(stage.cmd)}", flush=True)
    t0 = time.monotonic()
    env = {**os.environ, **stage.env}
    # Stream the output as it comes (a long stage shows progress) and keep it for counting.
    p = subprocess.Popen(stage.cmd, cwd=stage.cwd, env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True, errors="replace")
    out = []
    assert p.stdout
    for line in p.stdout:
        sys.stdout.write(line)
        out.append(line)
    rc = p.wait()
    return Outcome(stage, rc, stage.parse("".join(out)), time.monotonic() - t0)


def summary(outcomes: list[Outcome]) -> tuple[str, bool]:
    total = Counts()
    lines = ["", "=== summary", f"{'stage':<8} {'result':<7} {'passed':>7} {'failed':>7} {'skipped':>8} {'time':>8}"]
    for o in outcomes:
        total += o.counts
        result = "ok" if o.ok else "FAILED"
        note = "" if o.ok or o.counts.failed else f"  (exit status {o.rc})"
        lines.append(f"{o.stage.name:<8} {result:<7} {o.counts.passed:>7} {o.counts.failed:>7} "
                     f"{o.counts.skipped:>8} {o.seconds:>7.1f}s{note}")
    ok = all(o.ok for o in outcomes)
    if total.total == 0:
        ok = False
        lines.append("run-tests: no test ran: a stage found nothing to run, which counts as a failure")
    failed = total.failed + sum(1 for o in outcomes if not o.ok and o.counts.failed == 0)
    # The plain closing line CI reads: 'N passed, N failed[, N skipped]'.
    lines.append(f"{total.passed} passed, {failed} failed, {total.skipped} skipped")
    return "\n".join(lines), ok


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="run-tests", description="Run every test stage with one summary.")
    ap.add_argument("--only", help="comma-separated stages to run (default: all)")
    ap.add_argument("--firmware-dir", type=Path, default=ROOT / "firmware",
                    help="cargo workspace for the rust and lint stages")
    ap.add_argument("--pytest-path", type=Path, default=ROOT / "tests", help="what pytest runs")
    ap.add_argument("--qemu-images", nargs="*", default=[], help="QEMU images to run (default: all)")
    args = ap.parse_args(argv)
    all_stages = stages(args)
    chosen = all_stages
    if args.only:
        names = args.only.split(",")
        unknown = set(names) - {s.name for s in all_stages}
        if unknown:
            print(f"run-tests: unknown stage {', '.join(sorted(unknown))}; stages are: "
                  f"{', '.join(s.name for s in all_stages)}", file=sys.stderr)
            return 2
        chosen = [s for s in all_stages if s.name in names]
    outcomes = [run(s) for s in chosen]
    text, ok = summary(outcomes)
    print(text)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
