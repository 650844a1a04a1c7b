"""Runs the core crates' test suites as Cortex-M3 images under QEMU (lm3s6965evb).

Each binary of firmware/targets/qemu runs one crate's `selftest` suites and exits through
semihosting: status 0 when all passed, 1 on the first failure. `-icount` makes the runs
deterministic (instruction-counted virtual time). Usage:

    scripts/qemu-test [IMAGE ...]     # default: every suite image (not deliberate-failure, bench)
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tomllib
from pathlib import Path

from . import ROOT
from .results import libtest

WORKSPACE = ROOT / "firmware" / "targets" / "qemu"
TARGET = "thumbv7m-none-eabi"
# Exists to prove that a failure fails the run (tests/test_qemu_runner.py); not part of the suite.
DELIBERATE_FAILURE = "deliberate-failure"
# Images that are not test suites: run only when named (the benchmarks are run by scripts/bench).
NOT_SUITES = {DELIBERATE_FAILURE, "bench", "slot-path", "fusion", "gateway"}
TIMEOUT_S = 60


CORES = {"cortex-m3": TARGET, "cortex-m4": "thumbv7em-none-eabihf"}
"""The cores an image is built for (Rust target): the F103's, and the F407's with its FPU. QEMU's
lm3s6965evb takes either CPU (`-cpu`); only benchmarks run on the second (the slot path, the gateway)."""


def qemu_command(image: Path, cpu: str = "cortex-m3") -> list[str]:
    """The command line the workspace's cargo runner uses, read from its config, on `cpu`."""
    config = tomllib.loads((WORKSPACE / ".cargo" / "config.toml").read_text())
    args = config["target"][TARGET]["runner"].split()
    args[args.index("-cpu") + 1] = cpu
    return args + [str(image)]


def images() -> list[str]:
    return sorted(p.stem for p in (WORKSPACE / "src" / "bin").glob("*.rs"))


def build(profile: str = "dev", cpu: str = "cortex-m3", image: str | None = None,
          features: tuple[str, ...] = ()) -> Path:
    """Builds every image (or only `image`) for `cpu`, with the workspace's `features`; returns
    the folder they are in."""
    target = CORES[cpu]
    which = ["--bin", image] if image else ["--bins"]
    feats = ["--features", ",".join(features)] if features else []
    subprocess.run(["cargo", "build", "--locked", *which, *feats, "--profile", profile,
                    "--target", target], cwd=WORKSPACE, check=True)
    return WORKSPACE / "target" / target / ("debug" if profile == "dev" else profile)


def run_image(path: Path, cpu: str = "cortex-m3") -> tuple[int, str]:
    """Runs one image on `cpu`; returns QEMU's exit status and everything it printed."""
    try:
        p = subprocess.run(qemu_command(path, cpu), capture_output=True, text=True, timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired as e:
        out = (e.stdout or b"").decode(errors="replace") if isinstance(e.stdout, bytes) else (e.stdout or "")
        return 124, out + f"\nqemu-test: {path.name} did not exit within {TIMEOUT_S} s (hung or looping)\n"
    # QEMU prints "Timer with period zero, disabling" for the lm3s6965's unused timers: noise.
    err = "".join(l for l in p.stderr.splitlines(True) if "Timer with period zero" not in l)
    return p.returncode, p.stdout + err


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="qemu-test", description=__doc__.splitlines()[0])
    ap.add_argument("images", nargs="*", help="image names (files in firmware/targets/qemu/src/bin)")
    args = ap.parse_args(argv)
    known = images()
    chosen = args.images or [i for i in known if i not in NOT_SUITES]
    unknown = [i for i in chosen if i not in known]
    if unknown:
        print(f"qemu-test: no image {', '.join(unknown)} in {WORKSPACE / 'src/bin'}; "
              f"images are: {', '.join(known)}", file=sys.stderr)
        return 2
    try:
        outdir = build()
    except subprocess.CalledProcessError as e:
        print(f"qemu-test: building the test images failed (`{' '.join(e.cmd)}` in "
              f"{WORKSPACE.relative_to(ROOT)} exited {e.returncode}); cargo's message is above",
              file=sys.stderr)
        return 1
    failed = 0
    for name in chosen:
        rc, out = run_image(outdir / name)
        sys.stdout.write(out)
        counts = libtest(out)
        if rc != 0 or counts.failed or counts.total == 0:
            failed += 1
            print(f"qemu-test: image {name} FAILED (qemu exit status {rc})")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
