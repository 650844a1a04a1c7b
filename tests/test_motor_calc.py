"""hardware/motor revision A: the power stage's design calculation (r2ptools/kicad/calc/motor.py).

Every row must hold; each test below changes one design value the way a careless edit would and
checks that the row guarding it fails, so the calculation cannot pass whatever the values are.
"""
from __future__ import annotations

import pytest

from r2ptools.kicad.calc import motor as calc


def row(prefix: str) -> calc.Row:
    found = [r for r in calc.rows() if r.what.startswith(prefix)]
    assert len(found) == 1, f"{len(found)} rows start with {prefix!r}"
    return found[0]


def test_every_design_row_holds(capsys):
    failing = [f"{r.what}: {r.value} vs {r.limit}" for r in calc.rows()
               if not r.ok and "traded" not in r.note]
    assert not failing, failing
    assert calc.main([]) == 0
    assert "FAIL" not in capsys.readouterr().out


def test_junction_meets_the_issue_limit_at_20_a_and_40_c():
    tj, p = calc.junction(calc.I_CONT, calc.VIN_MAX, calc.HEATSINK_RTH)
    assert tj <= calc.TJ_LIMIT
    # the losses are the equations', not typed numbers: conduction is 2 I² R(T_J)
    assert p["conduction (4 FETs)"] == pytest.approx(2 * 20 ** 2 * calc.rds(tj), rel=1e-3)


@pytest.mark.parametrize("name, value, guarded", [
    # the firmware's 100 k divider reads only up to 36.3 V: blind to the over-voltage trip
    ("R_VMOT_TOP", 100e3, "VMOT_SENSE full scale"),
    # one electrolytic fewer: each carries a third more ripple than it is rated for
    ("N_BULK", 3, "per electrolytic"),
    # a divider that trips the coast above the TVS's breakdown
    ("R_OV_TOP", 430e3, "over-voltage trip"),
    # an encoder filter that eats the encoder's edges
    ("C_ENC", 10e-9, "encoder filter corner"),
    # 100 nF bootstrap capacitors: the high-side gate sags 2.6 V over one on-time
    ("C_BS", 100e-9, "bootstrap droop"),
    # a 10 k / 150 k / 10 k window: its 3.106 V lies beyond the sensor's swing (never trips)
    ("R_OC_MID", 150e3, "over-current trip"),
    # a 1 µF VDD reservoir cannot refill the bootstrap capacitors
    ("C_VDD", 1e-6, "C_VDD vs the bootstrap"),
    # a 100 k zener feed: at the minimum input, Q106's base current drops VDD below the driver's minimum
    ("R_VDD_BIAS", 100e3, f"driver VDD at the {calc.VIN_MIN:.0f} V minimum input"),
])
def test_a_changed_board_value_fails_its_row(monkeypatch, name, value, guarded):
    assert row(guarded).ok
    monkeypatch.setitem(calc.DESIGN_VALUES, name, value)
    assert not row(guarded).ok


@pytest.mark.parametrize("name, value, guarded", [
    ("HALL_MV_PER_A", 90.0, "ACS725LLCTR-30AB-T ±30 A into the ADC"),   # the ACS711-15AB's gain
    ("HEATSINK_RTH", 8.0, "T_J worst FET at 20 A"),                     # a bare plate, not a finned sink
    ("PWM_HZ", 100e3, "T_J worst FET at 20 A"),                         # switching losses × 5
    ("FET_RDS_MAX", 12e-3, "T_J worst FET at 20 A"),                    # a 12 mΩ MOSFET
    ("DEAD_TIME_S", 0.0, "dead time vs turn-off"),                      # no TIM1 guard: 200 ns
    ("TVS_VC", 82.4, "HIP4082 AHS/BHS at the TVS clamp"),              # SMCJ51A's clamp
    ("ENCODER_MA", 85.0, "from the bus"),                               # HEDS-5540 at its max
    ("ELCAP_T_LOCAL", 95.0, "electrolytic life"),                       # capacitors in a hot case
    ("HALL_RANGE", 15.5, "current resolution"),                         # below ±30 A (issue 19)
    ("ZENER_V", (15.3, 16.0, 17.1), "driver VDD (zener − V_BE)"),    # a 16 V zener: VDD over 15 V
    ("Q106_HFE_MIN", 20.0, f"driver VDD at the {calc.VIN_MIN:.0f} V minimum input"),     # a low-gain pass transistor
    ("HALL_T_RESPONSE", 10e-6, "current at switch-off"),                # a filtered sensor: 1 kA shorts
    ("OC_SENS_TOL", 0.08, "over-current trip"),                         # a sloppier sensor: past the swing
    ("DRV_I_PEAK", 0.1, "dead time vs turn-off"),                       # a weak driver: ~1 µs turn-off
    ("OC_FILTER_C", 1e-9, "over-current input filter"),                 # τ 1 µs: a short passes I_DM
    ("OC_HYST_R", 10e6, "over-current hysteresis"),                     # 2.8 mV: inside the offsets
    ("OC_HYST_R", 20e3, "over-current hysteresis"),                     # idle lift past the swing
    ("PAD_PRESSURE_MAX", 100e3, "board bow under the pads"),         # a firm pad: 0.5 mm of bow
    ("PAD_K", 3.0, "T_J at the 23 A peak"),                             # a common 3 W/(m·K) pad: 111 °C
])

