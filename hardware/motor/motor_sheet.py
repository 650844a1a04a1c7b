"""How the motor module's root sheet is drawn (hardware/motor/motor.kicad_sch).

Top row, along the motor current, left to right: the battery input (XT60, fuse, TVS, bulk and
commutation-loop capacitors) feeding VMOT; the H-bridge (leg A left, leg B right, high sides
above) with the Hall sensor in leg A's output and the motor connector. Second row: the gate
driver (MCU inputs on its left, gates and phase senses on its right, its VDD regulator and the
bootstrap parts around it), under it the over-current window; the supply sense and over-voltage
trip; the encoder input. Bottom left the bus tap.
The core sheet's box (the MCU, page 2) on the right. Only the MCU's signals, VMOT, the phase
nodes and the gate nets meet by label between blocks. Grid units of 2.54 mm (drawing.py); every
number in the notes is a row of calc/motor.py, looked up by its name (a renamed row fails here).
"""
from __future__ import annotations

from r2ptools.kicad.calc import motor as calc
from r2ptools.kicad.design import At, Block

A = At
_ROWS = {r.what: r for r in calc.rows()}


def _v(what: str) -> str:
    """The value calc/motor.py prints for row `what` (KeyError if the row is renamed)."""
    return _ROWS[what].value


_REFRESH = f"bootstrap refresh at the firmware's maximum duty {calc.max_duty():.2f}"

DRAWING = {
    # battery input: VBAT line at y = 11, VMOT rail at y = 14 (capacitor tops)
    "J101": A(8, 12, 180), "F102": A(16, 11, 90), "D101": A(22, 15.5, 270),
    **{f"C{101 + i}": A(28 + 5 * i, 15.5) for i in range(4)},
    **{f"C{105 + i}": A(48 + 4.5 * (i % 4), 15.5 if i < 4 else 22.5) for i in range(8)},
    "flag:VMOT": A(19, 8), "flag:GND": A(8, 17),
    # H-bridge: drains on VMOT at y = 10, sources to GND at y = 24
    "R101": A(74, 12, 90), "Q101": A(80, 12), "R102": A(74, 22, 90), "Q102": A(80, 22),
    "R103": A(98, 12, 90), "Q103": A(104, 12), "R104": A(98, 22, 90), "Q104": A(104, 22),
    "U102": A(90, 32), "C119": A(84, 27.5), "R107": A(99, 32, 90), "C120": A(103, 33.5),
    "J102": A(120, 20),
    # gate driver: inputs on the left, the enable inverter before DIS, VDD's regulator above,
    # the bootstrap diodes and capacitors on the right
    "U101": A(30, 72),
    "R105": A(22, 79.5), "flag:DRV_VDD": A(58, 57), "R106": A(20, 64.5), "Q105": A(14, 70), "R115": A(9, 73.5),
    "Q106": A(44, 56), "R120": A(40, 51.5), "D105": A(40, 58.5, 270), "C118": A(37, 58.5),
    "C113": A(50, 60.5), "C116": A(54, 60.5),
    "D103": A(40, 63.5, 180), "D104": A(40, 67.5, 180), "C114": A(46, 68.5), "C115": A(52, 70.5),
    # over-current window on the Hall sensor's output
    "R121": A(12, 87.5), "R122": A(12, 91.5), "R123": A(12, 95.5),
    "U105": A(28, 90), "U106": A(46, 90), "C127": A(33, 87), "C128": A(51, 87),
    # supply sense and over-voltage trip
    "R108": A(72, 56), "R109": A(72, 61), "C121": A(76, 61),
    "R110": A(86, 54), "R111": A(86, 58), "R112": A(86, 62), "R113": A(86, 67), "C122": A(90, 67),
    "U103": A(100, 64), "C123": A(106, 59.5), "R114": A(110, 62.5),
    # encoder input
    "J103": A(70, 95, 180), "D102": A(84, 101), "R116": A(77, 90.5), "R117": A(80, 90.5),
    "R118": A(94, 95, 90), "R119": A(94, 97, 90), "C124": A(98, 93.5, 180), "C125": A(100, 98.5),
    "U104": A(108, 96), "C126": A(114, 91.5),
    # bus tap
    "F101": A(20, 104, 90), "flag:+5V": A(10, 108), "flag:+5V_MOD": A(28, 108),
    "sheet:core": A(136, 30),
}

