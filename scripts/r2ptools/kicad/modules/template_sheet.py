"""How the template's root sheet is drawn (hardware/template/template.kicad_sch).

The template is the core alone: its root sheet holds the fused bus tap (F101) with the sheet's
power flags, and the core sheet's box (page 2). A new module copies this file with
`template.py` and draws its own blocks in the free space below the bus tap (docs/hardware.md).
Grid units of 2.54 mm (drawing.py).
"""
from __future__ import annotations

from ..design import At, Block

A = At

DRAWING = {
    # bus tap: +5V from the bus through the polyfuse to the module's supply
    "F101": A(12, 12, 90),
    # PWR_FLAGs: +5V_MOD's on F101's output pin, the bus rails' in free space
    "flag:+5V_MOD": A(13.5, 12), "flag:+5V": A(6, 21), "flag:GND": A(12, 20),
    # the core sheet's box (page 2)
    "sheet:core": A(124, 38),
}

BLOCKS = [
    Block("Bus tap", 4, 4, 44, 30, notes=[
        (5, 28, "F101: 0.5 A hold polyfuse: a short on this module trips\nits own fuse,"
                " not the whole bus (which passes through\nunfused). PWR_FLAGs: +5V and GND come"
                " from the bus\njacks (core sheet); +5V_MOD feeds the core's V5_IN (3.3 V LDO)."),
    ]),
    Block("Core (page 2)", 116, 34, 160, 78, notes=[
        (117, 77, "Bus jacks, CAN, 3.3 V LDO, MCU.\nEvery free GPIO: no-connect until a module"
                  "\nmaps it to a signal of its board file."),
    ]),
]
