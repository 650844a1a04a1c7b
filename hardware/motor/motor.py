"""hardware/motor revision A: the DC motor module, 36 V / 20 A H-bridge on the common core.

    XT60 in ─► F102 30 A ─► VMOT ─┬─ D101 SMCJ45A, C101-C104 4 × 1000 µF 63 V, C105-C112 8 × 2.2 µF 100 V
                                  ├─ leg A: Q101 (high) / Q102 (low) ─► SW_A ─► U102 ACS725 ─► MOT_A ─┐
                                  └─ leg B: Q103 (high) / Q104 (low) ─► MOT_B ─────────────────────────┴► XT60 motor
    U101 HIP4082 (four independent inputs = the board file's four PWM pins; its channel B drives
    leg A, channel A leg B; bootstrap high sides C114/C115 through D103/D104, turn-on delay R105,
    UVLO) drives the four gates through 10 Ω; its
    VDD (12.4 V) comes from VMOT through Q106 (BCX56-16 follower on D105's 13 V): the driver takes
    nothing from the bus. DIS is pulled to VDD by R106 (bridge off) and pulled low by Q105 when
    DRV_EN (PB0, active high; R115 holds it low in reset) enables the bridge.
    DRV_FAULT (PB12 = TIM1_BKIN, R114 pull-up) is a wired-OR of open drains: U103 (TLV3011,
    VMOT > 46.4-49.2 V) and the over-current window U105/U106 (LMV331, |I| > 30.1-32.4 A from the
    ACS725's raw output against a 10 k / 100 k / 10 k ladder from +3V3): TIM1's break input stops
    the PWM in hardware.
    U102 ±30 A Hall sensor (3.3 V, ratiometric) → 1 k / 4.7 nF → MOTOR_CURRENT (PA0);
    VMOT → 150 k / 10 k → VMOT_SENSE (PA1); encoder A/B (5 V or 3.3 V) → SRV05-4, 2.2 k pull-ups,
    1 k / 100 pF, U104 74LVC2G17 at 3.3 V → ENC_A/ENC_B (PA6/PA7, not 5 V tolerant).

Every value is calc/motor.py's (`DESIGN_VALUES`; `scripts/py -m r2ptools.kicad.calc.motor`).
Grounding (issue 19 item 5): the logic side (core, Hall sensor's supply, encoder) runs from the
bus through the fused bus tap; the power stage from VMOT. One ground: the bus GND and the power
GND are the same net, joined at the bulk capacitors' negative (star point) by the inner GND
plane; the motor current's loop (XT60 − → capacitors → low-side sources) stays in the right-hand
power section and never crosses the core. Isolated CAN is the revision B alternative (README).

NOT VERIFIED (README, "Before ordering"): the HIP4082's electrical tables (FN3676's front page was
read; the pin table is KiCad 9's own symbol), F102's land pattern (KiCad has no NANO2 456
footprint: the 462's is used), and the LCSC numbers of the parts parts.csv marks `-`.

Board: 164 × 50 mm (docs/bus.md's 60 × 50 mm bus end plus two 52 mm hole pitches: the power
stage's parts need 2880 mm² of courtyard, more than one pitch's 2525 mm²), 4 layers, 2 oz on every layer (the In1/In2 planes carry the motor current: calc/motor.py PATHS).
The core keeps its default placement on the left 60 mm.
"""
from __future__ import annotations

from r2ptools.kicad.design import Module, Place, Sheet, Text, Track, Via, Zone
from r2ptools.kicad.calc import motor as calc
from r2ptools.kicad.modules import core as core_mod
from r2ptools.kicad.modules import drawing_of
from r2ptools.kicad.modules.common import (BUS_TAP_PLACE, bus_tap, bus_tap_track, core_tracks,
                                           frame_texts, tvs_track)

NAME = "motor"
TITLE = "R2P DC motor module"
REVISION = "A"
SIZE = calc.BOARD_MM
HOLES = [(x, y) for y in (4.0, 46.0) for x in (4.0, 56.0, 108.0, 160.0)]
"""The bus grid's holes continued at the same 52 mm pitch: the 60 × 50 mm bus end plus two
pitches for the power stage (README: the parts do not fit in one)."""
FIDUCIALS = [(2.6, 20.2), (57.4, 14.5), (109.0, 30.0)]

PINS = {"PA8": "PWM_AH", "PB13": "PWM_AL", "PA9": "PWM_BH", "PB14": "PWM_BL",
        "PB12": "DRV_FAULT", "PA6": "ENC_A", "PA7": "ENC_B", "PA0": "MOTOR_CURRENT",
        "PA1": "VMOT_SENSE", "PB0": "DRV_EN"}
