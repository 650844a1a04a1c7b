"""The module manifest (modules.toml): the one list of modules, and its errors for bad entries."""
from __future__ import annotations

from pathlib import Path

import pytest

from conftest import ROOT
from r2ptools import build, firmware, manifest
from r2ptools.kicad import fab

TEXT = (ROOT / "modules.toml").read_text()


def tree(tmp: Path, text: str) -> Path:
    """A repository root whose hardware/ and firmware/ are the real ones, with `text` as manifest."""
    for d in ("hardware", "firmware"):
        (tmp / d).symlink_to(ROOT / d)
    (tmp / "modules.toml").write_text(text)
    return tmp


def error(tmp: Path, text: str) -> str:
    with pytest.raises(manifest.ManifestError) as e:
        manifest.load(tree(tmp, text))
    return str(e.value)


def line_of(text: str, needle: str) -> int:
    return text[:text.index(needle)].count("\n") + 1


def test_the_manifest_loads_and_its_readers_agree():
    modules = manifest.load()
    assert [m.name for m in modules][:5] == ["psu", "motor", "imu", "proximity", "gateway"]
    assert fab.FAB_BOARDS == [m.name for m in modules if m.fab]
    images = {i.name for i in firmware.manifest()}
    assert {m.name for m in modules if m.image} <= images
    assert set(build.module_images()) == {m.name for m in modules}


def test_a_missing_file_and_bad_toml_name_the_file(tmp_path):
    with pytest.raises(manifest.ManifestError, match="modules.toml: missing"):
        manifest.load(tmp_path)
    assert "modules.toml: not valid TOML" in error(tmp_path, TEXT.replace('name = "psu"', 'name = psu'))


@pytest.mark.parametrize("old, new, anchor, expect", [
    ('name = "motor"', 'name = "Motor"', 'name = "Motor"', "is not lowercase letters"),
    ('name = "imu"', 'name = "psu"', '"psu"\nkind = "inertial', "listed twice (also at line"),
    ('case = true\nemulator = "imu"', 'case = true\nemulatr = "imu"', "emulatr", "unknown key `emulatr`"),
    ('fab = true\ncase = true\nemulator = "imu"', 'fab = "no"\ncase = true\nemulator = "imu"',
     'fab = "no"', "`fab` must be true or false"),
    ('board_file = "firmware/boards/imu.toml"', 'board_file = "firmware/boards/imu2.toml"', "imu2.toml",
     "a module's board_file is 'firmware/boards/imu.toml'"),
    ('mcu = "STM32F103CB", budget_flash = 56192, budget_ram = 16384, slot = "active" }\n\n[[module]]\nname = "imu"',
     'mcu = "STM32F103CB", budget_flash = 655360, budget_ram = 16384, slot = "active" }\n\n[[module]]\nname = "imu"',
     "image = { workspace = \"targets/f103\", package = \"motor\"", "must be positive and within the STM32F103CB's"),
    ('package = "imu", mcu = "STM32F103CB"', 'package = "imu", mcu = "STM32F103C8"',
     'image = { workspace = "targets/f103", package = "imu"', "mcu 'STM32F103C8' is not a [mcu.*]"),
    ('budget_ram = 69632, slot = "active" }', 'budget_ram = 69632, slot = "dfu" }',
     'image = { workspace = "targets/f407"', "slot 'dfu' is not one of active"),
])
def test_a_bad_entry_names_the_file_the_line_and_the_fix(tmp_path, old, new, anchor, expect):
    assert old in TEXT
    text = TEXT.replace(old, new, 1)
    e = error(tmp_path, text)
    assert e.startswith(f"modules.toml:{line_of(text, anchor)}: module "), e
    assert expect in e, e



def test_fab_or_case_without_a_board_names_the_missing_file(tmp_path):
    """A module whose board is not designed yet cannot ask for a fab package or a case: the IMU's
    entry with fab = true and case = true over a hardware/imu/ that holds only its README."""
    hw = tmp_path / "hardware"
    hw.mkdir()
    for d in (ROOT / "hardware").iterdir():
        if d.name != "imu":
            (hw / d.name).symlink_to(d)
    (hw / "imu").mkdir()
    (hw / "imu" / "README.md").write_text("# imu\n")
    (tmp_path / "firmware").symlink_to(ROOT / "firmware")
    anchor = 'fab = true\ncase = true\nemulator = "imu"'
    assert anchor in TEXT
    text = TEXT
    (tmp_path / "modules.toml").write_text(text)
    with pytest.raises(manifest.ManifestError) as e:
        manifest.load(tmp_path)
    assert "`fab = true` but hardware/imu/imu.kicad_pcb does not exist" in str(e.value), e.value
    assert str(e.value).startswith(f"modules.toml:{line_of(text, anchor)}: "), e.value


def test_an_entry_missing_a_key_says_which(tmp_path):
    text = TEXT.replace('hardware = "hardware/gateway"\n', "")
    e = error(tmp_path, text)
    head = line_of(text, 'name = "gateway"') - 1
    assert e.startswith(f'modules.toml:{head}: module "gateway": `hardware` is missing'), e


def test_a_module_without_its_hardware_folder_is_refused(tmp_path):
    text = TEXT + '\n[[module]]\nname = "servo"\nkind = "x"\nhardware = "hardware/servo"\nfab = false\ncase = false\n'
    e = error(tmp_path, text)
    head = line_of(text, 'hardware = "hardware/servo"')
    assert "hardware/servo/README.md does not exist" in e and e.startswith(f"modules.toml:{head}:"), e


def test_the_checker_command_reports_errors(tmp_path, capsys):
    assert manifest.main([str(ROOT)]) == 0
    assert manifest.main([str(tree(tmp_path, TEXT.replace("fab = true\ncase", "fab = 1\ncase", 1)))]) == 1
    assert "`fab` must be true or false" in capsys.readouterr().err


def test_a_module_in_the_tree_without_an_entry_is_refused(tmp_path):
    # proximity's entry removed: its board, board file and app are still there
    start = TEXT.index('[[module]]\nname = "proximity"')
    text = TEXT[:start] + TEXT[TEXT.index("[[module]]", start + 1):]
    e = error(tmp_path, text)
    assert e == ("modules.toml: hardware/proximity/proximity.kicad_pro belongs to module 'proximity', "
                 "which has no [[module]] entry; add one (docs/adding-a-module.md) or remove the files"), e