def test_a_changed_part_or_assumption_fails_its_row(monkeypatch, name, value, guarded):
    assert row(guarded).ok
    monkeypatch.setattr(calc, name, value)
    assert not row(guarded).ok


def test_the_firmware_duty_limit_keeps_the_bootstrap_refreshed(monkeypatch):
    """No charge pump: at 100 % duty the low side never conducts and the high side's gate supply
    runs down; the firmware's duty_limit maximum (params.rs, 0.95) is what the row reads."""
    assert calc.firmware_assumptions()["duty_limit max"] == pytest.approx(0.95)
    assert row("bootstrap refresh at the firmware's maximum duty").ok
    monkeypatch.setattr(calc, "max_duty", lambda: 1.0)
    assert not row("bootstrap refresh at the firmware's maximum duty").ok


def test_narrow_copper_fails_its_ipc_row(monkeypatch):
    narrow = tuple((n, a, tuple((seg, length, tuple(tuple((k, 2.0 if k != "vias" else 2) for k, v in c)
                                                    for c in conductors))
                                for seg, length, conductors in segs))
                   for n, a, segs in calc.PATHS)
    monkeypatch.setattr(calc, "PATHS", narrow)
    assert not any(r.ok for r in calc.rows() if r.what.startswith("copper "))


def test_one_oz_inner_layers_fail_the_planes(monkeypatch):
    """JLC's default 1 oz inner copper: the VMOT and GND planes no longer carry 20 A at +10 °C."""
    assert row("copper VMOT: bulk → legs").ok and row("copper GND: legs → bulk").ok
    monkeypatch.setattr(calc, "CU_INNER_UM", 35.0)
    assert not row("copper VMOT: bulk → legs").ok
    assert not row("copper GND: legs → bulk").ok


def test_too_few_vias_limit_the_layer_they_feed(monkeypatch):
    """A B.Cu pour reached through 3 vias (the previous drawing) carries what the vias carry."""
    name, amps, segs = next(p for p in calc.PATHS if p[0] == "motor A")
    assert row("copper motor A: phase node").ok
    few = ((seg, length, tuple(tuple((k, 3 if k == "vias" else v) for k, v in c) for c in conductors))
           for seg, length, conductors in segs)
    monkeypatch.setattr(calc, "PATHS", tuple(p if p[0] != "motor A" else (name, amps, tuple(few))
                                             for p in calc.PATHS))
    assert not row("copper motor A: phase node").ok


def test_the_peak_is_bounded_by_heat_and_by_the_sensor(monkeypatch):
    assert row(f"T_J at the {calc.I_PEAK:.0f} A peak").ok
    monkeypatch.setattr(calc, "PEAK_S", 600.0)        # ten minutes at 30 A warms the heatsink through
    assert not row(f"T_J at the {calc.I_PEAK:.0f} A peak").ok


def test_firmware_constants_are_read_from_their_sources():
    fw = calc.firmware_assumptions()
    assert set(fw) == {"HALL_MV_PER_A", "VMOT_DIVIDER_TOP_OHM", "VMOT_DIVIDER_BOTTOM_OHM",
                       "pwm_hz", "dead_time_s", "current_limit max", "duty_limit max",
                       "bridge.rs PWM_HZ", "bridge.rs DEAD_TIME_NS"}
    # the board was designed around the firmware's PWM and dead time: those agree; the world
    # model's dead time is TIM1's plus the gate driver's own (the FETs see both)
    assert fw["pwm_hz"] == fw["bridge.rs PWM_HZ"] == calc.PWM_HZ
    assert fw["bridge.rs DEAD_TIME_NS"] == pytest.approx(calc.DEAD_TIME_S)
    assert fw["dead_time_s"] == pytest.approx(calc.DEAD_TIME_S + sum(calc.DRV_DEL_25C) / 2)
    assert calc.DRV_DEL_S[0] <= sum(calc.DRV_DEL_25C) / 2 <= calc.DRV_DEL_S[1]
    moved = dict(fw, pwm_hz=25_000.0)
    assert any(c.startswith("pwm_hz") for c in calc.firmware_changes(moved))