"""MCU pins → firmware/boards/motor.toml's signals (scripts/check-pins)."""

P = Place
PLACES = {
    # --- bridge: two legs as columns, high side above (tab = VMOT up, pins down onto the low
    # side's tab = the phase node), the motor connector between the legs at the bottom edge
    "Q101": P(66.0, 13.0, 90), "Q102": P(66.0, 31.0, 90),
    "Q103": P(95.0, 13.0, 90), "Q104": P(95.0, 31.0, 90),
    "J102": P(76.8, 34.6, 180), "U102": P(80.5, 26.0, 0), "C119": P(80.5, 21.5, 0),
    "R107": P(86.5, 23.6, 0), "C120": P(86.5, 26.0, 0),
    # commutation-loop ceramics beside each leg
    "C105": P(74.5, 15.5, 0), "C106": P(74.5, 19.5, 0), "C107": P(86.5, 15.5, 180),
    "C108": P(86.5, 19.5, 180), "C109": P(104.0, 10.0, 0), "C110": P(104.0, 14.0, 0),
    "C111": P(104.0, 18.0, 0), "C112": P(104.0, 22.0, 0),
    # gate driver between the legs' high sides, turned 90°: its outputs along its top edge, leg
    # A's (channel B) on the left, leg B's (channel A) on the right; inputs, DEL and DIS below
    "U101": P(80.5, 7.6, 90),
    "R102": P(73.6, 3.4, 180), "R101": P(73.6, 5.4, 180), "C114": P(74.4, 7.9, 90),
    "D103": P(77.4, 12.7, 0), "R105": P(81.3, 12.7, 0), "R106": P(84.4, 12.7, 0),
    "R104": P(78.2, 1.5, 0), "C116": P(81.5, 1.5, 0), "D104": P(85.6, 1.5, 0),
    "C115": P(86.6, 7.6, 270), "R103": P(88.5, 5.0, 90), "C113": P(80.5, 14.9, 0),
    # its VDD regulator above leg B's high side, the collector on VMOT
    "Q106": P(94.2, 3.0, 180), "R120": P(90.2, 3.0, 90), "D105": P(98.45, 3.0, 270),
    "C118": P(100.35, 3.0, 270),
    # the enable inverter and the over-current window comparators in the core's free band
    # (3.3 V logic beside the MCU and the over-voltage comparator)
    "Q105": P(37.8, 40.0, 0), "R115": P(34.0, 40.0, 0),
    "U105": P(40.2, 32.6, 0), "U106": P(40.0, 36.4, 0), "C127": P(44.3, 32.6, 0),
    "C128": P(44.3, 35.2, 0), "R121": P(47.6, 31.5, 90), "R122": P(47.6, 34.5, 90),
    "R123": P(47.6, 37.5, 90),
    # supply sense and over-voltage dividers beside leg B
    "R108": P(104.0, 26.0, 0), "R109": P(104.0, 28.0, 0), "C121": P(104.0, 30.0, 0),
    "R110": P(104.0, 32.0, 0), "R111": P(104.0, 34.0, 0), "R112": P(104.0, 36.0, 0),
    "R113": P(104.0, 38.0, 0), "C122": P(104.0, 40.0, 0),
    # input: bulk 2 × 2, battery XT60 on the right edge, fuse and TVS below the bulk
    "C101": P(116.0, 10.5, 0), "C102": P(116.0, 28.0, 0), "C103": P(132.6, 10.5, 0),
    "C104": P(132.6, 28.0, 0), "J101": P(147.5, 13.0, 270), "F102": P(140.0, 45.0, 180),
    "D101": P(122.0, 45.0, 180),
    # over-voltage comparator and DRV_FAULT pull-up, encoder input: the core's bottom band
    "U103": P(44.0, 41.0, 0), "C123": P(44.0, 37.8, 0), "R114": P(48.5, 41.0, 90),
    "J103": P(12.0, 47.2, 90), "D102": P(24.5, 46.5, 0),
    "R116": P(29.0, 44.0, 0), "R117": P(29.0, 46.0, 0), "R118": P(29.0, 48.0, 0),
    "R119": P(33.0, 44.0, 0), "C124": P(33.0, 46.0, 0), "C125": P(33.0, 48.0, 0),
    "U104": P(38.0, 46.0, 0), "C126": P(38.0, 42.5, 0),
}


def _grid(net: str, x0: float, y0: float, nx: int, ny: int, pitch: float = 1.2) -> list[Via]:
    """A field of 0.6/0.3 mm vias (thermal under a tab, or a plane connection)."""
    return [Via(net, round(x0 + i * pitch, 3), round(y0 + j * pitch, 3), 0.6, 0.3)
            for i in range(nx) for j in range(ny)]


