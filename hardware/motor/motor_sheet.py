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


_SHORT = f"current at switch-off, motor leads shorted, {calc.MOTOR_V_RATED:.0f} V supply"
_REFRESH = f"bootstrap refresh at the firmware's maximum duty {calc.max_duty():.2f}"

DRAWING = {
    # battery input: VBAT line at y = 11, VMOT rail at y = 14 (capacitor tops); the ceramics in
    # two rows under the electrolytics, 7 grid apart so each value reads clear of the next part
    "J101": A(16, 12, 180), "F102": A(22, 11, 90), "D101": A(26, 15.5, 270),
    **{f"C{101 + i}": A(33 + 7 * i, 15.5) for i in range(4)},
    **{f"C{105 + i}": A(30.5 + 7 * (i % 4), 24.5 if i < 4 else 33.5) for i in range(8)},
    "flag:VMOT": A(27, 9), "flag:GND": A(6, 19),
    # H-bridge: drains on VMOT at y = 10, sources to GND at y = 24; the Hall sensor right of
    # leg A's low side (its IP+ wire clear of Q102's text), the motor connector right
    "R101": A(70, 12, 90), "Q101": A(78, 12), "R102": A(70, 22, 90), "Q102": A(78, 22),
    "R103": A(99, 12, 90), "Q103": A(107, 12), "R104": A(99, 22, 90), "Q104": A(107, 22),
    "U102": A(94, 34), "C119": A(85, 30.5), "R107": A(106, 34, 90), "C120": A(111, 35.5),
    "J102": A(120, 20),
    # gate driver: VDD's regulator top left (VMOT → R120/D105 → Q106), the VDD rail at y = 61
    # with its decoupling, the bootstrap diode and capacitor of each channel in a column right
    # of the driver (A at x = 44, B at x = 56); inputs on the left, the enable inverter above them
    "R120": A(14, 54.5), "Q106": A(20, 57), "D105": A(8, 59.5, 270), "C118": A(14, 59.5),
    "C113": A(34, 62.5), "C116": A(40, 62.5), "R106": A(24, 62.5),
    "U101": A(30, 74),
    "Q105": A(12, 66), "R115": A(6, 67.5), "R105": A(21, 81.5),
    "D103": A(46, 62.5, 90), "C114": A(46, 72.5), "D104": A(57, 62.5, 90), "C115": A(57, 72.5),
    "flag:DRV_VDD": A(62, 58),
    # over-current window on the Hall sensor's output
    "R121": A(8, 92.5), "R122": A(8, 99.5), "R123": A(8, 109.5),
    "U105": A(22, 96), "U106": A(28, 107), "C127": A(34, 94.5), "C128": A(34, 105.5),
    # encoder input (right of the gate driver)
    "J103": A(78, 57, 180), "R116": A(86, 60.5, 180), "R117": A(90, 60.5, 180), "D102": A(101, 70),
    "R118": A(97, 52, 90), "R119": A(97, 60, 90), "C124": A(102, 53.5), "C125": A(104, 61.5),
    "U104": A(114, 59), "C126": A(118, 52.5),
    # supply sense and over-voltage trip (bottom right, left of the title block)
    "R108": A(75, 89.5), "R109": A(75, 95.5), "C121": A(80, 95.5),
    "R110": A(88, 88.5), "R111": A(88, 94.5), "R112": A(88, 100.5), "R113": A(88, 106.5),
    "C122": A(92, 106.5),
    "U103": A(101, 103), "C123": A(107, 96.5), "R114": A(112, 100.5),
    # bus tap
    "F101": A(64, 96.5), "flag:+5V": A(60, 104), "flag:+5V_MOD": A(60, 109),
    "sheet:core": A(136, 30),
}

