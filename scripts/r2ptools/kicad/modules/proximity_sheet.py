"""How the proximity module's root sheet is drawn (hardware/proximity/proximity.kicad_sch).

Top: the sensor supply, left to right along the power path: the fused bus tap (F101), the
TPS2553 switch with its limit resistor, enable pull-down and fault-flag pull-up, the sensor
rail's capacitors. Below: one block per sensor channel, jack on the left, series resistor,
divider and filter, the ADC net leaving for the core on the right; beside them the ESD array
shared by the four inputs. Right: the core sheet's box (page 2), its pins labelled with the
nets of this sheet. Grid units of 2.54 mm (drawing.py); the numbers in the notes come from
calc/proximity.py (`switch_limit_ma()`, `sensor_budget()`) and the divider's values below.
"""
from __future__ import annotations

import math

from ..design import At, Block
from ..calc import proximity as prox

A = At

CH_Y0 = [34, 49, 64, 79]
"""Top edge of each channel's block."""

DRAWING = {
    # sensor supply: bus tap, switch, limit, flags
    "F101": A(10, 12, 90), "C101": A(19, 13.5), "R101": A(23, 15.5),
    "U101": A(33, 13), "R111": A(39, 14.5), "R110": A(44, 17.5), "TP106": A(50, 19),
    "C102": A(48, 13.5), "C103": A(54, 13.5), "TP101": A(58, 12),
    # PWR_FLAGs, in a row under the bus tap (each with its wire and label to the right)
    "flag:+5V": A(6, 21), "flag:GND": A(14, 21), "flag:+5V_MOD": A(22, 21),
    # ESD array for the four inputs
    "U102": A(98, 47),
    # the core sheet's box (page 2)
    "sheet:core": A(124, 38),
}
for _ch, _y0 in enumerate(CH_Y0):
    DRAWING.update({
        f"J{101 + _ch}": A(12, _y0 + 6, 180),
        f"R{102 + 2 * _ch}": A(23, _y0 + 8, 90),
        f"R{103 + 2 * _ch}": A(29, _y0 + 9.5),
        f"C{104 + _ch}": A(33, _y0 + 9.5),
        f"TP{102 + _ch}": A(42, _y0 + 8),
    })

_lo, _nom, _hi = prox.switch_limit_ma()
_four = 4 * max(prox.SENSORS_MA.values())
_left = prox.MODULE_LIMIT_MA - prox.CORE_WORST_MA
_R_SER, _R_GND, _C_NF = 56.0, 100.0, 100.0           # kohm, kohm, nF: R102/R103/C104 per channel
_ratio = _R_GND / (_R_SER + _R_GND)
_r_src = _R_SER * _R_GND / (_R_SER + _R_GND)          # kohm
_pole_hz = 1 / (2 * math.pi * _r_src * 1e3 * _C_NF * 1e-9)
_tau_ms = _r_src * _C_NF * 1e-3

BLOCKS = [
    Block("Sensor supply: fused bus tap, current-limited switch", 4, 4, 100, 30, notes=[
        (5, 28, "F101: 0.5 A hold polyfuse: a short on this module trips\nits own fuse,"
                " not the whole bus (which passes through\nunfused). PWR_FLAGs: +5V and GND come"
                " from the bus\njacks (core sheet); +5V_MOD feeds the core's V5_IN (3.3 V LDO)."),
        (62, 8, f"I_LIM (TPS2553, SLVS841) set by R111 = {prox.R_ILIM_KOHM:g} k 1 %:\n"
                f"nom. 23950 / R^0.977 = {_nom:.0f} mA,\n"
                f"min. 25230 / (1.01 R)^1.016 = {_lo:.0f} mA >= 4 x 33 mA = {_four:.0f} mA"
                " (four GP2Y0A02),\n"
                f"max. 22980 / (0.99 R)^0.94 = {_hi:.0f} mA: a shorted cable is held there."),
        (62, 15.5, "R101 100 k: sensors off through reset (PB0 turns them on).\n"
                   "~OC: open drain, R110 10 k to 3.3 V; low after the 7.5 ms\n"
                   "deglitch while limiting: SENSOR_PWR_FAULT on PB1."),
        (34, 28, f"Bus budget exception (docs/bus.md §6): {prox.MODULE_LIMIT_MA:g} mA per module"
                 f" - {prox.CORE_WORST_MA:g} mA core\n= {_left:.0f} mA, not three Sharp"
                 f" sensors: this module may draw {_hi:.0f} + {prox.CORE_WORST_MA:g}"
                 f" = {_hi + prox.CORE_WORST_MA:.0f} mA.\nInrush: C102 + C103 ="
                 f" {prox.SENSOR_RAIL_UF:g} uF charge behind the limit (>="
                 f" {prox.SENSOR_RAIL_UF * 5.0 / _hi:.2f} ms);"
                 f" the bus sees {prox.BUS_SIDE_UF:g} uF (<= 22 uF)."),
    ]),
    *[Block(f"Sensor {ch} (S{ch})", 4, y0, 82, y0 + 13) for ch, y0 in enumerate(CH_Y0)],
    Block("ESD clamp at the jacks", 84, 34, 114, 60, notes=[
        (85, 57, "SRV05-4: one array for the four inputs,\nclamped to the sensor rail."),
    ]),
    Block("Core (page 2)", 116, 34, 160, 78, notes=[
        (117, 77, "Bus jacks, CAN, 3.3 V LDO, MCU.\nPA0-PA3 ADC, PB0 enable, PB1 fault;\n"
                  "the other free GPIOs: no-connect."),
    ]),
]
# the channels are identical: each note sits by the parts it sizes, in one channel's block
BLOCKS[1].notes.append((44, 38, f"Every channel: 56 k in series, 100 k to GND (R102-R109):\n"
                                f"5 V reads 5 x 100 / 156 = {5 * _ratio:.2f} V at the ADC (MaxBotix"
                                f" HRLV\nreaches ~0.98 Vcc); an unplugged input reads 0 V"
                                " (no sensor)."))
BLOCKS[2].notes.append((44, 53, f"Source 56 k || 100 k = {_r_src:.0f} k with {_C_NF:g} nF"
                                f" (C104-C107):\npole 1 / (2 pi R C) = {_pole_hz:.0f} Hz, above the"
                                f" Sharp's 26 Hz\nupdates; settled to 0.1 % in 7 tau ="
                                f" {7 * _tau_ms:.0f} ms."))
BLOCKS[3].notes.append((44, 68, f"The 56 k also limits what a miswired 24 V sensor\ninjects into"
                                f" the ADC pin's clamp: {24 / _R_SER:.1f} mA (F103: 5 mA)."))
BLOCKS[4].notes.append((44, 83, "JST PH 3-pin in the Sharp cable's order:\n1 signal, 2 GND,"
                                " 3 +5 V (the switched sensor rail)."))