LEGS = {  # column x, high-side net at the tab, phase node, low-side tab = phase node
    "A": (66.0, "SW_A"), "B": (95.0, "MOT_B")}


def planes() -> list[Zone]:
    """In1.Cu: GND under the whole board (the star: every return reaches it by vias). In2.Cu:
    VMOT under the power stage, GND under the core. B.Cu islands under the four tabs, each on
    its tab's net: the thermal vias' landing, pressed onto the heatsink's gap pad."""
    w, h = SIZE
    e = 0.3
    zs = [Zone("GND", "In1.Cu", [(e, e), (w - e, e), (w - e, h - e), (e, h - e)], solid=True),
          Zone("GND", "In2.Cu", [(e, e), (59.6, e), (59.6, h - e), (e, h - e)], solid=True),
          Zone("VMOT", "In2.Cu", [(60.4, e), (w - e, e), (w - e, h - e), (60.4, h - e)], solid=True)]
    for x, phase in LEGS.values():
        for y, net in ((13.0, "VMOT"), (31.0, phase)):
            zs.append(Zone(net, "B.Cu", [(x - 5.4, y - 6.2), (x + 5.4, y - 6.2), (x + 5.4, y + 3.2),
                                         (x - 5.4, y + 3.2)], priority=2, solid=True))
    return zs


SW_A_POUR = [(69.0, 21.5), (78.2, 21.5), (78.2, 25.7), (69.0, 25.7)]
"""Leg A's phase node from Q102's tab to U102's IP+ leads, on F.Cu and B.Cu (4.2 mm: calc/motor.py
PATHS "phase node → ACS725 IP+"); 0.6 mm (the HV class) from the IP− leads below it."""
MOT_A_POUR = [(74.6, 26.3), (79.4, 26.3), (79.4, 34.6), (74.6, 34.6)]
"""From U102's IP− leads into the motor XT60's pin 1, on F.Cu and B.Cu (4.8 mm)."""


def bridge_pour(x: float, layer: str) -> list[tuple[float, float]]:
    """Under leg `x`'s high-side source lead, down onto the low side's tab (the phase node): 4.4 mm
    wide (calc/motor.py PATHS "high side's source → phase node"), 3 mm clear of the high-side gate
    lead on its left for the gate's track; on B.Cu it starts 0.8 mm below the VMOT tab island."""
    return [(x + 1.0, 18.35 if layer == "F.Cu" else 17.0), (x + 5.4, 18.35 if layer == "F.Cu" else 17.0),
            (x + 5.4, 25.0), (x + 1.0, 25.0)]


def power_zones() -> list[Zone]:
    """The copper the motor current needs where tracks cannot be wide enough, as pours on both
    outer layers stitched by power_vias(): the Hall sensor's primary (a SOIC-8's lead rows leave
    no room for wide tracks) and each high side's source lead onto its phase node."""
    # priorities distinct from the tab islands' (2) and from each other where same-net pours overlap
    zs = [Zone(net, layer, pts, priority=4, solid=True)
          for net, pts in (("SW_A", SW_A_POUR), ("MOT_A", MOT_A_POUR)) for layer in ("F.Cu", "B.Cu")]
    zs += [Zone(phase, layer, bridge_pour(x, layer), priority=3, solid=True)
           for x, phase in LEGS.values() for layer in ("F.Cu", "B.Cu")]
    return zs


def power_tracks() -> list[Track]:
    """The motor current's copper on F.Cu (calc/motor.py PATHS; README, "Copper")."""
    T = Track
    out = []
    for x, phase in LEGS.values():
        # high side's source lead down onto the low side's tab: the phase node
        out.append(T(phase, [(x + 2.54, 20.65), (x + 2.54, 26.0)], 2.0))
        # low side's source lead onto its GND via field
        out.append(T("GND", [(x + 2.54, 38.65), (x + 2.54, 44.0)], 1.8))
    out += [
        # leg A's phase node → U102 → the connector's pin 1: the pours of power_zones()
        # leg B's phase node (Q104's tab) across to the connector's pin 2, both outer layers
        T("MOT_B", [(90.5, 33.5), (84.0, 34.6)], 5.0),
        T("MOT_B", [(90.5, 33.5), (84.0, 34.6)], 5.0, "B.Cu"),
        # battery: XT60 + down the right edge into the fuse; fuse out to the TVS and the bulk;
        # both outer layers (the fuse's pads reach B.Cu through via fields)
        T("VBAT", [(147.5, 20.2), (147.5, 38.0), (145.05, 41.0), (145.05, 45.0)], 6.0),
        T("VBAT", [(147.5, 20.2), (147.5, 38.0), (145.6, 39.3)], 6.0, "B.Cu"),
        T("VMOT", [(134.95, 45.0), (134.95, 40.0), (132.6, 35.0), (132.6, 28.0)], 6.0),
        T("VMOT", [(132.2, 38.6), (132.6, 35.0), (132.6, 28.0)], 6.0, "B.Cu"),
        T("VMOT", [(125.4, 45.0), (134.95, 45.0)], 2.5),
        T("VMOT", [(116.0, 28.0), (116.0, 36.0), (125.4, 42.0), (125.4, 45.0)], 4.0),
        T("VMOT", [(116.0, 28.0), (116.0, 36.0), (125.4, 42.0)], 4.0, "B.Cu"),
        # commutation ceramics' VMOT pads onto the high sides' tabs
        *[T("VMOT", [(73.02, y), (71.0, y)], 1.6) for y in (15.5,)],
        *[T("VMOT", [(87.98, y), (90.0, y)], 1.6) for y in (15.5,)],
        *[T("VMOT", [(102.52, y), (100.0, y)], 1.6) for y in (10.0, 14.0)],
    ]
    return out


