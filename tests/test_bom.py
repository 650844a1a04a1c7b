"""scripts/bom: parts database, per-module and robot BOMs with cost, completeness check.

Each case builds a repository in tmp_path from tests/fixtures/bom (parts.csv, a robot, a README
with the summary markers; prices there are test data) and a real KiCad schematic written by
tests/fixtures/pins/mksch.py, read through kicad-cli like a real board."""
from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest

from conftest import ROOT, run

sys.path.insert(0, str(ROOT / "tests" / "fixtures" / "pins"))
from mksch import Part, write_schematic  # noqa: E402

FIXTURES = ROOT / "tests" / "fixtures" / "bom"
BOM = str(ROOT / "scripts" / "bom")
SCH = "hardware/demo/demo.kicad_sch"
R0402, C0402 = "Resistor_SMD:R_0402_1005Metric", "Capacitor_SMD:C_0402_1005Metric"
R10K = {"MPN": "0402WGF1002TCE", "Manufacturer": "UNI-ROYAL(Uniroyal Elec)", "LCSC": "C25744"}
C100N = {"MPN": "CL05B104KO5NNNC"}


def parts(**override) -> list[Part]:
    """R1, R2 (10k), C1, C2 (100n), R10 (10k), a DNP R3 and an excluded-from-BOM TP1: neither of
    the last two needs an MPN."""
    p = {"R1": Part("R1", "Device:R", "10k", R0402, {"1": "BOOT1", "2": "GND"}, R10K),
         "R2": Part("R2", "Device:R", "10k", R0402, {}, R10K),
         "R10": Part("R10", "Device:R", "10k", R0402, {}, {"MPN": "0402WGF1002TCE"}),
         "C1": Part("C1", "Device:C", "100n", C0402, {"1": "+3V3", "2": "GND"}, C100N),
         "C2": Part("C2", "Device:C", "100n", C0402, {}, C100N),
         "R3": Part("R3", "Device:R", "1k", R0402, {}, {}, dnp=True),
         "TP1": Part("TP1", "Device:R", "TP", "", {}, {}, in_bom=False)}
    p.update(override)
    return [v for v in p.values() if v is not None]


def make_repo(tmp: Path, symbols: list[Part] | None = None, parts_csv: str | None = None) -> Path:
    (tmp / "bom" / "robots").mkdir(parents=True)
    shutil.copy(FIXTURES / "README.md", tmp / "bom")
    shutil.copy(FIXTURES / "robots" / "duo.toml", tmp / "bom" / "robots")
    (tmp / "bom" / "parts.csv").write_text(parts_csv or (FIXTURES / "parts.csv").read_text())
    (tmp / "hardware" / "future").mkdir(parents=True)
    write_schematic(tmp / SCH, {"PB2": "BOOT1"}, parts() if symbols is None else symbols)
    (tmp / SCH).with_suffix(".kicad_pro").write_text("{}\n")
    return tmp


def bom(repo: Path, command: str):
    result = run([BOM, command, "--root", str(repo)])
    return result.returncode, result.stdout


DEMO_CSV = """\
references,quantity,value,footprint,mpn,manufacturer,lcsc,unit_price_usd_qty10,line_cost_usd
"C1,C2",2,100n,Capacitor_SMD:C_0402_1005Metric,CL05B104KO5NNNC,Samsung Electro-Mechanics,C1525,0.0021,0.0042
"R1,R2,R10",3,10k,Resistor_SMD:R_0402_1005Metric,0402WGF1002TCE,UNI-ROYAL(Uniroyal Elec),C25744,0.0009,0.0027
U1,1,STM32F103CBTx,Package_QFP:LQFP-48_7x7mm_P0.5mm,STM32F103CBT6,STMicroelectronics,C8323,2.46,2.4600
TOTAL,6,,,,,,,2.4669
"""
DUO_CSV = """\
mpn,manufacturer,lcsc,package,description,quantity,used_in,unit_price_usd_qty10,line_cost_usd
0402WGF1002TCE,UNI-ROYAL(Uniroyal Elec),C25744,0402,10 kΩ ±1% 62.5 mW thick film resistor,6,demo 2x3,0.0009,0.0054
CL05B104KO5NNNC,Samsung Electro-Mechanics,C1525,0402,100 nF 16 V X7R ceramic capacitor,4,demo 2x2,0.0021,0.0084
STM32F103CBT6,STMicroelectronics,C8323,LQFP-48,"Arm Cortex-M3 MCU, 128 KB flash, 20 KB RAM, 72 MHz",2,demo 2x1,2.46,4.9200
TOTAL,,,,without future x1: not designed yet,12,,,4.9338
"""


