"""`make bench`, updates over the bus (issue 18): the committed motor image sent by `r2p update`'s
sender to an emulated motor module while its robot drives, at background loads of 10 % and 60 %
of a 1 Mbit/s bus (the robot's own traffic plus SRT messages of a load node), in the emulator's
virtual time (deterministic). The baseline, in the same run: the same update on the robot's own
traffic alone. Reported: the transfer time and rate, the share of the bus the update used, the
reboot-to-confirmed time, HRT slots the other modules missed; and the bootloaders' size.

    scripts/py -m r2ptools.bench_update
"""
from __future__ import annotations

import json
import subprocess
import sys

import tomllib

from . import ROOT, firmware, manifest

FIRMWARE = ROOT / "firmware"
TRAILER_LEN = 128


def slot_limit(mcu: str = "STM32F103CB") -> int:
    """The largest image an F103 module's active slot takes (its trailer at the slot's end)."""
    data = tomllib.loads((FIRMWARE / "images.toml").read_text())
    return data["mcu"][mcu]["partitions"]["active"]["size"] - TRAILER_LEN


def image() -> tuple[str, str]:
    """The motor image, or while it does not fit a slot the largest module image that does (the
    transfer's time depends on the size only; the emulated module runs its emulated firmware):
    its path and what to call it."""
    limit = slot_limit()
    sizes = {m.name: (FIRMWARE / "images" / f"{m.name}.bin").stat().st_size
             for m in manifest.load() if m.image and m.image.mcu == "STM32F103CB"}
    if sizes["motor"] <= limit:
        return str(FIRMWARE / "images" / "motor.bin"), "the motor image"
    name = max((m for m in sizes if sizes[m] <= limit), key=sizes.get)
    return (str(FIRMWARE / "images" / f"{name}.bin"),
            f"the {name} image in its place (the motor image, {sizes['motor']:,} B, is "
            f"{sizes['motor'] - limit:,} B over a slot's {limit:,} B)")
# The diffbot's own traffic is 4 % of the bus, so 10 % is reachable; the Triskar2's is 18 %.
RUNS = [("diffbot", "left", "0,0.1,0.6"), ("triskar2", "motor1", "0,0.6")]


def run() -> list[dict]:
    rows = []
    path, what = image()
    for robot, module, loads in RUNS:
        p = subprocess.run(["cargo", "run", "-q", "--release", "--locked", "-p", "r2p-updatebench", "--",
                            "--robot", robot, "--module", module, "--loads", loads, "--image", path],
                           cwd=FIRMWARE, capture_output=True, text=True)
        if p.returncode != 0:
            raise RuntimeError(f"r2p-updatebench {robot}: {p.stderr.strip()}")
        rows += [dict(json.loads(line), image=what)
                 for line in p.stdout.splitlines() if line.startswith("{")]
    return rows


def table(rows: list[dict]) -> str:
    lines = [f"{'robot':<9} {'module':<7} {'load':>6} {'during':>7} {'transfer':>9} {'KiB/s':>6} "
             f"{'vs own':>7} {'bus used':>9} {'to confirmed':>13} {'HRT missed':>11} {'timeouts':>9}"]
    base: dict[str, float] = {}
    for r in rows:
        if r["target_load"] == 0:
            base[r["robot"]] = r["transfer_s"]
        ratio = r["transfer_s"] / base[r["robot"]] if r["robot"] in base else float("nan")
        lines.append(
            f"{r['robot']:<9} {r['module']:<7} {100 * r['background_load']:5.1f}% "
            f"{100 * r['background_during']:6.1f}% {r['transfer_s']:8.2f}s {r['kib_per_s']:6.2f} "
            f"{ratio:6.2f}x {100 * r['update_share']:8.1f}% {r['reboot_to_confirmed_s']:12.1f}s "
            f"{r['hrt_missed_others']:>11} {r['timeouts']:>9}")
    return "\n".join(lines)


def loaded(elf) -> tuple[int, int]:
    """Bytes an image puts in flash (its loadable segments' file sizes, not the span: the
    bootloader's API table sits at its partition's end) and in static RAM (its RAM segments)."""
    out = subprocess.run(["arm-none-eabi-readelf", "-lW", str(elf)], capture_output=True, text=True,
                         check=True).stdout
    flash = ram = 0
    for parts in (line.split() for line in out.splitlines()):
        if parts and parts[0] == "LOAD":
            vaddr, _, filesz, memsz = (int(x, 16) for x in parts[2:6])
            if vaddr >= 0x2000_0000:
                ram += memsz
            else:
                flash += filesz
    return flash, ram


def bootloaders() -> str:
    data = tomllib.loads((FIRMWARE / "images.toml").read_text())
    lines = [f"{'image':<16} {'MCU':<12} {'flash':>9} {'partition':>10} {'spare':>8} {'static RAM':>11}"]
    for img in firmware.manifest():
        if img.name.startswith("bootloader"):
            flash, ram = loaded(ROOT / firmware.IMAGES_DIR / f"{img.name}.elf")
            part = data["mcu"][img.mcu]["partitions"]["bootloader"]["size"]
            lines.append(f"{img.name:<16} {img.mcu:<12} {flash:>7,} B {part:>8,} B {part - flash:>6,} B "
                         f"{ram:>9,} B")
    return "\n".join(lines) + "\n(static RAM 0: the bootloader runs on its stack alone)"


def report(rows: list[dict]) -> None:
    r = rows[0]
    print(f"\n=== updates over the bus: {r['image']}, {r['image_bytes']:,} B signed, sent to a motor "
          f"module, {r['window']} block in flight (emulated, virtual time)")
    print("load: the bus before the update (the robot's own traffic, then plus the load node); "
          "during: the others' traffic while it ran; vs own: transfer time against the robot's "
          "own traffic alone; to confirmed: REBOOT to the new image confirmed (swap, boot, trial)")
    print(table(rows))
    print("\nbootloaders (firmware/images):")
    print(bootloaders())


if __name__ == "__main__":
    try:
        report(run())
    except (RuntimeError, subprocess.CalledProcessError) as e:
        print(f"bench: updates: {e}", file=sys.stderr)
        sys.exit(1)