def power_vias() -> list[Via]:
    out = []
    for x, phase in LEGS.values():
        out += _grid("VMOT", x - 4.2, 7.6, 8, 6)          # high-side tab: 48 thermal vias
        out += _grid(phase, x - 4.2, 25.6, 8, 6)         # low-side tab
        out += _grid("GND", x + 0.74, 42.0, 4, 4)        # low-side source to the In1 GND plane
        # high-side source lead: both sides of its pad, onto the B.Cu bridge pour (15)
        out += _grid(phase, x + 1.5, 18.9, 1, 5) + _grid(phase, x + 3.8, 18.9, 2, 5, pitch=1.1)
    # ceramics' GND pads to In1, and the two lower ones' VMOT pads to In2
    out += [Via("GND", 77.4, y, 0.6, 0.3) for y in (15.5, 19.5)]
    out += [Via("GND", 83.6, y, 0.6, 0.3) for y in (15.5, 19.5)]
    out += [Via("GND", 107.0, y, 0.6, 0.3) for y in (10.0, 14.0, 18.0, 22.0)]
    out += [Via("VMOT", 72.0, 19.5, 0.6, 0.3), Via("VMOT", 89.0, 19.5, 0.6, 0.3),
            Via("VMOT", 101.3, 18.0, 0.6, 0.3), Via("VMOT", 101.3, 22.0, 0.6, 0.3)]
    # fuse output and TVS into the planes, the fuse's input onto B.Cu
    out += _grid("VMOT", 131.0, 38.0, 3, 2)
    out += _grid("GND", 114.0, 43.4, 2, 3)
    out += _grid("VBAT", 144.2, 38.6, 3, 2, pitch=1.4)
    out += [Via("VMOT", 125.4, 42.0, 0.6, 0.3), Via("VMOT", 124.2, 41.3, 0.6, 0.3)]
    out += _grid("SW_A", 72.0, 22.3, 5, 3)             # the IP+ pours' stitching (15)
    out += _grid("MOT_A", 75.2, 29.2, 4, 3)            # the IP− pours' stitching (12)
    return out


DRIVER_PHASE_LINKS = (
    # leg A: BHS (pin 15) under the body to C114, a via, B.Cu down into the SW_A pour
    ("SW_A", [(77.325, 4.9), (77.325, 7.125), (74.4, 7.125), (73.1, 7.4)], (73.1, 7.4),
     [(73.1, 7.4), (73.1, 22.2)]),
    # leg B: AHS (pin 11) under the body to C115, a via, B.Cu under Q103's island into MOT_B's pour
    ("MOT_B", [(82.405, 4.9), (82.405, 7.7), (85.9, 7.7), (86.6, 8.375), (87.3, 9.6)], (87.3, 9.6),
     [(87.3, 9.6), (87.3, 16.65), (96.6, 16.65), (96.6, 17.5)]),
)
"""The driver's phase-sense pins (high-voltage class) to their bootstrap capacitors and phase
nodes, drawn: the router could not reach them at 0.6 mm from the driver's other pins (the first
route left both open). Under the SOIC's body the tracks pass 0.7 mm from the input row."""


def driver_phase_links() -> tuple[list[Track], list[Via]]:
    tracks, vias = [], []
    for net, top, (vx, vy), bottom in DRIVER_PHASE_LINKS:
        tracks += [Track(net, top, 0.4), Track(net, bottom, 0.5, "B.Cu")]
        vias.append(Via(net, vx, vy, 0.6, 0.3))
    return tracks, vias


