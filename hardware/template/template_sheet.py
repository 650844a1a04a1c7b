"""How the template's own sheet is drawn: the fused bus tap, and the core sheet's box.

A new module's sheet starts here: its blocks go below and to the right of the bus tap, its
signals reach the MCU through the core box's pins (docs/hardware.md). Grid units of 2.54 mm.
"""
from __future__ import annotations

from r2ptools.kicad.design import At, Block

DRAWING = {
    "F101": At(20, 14, 90),
    "flag:+5V": At(8, 22), "flag:GND": At(18, 22), "flag:+5V_MOD": At(28, 22),
    "sheet:core": At(60, 8),
}

BLOCKS = [
    Block("Bus tap: the module's own fused 5 V", 4, 4, 50, 34, notes=[
        (6, 28, "F101 0.5 A hold polyfuse: a module that shorts inside trips its own fuse\n"
                "instead of pulling the whole bus into the PSU's current limit. The bus\n"
                "itself passes through the module unfused (core sheet: BUS IN, BUS OUT)."),
        (6, 8, "PWR_FLAGs: +5V and GND arrive from the bus jacks,\n+5V_MOD from the polyfuse.")]),
]
