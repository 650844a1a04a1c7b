"""How the PSU's root sheet is drawn (hardware/psu/psu.kicad_sch): the power path left to right.

Top row, along the battery current: battery input and protection, input current and voltage
sensing, the buck converter; the buck's 5 V output drops straight into the eFuse's IN_SYS pin on
the second row, where the bus output leaves as the +5V rail. The outer block "Power path" holds
these four and is listed first, so drawing.py wires every net whose pins lie inside it (a pin
belongs to the first block that contains it): VBAT_CONN → VBAT_IN → VIN_PROT → VIN_BUCK → SW →
+5V_BUCK is one wired line across the inner frames, which carry the titles and the design notes
next to the parts they size. Bottom row: the core sheet's box (the MCU, page 2, placed here by
"sheet:core") with the notes on the board as a whole, and the bus voltage sense. The MCU's
signals (VIN_SENSE, IIN_SENSE, VOUT_SENSE, BUS_EN, BUS_FAULT, +5V_BUCK) are the only nets that
meet by label. Grid units of 2.54 mm (drawing.py); every number in the notes is a row of
calc/psu.py (looked up by its name, so a renamed row fails loudly here).
"""
from __future__ import annotations

import math

from ..calc import psu as calc
from ..design import At, Block

A = At
_ROWS = {r.what: r for r in calc.rows()}
_BV = calc.BOARD_VALUES


def _en(reading: str) -> str:
    """Buck start/stop input voltages under EN reading A or B (calc/psu.py: not verified)."""
    start, stop = (next(r.value.split()[0] for w, r in _ROWS.items() if w.startswith(f"buck {k}, EN reading {reading}"))
                   for k in ("start", "stop"))
    return f"{start}/{stop} V"


def _v(what: str) -> str:
    """The value calc/psu.py prints for the row `what` (a KeyError if the row is renamed)."""
    return _ROWS[what].value


DRAWING = {
    # battery input and protection: the line at y = 20
    "J101": A(6.5, 21, 180), "F101": A(14, 20, 90), "Q101": A(20, 21, 90),
    "D101": A(29.5, 21.5, 270), "R101": A(20, 25.5), "D102": A(33.5, 21.5, 270),
    # sensing: the shunt in the line, the amplifier above it (Kelvin taps), the divider below
    "R102": A(41, 20, 90), "U101": A(49, 14), "C104": A(66, 10),
    "R103": A(59, 14, 90), "C105": A(65, 15.5), "TP105": A(67.5, 14),
    "R104": A(39.5, 23.5), "R105": A(39.5, 29), "C106": A(43.5, 29),
    # buck: input caps and EN divider left of U102 (line at y = 20); BIAS, BOOT, L101, feedback
    # and VCC on its right, the output line at y = 16
    "U102": A(105, 27),
    "TP101": A(74.5, 20), "C101": A(75.5, 21.5), "C102": A(81.5, 21.5), "C103": A(87.5, 21.5),
    "R106": A(95, 23, 90), "R107": A(95, 26.5, 270), "C110": A(86.5, 30.5),
    "C116": A(112, 17.5), "C109": A(114, 23.5), "L101": A(121, 17.5, 180),
    "R108": A(127, 17.5), "R109": A(127, 28.5), "C108": A(112, 31.5),
    "C111": A(134, 17.5), "C112": A(139.5, 17.5), "C113": A(145, 17.5), "C114": A(150.5, 17.5),
    "TP102": A(153.5, 16),
    # eFuse (second row): IN_SYS straight under the buck's output line
    "U103": A(131, 53),
    "R112": A(116, 49.5), "R113": A(116, 55.5), "R114": A(116, 60.5),
    "R110": A(122, 61.5), "TP103": A(120, 67, 180),
    "R111": A(141, 51.5), "TP104": A(145.5, 53),
    "R116": A(142.5, 59.5), "C115": A(139, 60.5),
    # bus voltage sense
    "R117": A(121, 84.5), "R118": A(121, 90.5), "C117": A(125, 90.5),
    # PWR_FLAGs
    "flag:VIN_BUCK": A(67.5, 20), "flag:+5V_BUCK": A(155, 23), "flag:GND": A(12, 25),
    # the core sheet (MCU, page 2): bottom, left of the title block
    "sheet:core": A(92, 79.5),
}

