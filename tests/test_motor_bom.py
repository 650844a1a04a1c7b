"""hardware/motor/power-stage-bom.csv: the parts draft adds up and is the design calculation's."""
from __future__ import annotations

import shutil

from r2ptools.kicad.calc import motor, motor_bom


def test_the_draft_adds_up_and_matches_the_calculation():
    assert motor_bom.problems() == []
    assert motor_bom.main() == 0


def test_a_line_whose_cost_is_not_quantity_times_price_is_reported(tmp_path):
    draft = tmp_path / "bom.csv"
    text = motor_bom.DRAFT.read_text().replace(",3.50,14.0000,", ",3.50,13.0000,")
    draft.write_text(text)
    found = motor_bom.problems(draft)
    assert any("Q101" in p and "line cost 13.0000" in p for p in found), found
    assert any(p.startswith("TOTAL") for p in found), found


def test_a_design_with_more_capacitors_than_the_draft_is_reported(monkeypatch, tmp_path):
    draft = tmp_path / "bom.csv"
    shutil.copy(motor_bom.DRAFT, draft)
    monkeypatch.setitem(motor.DESIGN_VALUES, "N_BULK", 5)
    assert motor_bom.problems(draft) == [
        "calc/motor.py designs with 5 bulk electrolytics; the draft has 4"]


def test_a_different_mosfet_in_the_calculation_is_reported(monkeypatch):
    monkeypatch.setattr(motor, "FET", "CSD19535KTT")
    assert "calc/motor.py designs with 4 × CSD19535KTT; the draft has 0" in motor_bom.problems()


def test_assembly_counts_every_unlooked_up_part_as_extended():
    c = motor_bom.assembled_cost(10)
    lines, _, _ = motor_bom.load()
    basic = motor_bom.load_fees(motor_bom.FEES, "fees").basic
    assembled = [ln for ln in lines if ln.footprint != motor_bom.OFF_BOARD]
    assert int(c["extended parts"]) == sum(1 for ln in assembled if ln.lcsc not in basic)
    assert c["assembly"] > motor_bom.assembled_cost(100)["assembly"]    # setup shared by more boards
