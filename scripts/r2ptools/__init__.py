"""R2P's build and test tooling, driven by the Makefile (see `make help`).

One module per job: `firmware` builds and sizes the MCU images, `qemu` runs the core suites on
an emulated Cortex-M3, `testrun` runs every test stage with one summary, `summary` prints what
`make` built. Paths are relative to the repository root, found from this file.
"""
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