REGULATOR_LINKS = (
    # Q106's pads (SOT-89, turned 180°): 1 emitter at (96.15, 4.5), 3 base at (96.15, 1.5), the
    # collector tab between them (NXP BCP56_BCX56_BC56PA Rev. 9, Table 3: SOT89 1 E, 2 C, 3 B)
    # VMOT: two vias in Q106's collector tab into the In2.Cu plane; R120's VMOT pad onto the tab
    ("VMOT", [(90.2, 3.825), (92.6, 3.4)], 0.4),
    ("VMOT", [(93.2, 3.0), (92.8, 3.4), (92.6, 3.4)], 0.3),
    # VG: R120 → along the board edge → Q106's base → D105's cathode → C118
    ("DRV_VG", [(90.2, 2.175), (90.2, 0.8), (96.15, 0.8), (96.15, 1.5)], 0.3),
    ("DRV_VG", [(96.15, 1.5), (98.45, 1.35)], 0.3),
    ("DRV_VG", [(98.45, 1.35), (100.35, 2.225)], 0.3),
    # GND: D105's anode and C118's ground pad to a via into In1.Cu
    ("GND", [(98.45, 4.65), (100.35, 4.65), (100.35, 3.775)], 0.3),
    ("GND", [(100.35, 4.65), (101.4, 4.65)], 0.3),
    # VDD: Q106's emitter to a via, on B.Cu above GATE_BH's via to D104's anode via (the router
    # takes it on to the driver)
    ("DRV_VDD", [(96.15, 4.5), (96.15, 5.55)], 0.3),
    ("DRV_VDD", [(96.15, 5.55), (91.6, 5.55), (90.0, 3.95), (90.0, 0.9), (86.17, 0.9), (85.57, 1.5)],
     0.3, "B.Cu"),
    # the supply-sense dividers' VMOT from C112's plane via down the column's left
    ("VMOT", [(101.3, 22.0), (102.0, 22.7), (102.0, 32.0), (103.225, 32.0)], 0.3),
    ("VMOT", [(102.0, 26.0), (103.225, 26.0)], 0.3),
)
REGULATOR_VIAS = (("VMOT", 93.2, 3.0), ("VMOT", 94.4, 3.0), ("GND", 101.4, 4.65),
                  ("DRV_VDD", 96.15, 5.55))
"""The driver's VDD regulator above leg B's high side, drawn: its parts sit between the board
edge and Q103's tab, where the router left every one of its connections open (second route);
and the VMOT feed of the VMOT_SENSE and over-voltage dividers, which it also left open."""


def regulator_links() -> tuple[list[Track], list[Via]]:
    return ([Track(net, pts, w, *layer) for net, pts, w, *layer in REGULATOR_LINKS],
            [Via(net, x, y, 0.6, 0.3) for net, x, y in REGULATOR_VIAS])


GND_FANOUT = (   # (pad centre, via) in mm, F.Cu track 0.3 mm
    ((39.525, 24.865), (41.15, 24.86)), ((44.475, 23.595), (46.1, 23.59)),
    ((38.862, 36.4), (40.17, 36.4)), ((17.8, 27.625), (18.93, 27.62)), ((39.062, 32.6), (40.38, 32.6)),
    ((45.075, 32.6), (46.18, 32.6)), ((34.825, 40.0), (35.88, 40.0)), ((45.075, 35.2), (46.18, 35.2)),
    ((36.862, 40.95), (38.25, 40.95)), ((5.0, 34.475), (6.15, 34.48)), ((11.0, 34.475), (12.15, 34.48)),
    ((37.0, 24.225), (38.04, 24.82)), ((21.775, 24.4), (22.88, 24.4)), ((23.363, 46.5), (22.05, 46.5)),
    ((47.6, 36.675), (48.73, 36.67)), ((22.4, 28.45), (23.75, 28.45)),
    # found open after the second route: U1's four VSS pins (vias under its body), the core's
    # C6, C10, C11, D1, R2, TP3 and the Hall sensor's C119
    ((25.837, 29.25), (27.87, 29.25)), ((32.25, 32.663), (32.25, 30.63)), ((34.163, 26.25), (32.12, 26.25)),
    ((27.75, 24.337), (27.75, 26.37)), ((81.275, 21.5), (82.38, 21.5)), ((33.337, 16.0), (34.73, 16.0)),
    ((53.6, 20.2), (54.75, 20.2)), ((30.325, 35.2), (31.38, 35.2)), ((21.6, 30.225), (20.56, 30.82)),
    ((23.2, 30.225), (24.32, 30.23)), ((20.775, 33.5), (21.88, 33.5)))
