"""hardware/psu revision B: battery in (6-42 V, 2S-10S Li-ion), bus out (5 V, 2.4 A), battery
voltage and current sensing.

Power path, left to right along the bottom edge:

    XT30 ──► F101 5 A T ──► Q101 P-MOSFET (reverse polarity) ──► VIN_PROT ──► R102 10 mΩ ──► VIN_BUCK
                            D101 15 V zener holds Vgs,   D102 SMBJ40A TVS    INA293A2 ×50 → IIN_SENSE
                            R101 pulls the gate down     R104/R105 → VIN_SENSE (÷16)
    VIN_BUCK ──► U102 LM76005 synchronous buck, 400 kHz, L101 10 µH, BIAS on 5 V ──► +5V_BUCK
    +5V_BUCK ──► core LDO (MCU)
    +5V_BUCK ──► U103 TPS16630 eFuse (BUS_EN, BUS_FAULT, 2.41-2.89 A limit, 6.0-6.2 V OVP) ──► +5V

Every value of the power path is computed, with its datasheet equation and margin, in
`r2ptools.kicad.calc.psu` (`scripts/py -m r2ptools.kicad.calc.psu` prints the table), and
tests/test_hardware.py checks that the values it assumes are the ones below. In short: the TVS
clamps at 64.5 V at its rated pulse, under the LM76005's 65 V absolute maximum, at the price of a
40 V stand-off (its breakdown stays above the 42.4 V of a charger); every input-side part is
rated above the clamp; the fuse carries the 3.1 A worst case (6 V in, bus at its limit) at 63 %;
one eFuse limit of at most 2.89 A keeps either jack under docs/bus.md's 3.0 A whatever the split.
The buck output feeds the PSU's own MCU ahead of the eFuse, so the firmware keeps running and
reports a tripped bus (BUS_FAULT) instead of browning out with it.
"""
from __future__ import annotations

from ..design import Keepout, Module, Place, Sheet, Text, Track, Via
from . import core as core_mod
from .common import frame_texts

NAME = "psu"
TITLE = "R2P power supply module"
REVISION = "B"

FIDUCIALS = [(1.8, 40.0), (22.3, 19.4), (57.5, 40.5)]
"""Three board-only fiducials, clear of the PSU's parts."""

BUCK_DY = -0.45
"""How far U102, its top-row parts and L101 moved up to make room for C103 on the top side."""


