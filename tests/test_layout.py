"""What a newcomer relies on finding: the folder map, a licence per folder, `make help`."""
import re
from pathlib import Path

from conftest import ROOT, run
from r2ptools import manifest

FOLDERS = {
    # folder: words its licence statement must contain
    "hardware": "CERN-OHL-S-2.0",
    "enclosures": "CERN-OHL-S-2.0",
    "bom": "CC-BY-4.0",
    "firmware": "MIT OR Apache-2.0",
    "scripts": "MIT OR Apache-2.0",
    "tests": "MIT OR Apache-2.0",
    "docs": "CC-BY-4.0",
    "robots": "MIT OR Apache-2.0",
}


def test_every_top_level_folder_has_a_readme_and_states_its_licence():
    for folder, spdx in FOLDERS.items():
        assert (ROOT / folder / "README.md").is_file(), f"{folder}/README.md"
        licence = (ROOT / folder / "LICENSE.md").read_text()
        assert f"SPDX-License-Identifier: {spdx}" in licence, folder


def test_every_top_level_folder_is_in_the_map():
    # A new top-level folder needs a README, a licence and a row in the README's folder table.
    readme = (ROOT / "README.md").read_text()
    for d in ROOT.iterdir():
        if d.is_dir() and not d.name.startswith(".") and d.name != "LICENSES":
            assert d.name in FOLDERS, f"{d.name}/ is not in tests/test_layout.py's FOLDERS"
            assert f"[`{d.name}/`]({d.name}/)" in readme, f"{d.name}/ is not in README.md's folder table"


def test_every_module_has_its_hardware_folder():
    modules = manifest.load(ROOT)   # also checks every entry against the files it names
    assert {"psu", "motor", "imu", "proximity", "gateway"} <= {m.name for m in modules}
    for m in modules:
        assert (ROOT / m.hardware / "README.md").is_file(), m.name


def test_readme_gives_exactly_the_two_commands():
    readme = (ROOT / "README.md").read_text()
    block = re.search(r"```sh\n(.*?)```", readme, re.S)
    assert block and block.group(1).split("\n")[:2] == ["make", "make test"]


def test_make_help_lists_every_target_with_one_line():
    p = run(["make", "--no-print-directory", "help"])
    assert p.returncode == 0
    listed = [l.split()[1] for l in p.stdout.splitlines() if l.startswith("  make ")]
    phony = re.search(r"^\.PHONY:(.*)$", (ROOT / "Makefile").read_text(), re.M).group(1).split()
    assert sorted(listed) == sorted(phony)
    for line in p.stdout.splitlines():
        assert len(line.split(None, 2)) == 3, f"target without a description: {line}"


def _table_cells(readme: str) -> set[str]:
    """What the first cell of every table row names in backticks."""
    return {name for m in re.finditer(r"^\| (`[^|]+`) \|", readme, re.M)
            for name in re.findall(r"`([^`]+)`", m.group(1))}


def test_firmware_readme_lists_every_crate():
    listed = _table_cells((ROOT / "firmware" / "README.md").read_text())
    fw = ROOT / "firmware"
    files = run(["git", "ls-files", "firmware/**Cargo.toml"]).stdout.split()
    crates = {str(Path(f).parent.relative_to("firmware")) for f in files
              if "[package]" in (ROOT / f).read_text()}
    assert crates - listed == set(), "crates missing from firmware/README.md's table"
    assert {c for c in listed if "/" in c or c == "fuzz"} - crates == set(), "rows without a crate"
    assert (fw / "apps" / "template" / "Cargo.toml").is_file()


def test_scripts_readme_lists_every_script():
    listed = _table_cells((ROOT / "scripts" / "README.md").read_text())
    scripts = {p.name for p in (ROOT / "scripts").iterdir()
               if p.is_file() and p.name not in ("README.md", "LICENSE.md")}
    scripts |= {f"{d}/{p.name}" for d in ("python", "freerouting")
                for p in (ROOT / "scripts" / d).iterdir() if p.name != "requirements.lock"}
    missing = scripts - listed
    assert missing == set(), "scripts missing from scripts/README.md's table"
