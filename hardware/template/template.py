"""hardware/template: the starting point of a new module, and a board in its own right.

It is the common core with the fused bus tap and nothing else: every free MCU pin is marked
no-connect and the area below the core is empty. The board's generator input lives here, in its
own folder (its drawing in `template_sheet.py`); the generator (`scripts/hwgen`, shared tooling in
scripts/r2ptools/kicad) finds it through the module manifest. A new module described in Python
copies both files to `hardware/<name>/<name>.py` and `<name>_sheet.py`, adds its parts
(references from 101) and places them in the free area (y > 42 mm and the bottom edge for
connectors), and maps the MCU pins it uses to the signal names of its firmware board file
(docs/hardware.md). Built and checked like every module, so the template itself is known to pass
ERC and DRC.
"""
from __future__ import annotations

from r2ptools.kicad.design import Module, Place, Sheet, Track, Via
from r2ptools.kicad.modules import core as core_mod
from r2ptools.kicad.modules import drawing_of
from r2ptools.kicad.modules.common import (BUS_TAP_PLACE, bus_tap, bus_tap_track, core_tracks,
                                           frame_texts, tvs_track)

NAME = "template"
TITLE = "R2P module template"
REVISION = "B"


def led_bus_track() -> list[Track]:
    """LED_BUS (R5 to PC14) by hand, under the crystal's side: with the core alone freerouting
    leaves this one connection boxed in (60 passes)."""
    return [Track("LED_BUS", [(7.325, 26.0), (6.65, 26.675), (6.65, 28.5), (8.05, 29.9),
                              (19.6, 29.9), (20.2, 29.3), (23.85, 29.3)], 0.2),
            Track("LED_BUS", [(23.85, 29.3), (24.5, 29.3), (27.05, 26.75)], 0.2, "B.Cu"),
            Track("LED_BUS", [(27.05, 26.75), (25.84, 26.75)], 0.2)]


def build(core: Sheet) -> Module:
    s = Sheet(NAME, f"{TITLE}: the common core alone")
    bus_tap(s, "+5V_MOD", at=BUS_TAP_PLACE)
    pins = {p: "" for p in core_mod.FREE_GPIO}
    pins["V5_IN"] = "+5V_MOD"
    s.use(core, pins)
    sheet = drawing_of(__file__)
    s.drawing, s.blocks = sheet.DRAWING, sheet.BLOCKS
    m = Module(NAME, TITLE, REVISION, s,
               tracks=[*core_mod.bus_tracks(), bus_tap_track(), tvs_track(), *core_tracks(),
                       *led_bus_track()],
               vias=[Via("LED_BUS", 23.85, 29.3, 0.7, 0.3), Via("LED_BUS", 27.05, 26.75, 0.7, 0.3)],
               seed=9)
    m.fiducials = list(core_mod.FIDUCIALS)
    m.texts = frame_texts(NAME, REVISION)
    return m