BLOCKS = [
    Block("Battery input: 15-44 V, fuse, TVS, bulk", 4, 4, 63, 46, notes=[
        (5, 45.3, f"F102 30 A (NANO2 456): {_v('fuse Littelfuse 0456030.ER (NANO2 456, 30 A)')}, "
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
    Block("H-bridge: 4 × CSD19536KTT 100 V, Hall current sensor", 65, 4, 127, 46, notes=[
        (66, 45.3, f"20 A continuous, {calc.I_PEAK:.0f} A for 10 s: T_J {_v('T_J worst FET at 20 A, 40 °C, heatsink 2.0 °C/W')} "
                 f"/ {_v(f'T_J at the {calc.I_PEAK:.0f} A peak for 10 s')} on a 2.0 °C/W heatsink\n"
                 f"(board {_v('board total at 20 A')} at 20 A, 44.1 V). "
                 f"V_DS {_v('MOSFET V_DS at the over-voltage trip + overshoot')} at the trip + ringing.\n"
                 f"U102 ACS725 ±30 A: 44 mV/A at 3.3 V, 0 A = VDDA/2, {_v('current resolution')};\n"
                 f"R107/C120 1 k / 4.7 nF = 34 kHz into PA0, sampled at the PWM centre."),
    ]),
    Block("Gate driver HIP4082: 4 inputs, bootstrap high sides, VDD from VMOT", 4, 48, 70, 86, notes=[
        (38, 85.3, f"VDD {_v('driver VDD (zener − V_BE), worst high')} (Q106, D105, R120);\n"
                f"{_v(f'driver VDD at the {calc.VIN_MIN:.0f} V minimum input')} at {calc.VIN_MIN:.0f} V in. "
                f"Q106 {_v('Q106 dissipation at the over-voltage trip')}.\n"
                f"Dead time {_v('dead time vs turn-off + driver skew (50 ns)')}:\n"
                f"TIM1's {calc.DEAD_TIME_S * 1e9:.0f} ns + R105's DEL delay.\n"
                f"Switching {_v('switching times (Q_gs/2 + Q_gd) / I_gate')}.\n"
                f"C114/C115 470 nF: droop {_v('bootstrap droop over the longest on-time')};\n"
                f"at duty {calc.max_duty():.2f}: {_v(_REFRESH)}.\n"
                "DRV_EN high: Q105 pulls DIS low (on);\nin reset R115 and R106 hold DIS high (off)."),
    ]),
    Block("Over-current window", 4, 87, 56, 113, notes=[
        (38, 112.3, "U105/U106 on the ACS725's HALL_OUT,\nopen drain into DRV_FAULT (TIM1_BKIN).\n"
                    f"Trip {_v('over-current trip (U105/U106 → DRV_FAULT → TIM1_BKIN)')}:\n"
                    "10 k / 56 k / 10 k from 3.3 V\n(ratiometric, like the sensor).\n"
                    f"Shorted leads: {_v(_SHORT)}\nat switch-off at {calc.MOTOR_V_RATED:.0f} V (≤ 400 A I_DM)."),
    ]),
    Block("Supply sense and over-voltage trip", 72, 82, 117, 113, notes=[
        (73, 112.3, f"VMOT_SENSE = VMOT × 10 k / 160 k: full scale {_v('VMOT_SENSE full scale')}.\n"
                 f"Trip: 1.242 V × (174 k + 174 k + 27 k + 10 k) / 10 k, "
                 f"{_v('over-voltage trip (TLV3011 → DRV_FAULT: coast)')}:\n"
                 "U103 pulls DRV_FAULT low with U105/U106 (TIM1_BKIN)."),
    ]),
    Block("Encoder input: 5 V or 3.3 V, A/B", 72, 48, 126, 80, notes=[
        (73, 79.3, f"R118/C124 1 k / 100 pF: {_v('encoder filter corner')}; "
                  "U104 at 3.3 V takes 5 V inputs\n(PA6/PA7 are not 5 V tolerant). "
                  f"Bus budget {_v('from the bus (core, ACS725, encoder, pull-ups)')} of 200 mA."),
    ]),
    Block("Bus tap", 58, 87, 70, 113),
]