"""A via into the In1 GND plane beside each GND pad of the core band's parts (SW1, Y1, C1, C2,
C4, U3, D102 and this board's comparators and enable inverter), found clear of
every other net by a search over the placed board: freerouting left six such pads as F.Cu
islands without one (the previous route's leftovers)."""


def gnd_fanout() -> tuple[list[Track], list[Via]]:
    return ([Track("GND", [pad, via], 0.3) for pad, via in GND_FANOUT],
            [Via("GND", x, y, 0.6, 0.3) for _, (x, y) in GND_FANOUT])


HV_NETS = ("VBAT", "VMOT", "SW_A", "MOT_A", "MOT_B", "GATE_AH", "GATE_BH", "GHA", "GHB",
           "DRV_BOOT_A", "DRV_BOOT_B", "OV_A", "OV_B")
"""Nets at the motor supply (up to 49.2 V at the trip, 72.7 V at the TVS clamp) or riding on it
(the high-side gates and the bootstrap supplies, ≤ 15 V above it); among themselves they differ by less
than 15 V, from every other net by up to the clamp."""
FINE_PITCH = ("U102", "Q106")
"""Inside these courtyards the maker's pin spacing rules: the sensor's (its IP+ and IP− leads are
one net each) and the VDD regulator's SOT-89 (collector tab on VMOT, 0.5 mm from its base and
emitter pads). The driver's SOIC-16 keeps 0.67 mm between pads and needs no exemption."""


def ipc2221b_rules() -> str:
    """IPC-2221B table 6-1, B2 (external, uncoated): 0.6 mm for 31-100 V, as on the PSU."""
    def anyof(side: str) -> str:
        return "(" + " || ".join(f"{side}.NetName == '/{n}'" for n in HV_NETS) + ")"
    exempt = " && ".join(f"!(A.intersectsCourtyard('{r}') && B.intersectsCourtyard('{r}'))"
                         for r in FINE_PITCH)
    return ("# IPC-2221B table 6-1, B2 (external, uncoated): 0.6 mm for 31-100 V between conductors.\n"
            "# Motor supply: 44.1 V steady, 49.2 V at the trip, 72.7 V at the TVS clamp (calc/motor.py).\n"
            '(rule "ipc2221b: motor supply nets 0.6 mm from other potentials"\n'
            f'    (condition "{anyof("A")} && !{anyof("B")} && {exempt}")\n'
            "    (constraint clearance (min 0.6mm)))\n")


