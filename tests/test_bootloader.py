"""The committed bootloader image (issue 18 item 2): its API table where images look for it, with
the development key; its code inside its partition of the flash map; its RAM above the images'."""
import struct
import tomllib

import pytest

from r2ptools import probe_targets

from conftest import ROOT

IMAGES = ROOT / "firmware" / "images"
FLASH_BASE = 0x0800_0000
API_LEN = 64  # r2p-boot's api::API_LEN


# image, MCU, the bootloader's RAM (its build.rs)
BOOTLOADERS = [("bootloader-f103", "STM32F103CB", (0x2000_4000, 0x2000_5000)),
               ("bootloader-f407", "STM32F407VG", (0x2001_C000, 0x2002_0000))]


def flash_map(mcu):
    return tomllib.loads((ROOT / "firmware" / "images.toml").read_text())["mcu"][mcu]["partitions"]


def development_key() -> bytes:
    text = (ROOT / "firmware" / "keys" / "development.pub").read_text()
    return bytes.fromhex("".join(l for l in text.splitlines() if not l.startswith("#")).strip())


def load_segments(elf):
    """(vaddr, paddr, filesz, memsz) of each loaded segment (probe_targets' ELF reader)."""
    return [(g.vaddr, g.paddr, g.filesz, g.memsz) for g in probe_targets.read_elf(elf).segments]


@pytest.mark.parametrize("name,mcu,ram", BOOTLOADERS)
def test_the_api_table_is_at_the_end_of_the_bootloader_partition_with_the_development_key(name, mcu, ram):
    boot = flash_map(mcu)["bootloader"]
    image = (IMAGES / f"{name}.bin").read_bytes()
    at = boot["size"] - API_LEN
    magic, version, key, verify = struct.unpack_from("<II32sI", image, at)
    assert magic == int.from_bytes(b"R2PB", "little") and version == 1
    assert key == development_key(), "the committed bootloader trusts firmware/keys/development.pub"
    assert verify & 1, "a Thumb function address"
    assert FLASH_BASE < verify < FLASH_BASE + at, "the check lies in the bootloader's code"


@pytest.mark.parametrize("name,mcu,ram", BOOTLOADERS)
def test_the_bootloader_keeps_to_its_partition_and_its_ram(name, mcu, ram):
    boot = flash_map(mcu)["bootloader"]
    for vaddr, paddr, filesz, memsz in load_segments(IMAGES / f"{name}.elf"):
        if filesz:
            assert FLASH_BASE + boot["offset"] <= paddr and paddr + filesz <= FLASH_BASE + boot["offset"] + boot["size"]
        if vaddr >= 0x2000_0000:
            assert ram[0] <= vaddr and vaddr + memsz <= ram[1], hex(vaddr)


@pytest.mark.parametrize("name,mcu,ram", BOOTLOADERS)
def test_images_leave_the_bootloader_ram_alone(name, mcu, ram):
    # An image's statics and its panic report (RAM that start-up leaves alone) lie below the
    # bootloader's: otherwise the bootloader's stack would overwrite the report of a panic.
    from r2ptools import firmware
    for img in firmware.manifest():
        if img.mcu == mcu and img.package != "bootloader":
            for vaddr, _, _, memsz in load_segments(IMAGES / f"{img.name}.elf"):
                if 0x2000_0000 <= vaddr < 0x2002_0000:
                    assert vaddr + memsz <= ram[0], f"{img.name}: RAM up to {vaddr + memsz:#x}"
