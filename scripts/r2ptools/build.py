"""`make`: build every artifact the repository has into its place, then one summary table.

Stages build what exists and say plainly what does not exist yet, so the table is also a map
of the project's state: firmware images (flash/RAM against the MCU and the image's budget),
fab packages per board, enclosures per module.
"""
from __future__ import annotations

import subprocess
import sys
import time

from . import ROOT, firmware, manifest


def module_images() -> dict[str, str]:
    names = {i.name for i in firmware.manifest()}
    return {m.name: ("in modules.toml" if m.name in names else "not yet: no module firmware")
            for m in manifest.load()}


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

    for name, cmd in (("fab", ["scripts/fab"]), ("enclosures", ["scripts/enclosures", "generate"])):
        t0 = time.monotonic()
        rc = subprocess.run(cmd, cwd=ROOT).returncode
        times.append((name, f"{time.monotonic() - t0:.0f} s"))
        if rc:
            print(f"make: the {name} stage failed (above); stopped", file=sys.stderr)
            return rc

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
    modules = manifest.load()
    for mod in modules:
        m = mod.name
        zip_file = ROOT / "hardware" / m / "fab" / f"{m}-gerbers.zip"
        if mod.fab and zip_file.exists():
            print(f"{m:<18} {zip_file.relative_to(ROOT)} ({zip_file.stat().st_size / 1024:.0f} KiB), "
                  f"JLC BOM and CPL, iBOM, assembly PDF and checklist, schematic PDF, renders")
        elif (ROOT / mod.pcb).exists():
            print(f"{m:<18} not made: `fab = false` in modules.toml")
        else:
            print(f"{m:<18} not yet: no {mod.pcb}")
    print("\nenclosures (enclosures/<module>)")
    for m in (m.name for m in modules):
        step = ROOT / "enclosures" / m / f"{m}-assembly.step"
        print(f"{m:<18} " + (f"enclosures/{m}/: {m}-base.stl, {m}-lid.stl, {m}-assembly.step, {m}.png"
                             if step.exists() else "not yet: needs the module's board"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
