"""Every committed image fits probe-rs's own description of its chip (issue 18 item 1): what
probe-rs writes lies in the chip's flash, every section in its flash or RAM, and the vector table
is where the chip (and later a bootloader) looks for it. The descriptions come from the probe-rs
crate pinned in firmware/tools/probe-rs, fetched by cargo (no probe-rs build)."""
import dataclasses

import pytest

from r2ptools import firmware, probe_targets

from conftest import ROOT


@pytest.fixture(scope="module")
def crate():
    return probe_targets.crate_dir()


def test_every_committed_image_fits_its_chip_as_probe_rs_describes_it(crate):
    assert probe_targets.check_all() == []
    # It checked something: every image's chip is described, with flash and RAM.
    for img in firmware.manifest():
        kinds = {r.kind for r in probe_targets.chip_regions(crate, img.mcu)}
        assert {"Nvm", "Ram"} <= kinds, img.mcu


def test_the_f103cb_is_128_kib_of_flash_and_20_kib_of_ram_to_probe_rs(crate):
    regions = probe_targets.contiguous(probe_targets.chip_regions(crate, "STM32F103CB"))
    assert [(r.kind, r.start, r.end - r.start) for r in regions] == [
        ("Nvm", 0x0800_0000, 128 * 1024), ("Ram", 0x2000_0000, 20 * 1024)]
    # firmware/images.toml's sizes (the budgets' base) agree with probe-rs's.
    img = next(i for i in firmware.manifest() if i.mcu == "STM32F103CB")
    assert (img.mcu_flash, img.mcu_ram) == (128 * 1024, 20 * 1024)


def test_an_image_too_large_for_the_chip_is_refused(crate):
    # The motor image (~54 KiB, 8.4 KiB of RAM) on the 32 KiB / 10 KiB STM32F103C6: its code lies
    # beyond the flash, and its stack (linked for the CB's 20 KiB) starts beyond the RAM.
    elf = probe_targets.read_elf(ROOT / firmware.IMAGES_DIR / "motor.elf")
    origin = next(i for i in firmware.manifest() if i.name == "motor").origin
    errs = probe_targets.check("motor", elf, probe_targets.chip_regions(crate, "STM32F103C6"), origin)
    assert any("outside the chip's flash (BANK_1 0x8000000..0x8008000)" in e for e in errs), errs
    assert "motor: the initial stack pointer 0x20005000 is not in the chip's RAM" in errs, errs


def test_a_vector_table_elsewhere_than_image_origin_is_refused(crate):
    elf = probe_targets.read_elf(ROOT / firmware.IMAGES_DIR / "motor.elf")
    regions = probe_targets.chip_regions(crate, "STM32F103CB")
    motor = next(i for i in firmware.manifest() if i.name == "motor")
    assert probe_targets.check("motor", elf, regions, motor.origin) == []
    errs = probe_targets.check("motor", elf, regions, 0x0800_8000)
    assert errs == ["motor: the vector table is at 0x08003c00, expected at 0x08008000 (image_origin in "
                    "firmware/images.toml, or the active slot of its flash map for an image behind the bootloader)"]


def test_an_image_behind_the_bootloader_starts_at_the_active_slot():
    # The gateway's image is linked at the F407 map's active slot, where its bootloader jumps.
    gateway = next(i for i in firmware.manifest() if i.name == "gateway")
    assert gateway.origin == 0x0800_0000 + firmware_map("STM32F407VG")["active"]["offset"] == 0x0802_0000
    images = {i.name: i for i in firmware.manifest()}
    slot = 0x0800_0000 + firmware_map("STM32F103CB")["active"]["offset"]
    for name in ("template", "proximity", "psu", "motor"):
        assert images[name].origin == slot == 0x0800_3C00, name
    # The IMU is out of a slot for now (docs/flashing.md, "The IMU's flash"): at the flash base.
    assert images["imu"].origin == 0x0800_0000


def firmware_map(mcu):
    import tomllib
    return tomllib.loads((ROOT / "firmware" / "images.toml").read_text())["mcu"][mcu]["partitions"]


def test_a_reset_vector_outside_flash_is_refused(crate):
    elf = probe_targets.read_elf(ROOT / firmware.IMAGES_DIR / "template.elf")
    regions = probe_targets.chip_regions(crate, "STM32F103CB")
    vt = elf.offsets[0]
    data = bytearray(elf.data)
    data[vt + 4:vt + 8] = (0x2000_0101).to_bytes(4, "little")  # a "reset handler" in RAM
    bad = dataclasses.replace(elf, data=bytes(data))
    origin = next(i for i in firmware.manifest() if i.name == "template").origin
    assert probe_targets.check("template", bad, regions, origin) == [
        "template: the reset vector 0x20000101 is not Thumb code in the chip's flash"]


def test_an_mcu_probe_rs_does_not_know_is_a_clear_error(crate):
    with pytest.raises(probe_targets.TargetsError, match="no chip named STM32F103ZZ"):
        probe_targets.chip_regions(crate, "STM32F103ZZ")
