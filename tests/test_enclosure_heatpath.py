"""The motor case's heat path (scripts/r2ptools/enclosure/heatpath.py): gap pad, aluminium blocks,
heatsink on the case's underside and its screws, derived from the board and the case and proved
on the solids by the fit check. Each geometric test fails when one dimension is wrong."""
from __future__ import annotations

import copy

import pytest

from conftest import ROOT

from r2ptools.enclosure import board_facts, fit, heatpath, layout, params, solid
from r2ptools.enclosure.case_rules import DESIGN

MOTOR = ROOT / "enclosures" / "motor" / "motor.json"


@pytest.fixture(scope="module")
def doc() -> dict:
    return params.read_json(MOTOR)


@pytest.fixture(scope="module")
def case(doc) -> solid.Case:
    return solid.Case(solid.Params(doc))


def _plan(doc, design=DESIGN, stack=heatpath.STACK, window=None):
    """heatpath.plan on the committed board facts and case (no KiCad needed)."""
    b = board_facts.Board.from_dict(doc["board"])
    c = doc["case"]
    F = layout.Frame(b)
    holes = [tuple(h) for h in c["holes"]]
    return heatpath.plan(b, design, F, c["z"], c["interior"], [window or c["floor_windows"][0]], holes,
                         [tuple(m) for m in c["mounts"]], stack)


def test_the_stack_is_derived_from_board_and_case(doc):
    c, hp = doc["case"], doc["case"]["heat_path"]
    assert hp == _plan(doc)                               # the committed file is the plan
    # Two blocks: the motor XT60's leads (J102, MOT_A/MOT_B) stand between the legs.
    assert [b["tabs"] for b in hp["blocks"]] == [["Q101", "Q102"], ["Q103", "Q104"]]
    gap = c["z"]["board_bot"]                             # 6.5 mm boss on a 2 mm floor
    assert gap == 8.5
    for b, pad in zip(hp["blocks"], hp["pads"]):
        assert b["box"][2] == 0.0 and b["box"][5] == pytest.approx(gap - 0.7125)   # 7.79 mm
        assert pad[2] == b["box"][5] and pad[5] == gap
        assert b["bar"] == [12.0, 10.0]                   # 10.8 mm across, 7.79 mm tall, + 0.5 mm to face
    # A 1.25 mm putty pad squeezed to 0.7125 mm: +/-0.3 mm of stack (a printed layer, the block's
    # face, the sink's flatness) and +/-10 % of pad keep it within its maker's 10-70 % both ways,
    # exactly (1.0 mm would need 0.51-0.63 mm of gap at once).
    assert (hp["pad_t"], hp["compression"], hp["pad_compressed"]) == (1.25, 0.43, 0.7125)
    assert hp["compression_range"] == [0.1, 0.7] and hp["pad_thickest"] == 1.0125
    # The islands are the tabs: Q101's from the board (case frame: y flipped).
    assert hp["tabs"][0] == ["Q101", 60.6, 33.8, 71.4, 43.2]
    sc = hp["screw"]
    assert (sc["length"], sc["engagement"], sc["tapped_depth"]) == (6.0, 4.0, 5.0)
    # The sink keeps off the bus end's mounts: M5 head edge at x 45 + 4.75 + 0.5.
    assert hp["sink"][0] == 50.25 and hp["sink"][3] - hp["sink"][0] == 100.0


def test_the_committed_stack_fits(case):
    rep = fit.check(case)
    assert rep.ok, "\n".join(map(str, rep.findings))
    assert rep.nearest["block1"] == (0.5, "base")          # the window's min_clearance


def _findings(case, doc, change) -> list[str]:
    d = copy.deepcopy(doc)
    change(d["case"]["heat_path"])
    return [str(f) for f in fit.check(case.with_standin(d)).findings]


def test_a_block_half_a_mm_too_tall_is_caught(case, doc):
    def taller(hp):
        for b, p in zip(hp["blocks"], hp["pads"]):
            b["box"][5] += 0.5
            p[2] += 0.5
            p[5] += 0.5
    found = _findings(case, doc, taller)
    assert any(f.startswith("gap pad1 vs board: overlaps") for f in found), found
    assert "block1 vs board: clearance 0.213 mm < 0.7125 mm" in found, found    # the pad crushed by 0.5 mm


def test_a_block_too_short_leaves_the_pad_loose(case, doc):
    def shorter(hp):
        for b in hp["blocks"]:
            b["box"][5] -= 0.3
    found = _findings(case, doc, shorter)
    assert "gap pad1 vs block1: does not touch it (gap 0.300 mm)" in found, found


def test_a_block_off_the_window_or_near_live_leads_is_caught(case, doc):
    def shifted(hp):                       # 0.3 mm towards the window's edge: 0.2 mm left
        hp["blocks"][0]["box"][0] -= 0.3
    assert "block1 vs base: clearance 0.200 mm < 0.5 mm" in _findings(case, doc, shifted)

    def wide(hp):                          # block 2 reaching over to J102's leads (x 87.6 mm)
        hp["blocks"][1]["box"][0] = 87.9
    found = _findings(case, doc, wide)
    assert any(f.startswith("block2 vs J102 leads: clearance 0.300 mm < 0.6") for f in found), found


def test_a_pad_that_misses_an_island_is_caught(case, doc):
    def short_pad(hp):
        hp["pads"][0][4] -= 1.0
    assert "gap pad1 vs Q101 island: does not cover it" in _findings(case, doc, short_pad)


