"""scripts/bom with off-board parts (r2ptools/offboard.py): a module's hardware/<module>/off-board.csv
is priced into bom/<module>-off-board.csv, the README's module and robot costs and the robot's
order; a malformed row stops generation with file:line, what is wrong and what to do. The
repository's own table (hardware/motor/off-board.csv) agrees with the heatsink model it quotes."""
from __future__ import annotations

import csv

import pytest

from conftest import ROOT
from test_bom import FIXTURES, bom, make_repo

HEADER = ("item,quantity,description,mpn,manufacturer,distributor,distributor_pn,"
          "unit_price_usd_qty10,source\n")
SINK = ('HS1,1,"Heatsink, 50 x 50 mm",SK 104 50 SA,Fischer Elektronik,Digi-Key,-,4.50,'
        "test data\n")
SCREW = "HS2,2,Screw M3 x 10,ISO 7045 M3x10 A2,any (standard part),any,-,0.05,test data\n"
TABLE = HEADER + SINK + SCREW

DEMO_OFF_BOARD_CSV = """\
item,quantity,description,mpn,manufacturer,distributor,distributor_pn,unit_price_usd_qty10,line_cost_usd
HS1,1,"Heatsink, 50 x 50 mm",SK 104 50 SA,Fischer Elektronik,Digi-Key,-,4.50,4.5000
HS2,2,Screw M3 x 10,ISO 7045 M3x10 A2,any (standard part),any,-,0.05,0.1000
TOTAL,3,,,,,,,4.6000
"""


def repo_with(tmp_path, table: str):
    repo = make_repo(tmp_path)
    (repo / "hardware" / "demo" / "off-board.csv").write_text(table)
    return repo


def test_off_board_parts_are_priced_and_join_the_robots_order(tmp_path):
    repo = repo_with(tmp_path, TABLE)
    rc, out = bom(repo, "generate")
    assert rc == 0, out
    assert (repo / "bom" / "demo-off-board.csv").read_text() == DEMO_OFF_BOARD_CSV
    duo = (repo / "bom" / "duo.csv").read_text().splitlines()
    assert ('ISO 7045 M3x10 A2,any (standard part),-,off-board,Screw M3 x 10,4,demo 2x2,0.05,0.2000'
            in duo)
    assert 'SK 104 50 SA,Fischer Elektronik,-,off-board,"Heatsink, 50 x 50 mm",2,demo 2x1,4.50,9.0000' in duo
    # the board's 4.9338 USD for two demo boards plus 2 × 4.60 of off-board parts
    assert duo[-1] == "TOTAL,,,,without future x1: not designed yet,18,,,14.1338"
    readme = (repo / "bom" / "README.md").read_text()
    assert "| demo | 2 | 3 | 4.60 | 7.07 | [demo-off-board.csv](demo-off-board.csv) |" in readme
    assert "| demo | 6 | 3 | 2.47 | [demo.csv](demo.csv) |" in readme          # the board's own BOM
    assert ("| demo ×2, future ×1 | 14.13 without future ×1 (not designed yet) | — | [duo.csv](duo.csv) |"
            in readme)
    assert bom(repo, "check") == (0, "bom: future: not designed yet (no hardware/future/future.kicad_sch): "
                                     "skipped\nbom: ok (4 generated file(s) current)\n")


def test_removing_the_table_removes_its_bom(tmp_path):
    repo = repo_with(tmp_path, TABLE)
    assert bom(repo, "generate")[0] == 0
    (repo / "hardware" / "demo" / "off-board.csv").unlink()
    rc, out = bom(repo, "check")
    assert rc == 1 and "bom: bom/demo-off-board.csv is out of date" in out
    assert bom(repo, "generate")[0] == 0
    assert not (repo / "bom" / "demo-off-board.csv").exists()


