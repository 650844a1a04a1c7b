"""Firmware images: committed, reproducible from any folder, sized against their budgets."""
from r2ptools import firmware

from conftest import ROOT, run


def test_committed_images_regenerate_byte_for_byte_from_another_folder():
    # Rebuilds every image in firmware/images.toml from a copy of the sources in another folder.
    diffs = firmware.verify()
    assert diffs == [], "\n".join(diffs)


def test_every_image_in_the_manifest_is_committed_in_three_formats():
    for img in firmware.manifest():
        for ext in ("elf", "bin", "hex"):
            assert (ROOT / firmware.IMAGES_DIR / f"{img.name}.{ext}").is_file(), f"{img.name}.{ext}"


def test_images_fit_their_budgets():
    for img in firmware.manifest():
        size = firmware.size_of(ROOT / firmware.IMAGES_DIR / f"{img.name}.elf")
        assert firmware.over_budget(img, size) == []
        # The .bin is exactly the flash contents the sizes claim.
        assert (ROOT / firmware.IMAGES_DIR / f"{img.name}.bin").stat().st_size == size.flash


def test_over_budget_names_image_resource_and_file():
    img = firmware.manifest()[0]
    errs = firmware.over_budget(img, firmware.Size(flash=img.budget_flash + 1, ram=img.budget_ram + 1))
    assert len(errs) == 2
    assert errs[0].startswith(f"{img.name}: flash {img.budget_flash + 1} B exceeds its budget")
    assert "static RAM" in errs[1] and "firmware/images.toml" in errs[1]


def test_sizes_table_lists_every_image():
    p = run([str(ROOT / "scripts" / "firmware"), "sizes"])
    assert p.returncode == 0, p.stdout
    for img in firmware.manifest():
        assert img.name in p.stdout and img.mcu in p.stdout


def test_unknown_image_name_is_refused():
    p = run([str(ROOT / "scripts" / "firmware"), "build", "no-such-image"])
    assert p.returncode == 2
    assert "no image named no-such-image" in p.stdout