def test_generate_writes_module_and_robot_boms_with_cost_and_the_summary(tmp_path):
    repo = make_repo(tmp_path)
    rc, out = bom(repo, "generate")
    assert rc == 0, out
    assert "bom: future: not designed yet (no hardware/future/future.kicad_sch): skipped" in out
    assert (repo / "bom" / "demo.csv").read_text() == DEMO_CSV
    assert (repo / "bom" / "duo.csv").read_text() == DUO_CSV
    readme = (repo / "bom" / "README.md").read_text()
    assert "| demo | 6 | 3 | 2.47 | [demo.csv](demo.csv) |" in readme
    assert "| future | | | not designed yet | |" in readme
    assert ("| [Duo](robots/duo.toml): two demo boards | demo ×2, future ×1 | 4.93 without future ×1 "
            "(not designed yet) | — | [duo.csv](duo.csv) |") in readme    # no .kicad_pcb: not assembled
    assert "### Off-board parts" not in readme
    assert readme.startswith("# Fixture bom/README.md") and readme.endswith(
        "<!-- END generated -->\nText after the summary stays.\n")


def test_a_part_lcsc_does_not_stock_is_listed_for_consignment(tmp_path):
    csv = (FIXTURES / "parts.csv").read_text().replace(",C1525,", ",-,")
    repo = make_repo(tmp_path, parts_csv=csv)
    rc, out = bom(repo, "generate")
    assert rc == 0, out
    assert "CL05B104KO5NNNC,Samsung Electro-Mechanics,-,0.0021" in (repo / "bom" / "demo.csv").read_text()
    assert "Not stocked by LCSC (`-` in `parts.csv`): `CL05B104KO5NNNC`." in \
        (repo / "bom" / "README.md").read_text()


def test_a_shared_sheet_is_not_a_module(tmp_path):
    repo = make_repo(tmp_path)
    (repo / "hardware" / "core").mkdir()
    shutil.copy(repo / SCH, repo / "hardware" / "core" / "core.kicad_sch")
    rc, out = bom(repo, "generate")
    assert rc == 0, out
    assert "core" not in out and not (repo / "bom" / "core.csv").exists()
    assert "| core |" not in (repo / "bom" / "README.md").read_text()


def test_generation_is_reproducible_and_check_sees_stale_files(tmp_path):
    repo = make_repo(tmp_path)
    assert bom(repo, "generate")[0] == 0
    first = {p.name: p.read_bytes() for p in (repo / "bom").glob("*.*")}
    rc, out = bom(repo, "generate")
    assert rc == 0 and "wrote" not in out
    assert {p.name: p.read_bytes() for p in (repo / "bom").glob("*.*")} == first
    rc, out = bom(repo, "check")
    assert rc == 0 and "bom: ok (3 generated file(s) current)" in out, out

    (repo / "bom" / "demo.csv").write_text(DEMO_CSV.replace("2.4669", "2.47"))
    (repo / "bom" / "old.csv").write_text("x\n")
    rc, out = bom(repo, "check")
    assert rc == 1
    assert "bom: bom/demo.csv is out of date: run scripts/bom generate and commit it" in out
    assert "bom: bom/old.csv is out of date: run scripts/bom generate and commit it" in out
    assert bom(repo, "generate")[0] == 0
    assert not (repo / "bom" / "old.csv").exists()
    assert (repo / "bom" / "demo.csv").read_text() == DEMO_CSV


def test_a_symbol_without_mpn_names_the_reference_field_and_file(tmp_path):
    repo = make_repo(tmp_path, parts(C2=Part("C2", "Device:C", "100n", C0402, {}, {})))
    rc, out = bom(repo, "generate")
    assert rc == 1
    assert (f"demo: C2 (100n) has no MPN field in {SCH}: add the manufacturer part number, and its "
            "row to bom/parts.csv") in out.splitlines()
    assert "bom: 1 problem(s); nothing written" in out
    assert not (repo / "bom" / "demo.csv").exists()


def test_an_mpn_without_a_row(tmp_path):
    repo = make_repo(tmp_path, parts(R2=Part("R2", "Device:R", "4k7", R0402, {}, {"MPN": "0402WGF4701TCE"})))
    rc, out = bom(repo, "check")
    assert rc == 1
    assert f"demo: R2 MPN 0402WGF4701TCE ({SCH}) has no row in bom/parts.csv" in out.splitlines()


def test_an_incomplete_row_is_reported_for_the_row_and_for_each_reference(tmp_path):
    text = (FIXTURES / "parts.csv").read_text().replace(
        ",https://product.samsungsem.com/mlcc/CL05B104KO5NNN.do,", ",,")
    rc, out = bom(make_repo(tmp_path, parts_csv=text), "check")
    assert rc == 1
    lines = out.splitlines()
    assert "bom/parts.csv:3: CL05B104KO5NNNC: no datasheet" in lines
    assert f"demo: C1 MPN CL05B104KO5NNNC ({SCH}): bom/parts.csv:3 has no datasheet" in lines
    assert f"demo: C2 MPN CL05B104KO5NNNC ({SCH}): bom/parts.csv:3 has no datasheet" in lines
    assert "bom: 3 problem(s)" in lines