def test_firmware_agrees_with_the_board():
    assert calc.firmware_changes() == []


def test_the_readme_table_is_the_calculations():
    text = calc.README.read_text()
    assert calc.readme_with_table(text) == text, \
        "hardware/motor/README.md is stale: run scripts/py -m r2ptools.kicad.calc.motor --readme"


def test_a_stale_readme_table_is_caught(monkeypatch):
    text = calc.README.read_text()
    monkeypatch.setitem(calc.DESIGN_VALUES, "N_BULK", 5)
    assert calc.readme_with_table(text) != text


def _segment(name: str):
    """calc/motor.py's conductors for segment `name`, as {layer or "vias": [sizes]}."""
    for _, _, segs in calc.PATHS:
        for seg, _, conductors in segs:
            if seg == name:
                found: dict[str, list[float]] = {}
                for pieces in conductors:
                    for kind, size in pieces:
                        found.setdefault(kind, []).append(size)
                return found
    raise KeyError(name)


def test_the_paths_are_the_boards_copper():
    """Each outer-layer width and via count calc/motor.py credits is what hardware/motor/motor.py
    draws: a narrowed track, a smaller pour or a missing via there fails here."""
    from r2ptools.kicad import modules
    m = modules.build("motor")

    def width(net, layer, end=None):   # the narrowest track of `net` on `layer` (ending at `end`)
        return min(t.width for t in m.tracks if t.net == net and t.layer == layer
                   and (end is None or end in t.points))

    def pour(net, layer, axis, x0=0.0, x1=1e3):   # a pour's extent across the current
        (z,) = [z for z in m.zones if z.net == net and z.layer == layer and z.priority > 2
                and x0 <= min(p[0] for p in z.polygon) <= x1]
        return round(max(p[axis] for p in z.polygon) - min(p[axis] for p in z.polygon), 3)

    def vias(net, x0, x1, y0, y1):
        return sum(1 for v in m.vias if v.net == net and x0 <= v.x <= x1 and y0 <= v.y <= y1)

    seg = _segment("leg B → XT60")
    xt60_pin2 = (84.0, 34.6)
    assert [width("MOT_B", "F.Cu", xt60_pin2), width("MOT_B", "B.Cu", xt60_pin2)] == \
        seg["F.Cu"] + seg["B.Cu"]
    seg = _segment("XT60 + → fuse")
    assert width("VBAT", "F.Cu") >= seg["F.Cu"][0] and width("VBAT", "B.Cu") >= seg["B.Cu"][0]
    assert vias("VBAT", 140, 150, 36, 42) == seg["vias"][0]
    seg = _segment("fuse → bulk")
    assert vias("VMOT", 129, 135, 36, 41) == seg["vias"][0]
    seg = _segment("phase node → ACS725 IP+")
    assert [pour("SW_A", layer, 1, 68.5, 70) for layer in ("F.Cu", "B.Cu")] == seg["F.Cu"] + seg["B.Cu"]
    assert vias("SW_A", 71.3, 79, 21, 26) == seg["vias"][0]
    seg = _segment("ACS725 IP− → XT60")
    assert [pour("MOT_A", "F.Cu", 0), pour("MOT_A", "B.Cu", 0)] == seg["F.Cu"] + seg["B.Cu"]
    assert vias("MOT_A", 74, 80, 26, 35) == seg["vias"][0]
    seg = _segment("low-side source → In1.Cu")
    for leg_x, _ in m_legs():
        assert vias("GND", leg_x + 0.5, leg_x + 4.6, 41.5, 46) == seg["vias"][0]
    seg = _segment("high side's source → phase node")
    for leg_x, phase in m_legs():
        assert [pour(phase, layer, 0, leg_x + 0.5, leg_x + 2) for layer in ("F.Cu", "B.Cu")] == \
            seg["F.Cu"] + seg["B.Cu"]
        assert vias(phase, leg_x, leg_x + 5.2, 17, 24) == seg["vias"][0]
    seg = _segment("In2.Cu → high-side tab")
    for leg_x, _ in m_legs():
        assert vias("VMOT", leg_x - 5, leg_x + 5, 7, 15) == seg["vias"][0]


def m_legs():
    from r2ptools.kicad.modules import description_file, _load
    return _load(description_file("motor")).LEGS.values()