def _up(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Points of copper that moved with the buck (BUCK_DY)."""
    return [(x, round(y + BUCK_DY, 3)) for x, y in points]


P = Place
PLACES = {
    # --- test pads (TP1-TP8 the core's, TP101-TP105 the PSU's): a grid right of the buck, and
    # three beside the SWD header; TP101 on the EN divider's VIN_BUCK feed and TP102 below the
    # output capacitors (hand tracks)
    "TP1": P(48.5, 35.5, 0), "TP2": P(51.0, 35.5, 0), "TP3": P(53.5, 35.5, 0),
    "TP4": P(57.0, 35.5, 0), "TP5": P(48.5, 38.0, 0), "TP6": P(51.0, 38.0, 0),
    "TP7": P(53.5, 38.0, 0), "TP8": P(57.0, 38.0, 0), "TP102": P(55.4, 34.1, 0),
    "TP101": P(48.5, 44.3, 0), "TP103": P(35.5, 29.5, 0), "TP104": P(35.5, 32.0, 0),
    "TP105": P(38.0, 29.5, 0),
    # core rev B parts: the +5V TVS right of BUS OUT's pins, VDDA's 1 uF beside its 10 nF (C6)
    "D5": P(44.1, 20.3, 0), "C11": P(11.2, 30.3, 90),
    # --- power stage (bottom edge and right side)
    "J101": P(12.4, 37.15, 180), "Q101": P(28.87, 46.3, 180),
    "D102": P(31.3, 40.3, 180), "R102": P(38.8, 44.3, 0), "U101": P(37.2, 40.2, 0),
    "D101": P(38.5, 46.9, 0), "R101": P(38.5, 49.0, 0),
    # every part on the top side (one-sided economic PCBA at JLCPCB): the buck, its top-row
    # parts and L101 sit BUCK_DY higher than in the first layout so that the HF input capacitor
    # C103 fits between the PVIN/PGND pins and the bulk capacitors C101/C102
    "U102": P(43.0, 39.5 + BUCK_DY, 270),
    # C103 straddles PVIN (pins 20-22) and PGND (24-26), 0.6 mm below them: the smallest loop
    "C103": P(43.9, 42.53, 0),
    "C101": P(43.9, 44.97, 0), "C102": P(43.9, 48.28, 0),
    # U102's top-row parts, left to right as their pins: SS (11), BIAS (9), VCC (8), BOOT (6)
    "C110": P(38.9, 35.16 + BUCK_DY, 90), "C116": P(40.5, 35.16 + BUCK_DY, 90),
    "C108": P(42.1, 35.16 + BUCK_DY, 90), "C109": P(43.7, 35.16 + BUCK_DY, 90),
    "R108": P(37.6, 37.6, 0), "R109": P(34.5, 37.1, 0),
    "R104": P(31.5, 36.4, 90), "R105": P(29.7, 36.4, 90), "C106": P(27.9, 36.4, 90),
    # the fuse upright between the XT30's + pin and Q101's drain tab, right above the tab
    "F101": P(24.05, 38.7, 270),
    "R106": P(47.2, 48.0, 90), "R107": P(49.4, 48.0, 90), "C104": P(51.2, 48.0, 90),
    "L101": P(47.5, 28.2 + BUCK_DY, 0),
    "C111": P(56.85, 20.3, 0), "C112": P(56.85, 24.0, 0), "C113": P(56.85, 27.7, 0),
    "C114": P(56.85, 31.4, 0),
    "U103": P(56.05, 13.5, 90),
    # eFuse set-up parts in a row between D5 and the output capacitors, reached from the bottom
    # pin row's vias on the back (the +5V_BUCK feed fills the row on top); R_ILIM above the top
    # row's left end, between BUS OUT and the mounting hole: right above the ILIM pin (11) it
    # would wall in BUS_EN (13), whose only way out is up to a via there
    "C115": P(48.45, 20.88, 270), "R114": P(50.05, 20.88, 270), "R113": P(51.65, 20.88, 270),
    "R112": P(53.25, 20.88, 270),
    "R116": P(54.0, 8.3, 180),
    "R110": P(31.6, 33.2, 0), "R111": P(28.5, 33.2, 0),
    # the IIN_SENSE filter beside the amplifier, where F101 took its first place
    "R103": P(34.3, 35.1, 180), "C105": P(38.6, 32.2, 0),
    "R117": P(4.0, 16.6, 0), "R118": P(1.9, 36.9, 90), "C117": P(3.7, 36.9, 90),
    # --- core parts moved to make room (the core's schematic is unchanged)
    "D2": P(2.2, 9.6, 180), "R4": P(5.3, 9.6, 0), "D3": P(2.2, 11.6, 180), "R5": P(5.3, 11.6, 0),
    "D4": P(2.2, 13.6, 180), "R6": P(5.3, 13.6, 0),
    "SW1": P(3.95, 23.0, 90), "SW2": P(3.95, 31.0, 90),
    "U1": P(19.0, 26.0, 0), "C3": P(14.6, 19.6, 0), "R1": P(18.4, 19.6, 0), "C4": P(25.5, 19.9, 0),
    "C6": P(12.9, 30.3, 90), "C5": P(25.4, 33.1, 0), "R2": P(22.3, 33.1, 0),
    "Y1": P(10.4, 25.2, 0), "C1": P(8.8, 28.7, 0), "C2": P(10.4, 21.7, 0),
    "C10": P(8.8, 30.6, 0),
    "U2": P(16.0, 33.1, 0), "C8": P(12.0, 33.6, 0), "C7": P(19.3, 33.1, 90),
    "U3": P(28.8, 26.5, 0), "C9": P(28.8, 30.4, 0),
    "J4": P(36.8, 22.7, 90),
}


def power_tracks() -> list[Track]:
    """The 4 A paths, drawn here rather than left to the autorouter.

    Widths follow docs/hardware.md: 2.0 mm carries 4 A on 1 oz outer copper at a 10 °C rise
    (IPC-2221 external-layer curve; IPC-2152 gives less for outer layers over a plane), so the
    long runs are 2.0-3.0 mm and only the last millimetre into a fine-pitch pin narrows to the
    pin. The buck's hot loop is the short one: C103/C101/C102 sit directly under U102's PVIN
    and PGND pins, the switch node runs 6 mm straight up to L101, the output capacitors line
    L101's far pad, and the eFuse input is fed from the same trunk."""
    T = Track
    return [
        # battery +: XT30 pin 2 across to F101's upper pad, F101's lower pad down into Q101's
        # drain tab
        T("VBAT_CONN", [(17.4, 36.25), (24.05, 36.25)], 2.0),
        T("VBAT_IN", [(24.05, 41.15), (24.05, 42.4), (25.4, 43.75), (25.4, 45.0)], 2.4),
        # Q101 source to the shunt, and to the TVS
        T("VIN_PROT", [(33.9, 44.0), (35.6, 44.0), (35.9, 44.3), (37.34, 44.3)], 1.8),
        T("VIN_PROT", [(33.9, 44.0), (33.9, 41.5), (33.3, 40.3)], 1.2),
        # shunt to the input capacitors, up to PVIN (neck to the 0.5 mm-pitch pins)
        T("VIN_BUCK", [(40.26, 44.3), (42.6, 44.3)], 1.8),
        T("VIN_BUCK", [(42.6, 48.3), (42.6, 43.1)], 2.0),
        # the neck passes through C103's VIN pad, the PGND stub through its GND pad: C103's loop
        # is the pins, its pads and 0.6 mm of copper
        T("VIN_BUCK", [(42.6, 43.1), (43.0, 42.7), (43.0, 41.36 + BUCK_DY)], 0.9),
        T("VIN_BUCK", _up([(42.5, 41.36), (43.5, 41.36)]), 0.3),
        # power ground of the hot loop: PGND pins to the capacitor returns (vias to both pours)
        T("GND", _up([(44.5, 41.36), (45.5, 41.36)]), 0.3),
        T("GND", [(45.0, 41.36 + BUCK_DY), (45.0, 42.1), (45.4, 42.5), (45.4, 48.6)], 1.2),
        # small-signal pins of U102 to their parts, fanned out from the 0.5 mm pitch by hand
        T("GND", _up([(41.0, 41.36), (41.0, 40.3)]), 0.2),             # SYNC/MODE: auto mode
        T("BOOT", _up([(43.7, 35.94), (43.7, 36.6), (43.05, 36.95), (43.05, 37.64)]), 0.25),
        T("VCC_BUCK", _up([(42.1, 35.94), (42.0, 36.5), (42.0, 37.64)]), 0.25),
        # BIAS to +5V_BUCK (SNVSBK5 §5 for a 5 V output) with C116 at the pin
        T("+5V_BUCK", _up([(40.5, 35.94), (41.5, 36.7), (41.5, 37.64)]), 0.25),
        T("SS_BUCK", _up([(38.9, 35.94), (39.6, 36.9), (40.5, 36.9), (40.5, 37.64)]), 0.25),
        T("GND", _up([(38.9, 34.38), (38.9, 33.6), (42.1, 33.6), (42.1, 34.38)]), 0.3),
        T("GND", _up([(40.5, 34.38), (40.5, 33.6)]), 0.3),
        T("SW", _up([(43.7, 34.38), (45.4, 34.38)]), 0.4),
        T("VIN_PROT", [(31.5, 37.225), (31.5, 38.2), (32.6, 39.3)], 0.3),
        T("VIN_PROT", [(36.85, 46.9), (36.85, 45.0)], 0.5),            # D101 (gate zener)
        # bus voltage divider top (R117) to BUS IN's +5V pin 7, between the jack's GND pins 6 and 8
        T("+5V", [(3.175, 16.6), (4.2, 17.6), (12.58, 17.6), (12.58, 13.52)], 0.4),
        # Kelvin sense lines from the shunt's pads to the amplifier inputs
        T("VIN_PROT", [(36.06, 41.15), (36.7, 41.8), (37.34, 43.45)], 0.25),
        T("VIN_BUCK", [(38.34, 41.15), (39.2, 42.0), (40.0, 43.4)], 0.25),
        # eFuse bottom-row set-up pins down to vias (the +5V_BUCK feed fills the row on top); the
        # router takes them on the back to the set-up parts' row
        T("EFUSE_UV", [(57.02, 16.45), (57.02, 17.4), (57.15, 18.05)], 0.25),
        T("EFUSE_OV", [(57.67, 16.45), (57.67, 17.4), (58.0, 18.05)], 0.25),
        T("EFUSE_DVDT", [(58.97, 16.45), (58.97, 17.4), (58.85, 18.05)], 0.25),
        # the UVLO divider's top (R112 pad 1) up into the eFuse's +5V_BUCK feed
        T("+5V_BUCK", [(53.25, 20.1), (53.25, 19.2)], 0.4),
        # EN (pin 18) out between the PGND pins and the PVIN trunk's 0.6 mm, on the back to the
        # divider: R106's EN pad (via A) and R107's (via B)
        T("EN_BUCK", [(41.5, 41.36 + BUCK_DY), (41.5, 41.6), (40.6, 42.6)], 0.25),
        T("EN_BUCK", [(40.6, 42.6), (40.6, 43.8), (47.4, 43.8), (47.4, 46.1), (50.2, 46.1),
                      (50.2, 48.0)], 0.25, "B.Cu"),
        T("EN_BUCK", [(47.4, 46.1), (47.2, 46.5), (47.2, 47.17)], 0.25),
        T("EN_BUCK", [(50.2, 48.0), (49.4, 48.83)], 0.25),
        # TP101 (VIN_BUCK) down between the EN divider's resistors to the feed's via
        T("VIN_BUCK", [(48.5, 44.3), (48.05, 45.2), (48.05, 49.2)], 0.3),
        # EN divider feed: under the hot-loop ground on B.Cu, from a via at the feed track's left
        # edge beside C102's pad (a via in the pad would wick its solder away)
        T("VIN_BUCK", [(41.4, 47.9), (41.4, 49.2), (48.05, 49.2)], 0.3, "B.Cu"),
        T("VIN_BUCK", [(48.05, 49.2), (47.2, 48.825)], 0.3),
        # switch node: the SW pins to L101
        T("SW", _up([(43.5, 37.64), (45.5, 37.64)]), 0.3),
        T("SW", _up([(45.25, 37.64), (45.25, 36.9)]), 0.8),
        T("SW", _up([(45.4, 36.9), (45.4, 29.0), (43.03, 28.2)]), 2.0),
        # buck output: L101 to the output capacitors' trunk, up to the eFuse inputs
        T("+5V_BUCK", _up([(51.97, 28.2), (55.37, 28.2)]), 2.5),
        T("+5V_BUCK", [(55.375, 31.4), (55.4, 34.1)], 0.6),             # TP102 below C114
        # BIAS's via (under the top-row parts) on the back to TP102's track
        T("+5V_BUCK", [(41.0, 36.5 + BUCK_DY), (41.45, 35.6), (53.9, 35.6), (55.4, 34.1),
                       (55.4, 33.2)], 0.4, "B.Cu"),
        T("+5V_BUCK", [(55.37, 31.4), (55.37, 19.4)], 2.5),
        T("+5V_BUCK", [(55.37, 19.4), (54.4, 18.6), (53.13, 18.6)], 1.5),
        T("+5V_BUCK", [(53.13, 18.6), (53.13, 16.45)], 0.45),
        T("+5V_BUCK", [(53.78, 18.6), (53.78, 16.45)], 0.45),
        T("+5V_BUCK", [(54.43, 18.6), (54.43, 16.45)], 0.45),
        T("+5V_BUCK", [(55.37, 19.4), (56.38, 18.6), (56.38, 16.45)], 0.45),
        # eFuse output down to the bus line on B.Cu (core.bus_tracks, extended to x = 52.4)
        T("+5V", [(50.2, 10.0), (53.4, 10.0)], 1.8),
    ]


def power_vias() -> list[Via]:
    out = [Via("+5V", x, y, 0.8, 0.4) for x in (50.4, 51.4, 52.4) for y in (9.5, 10.5)]
    # thermal vias in U102's exposed pad (2 x 5 at 0.9 x 0.8 mm; KiCad's _ThermalVias variant
    # drills 0.2 mm, below the fab's 0.3 mm), the hot-loop ground, the output returns
    out += [Via("GND", x, y + BUCK_DY, 0.6, 0.3) for x in (41.3, 42.15, 43.0, 43.85, 44.7)
            for y in (39.05, 39.95)]
    out += [Via("GND", 46.7, y, 0.6, 0.3) for y in (42.9, 45.1)]
    out += [Via("GND", 40.5, 33.0 + BUCK_DY, 0.6, 0.3)]
    out += [Via("+5V_BUCK", 41.0, 36.5 + BUCK_DY, 0.6, 0.3),
            Via("+5V_BUCK", 55.4, 33.2, 0.6, 0.3)]                                   # BIAS
    out += [Via("EN_BUCK", x, y, 0.6, 0.3) for x, y in ((40.6, 42.6), (47.4, 46.1), (50.2, 48.0))]
    out += [Via("VIN_BUCK", 41.4, 47.9, 0.7, 0.3), Via("VIN_BUCK", 48.05, 49.2, 0.7, 0.3)]
    out += [Via(n, x, 18.05, 0.7, 0.3) for n, x in (("EFUSE_UV", 57.15), ("EFUSE_OV", 58.0),
                                                     ("EFUSE_DVDT", 58.85))]
    out += [Via("GND", x, y, 0.6, 0.3) for x in (53.8, 55.2, 56.9, 58.3) for y in (12.6, 14.4)]
    out += [Via("GND", 59.0, y, 0.6, 0.3) for y in (22.2, 25.9, 29.6, 33.3)]
    return out


SOLID_PADS = ("J101", "F101", "Q101", "D102", "R102", "C101", "C102", "C103", "U102", "L101",
              "C111", "C112", "C113", "C114", "U103")
"""Power parts whose pads join the GND pours solid (no thermal spokes), the XT30's THT pins too."""

BATTERY_NETS = ("VBAT_CONN", "VBAT_IN", "VIN_PROT", "VIN_BUCK")
"""Nets at the battery voltage (up to 42.4 V, 64.5 V at the TVS clamp); among themselves they
differ by at most the shunt's and the MOSFET's drop."""
SWITCH_NETS = ("SW", "BOOT")
"""The switch node swings between GND and VIN (BOOT rides 5 V above it): 42.4 V to both."""
LOW_DIFF_NETS = ("EN_BUCK", "Q_GATE")
"""Battery-derived nets within 30 V of VIN_BUCK/VIN_PROT (EN at 36 % of VIN, the gate 15 V below
the source): the 16-30 V row (0.1 mm, the fab minimum) covers them against the battery nets."""
FINE_PITCH = ("U101", "U102")
"""Parts whose own pin pitch is below the rule (0.5 and 0.95 mm): inside their courtyards the
spacing is the part maker's (rated for the full voltage), not a board conductor spacing."""


def ipc2221b_rules() -> str:
    # The same nets form the net class "HV" with a 0.6 mm clearance: the autorouter knows net
    # classes, not custom rules, so it keeps its tracks that far from them. DRC checks the rules
    # below (custom rules take precedence over net classes).
    """The board's high-voltage clearance as a KiCad custom rule (calc/psu.py prints the row).

    IPC-2221B table 6-1, B2 (external conductors, uncoated, sea level to 3050 m): 31-50 V and
    51-100 V both ask 0.6 mm. The battery side reaches 42.4 V (a charger on a 10S pack) and
    64.5 V at the TVS's rated clamp, so every battery-side conductor keeps 0.6 mm from every
    conductor at another potential. Net names are the board's (root-sheet labels: '/NAME')."""
    def anyof(side: str, nets: tuple[str, ...]) -> str:
        return "(" + " || ".join(f"{side}.NetName == '/{n}'" for n in nets) + ")"
    exempt = " && ".join(f"!(A.intersectsCourtyard('{r}') && B.intersectsCourtyard('{r}'))"
                         for r in FINE_PITCH)
    return (
        "# IPC-2221B table 6-1, B2 (external, uncoated): 0.6 mm for 31-100 V between conductors.\n"
        "# Battery side: up to 42.4 V (10S + charger), 64.5 V at the TVS clamp (calc/psu.py).\n"
        '(rule "ipc2221b: battery nets 0.6 mm from other potentials"\n'
        f'    (condition "{anyof("A", BATTERY_NETS)} && !{anyof("B", BATTERY_NETS + LOW_DIFF_NETS)}'
        f' && {exempt}")\n'
        "    (constraint clearance (min 0.6mm)))\n"
        '(rule "ipc2221b: switch node 0.6 mm from other potentials"\n'
        f'    (condition "{anyof("A", SWITCH_NETS)} && !{anyof("B", SWITCH_NETS)} && {exempt}")\n'
        "    (constraint clearance (min 0.6mm)))\n")


def build(core: Sheet) -> Module:
    s = Sheet(NAME, f"{TITLE}: 6-42 V in, 5 V 2.4 A bus out")
    pins = {p: "" for p in core_mod.FREE_GPIO}
    pins.update({"PA0": "VIN_SENSE", "PA1": "IIN_SENSE", "PA2": "VOUT_SENSE", "PB0": "BUS_EN",
                 "PB1": "BUS_FAULT", "V5_IN": "+5V_BUCK"})
    s.use(core, pins)
    s.flags += ["GND", "VIN_BUCK", "+5V_BUCK"]

    # input, reverse polarity, surge
    # XT30PW-M: pin 2 is + (the footprint's and the connector's marking), pin 1 is -
    s.part("J101", "XT30", {"1": "GND", "2": "VBAT_CONN"}, at=Place(12.4, 37.15, 180), value="BATTERY")
    # 5 A time-lag fuse: carries the 3.1 A worst-case input current (6 V, bus at its limit) at
    # 63 % of its rating and rides through the input capacitors' hot-plug surge (calc/psu.py)
    s.part("F101", "FUSE_5A_SLOW", {"1": "VBAT_CONN", "2": "VBAT_IN"})
    s.part("Q101", "SQD50P06-15L", {"D": "VBAT_IN", "S": "VIN_PROT", "G": "Q_GATE"})
    s.part("D101", "Z_15V", {"K": "VIN_PROT", "A": "Q_GATE"})
    s.part("R101", "R_100k", {"1": "Q_GATE", "2": "GND"})
    # pad 1 of D_SMB is the cathode
    s.part("D102", "SMBJ40A", {"1": "VIN_PROT", "2": "GND"})

    # input current and voltage sensing
    s.part("R102", "R_10m", {"1": "VIN_PROT", "2": "VIN_BUCK"})
    s.part("U101", "INA293A2", {"IN+": "VIN_PROT", "IN-": "VIN_BUCK", "Vs": "+3V3", "GND": "GND",
                                "OUT": "IIN_AMP"})
    s.part("C104", "C_100n", {"1": "+3V3", "2": "GND"})
    s.part("R103", "R_1k", {"1": "IIN_AMP", "2": "IIN_SENSE"})
    s.part("C105", "C_100n", {"1": "IIN_SENSE", "2": "GND"})
    s.part("R104", "R_150k", {"1": "VIN_PROT", "2": "VIN_SENSE"})
    s.part("R105", "R_10k", {"1": "VIN_SENSE", "2": "GND"})
    s.part("C106", "C_100n", {"1": "VIN_SENSE", "2": "GND"})

    # buck: input caps straddle PVIN/PGND on the IC's right side, the inductor on its SW side
    s.part("U102", "LM76005", {
        "PVIN": "VIN_BUCK", "EN": "EN_BUCK", "SW": "SW", "BOOT": "BOOT", "VCC": "VCC_BUCK",
        "BIAS": "+5V_BUCK", "SS/TRK": "SS_BUCK", "SYNC/MODE": "GND", "FB": "FB_BUCK",
        "AGND": "GND", "PGND": "GND", "NC_{GND}": "GND"}, nc=("RT", "PGOOD"))
    for ref in ("C101", "C102"):
        s.part(ref, "C_2u2_100V", {"1": "VIN_BUCK", "2": "GND"})
    s.part("C103", "C_100n_100V", {"1": "VIN_BUCK", "2": "GND"})
    s.part("R106", "R_100k", {"1": "VIN_BUCK", "2": "EN_BUCK"})
    s.part("R107", "R_56k", {"1": "EN_BUCK", "2": "GND"})
    s.part("C108", "C_1u", {"1": "VCC_BUCK", "2": "GND"})
    s.part("C116", "C_1u", {"1": "+5V_BUCK", "2": "GND"})          # BIAS decoupling at the pin
    s.part("C109", "C_470n", {"1": "BOOT", "2": "SW"})
    s.part("C110", "C_22n", {"1": "SS_BUCK", "2": "GND"})
    s.part("R108", "R_102k_0.1%", {"1": "+5V_BUCK", "2": "FB_BUCK"})
    s.part("R109", "R_25k5_0.1%", {"1": "FB_BUCK", "2": "GND"})
    s.part("L101", "L_10u", {"1": "SW", "2": "+5V_BUCK"})
    for i in range(4):
        s.part(f"C{111 + i}", "C_22u_25V", {"1": "+5V_BUCK", "2": "GND"})

    # bus output switch
    # TPS16630 on the TPS26631PWP symbol (catalog.py): "IN_SYS" is its P_IN (to IN), "PGTH" (16)
    # its PGOOD and "PGOOD" (17), "B_GATE" (4), "DRV" (5) its NC pins: all left open
    s.part("U103", "TPS16630", {
        "IN": "+5V_BUCK", "IN_SYS": "+5V_BUCK", "OUT": "+5V", "GND": "GND", "~{SHDN}": "BUS_EN",
        "~{FLT}": "BUS_FAULT", "UVLO": "EFUSE_UV", "OVP": "EFUSE_OV", "ILIM": "EFUSE_ILIM",
        "dVdT": "EFUSE_DVDT"}, nc=("B_GATE", "DRV", "MODE", "PGOOD", "PGTH", "IMON"))
    # 10 k, not 100 k: SHDN sources up to 10 µA, and 0.1 V stays below its 0.8 V off threshold
    s.part("R110", "R_10k", {"1": "BUS_EN", "2": "GND"})
    s.part("R111", "R_10k", {"1": "+3V3", "2": "BUS_FAULT"})
    # one divider chain sets both thresholds: +5V_BUCK - 100 k - UVLO - 10 k - OVP - 27 k - GND
    s.part("R112", "R_100k", {"1": "+5V_BUCK", "2": "EFUSE_UV"})
    s.part("R113", "R_10k", {"1": "EFUSE_UV", "2": "EFUSE_OV"})
    s.part("R114", "R_27k", {"1": "EFUSE_OV", "2": "GND"})
    s.part("R116", "R_6k8", {"1": "EFUSE_ILIM", "2": "GND"})
    s.part("C115", "C_22n", {"1": "EFUSE_DVDT", "2": "GND"})
    # test pads (bare 1 mm copper, no BOM line): the PSU's own key signals; the core adds
    # +5V, +3V3, GND, CAN_H/L, NRST, SWD (TP1-TP8)
    for ref, net in (("TP101", "VIN_BUCK"), ("TP102", "+5V_BUCK"), ("TP103", "BUS_EN"),
                     ("TP104", "BUS_FAULT"), ("TP105", "IIN_SENSE")):
        s.part(ref, "TP", {"1": net}, value=net)
    s.part("R117", "R_10k", {"1": "+5V", "2": "VOUT_SENSE"})
    s.part("R118", "R_10k", {"1": "VOUT_SENSE", "2": "GND"})
    s.part("C117", "C_100n", {"1": "VOUT_SENSE", "2": "GND"})
    from . import psu_sheet           # the drawing imports calc/psu.py's numbers
    s.drawing, s.blocks = psu_sheet.DRAWING, psu_sheet.BLOCKS

    m = Module(NAME, TITLE, REVISION, s, tracks=core_mod.bus_tracks(extend_to=52.4) + power_tracks(),
               vias=power_vias(), places=PLACES, seed=3, dru_rules=ipc2221b_rules(),
               solid_pads=SOLID_PADS, netclasses={"HV": [*BATTERY_NETS, *SWITCH_NETS]},
               netclass_defs={"HV": (0.6, 0.3, 0.7, 0.3)},
               keepouts=[Keepout([(x - 1.6, y - 1.6), (x + 1.6, y - 1.6), (x + 1.6, y + 1.6),
                                  (x - 1.6, y + 1.6)]) for x, y in FIDUCIALS])
    m.fiducials = list(FIDUCIALS)
    # the +5V TVS D5 sits where the front "BUS OUT" label goes on other boards, and no gap
    # around it holds the label: on the PSU the jacks are named on the back only
    texts = [t for t in frame_texts(NAME, REVISION, bus_in=(11.0, 18.4))
             if (t.text, t.layer) != ("BUS OUT", "F.SilkS")]
    m.texts = texts + [
        Text("+", 16.0, 40.6, 1.5, "B.SilkS"), Text("-", 12.4, 40.6, 1.5, "B.SilkS"),
        Text("BATTERY 6-42V", 15.0, 33.0, 1.0, "B.SilkS")]
    return m