@pytest.mark.parametrize("old, new, message", [
    (",2.46,", ",about 2,", "STM32F103CBT6: unit_price_usd_qty10 'about 2' is not a positive price in "
                            "USD (e.g. 0.0123)"),
    (",C8323,", ",8323,", "STM32F103CBT6: lcsc '8323' is not an LCSC part number (C followed by digits; - if LCSC does not stock the part)"),
    ("https://www.st.com", "www.st.com", "STM32F103CBT6: datasheet 'www.st.com/resource/en/datasheet/"
                                         "stm32f103cb.pdf' is not an http(s) link"),
])
def test_malformed_fields(tmp_path, old, new, message):
    text = (FIXTURES / "parts.csv").read_text().replace(old, new)
    rc, out = bom(make_repo(tmp_path, parts_csv=text), "check")
    assert rc == 1
    assert f"bom/parts.csv:4: {message}" in out.splitlines()


def test_database_header_and_duplicates(tmp_path):
    text = (FIXTURES / "parts.csv").read_text()
    rc, out = bom(make_repo(tmp_path, parts_csv=text.replace("lcsc,", "lcsc_part,", 1)), "check")
    assert rc == 1
    assert ("bom/parts.csv: the header must be exactly mpn,manufacturer,lcsc,package,"
            "unit_price_usd_qty10,datasheet,description (found mpn,manufacturer,lcsc_part,package,"
            "unit_price_usd_qty10,datasheet,description)") in out
    lines = text.splitlines()
    rc, out = bom(make_repo(tmp_path / "b", parts_csv="\n".join(lines + [lines[2]]) + "\n"), "check")
    assert rc == 1
    assert "bom/parts.csv:5: CL05B104KO5NNNC is already on line 3: one row per part" in out


def test_schematic_fields_must_agree_with_the_database(tmp_path):
    wrong = {**R10K, "LCSC": "C25745", "Manufacturer": "YAGEO"}
    repo = make_repo(tmp_path, parts(R2=Part("R2", "Device:R", "10k", R0402, {}, wrong)))
    rc, out = bom(repo, "check")
    assert rc == 1
    lines = out.splitlines()
    assert (f"demo: R2 Manufacturer YAGEO in {SCH} differs from UNI-ROYAL(Uniroyal Elec) in "
            "bom/parts.csv:2 for 0402WGF1002TCE") in lines
    assert f"demo: R2 LCSC C25745 in {SCH} differs from C25744 in bom/parts.csv:2 for 0402WGF1002TCE" in lines


def test_one_part_on_two_footprints(tmp_path):
    repo = make_repo(tmp_path, parts(R2=Part("R2", "Device:R", "10k", "Resistor_SMD:R_0603_1608Metric",
                                             {}, R10K)))
    rc, out = bom(repo, "check")
    assert rc == 1
    assert (f"demo: R1 and R2 are both 0402WGF1002TCE but have footprints {R0402} and "
            f"Resistor_SMD:R_0603_1608Metric in {SCH}") in out.splitlines()


def test_robot_files_are_checked(tmp_path):
    repo = make_repo(tmp_path)
    (repo / "bom" / "robots" / "bad.toml").write_text(
        '[robot]\nname = "Bad"\ndescription = "x"\n[modules]\ndemo = 0\nwheel = 1\n')
    rc, out = bom(repo, "check")
    assert rc == 1
    lines = out.splitlines()
    assert "bom/robots/bad.toml: [modules] demo = 0: a count must be a positive integer" in lines
    assert "bom/robots/bad.toml: [modules] wheel is not a module (hardware/ has demo, future)" in lines


def test_a_designed_module_needs_the_database(tmp_path):
    repo = make_repo(tmp_path)
    (repo / "bom" / "parts.csv").unlink()
    rc, out = bom(repo, "check")
    assert rc == 1
    assert ("bom/parts.csv does not exist: create it with the header mpn,manufacturer,lcsc,package,"
            "unit_price_usd_qty10,datasheet,description and one row per part") in out


def test_the_repositorys_boms_are_complete_and_current():
    """Every designed module's parts are in bom/parts.csv; bom/*.csv and the README summary are
    what `scripts/bom generate` writes; modules without a schematic are named as skipped."""
    result = run([BOM, "check"])
    assert result.returncode == 0, result.stdout
    for module in sorted(d.name for d in (ROOT / "hardware").iterdir() if d.is_dir()):
        if module == "core":
            continue                      # the shared sheet: its parts count in every module
        designed = (ROOT / "hardware" / module / f"{module}.kicad_sch").is_file()
        assert designed == (ROOT / "bom" / f"{module}.csv").is_file(), module
        if not designed:
            assert f"bom: {module}: not designed yet" in result.stdout