@pytest.mark.parametrize("table, message", [
    (HEADER + SINK.replace(",1,", ",two,", 1),
     "hardware/demo/off-board.csv:2: HS1: quantity 'two' is not a positive whole number: give how "
     "many one module needs"),
    (HEADER + SINK.replace(",1,", ",0,", 1), "hardware/demo/off-board.csv:2: HS1: quantity '0'"),
    (HEADER + SINK.replace(",4.50,", ",4,50,"),
     "hardware/demo/off-board.csv:2: more fields than the header's 9: quote a field that holds a comma"),
    (HEADER + SINK.replace(",4.50,", ",free,"),
     "hardware/demo/off-board.csv:2: HS1: unit_price_usd_qty10 'free' is not a positive price in USD"),
    (HEADER + SINK.replace(",Digi-Key,", ",,"),
     "hardware/demo/off-board.csv:2: HS1: no distributor: fill it in"),
    (HEADER + SINK + SINK.replace("HS1", "HS3"),
     "hardware/demo/off-board.csv:3: HS3: MPN SK 104 50 SA is already on line 2: one row per part"),
    (HEADER + SINK + SCREW.replace("HS2", "HS1"),
     "hardware/demo/off-board.csv:3: HS1: is already on line 2: one row per item"),
    (HEADER + SCREW.replace("ISO 7045 M3x10 A2", "STM32F103CBT6"),
     "hardware/demo/off-board.csv:2: HS2: MPN STM32F103CBT6 is a board part (bom/parts.csv): put it "
     "on the schematic, not here"),
    (HEADER.replace("distributor_pn", "order_code") + SINK,
     "hardware/demo/off-board.csv: the header must be exactly item,quantity,description,mpn,"
     "manufacturer,distributor,distributor_pn,unit_price_usd_qty10,source"),
    (HEADER, "hardware/demo/off-board.csv: no parts: delete the file if the module needs none"),
])
def test_a_malformed_table_is_named_and_nothing_is_written(tmp_path, table, message):
    repo = repo_with(tmp_path, table)
    rc, out = bom(repo, "generate")
    assert rc == 1
    assert any(line.startswith(message) for line in out.splitlines()), out
    assert "nothing written" in out and not (repo / "bom" / "demo.csv").exists()


def test_the_motor_table_quotes_the_heatsink_model():
    """HS101's source gives the model's R_th for the candidate's envelope; a changed model (or
    board loss) must be carried into the table."""
    from r2ptools.kicad.calc import heatsink, motor
    with open(ROOT / "hardware/motor/off-board.csv", newline="") as f:
        rows = {r["item"]: r for r in csv.DictReader(f)}
    sink = rows["HS101"]
    assert sink["mpn"] == "SK 88 100 SA" and sink["manufacturer"] == "Fischer Elektronik"
    cand = heatsink.best_in_envelope(*heatsink.CANDIDATE_MM, round(motor.board_loss(), 6), motor.T_AMB)
    assert f"gives {cand.r:.2f} C/W" in sink["source"] and "NOT VERIFIED" in sink["source"]
    assert all("NOT VERIFIED" in r["source"] or "estimate" in r["source"] for r in rows.values())


def test_the_motor_bom_has_the_parts_the_calculation_designs_with():
    """bom/motor.csv (the schematic's) carries the MOSFETs, driver, sensor, TVS and capacitors
    calc/motor.py is worked out for (the role the retired power-stage draft had)."""
    from r2ptools.kicad.calc import motor
    with open(ROOT / "bom/motor.csv", newline="") as f:
        qty: dict[str, int] = {}
        for r in csv.DictReader(f):
            qty[r["mpn"]] = qty.get(r["mpn"], 0) + int(r["quantity"])
    v = motor.DESIGN_VALUES
    assert qty.get(motor.FET) == 4 and qty.get(motor.DRV) == 1 and qty.get(motor.HALL) == 1
    assert qty.get(motor.TVS_MPN) == 1 and qty.get(motor.CER) == v["N_CER"]
    assert qty.get("EEU-FS1J102") == v["N_BULK"] and motor.ELCAP.startswith("Panasonic EEU-FS1J102")
