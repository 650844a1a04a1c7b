"""Runs the cargo-fuzz targets of firmware/fuzz for a bounded number of iterations.

Each target gets a fresh corpus and a fixed seed, so a run is repeatable; a crash (a panic on
some input) fails it and libFuzzer's report names the input file that reproduces it. Output
closes with a libtest-style `test result:` line that the test driver counts.

    scripts/fuzz [--runs N] [TARGET ...]     # default: every target, 100000 runs each
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import tomllib

from . import ROOT

FUZZ_DIR = ROOT / "firmware" / "fuzz"
CARGO_FUZZ = ROOT / ".tools" / "cargo-fuzz" / "bin" / "cargo-fuzz"
DEFAULT_RUNS = 100_000


def targets() -> list[str]:
    manifest = tomllib.loads((FUZZ_DIR / "Cargo.toml").read_text())
    return [b["name"] for b in manifest.get("bin", [])]


def toolchain() -> str:
    return tomllib.loads((FUZZ_DIR / "rust-toolchain.toml").read_text())["toolchain"]["channel"]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="fuzz", description=__doc__.splitlines()[0])
    ap.add_argument("targets", nargs="*", help="fuzz targets (default: all)")
    ap.add_argument("--runs", type=int, default=DEFAULT_RUNS, help="iterations per target")
    args = ap.parse_args(argv)
    if not CARGO_FUZZ.exists():
        print(f"fuzz: {CARGO_FUZZ.relative_to(ROOT)} is missing: run scripts/setup", file=sys.stderr)
        return 2
    known = targets()
    chosen = args.targets or known
    unknown = [t for t in chosen if t not in known]
    if unknown:
        print(f"fuzz: no target {', '.join(unknown)}; targets are: {', '.join(known)}", file=sys.stderr)
        return 2
    env = {**os.environ, "RUSTUP_TOOLCHAIN": toolchain()}
    passed = failed = 0
    for t in chosen:
        with tempfile.TemporaryDirectory(prefix=f"r2p-fuzz-{t}-") as corpus:
            cmd = [str(CARGO_FUZZ), "fuzz", "run", "--fuzz-dir", str(FUZZ_DIR), t, corpus, "--",
                   f"-runs={args.runs}", "-seed=1", "-max_len=256", "-print_final_stats=1"]
            p = subprocess.run(cmd, cwd=ROOT / "firmware", env=env, capture_output=True, text=True)
        execs = next((l.split()[-1] for l in p.stderr.splitlines() if "stat::number_of_executed_units" in l), "?")
        if p.returncode == 0:
            passed += 1
            print(f"test fuzz::{t} ({execs} inputs) ... ok")
        else:
            failed += 1
            sys.stdout.write(p.stdout + p.stderr[-6000:])
            print(f"test fuzz::{t} ... FAILED (exit status {p.returncode})")
    status = "ok" if failed == 0 else "FAILED"
    print(f"\ntest result: {status}. {passed} passed; {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
