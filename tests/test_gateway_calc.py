"""The gateway's supply and PHY-clock numbers (calc/gateway.py) and the schematic they describe.

Issue 20, revision A fix: one AP2112K-3.3 for the whole board reached 138 °C worst case at 40 °C
ambient; the PHY now has its own regulator, each is held to TJ_LIMIT, and the 25 MHz crystal has
the series resistor DS00001989A's 100 µW case asks for. The numbers are checked here, and the
schematic is read to show the board is split the way the numbers assume.
"""
from __future__ import annotations

import shutil

import pytest

from conftest import ROOT
from r2ptools.kicad.calc import gateway as calc

SCH = ROOT / "hardware" / "gateway" / "gateway.kicad_sch"
VOUT, VIN, EN = "5", "1", "3"                  # AP2112K-3.3 SOT-23-5 (DS39724)
PHY_SUPPLY_PINS = {"9": "VDDIO", "19": "VDD1A", "1": "VDD2A"}     # LAN8742A SQFN-24


def test_each_regulator_stays_under_the_junction_limit_in_the_worst_case():
    r = calc.rails()
    assert set(r) == set(calc.REGULATORS) == {"U2", "U102"}
    for ref, x in r.items():
        assert x["tj_worst"] <= calc.TJ_LIMIT, f"{ref}: {x['tj_worst']:.0f} C at {calc.T_AMB:g} C ambient"
        assert x["tj_typ"] <= x["tj_worst"]
        # the ambient printed as the limit is where the worst case meets it
        assert abs(x["amb_limit"] + x["w_worst"] * calc.LDO_THETA_JA - calc.TJ_LIMIT) < 1e-9
        assert x["amb_limit"] >= calc.T_AMB
    # what issue 20 fixed: one regulator for all would not pass
    assert calc.single_ldo()["tj_worst"] > calc.TJ_LIMIT


def test_the_two_rails_carry_the_whole_budget_about_half_each():
    r, b = calc.rails(), calc.budget()
    assert abs(sum(x["typ_ma"] for x in r.values()) - b["typ_ma"]) < 1e-9
    assert abs(sum(x["worst_ma"] for x in r.values()) - b["worst_ma"]) < 1e-9
    for x in r.values():
        assert 0.35 < x["typ_ma"] / b["typ_ma"] < 0.65
    assert b["worst_ma"] <= calc.COUNTED_AS_MA


def test_a_regulator_over_its_limit_fails_the_calculation(monkeypatch, capsys):
    assert calc.main() == 0
    monkeypatch.setattr(calc, "CAN_MAX_MA", 120.0)     # U2's worst case past TJ_LIMIT
    assert calc.rails()["U2"]["tj_worst"] > calc.TJ_LIMIT
    assert calc.main() == 1


def test_the_crystal_needs_rs_and_rs_brings_it_within_its_rating(monkeypatch, capsys):
    d = calc.drive_level()
    assert d["no_rs_uw"] > calc.XTAL25_RATED_UW          # 0 ohm would overdrive it
    assert d["nom_uw"] <= calc.XTAL25_RATED_UW < d["no_rs_uw"]
    assert d["worst_uw"] > d["nom_uw"]                   # less capacitance, less attenuation
    assert abs(calc.XTAL25_RS_OHM / calc.XTAL25_RS_DATASHEET_OHM - 1) <= 0.05
    assert calc.drive_level(0.0)["nom_uw"] == pytest.approx(calc.XTAL25_DRIVE_UW)
    assert calc.BOARD_VALUES["R112"] == calc.XTAL25_RS_OHM
    monkeypatch.setattr(calc, "XTAL25_RS_OHM", 0.0)
    assert calc.main() == 1
    assert "drive level: no RS 300 uW" in capsys.readouterr().out


@pytest.fixture(scope="module")
def pins():
    if shutil.which("kicad-cli") is None:
        pytest.fail("kicad-cli is not installed: run scripts/setup (installs KiCad 9)", pytrace=False)
    from r2ptools.kicad import netlist
    return netlist.export(SCH).pin_nets()


def test_the_schematic_splits_the_supply_as_the_calculation_assumes(pins):
    mcu_rail, phy_rail = pins[("U2", VOUT)], pins[("U102", VOUT)]
    assert mcu_rail == "+3V3" and phy_rail.endswith("+3V3_PHY")
    for reg in ("U2", "U102"):
        assert pins[(reg, VIN)] == pins[(reg, EN)] == pins[("U2", VIN)], f"{reg} not on +5V_MOD"
    for pin, name in PHY_SUPPLY_PINS.items():
        assert pins[("U101", pin)] == phy_rail, f"LAN8742A {name}"
    for node in (("J101", "4"), ("J101", "5"), ("R102", "1"), ("R103", "1"), ("R104", "1"),
                 ("R105", "1"), ("C109", "1"), ("C110", "1")):
        assert pins[node] == phy_rail, f"{node}: centre taps and MDI terminations on the PHY's rail"
    u1 = {net for (ref, _), net in pins.items() if ref == "U1"}
    assert mcu_rail in u1 and phy_rail not in u1
    assert pins[("U3", "3")] == mcu_rail                 # SN65HVD230 VCC
    # both regulators have their input and output capacitors
    for cap, net in (("C8", pins[("U2", VIN)]), ("C7", mcu_rail), ("C111", pins[("U102", VIN)]),
                     ("C112", phy_rail)):
        assert pins[(cap, "1")] == net and pins[(cap, "2")] == "GND", cap


def test_rs_sits_between_xtal2_and_the_crystal(pins):
    xtal2, xo = pins[("U101", "4")], pins[("Y101", "3")]
    assert xtal2 != xo
    assert {pins[("R112", "1")], pins[("R112", "2")]} == {xtal2, xo}
    assert pins[("C102", "1")] == xo                     # the load capacitor on the crystal's side
    assert sorted(r for (r, _), n in pins.items() if n == xtal2) == ["R112", "U101"]


def test_the_readme_prints_what_the_calculation_prints():
    """hardware/gateway/README.md's design numbers are calc/gateway.py's output, pasted whole."""
    import re
    readme = (ROOT / "hardware" / "gateway" / "README.md").read_text()
    block = re.search(r"Design numbers \(`scripts/py -m r2ptools.kicad.calc.gateway`\):\n\n```\n(.*?)```",
                      readme, re.S)
    assert block, "the README's design-numbers block is gone"
    assert block.group(1) == calc.report() + "\n", \
        "paste `scripts/py -m r2ptools.kicad.calc.gateway` into hardware/gateway/README.md"