def test_the_sink_must_lie_on_the_case_and_the_screws_reach(case, doc):
    def lowered(hp):
        hp["sink"][2] -= 0.5
        hp["sink"][5] -= 0.5
    found = _findings(case, doc, lowered)
    assert "heatsink base vs base: does not touch it (gap 0.500 mm)" in found, found

    def short_screws(hp):
        hp["screw"]["length"] = 5.0
    found = _findings(case, doc, short_screws)
    assert "sink screw1 vs heatsink base: engages 3.00 mm < 3.75 mm" in found, found

    def long_screws(hp):
        hp["screw"]["length"] = 8.0
    assert "sink screw1 vs heatsink base: bottoms out: 6.00 mm > the 5.0 mm tapped hole" in \
        _findings(case, doc, long_screws)


def test_the_pad_absorbs_the_stack_and_its_own_tolerance():
    """The thinnest pad that stays in the window at every extreme of the stack and of its own
    thickness; a tighter print takes a thinner one, a sloppier stack or a narrow window none."""
    assert heatpath.pad_for(heatpath.STACK) == (1.25, pytest.approx(0.5375), pytest.approx(0.3))
    assert heatpath.pad_for(heatpath.Stack(print_z_tol=0.1))[0] == 1.0      # +/-0.2: 14-66 %
    # +/-0.25: a 1.0 mm pad would need a gap >= 0.58 and <= 0.56 mm; the pad's own 10 % decides it
    assert heatpath.pad_for(heatpath.Stack(print_z_tol=0.15))[0] == 1.25
    assert heatpath.pad_for(heatpath.Stack(print_z_tol=0.15, pad_thickness_tol=0.0))[0] == 1.0
    # a Shore 00 60 gap pad's 20-45 % cannot take +/-0.3 mm and +/-10 % below 5.2 mm
    with pytest.raises(board_facts.BoardError, match="within 20%-45% compression"):
        heatpath.pad_for(heatpath.Stack(compression_window=(0.20, 0.45)))
    assert heatpath.pad_for(heatpath.Stack(compression_window=(0.20, 0.45), pad_thickness_tol=0.0))[0] == 2.5
    with pytest.raises(board_facts.BoardError,
                       match=r"no pad of 5.0 mm or less keeps a \+/-1.30 mm stack and \+/-10% of its own"):
        heatpath.pad_for(heatpath.Stack(print_z_tol=1.2))


def test_the_compression_range_takes_the_pads_tolerance():
    """The loosest case is the thinnest pad on the widest gap, the tightest the thickest pad on
    the narrowest gap."""
    lo, hi = heatpath.compression_range(heatpath.STACK, 1.25, 0.7125, 0.3)
    assert (lo, hi) == (pytest.approx(1 - 1.0125 / 1.125), pytest.approx(1 - 0.4125 / 1.375))
    lo0, hi0 = heatpath.compression_range(heatpath.Stack(pad_thickness_tol=0.0), 1.25, 0.7125, 0.3)
    assert (lo0, hi0) == (pytest.approx(0.19), pytest.approx(0.67))


def test_impossible_geometry_is_refused(doc):
    w = doc["case"]["floor_windows"][0]
    with pytest.raises(board_facts.BoardError, match=r"block under Q101\+Q102 .* does not fit the floor window"):
        _plan(doc, window=[w[0] + 0.5, w[1], w[2], w[3]])
    with pytest.raises(board_facts.BoardError, match="leaves an M3 screw less than 3.75 mm"):
        _plan(doc, stack=heatpath.Stack(sink_base=4.0))
    with pytest.raises(board_facts.BoardError, match="larger than the flat bar sizes"):
        _plan(doc, stack=heatpath.Stack(bar_thicknesses=(4.0, 5.0, 6.0)))
    with pytest.raises(board_facts.BoardError, match="a 30 mm heatsink kept clear of the mounts .* does not cover the blocks"):
        _plan(doc, stack=heatpath.Stack(sink_x=30.0))
    # A bottom-side part under an island: no block can press a pad there.
    d = copy.deepcopy(doc)
    part = dict(d["board"]["parts"][0], ref="C999", side="bottom", x0=62.0, y0=8.0, x1=64.0, y1=10.0,
                leads=None, edge=None)
    d["board"]["parts"].append(part)
    with pytest.raises(board_facts.BoardError, match="C999 stand.* under Q101's tab island"):
        _plan(d)


def test_the_off_board_table_orders_the_stack_the_case_is_made_for(doc):
    """hardware/motor/off-board.csv is written by hand: its blocks, pad and screws must be the
    ones the case was generated for (a changed board or case changes the stack)."""
    import csv
    with open(ROOT / "hardware/motor/off-board.csv", newline="") as f:
        rows = {r["item"]: r for r in csv.DictReader(f)}
    hp = doc["case"]["heat_path"]
    (w, l, h), = {(round(b["box"][3] - b["box"][0], 4), round(b["box"][4] - b["box"][1], 4),
                   round(b["box"][5] - b["box"][2], 4)) for b in hp["blocks"]}
    block = rows["HS104"]
    assert int(block["quantity"]) == len(hp["blocks"])
    assert f"{w:.2f} x {l:.2f} x {h:.2f} mm" in block["description"]
    assert f"{hp['blocks'][0]['bar'][0]:g} x {hp['blocks'][0]['bar'][1]:g} mm flat bar" in block["description"]
    screw = rows["HS103"]
    assert int(screw["quantity"]) == len(hp["screws"])
    assert screw["mpn"] == f"ISO 7045 M3x{hp['screw']['length']:g} A2"
    assert f"tapped {hp['screw']['tapped_depth']:g} mm deep" in rows["HS101"]["description"]
    assert f"{w:.1f} x {l:.1f} mm each" in rows["HS102"]["description"]
