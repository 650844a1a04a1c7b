"""The assembled cost a maker sees in bom/README.md: joints counted from the board, the right
PCBA kind, extended parts charged once each, fee-file mistakes named."""
from __future__ import annotations

from decimal import Decimal
from pathlib import Path

import pytest

from conftest import ROOT
from r2ptools import assembly_cost as ac
from r2ptools.kicad import fab

FEES = ROOT / "bom" / "jlcpcb-fees.toml"


def _fp(ref: str, layer: str, attr: str, pads: list[str]) -> str:
    pad_text = " ".join(f'(pad "{i + 1}" {kind} rect (at 0 0) (size 1 1) (layers "{layer}"))'
                        for i, kind in enumerate(pads))
    return (f'(footprint "X:Y" (layer "{layer}") (property "Reference" "{ref}") (attr {attr}) '
            f'{pad_text})')


def _board(tmp_path: Path, *footprints: str) -> Path:
    pcb = tmp_path / "b.kicad_pcb"
    pcb.write_text("(kicad_pcb (version 20241229) " + " ".join(footprints) + ")\n")
    return pcb


def _fees(**basic) -> ac.Fees:
    f = ac.load_fees(FEES, "bom/jlcpcb-fees.toml")
    return ac.Fees(f.economic, f.standard, f.any, frozenset(basic.get("basic", f.basic)), f.checked)


def test_joints_count_smd_and_tht_pads_but_not_the_vias_of_an_exposed_pad(tmp_path):
    pcb = _board(tmp_path,
                 _fp("U1", "F.Cu", "smd", ["smd"] * 4 + ["thru_hole"] * 6),   # QFN with thermal vias
                 _fp("J1", "F.Cu", "through_hole", ["thru_hole"] * 8 + ["np_thru_hole"] * 2),
                 _fp("R1", "B.Cu", "smd", ["smd", "smd"]))
    j = ac.board_joints(pcb)
    assert j["U1"] == ac.Joints(4, 0, False)
    assert j["J1"] == ac.Joints(0, 8, False)
    assert j["R1"] == ac.Joints(2, 0, True)


def test_an_smd_part_on_the_back_makes_the_order_a_two_sided_standard_pcba(tmp_path):
    lines = [ac.Line(("R1",), "C25804", Decimal("0.01"))]
    fees = _fees()
    top = ac.board_joints(_board(tmp_path, _fp("R1", "F.Cu", "smd", ["smd", "smd"])))
    e = ac.estimate(lines, top, fees, 10)
    assert e.kind == "economic" and e.setup == fees.economic["setup"]
    bottom = ac.board_joints(_board(tmp_path, _fp("R1", "B.Cu", "smd", ["smd", "smd"])))
    e = ac.estimate(lines, bottom, fees, 10)
    assert e.kind == "standard (two sides)"
    assert e.setup == 2 * fees.standard["setup_per_side"]
    assert e.stencil == 2 * fees.standard["stencil_per_side"]


def test_each_distinct_extended_part_is_charged_once_and_basic_parts_not_at_all(tmp_path):
    joints = ac.board_joints(_board(tmp_path, *[_fp(r, "F.Cu", "smd", ["smd", "smd"])
                                                for r in ("R1", "R2", "U1", "U2")]))
    lines = [ac.Line(("R1", "R2"), "C25804", Decimal("0.002")),
             ac.Line(("U1",), "C8323", Decimal("4.2")), ac.Line(("U2",), "C51118", Decimal("0.08"))]
    e = ac.estimate(lines, joints, _fees(basic={"C25804"}), 10)
    assert e.extended == 2 and e.loading == 2 * _fees().any["extended_part_loading"]
    assert e.smd_joints == 8 and e.smt == _fees().economic["smt_joint"] * 8 * 10
    assert e.parts == (Decimal("0.004") + Decimal("4.2") + Decimal("0.08")) * 10
    assert e.tht == 0


def test_through_hole_parts_pay_the_hand_soldering_labour_once_and_each_joint_per_board(tmp_path):
    joints = ac.board_joints(_board(tmp_path, _fp("J1", "F.Cu", "through_hole", ["thru_hole"] * 4)))
    fees = _fees()
    e10 = ac.estimate([ac.Line(("J1",), "C1", Decimal(1))], joints, fees, 10)
    e100 = ac.estimate([ac.Line(("J1",), "C1", Decimal(1))], joints, fees, 100)
    assert e10.tht == fees.any["hand_soldering_labour"] + fees.any["tht_joint"] * 40
    assert e100.tht == fees.any["hand_soldering_labour"] + fees.any["tht_joint"] * 400
    assert e100.per_board < e10.per_board


def test_a_bom_part_missing_from_the_board_is_named(tmp_path):
    joints = ac.board_joints(_board(tmp_path, _fp("R1", "F.Cu", "smd", ["smd"])))
    with pytest.raises(KeyError, match="R2"):
        ac.estimate([ac.Line(("R1", "R2"), "C1", Decimal(1))], joints, _fees(), 10)


@pytest.mark.parametrize("text, complaint", [
    ("[fees]\nchecked = '2026-11'\n", "missing table [fees.economic]"),
    (FEES.read_text().replace("setup = 8.00", "setup = 'eight'"), "[fees.economic] setup = 'eight'"),
    (FEES.read_text().replace('checked = "2026-11"', ""), "checked"),
    (FEES.read_text().replace('"C21190",', '"21190",'), "[basic] lcsc"),
])
def test_a_malformed_fee_file_is_a_clear_error(tmp_path, text, complaint):
    path = tmp_path / "fees.toml"
    path.write_text(text)
    with pytest.raises(ac.FeeError) as e:
        ac.load_fees(path, "bom/jlcpcb-fees.toml")
    assert complaint in str(e.value) and "bom/jlcpcb-fees.toml" in str(e.value)


def test_the_readme_states_the_assembled_cost_of_every_board():
    text = (ROOT / "bom" / "README.md").read_text()
    for board in fab.FAB_BOARDS:
        row = next(l for l in text.splitlines() if l.startswith(f"| {board} | economic")
                   or l.startswith(f"| {board} | standard"))
        per10, per100 = (Decimal(x) for x in row.strip("| ").split(" | ")[-2:])
        assert per10 > per100 > 0


@pytest.mark.parametrize("board", ["proximity", "psu"])
def test_every_shipped_board_is_a_one_sided_economic_order(board):
    """A single SMD part on the back turns the order into a two-sided standard PCBA (about 60 USD
    more per order, bom/README.md): every part of a shipped board stays on the top side. Copper
    that is not placed (test pads, fiducials: not in the CPL) may sit on the back."""
    from r2ptools.kicad import jlc
    pcb = ROOT / "hardware" / board / f"{board}.kicad_pcb"
    joints = ac.board_joints(pcb)
    placed, _ = jlc.parts(pcb)
    back = sorted(p.ref for p in placed if p.bottom and joints[p.ref].smd)
    assert not back, f"{board}: SMD parts on the back make a standard PCBA order: {back}"
