"""The committed bootloader image (issue 18 item 2): its API table where images look for it, with
the development key; its code inside its partition of the flash map; its RAM above the images'."""
import struct
import subprocess
import tomllib

from conftest import ROOT

IMAGES = ROOT / "firmware" / "images"
FLASH_BASE = 0x0800_0000
API_LEN = 64  # r2p-boot's api::API_LEN


def f103_map():
    return tomllib.loads((ROOT / "firmware" / "images.toml").read_text())["mcu"]["STM32F103CB"]["partitions"]


def development_key() -> bytes:
    text = (ROOT / "firmware" / "keys" / "development.pub").read_text()
    return bytes.fromhex("".join(l for l in text.splitlines() if not l.startswith("#")).strip())


def load_segments(elf):
    out = subprocess.run(["arm-none-eabi-readelf", "-lW", str(elf)], capture_output=True, text=True, check=True).stdout
    segs = []
    for line in out.splitlines():
        p = line.split()
        if p and p[0] == "LOAD":
            segs.append(tuple(int(x, 16) for x in p[2:6]))  # vaddr, paddr, filesz, memsz
    return segs


def test_the_api_table_is_at_the_end_of_the_bootloader_partition_with_the_development_key():
    boot = f103_map()["bootloader"]
    image = (IMAGES / "bootloader-f103.bin").read_bytes()
    at = boot["size"] - API_LEN
    magic, version, key, verify = struct.unpack_from("<II32sI", image, at)
    assert magic == int.from_bytes(b"R2PB", "little") and version == 1
    assert key == development_key(), "the committed bootloader trusts firmware/keys/development.pub"
    assert verify & 1, "a Thumb function address"
    assert FLASH_BASE < verify < FLASH_BASE + at, "the check lies in the bootloader's code"


def test_the_bootloader_keeps_to_its_partition_and_the_top_4_kib_of_ram():
    boot = f103_map()["bootloader"]
    for vaddr, paddr, filesz, memsz in load_segments(IMAGES / "bootloader-f103.elf"):
        if filesz:
            assert FLASH_BASE + boot["offset"] <= paddr and paddr + filesz <= FLASH_BASE + boot["offset"] + boot["size"]
        if vaddr >= 0x2000_0000:
            assert 0x2000_4000 <= vaddr and vaddr + memsz <= 0x2000_5000, hex(vaddr)


def test_module_images_leave_the_bootloader_ram_alone():
    # A module image's statics and its panic report (RAM that start-up leaves alone) lie below the
    # bootloader's 4 KiB: otherwise the bootloader's stack would overwrite the report of a panic.
    from r2ptools import firmware
    for img in firmware.manifest():
        if img.mcu == "STM32F103CB" and img.package != "bootloader":
            for vaddr, _, _, memsz in load_segments(IMAGES / f"{img.name}.elf"):
                if vaddr >= 0x2000_0000:
                    assert vaddr + memsz <= 0x2000_4000, f"{img.name}: RAM up to {vaddr + memsz:#x}"