def build(core: Sheet) -> Module:
    s = Sheet(NAME, f"{TITLE}: 15-44 V, 20 A continuous H-bridge, encoder, Hall current sense")
    bus_tap(s, "+5V_MOD", at=BUS_TAP_PLACE)
    pins = {p: "" for p in core_mod.FREE_GPIO}
    pins.update(PINS)
    pins["V5_IN"] = "+5V_MOD"
    s.use(core, pins)
    s.flags += ["VMOT", "DRV_VDD"]

    # input: XT60 male (pin 1 −, pin 2 +), fuse, TVS, bulk and the commutation-loop ceramics
    s.part("J101", "XT60_M", {"1": "GND", "2": "VBAT"}, value="BATTERY 15-44V")
    s.part("F102", "FUSE_30A", {"1": "VBAT", "2": "VMOT"})
    s.part("D101", "SMCJ45A", {"1": "VMOT", "2": "GND"})          # D_SMC pad 1 = cathode
    for i in range(4):
        s.part(f"C{101 + i}", "C_1000u_63V", {"1": "VMOT", "2": "GND"})
    for i in range(8):
        s.part(f"C{105 + i}", "C_2u2_100V", {"1": "VMOT", "2": "GND"})

    # the bridge: high sides' drains on VMOT, low sides' sources on GND (SLA/SLB sense them)
    s.part("Q101", "CSD19536KTT", {"G": "GATE_AH", "D": "VMOT", "S": "SW_A"})
    s.part("Q102", "CSD19536KTT", {"G": "GATE_AL", "D": "SW_A", "S": "GND"})
    s.part("Q103", "CSD19536KTT", {"G": "GATE_BH", "D": "VMOT", "S": "MOT_B"})
    s.part("Q104", "CSD19536KTT", {"G": "GATE_BL", "D": "MOT_B", "S": "GND"})
    for ref, drv, gate in (("R101", "GHA", "GATE_AH"), ("R102", "GLA", "GATE_AL"),
                           ("R103", "GHB", "GATE_BH"), ("R104", "GLB", "GATE_BL")):
        s.part(ref, "R_10R", {"1": drv, "2": gate})

    # gate driver U101 HIP4082 (Renesas FN3676; KiCad 9's Driver_FET:HIP4082xB symbol and pin
    # table): four independent inputs (the board file's four PWM pins), bootstrap high sides,
    # turn-on delay set by R105 on DEL, under-voltage lockout on VDD; DIS high = every output low.
    # Its two half-bridge channels are alike: channel B drives leg A and channel A leg B, so that
    # turned 90° each channel's outputs face their leg (motor.py PLACES)
    s.part("U101", "HIP4082", {
        "BHI": "PWM_AH", "BLI": "PWM_AL", "AHI": "PWM_BH", "ALI": "PWM_BL", "DIS": "DRV_DIS",
        "DEL": "DRV_DEL", "VDD": "DRV_VDD", "VSS": "GND",
        "BHB": "DRV_BOOT_A", "BHO": "GHA", "BHS": "SW_A", "BLO": "GLA",
        "AHB": "DRV_BOOT_B", "AHO": "GHB", "AHS": "MOT_B", "ALO": "GLB"})
    s.part("C113", "C_10u", {"1": "DRV_VDD", "2": "GND"})             # VDD reservoir (10 × C_BS)
    s.part("C116", "C_100n", {"1": "DRV_VDD", "2": "GND"})            # VDD at the pin
    s.part("C114", "C_470n", {"1": "DRV_BOOT_A", "2": "SW_A"})        # bootstrap, leg A
    s.part("C115", "C_470n", {"1": "DRV_BOOT_B", "2": "MOT_B"})       # bootstrap, leg B
    s.part("D103", "1N4148W", {"A": "DRV_VDD", "K": "DRV_BOOT_A"})    # bootstrap diodes: 100 V, 4 ns
    s.part("D104", "1N4148W", {"A": "DRV_VDD", "K": "DRV_BOOT_B"})
    s.part("R105", "R_10k", {"1": "DRV_DEL", "2": "GND"})             # DEL: the shortest delays
    # VDD ≈ 12.4 V from VMOT: Q106 (BCX56-16, 80 V) follows D105's 13 V; R120 feeds the zener
    # and the base (calc/motor.py: VDD at the 13 V minimum input, Q106's dissipation)
    s.part("Q106", "BCX56", {"C": "VMOT", "B": "DRV_VG", "E": "DRV_VDD"})
    s.part("R120", "R_24k9", {"1": "VMOT", "2": "DRV_VG"})
    s.part("D105", "Z_13V", {"K": "DRV_VG", "A": "GND"})
    s.part("C118", "C_100n", {"1": "DRV_VG", "2": "GND"})
    # DRV_EN (PB0, active high) → Q105 pulls DIS low; R106 pulls DIS to VDD (bridge off) while
    # PB0 floats (MCU in reset, or the bus unpowered) and R115 holds Q105's gate low
    s.part("Q105", "2N7002", {"G": "DRV_EN", "D": "DRV_DIS", "S": "GND"})
    s.part("R106", "R_10k", {"1": "DRV_VDD", "2": "DRV_DIS"})

    # Hall sensor in leg A's output, ratiometric to the ADC's 3.3 V
    s.part("U102", "ACS725-30AB", {"IP+": "SW_A", "IP-": "MOT_A", "VCC": "+3V3", "GND": "GND",
                                   "VIOUT": "HALL_OUT"}, nc=("FILTER",))
    s.part("C119", "C_100n", {"1": "+3V3", "2": "GND"})
    s.part("R107", "R_1k", {"1": "HALL_OUT", "2": "MOTOR_CURRENT"})
    s.part("C120", "C_4n7", {"1": "MOTOR_CURRENT", "2": "GND"})
    s.part("J102", "XT60_F", {"1": "MOT_A", "2": "MOT_B"}, value="MOTOR")

    # motor supply sense (÷16) and the over-voltage trip (375 k / 10 k into the 1.242 V reference)
    s.part("R108", "R_150k", {"1": "VMOT", "2": "VMOT_SENSE"})
    s.part("R109", "R_10k", {"1": "VMOT_SENSE", "2": "GND"})
    s.part("C121", "C_100n", {"1": "VMOT_SENSE", "2": "GND"})
    s.part("R110", "R_174k", {"1": "VMOT", "2": "OV_A"})
    s.part("R111", "R_174k", {"1": "OV_A", "2": "OV_B"})
    s.part("R112", "R_27k", {"1": "OV_B", "2": "OV_SENSE"})
    s.part("R113", "R_10k", {"1": "OV_SENSE", "2": "GND"})
    s.part("C122", "C_10n", {"1": "OV_SENSE", "2": "GND"})
    # output low (open drain) when OV_SENSE (IN−) rises above the reference (IN+)
    s.part("U103", "TLV3011", {"IN+": "OV_REF", "REF": "OV_REF", "IN-": "OV_SENSE",
                               "OUT": "DRV_FAULT", "V+": "+3V3", "V-": "GND"})
    s.part("C123", "C_100n", {"1": "+3V3", "2": "GND"})
    s.part("R114", "R_10k", {"1": "+3V3", "2": "DRV_FAULT"})
    s.part("R115", "R_100k", {"1": "DRV_EN", "2": "GND"})       # driver off while the MCU resets

    # over-current: the Hall sensor's raw output against a window from the same 3.3 V (ratiometric
    # like the sensor): U105 pulls DRV_FAULT low above OC_HI, U106 below OC_LO (calc/motor.py)
    s.part("R121", "R_10k", {"1": "+3V3", "2": "OC_HI"})
    s.part("R122", "R_56k", {"1": "OC_HI", "2": "OC_LO"})
    s.part("R123", "R_10k", {"1": "OC_LO", "2": "GND"})
    s.part("U105", "LMV331", {"1": "OC_HI", "3": "HALL_OUT", "4": "DRV_FAULT", "5": "+3V3", "2": "GND"})
    s.part("U106", "LMV331", {"1": "HALL_OUT", "3": "OC_LO", "4": "DRV_FAULT", "5": "+3V3", "2": "GND"})
    s.part("C127", "C_100n", {"1": "+3V3", "2": "GND"})
    s.part("C128", "C_100n", {"1": "+3V3", "2": "GND"})

    # encoder: 1 +5V_MOD, 2 A, 3 B, 4 GND; open-collector pull-ups to the encoder's 5 V
    s.part("J103", "HDR_1x4", {"1": "+5V_MOD", "2": "ENC_A_IN", "3": "ENC_B_IN", "4": "GND"},
           value="ENCODER")
    s.part("D102", "SRV05-4", {"IO1": "ENC_A_IN", "IO2": "ENC_B_IN", "VP": "+5V_MOD", "VN": "GND"},
           nc=("IO3", "IO4"))
    s.part("R116", "R_2k2", {"1": "+5V_MOD", "2": "ENC_A_IN"})
    s.part("R117", "R_2k2", {"1": "+5V_MOD", "2": "ENC_B_IN"})
    s.part("R118", "R_1k", {"1": "ENC_A_IN", "2": "ENC_A_F"})
    s.part("R119", "R_1k", {"1": "ENC_B_IN", "2": "ENC_B_F"})
    s.part("C124", "C_100p", {"1": "ENC_A_F", "2": "GND"})
    s.part("C125", "C_100p", {"1": "ENC_B_F", "2": "GND"})
    s.part("U104", "74LVC2G17", {"1A": "ENC_A_F", "2A": "ENC_B_F", "1Y": "ENC_A", "2Y": "ENC_B",
                                 "VCC": "+3V3", "GND": "GND"})
    s.part("C126", "C_100n", {"1": "+3V3", "2": "GND"})

    for p in s.parts:
        if p.ref in PLACES:
            p.place = PLACES[p.ref]
    sheet = drawing_of(__file__)
    s.drawing, s.blocks = sheet.DRAWING, sheet.BLOCKS

    m = Module(NAME, TITLE, REVISION, s,
               tracks=[*core_mod.bus_tracks(), bus_tap_track(), tvs_track(), *core_tracks(),
                       *power_tracks(), *gnd_fanout()[0], *driver_phase_links()[0],
                       *regulator_links()[0]],
               vias=power_vias() + gnd_fanout()[1] + driver_phase_links()[1] + regulator_links()[1], zones=planes() + power_zones(),
               seed=19, size=SIZE, holes=HOLES, copper_layers=4,
               netclasses={"HV": list(HV_NETS)}, dru_rules=ipc2221b_rules(),
               netclass_defs={"HV": (0.6, 0.3, 0.8, 0.4)},
               solid_pads=("J101", "J102", "F102", "D101", "C101", "C102", "C103", "C104",
                           "Q101", "Q102", "Q103", "Q104", "U102"))
    m.fiducials = list(FIDUCIALS)
    m.texts = frame_texts(NAME, REVISION) + [
        Text("MOTOR SUPPLY 15-44V", 130.0, 19.3, 1.2, "B.SilkS"),
        Text("+", 152.0, 20.2, 1.5, "B.SilkS"), Text("-", 152.0, 13.0, 1.5, "B.SilkS"),
        Text("BATTERY", 152.5, 30.0, 1.0, "B.SilkS"), Text("MOTOR", 80.5, 44.0, 1.0, "B.SilkS")]
    return m