_ILIM = calc.EFUSE_ILIM_K / (_BV["R116"] / 1e3)
_SLEW = calc.EFUSE_IDVDT * calc.EFUSE_GAIN_DVDT / _BV["C115"]          # V/s
_RC_HZ = 1 / (2 * math.pi * 1e3 * 100e-9)                             # R103/C105
_DIV = (_BV["R104"] + _BV["R105"]) / _BV["R105"]

BLOCKS = [
    Block("Power path: battery 6-42 V in, 5 V bus out", 4, 4, 161, 77),
    Block("Battery input and protection", 5, 6.5, 37, 76, notes=[
        (6, 37, f"F101 5 A time-lag, 125 V DC: max input current\n"
                f"{_v('max input current')} (6 V in, bus at its limit, eff. 85 %)\n"
                f"{_ROWS['fuse F101 5 A T (0452005.MRL)'].limit}.\n"
                f"Hot-plug I²t into C_in {_v('hot-plug inrush I²t into C_in')}\n"
                f"{_ROWS['hot-plug inrush I²t into C_in'].limit}."),
        (6, 42, f"Q101 P-MOSFET: reverse polarity. Battery reversed:\n"
                f"V_DS {_v('Q101 V_DS, battery reversed')} "
                f"{_ROWS['Q101 V_DS, battery reversed'].limit} "
                f"({_ROWS['Q101 V_DS, battery reversed'].note}).\n"
                "D101 15 V zener holds V_GS, R101 turns it on."),
        (6, 51, f"D102 SMBJ40A clamps {_v('TVS clamp at rated pulse vs LM76005 abs max')}\n"
                f"{_ROWS['TVS clamp at rated pulse vs LM76005 abs max'].limit} (LM76005 abs max):\n"
                f"{_ROWS['TVS clamp at rated pulse vs LM76005 abs max'].note}.\n"
                f"Stand-off {_v('TVS stand-off vs max input')} < {calc.VIN_MAX:.2f} V max input,"
                " traded:\n"
                f"V_BR {_v('TVS min breakdown at 0 °C vs charger max')} min at 0 °C,"
                " leaks < 1 mA below it.\n"
                f"2 A hot-plug surge: {_v('TVS clamp at a 2 A hot-plug surge')}"
                f" {_ROWS['TVS clamp at a 2 A hot-plug surge'].limit}.\n"
                "Input-side parts rated above the clamp:\n"
                f"caps {calc.CIN_RATED:.0f} V, INA293 {calc.INA293_CM_MAX:.0f} V, eFuse {calc.EFUSE_ABS_MAX:.0f} V.")]),
    Block("Input current and voltage sensing", 38, 6.5, 73, 76, notes=[
        (48, 30, f"IIN_SENSE = I_IN × R102 × 50 (INA293A2)\n"
                 f"= {_v('IIN_SENSE scale')}: {_ROWS['IIN_SENSE scale'].limit},\n"
                 f"{_ROWS['IIN_SENSE scale'].note}.\n"
                 f"R102 10 mΩ: {_v('shunt R102 dissipation')} at {_v('max input current')}"
                 f" ({_ROWS['shunt R102 dissipation'].limit}).\n"
                 f"R103/C105: {_RC_HZ / 1e3:.1f} kHz anti-alias filter.\n"
                 "IN+/IN- are Kelvin taps on the shunt's pads."),
        (39, 37, f"VIN_SENSE = VIN × R105 / (R104 + R105) = VIN/{_DIV:.0f}:\n"
                 f"{_ROWS['VIN_SENSE scale'].limit}; {_ROWS['VIN_SENSE scale'].note}.\n"
                 f"At the clamp: R104 sees {_v('VIN divider top (R104) voltage at the clamp')}"
                 f" ({_ROWS['VIN divider top (R104) voltage at the clamp'].limit}),\n"
                 f"the ADC pin {_v('ADC pin injection at the clamp')}"
                 f" ({_ROWS['ADC pin injection at the clamp'].limit}).")]),
    Block("Buck converter LM76005 (60 V, 400 kHz, synchronous)", 74, 6.5, 160, 42, notes=[
        (75, 41, f"C101-C103: {_ROWS['input ripple at duty 0.5, 2.5 A rated'].note} at 42 V:\n"
                 f"{_v('input ripple at duty 0.5, 2.5 A rated')} (duty 0.5, 2.5 A).\n"
                 f"EN start/stop {_en('A')} ({_en('B')} at 1.2 V),\n"
                 f"soft start C110 × {calc.BUCK_VFB:.1f} V /"
                 f" {calc.BUCK_ISS * 1e6:.0f} µA ="
                 f" {_v('soft start t = C_SS V_FB / I_SS')}."),
        (110, 41, f"VOUT = VFB (1 + R108/R109) = {_v('VOUT typical = VFB (1 + R108/R109)')}\n"
                  f"{_BV['R108'] / 1e3:g}k/{_BV['R109'] / 1e3:g}k {calc.FB_RES_TOL:.1%}: "
                  f"{_v('VOUT worst case (reference range, resistor tolerance)')} worst\n"
                  "BOOT 470 nF 25 V; BIAS on +5V_BUCK,\nC116 1 µF at the pin (SNVSBK5 §5)."),
        (133, 33, f"L101 10 µH: ripple {_v('inductor ripple at max input, f min')} at"
                  f" {calc.VIN_MAX:.1f} V,\n{calc.BUCK_FSW_MIN / 1e3:.0f} kHz"
                  f" ({_ROWS['inductor ripple at max input, f min'].note});\n"
                  f"peak {_v('inductor peak')} {_ROWS['inductor peak'].limit}.\n"
                  f"C111-C114 4 × 22 µF 25 V: {_v('output capacitance at 5 V DC bias')}"
                  f" at 5 V,\n{_ROWS['output capacitance at 5 V DC bias'].note}.\n"
                  f"Output worst case {_v('buck output, worst case')}.\n"
                  f"U102 at 42 V, 3 A: {_v('U102 rise at 42 V, 3.0 A (estimate)')}"
                  " (estimate).")]),
    Block("eFuse TPS16630 and bus output", 106, 44, 160, 76, notes=[
        (107, 75, f"I_LIM = {calc.EFUSE_ILIM_K:g} / R116 = {calc.EFUSE_ILIM_K:g} / {_BV['R116'] / 1e3:g} k"
                  f" = {_ILIM:.2f} A; with ±{calc.EFUSE_ILIM_TOL:.0%}, R ±1 %:\n"
                  f"{_v('eFuse limit 18/R_ILIM')} {_ROWS['eFuse limit 18/R_ILIM'].limit}.\n"
                  f"UVLO = {calc.EFUSE_VTH[1]} V (R112+R113+R114)/(R113+R114) = {_v('eFuse UVLO on +5V_BUCK')}\n"
                  f"OVP = {calc.EFUSE_VTH[0]}-{calc.EFUSE_VTH[2]} V (R112+R113+R114)/R114 ="
                  f" {_v('eFuse OVP on +5V_BUCK')}\n"
                  f"dV/dt: C115 {_BV['C115'] * 1e9:g} nF → {_v('bus turn-on slew')}: 5 V in"
                  f" {5.0 / _SLEW * 1e3:.1f} ms, {_ROWS['bus turn-on slew'].limit}.\n"
                  f"R110 holds SHDN at {_v('SHDN held off by R110 (10 µA source)')}: bus off"
                  " until BUS_EN.")]),
    Block("Bus voltage sense", 117, 78, 160, 97, notes=[
        (131, 90, "VOUT_SENSE = +5V × R118 / (R117 + R118)\n= +5V / 2: "
                  f"{calc.ADC_FS * (_BV['R117'] + _BV['R118']) / _BV['R118']:.1f} V full scale.")]),
    Block("MCU (core sheet, page 2)", 4, 78, 116, 113, notes=[
        (6, 88, "The MCU reads VIN_SENSE (PA0), IIN_SENSE (PA1) and VOUT_SENSE (PA2),\n"
                "enables the bus (BUS_EN, PB0) and sees its fault (BUS_FAULT, PB1).\n"
                "+5V_BUCK feeds its LDO ahead of the eFuse: the firmware keeps running\n"
                "and reports a tripped bus instead of browning out with it."),
        (6, 98, f"Input {_v('input range')}: 2S-10S Li-ion, charger ±1 %.\n"
                f"No power switch: a switch on EN would still drain"
                f" {_v('pack drain with the buck off (an EN switch)')}\n"
                f"({_ROWS['pack drain with the buck off (an EN switch)'].note}).\n"
                f"Battery-side spacing {_v('battery-side spacing (IPC-2221B B2)')}"
                f" (IPC-2221B B2, {_ROWS['battery-side spacing (IPC-2221B B2)'].limit}):\n"
                "psu.kicad_dru rule 'ipc2221b'.")]),
]