BLOCKS = [
    Block("Battery input: 12-44 V, fuse, TVS, bulk", 4, 4, 66, 40, notes=[
        (5, 27, f"F102 30 A (NANO2 456): {_v('fuse Littelfuse 0456030.ER (NANO2 456, 30 A)')}, "
                f"{_ROWS['fuse Littelfuse 0456030.ER (NANO2 456, 30 A)'].limit}.\n"
                f"D101 SMCJ45A: V_BR {_v('TVS SMCJ45A min breakdown at -20 °C')} at -20 °C, above the "
                f"{_v('over-voltage trip (TLV3011 → DRV_FAULT: coast)')} trip;\n"
                f"clamp {_v('HIP4082 AHS/BHS at the TVS clamp')} ≤ the driver's 80 V.\n"
                f"C101-C104 4 × 1000 µF 63 V: ripple {_v('input ripple at 20 A, d = 0.5')} at 20 A, "
                f"d = 0.5, I √(d(1 − d)):\n{_v('per electrolytic')} each "
                f"({_ROWS['per electrolytic'].limit}), life {_v('electrolytic life at that point')}.\n"
                f"C105-C112 8 × 2.2 µF 100 V X7R close the commutation loop (≤ 10 nH:\n"
                f"{_v('switch-node overshoot L_loop · I / t_off')} overshoot at {calc.I_PEAK:.0f} A).\n"
                "Not reverse-polarity protected: XT60 keyed, + and − marked (README)."),
    ]),
    Block("H-bridge: 4 × CSD19536KTT 100 V, Hall current sensor", 68, 4, 128, 44, notes=[
        (69, 39, f"20 A continuous, {calc.I_PEAK:.0f} A for 10 s: T_J {_v('T_J worst FET at 20 A, 40 °C, heatsink 2.0 °C/W')} "
                 f"/ {_v(f'T_J at the {calc.I_PEAK:.0f} A peak for 10 s')} on a 2.0 °C/W heatsink\n"
                 f"(board {_v('board total at 20 A')} at 20 A, 44.1 V). "
                 f"V_DS {_v('MOSFET V_DS at the over-voltage trip + overshoot')} at the trip + ringing.\n"
                 f"U102 ACS725 ±30 A: 44 mV/A at 3.3 V, 0 A = VDDA/2, {_v('current resolution')};\n"
                 f"R107/C120 1 k / 4.7 nF = 34 kHz into PA0, sampled at the PWM centre."),
    ]),
    Block("Gate driver HIP4082: 4 inputs, bootstrap high sides, VDD from VMOT", 4, 46, 64, 83, notes=[
        (5, 61.5, f"VDD {_v('driver VDD (zener − V_BE), worst high')} (Q106, D105, R120);\n"
                f"{_v(f'driver VDD at the {calc.VIN_MIN:.0f} V minimum input')} at {calc.VIN_MIN:.0f} V in. "
                f"Q106 {_v('Q106 dissipation at the over-voltage trip')}.\n"
                f"Dead time {_v('dead time vs turn-off + driver skew (50 ns)')}:\n"
                "TIM1's 500 ns + R105's DEL delay.\n"
                f"Switching {_v('switching times (Q_gs/2 + Q_gd) / I_gate')}.\n"
                f"C114/C115 470 nF: droop {_v('bootstrap droop over the longest on-time')};\n"
                f"at duty {calc.max_duty():.2f}: {_v(_REFRESH)}.\n"
                "DRV_EN high: Q105 pulls DIS low (on);\nin reset R115 and R106 hold DIS high (off)."),
    ]),
    Block("Over-current window: ACS725 output → DRV_FAULT", 4, 84, 64, 99, notes=[
        (17, 98.3, f"Trip {_v('over-current trip (U105/U106 → DRV_FAULT → TIM1_BKIN)')}: 10 k / 100 k / 10 k "
                 "from 3.3 V (ratiometric).\n"
                 f"Shorted leads: {_v('current at switch-off, motor leads shorted')} at switch-off "
                 f"(≤ 400 A I_DM)."),
    ]),
    Block("Supply sense and over-voltage trip", 66, 48, 118, 78, notes=[
        (67, 73.5, f"VMOT_SENSE = VMOT × 10 k / 160 k: full scale {_v('VMOT_SENSE full scale')}.\n"
                 f"Trip: 1.242 V × (174 k + 174 k + 27 k + 10 k) / 10 k, "
                 f"{_v('over-voltage trip (TLV3011 → DRV_FAULT: coast)')}:\n"
                 "U103 pulls DRV_FAULT low with U105/U106 (TIM1_BKIN)."),
    ]),
    Block("Encoder input: 5 V or 3.3 V, A/B", 66, 80, 118, 112, notes=[
        (67, 107, f"R118/C124 1 k / 100 pF: {_v('encoder filter corner')}; "
                  "U104 at 3.3 V takes 5 V inputs\n(PA6/PA7 are not 5 V tolerant). "
                  f"Bus budget {_v('from the bus (core, ACS725, encoder, pull-ups)')} of 200 mA."),
    ]),
    Block("Bus tap", 4, 100, 40, 112),
]
