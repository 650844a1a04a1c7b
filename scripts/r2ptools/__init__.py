"""R2P's build and test tooling, driven by the Makefile (see `make help`).

One module per job: `firmware` builds and sizes the MCU images, `qemu` runs the core suites on
an emulated Cortex-M3, `testrun` runs every test stage with one summary, `summary` prints what
`make` built. Paths are relative to the repository root, found from this file.
"""
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def is_shared_sheet(folder: Path) -> bool:
    """A hardware/ folder with a schematic but no KiCad project: a sheet every module's
    schematic includes (hardware/core), not a module of its own."""
    return any(folder.glob("*.kicad_sch")) and not any(folder.glob("*.kicad_pro"))
