"""`make`: build every artifact the repository has into its place, then one summary table.

Stages build what exists and say plainly what does not exist yet, so the table is also a map
of the project's state: firmware images (flash/RAM against the MCU and the image's budget),
fab packages per board, enclosures per module.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

from . import ROOT, firmware

MODULES = ["psu", "motor", "imu", "proximity", "gateway"]


def board_file(module: str) -> Path:
    return ROOT / "hardware" / module / f"{module}.kicad_pcb"


def module_images() -> dict[str, str]:
    names = {i.name for i in firmware.manifest()}
    return {m: ("in firmware/images.toml" if m in names else "not yet: no module firmware") for m in MODULES}


def main() -> int:
    times: list[tuple[str, str]] = []
    setup_s = ROOT / ".setup" / "last-seconds"
    if setup_s.exists():
        times.append(("setup", f"{setup_s.read_text().strip()} s"))

    t0 = time.monotonic()
    rc = firmware.main(["build"])
    times.append(("firmware", f"{time.monotonic() - t0:.0f} s"))
    if rc:
        print("make: the firmware stage failed (above); nothing else was built", file=sys.stderr)
        return rc

    boards = [m for m in MODULES if board_file(m).exists()]
    times.append(("fab", "skipped: no KiCad boards yet" if not boards else "not wired yet"))
    times.append(("enclosures", "skipped: no boards to fit yet"))

    print("\n=== make: summary")
    print(f"{'stage':<12} time")
    for name, t in times:
        print(f"{name:<12} {t}")
    print("\nfirmware images (firmware/images/*.elf|bin|hex)")
    rows = []
    for img in firmware.manifest():
        elf = ROOT / firmware.IMAGES_DIR / f"{img.name}.elf"
        rows.append((img, firmware.size_of(elf) if elf.exists() else None))
    print(firmware.table(rows))
    for m, state in module_images().items():
        if state.startswith("not yet"):
            print(f"{m:<18} {state}")
    print("\nfab packages (hardware/<module>/fab)")
    for m in MODULES:
        print(f"{m:<18} {'board present' if board_file(m).exists() else 'not yet: no hardware/' + m + '/' + m + '.kicad_pcb'}")
    print("\nenclosures (enclosures/<module>)")
    for m in MODULES:
        print(f"{m:<18} not yet: needs the module's board")
    return 0


if __name__ == "__main__":
    sys.exit(main())
