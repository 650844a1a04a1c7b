"""hardware/motor revision A: the DC motor module, 36 V / 20 A H-bridge on the common core.

    XT60 in ─► F102 30 A ─► VMOT ─┬─ D101 SMCJ45A, C101-C104 4 × 1000 µF 63 V, C105-C112 8 × 2.2 µF 100 V
                                  ├─ leg A: Q101 (high) / Q102 (low) ─► SW_A ─► U102 ACS725 ─► MOT_A ─┐
                                  └─ leg B: Q103 (high) / Q104 (low) ─► MOT_B ─────────────────────────┴► XT60 motor
    U101 DRV8350H (6x PWM, hardware interface, charge pump) drives the four gates through 10 Ω;
    VM and VDRAIN from VMOT (the driver takes nothing from the bus); nFAULT and U103 (TLV3011,
    VMOT > 46.4-49.2 V) pull DRV_FAULT low: TIM1's break input stops the PWM in hardware.
    U102 ±30 A Hall sensor (3.3 V, ratiometric) → 1 k / 4.7 nF → MOTOR_CURRENT (PA0);
    VMOT → 150 k / 10 k → VMOT_SENSE (PA1); encoder A/B (5 V or 3.3 V) → SRV05-4, 2.2 k pull-ups,
    1 k / 100 pF, U104 74LVC2G17 at 3.3 V → ENC_A/ENC_B (PA6/PA7, not 5 V tolerant).

Every value is calc/motor.py's (`DESIGN_VALUES`; `scripts/py -m r2ptools.kicad.calc.motor`).
Grounding (issue 19 item 5): the logic side (core, Hall sensor's supply, encoder) runs from the
bus through the fused bus tap; the power stage from VMOT. One ground: the bus GND and the power
GND are the same net, joined at the bulk capacitors' negative (star point) by the inner GND
plane; the motor current's loop (XT60 − → capacitors → low-side sources) stays in the right-hand
power section and never crosses the core. Isolated CAN is the revision B alternative (README).

NOT VERIFIED, and why this board must not be ordered as is (README, errata): U101's pin NUMBERS
(R2P:DRV8350H carries the datasheet's pin names; KiCad has no DRV835x symbol and SLVSDY6's pin
table could not be read here), the IDRIVE and VDS resistor levels, F102's land pattern (KiCad has
no NANO2 456 footprint: the 462's is used), and LCSC numbers for U101, U102, D101, F102 and the
electrolytics (parts.csv `-`).

Board: 112 × 50 mm (docs/bus.md's 60 × 50 mm bus end plus one 52 mm hole pitch, calc/motor.py
BOARD_MM), 4 layers, 2 oz outer. The core keeps its default placement on the left 60 mm.
"""
from __future__ import annotations

from r2ptools.kicad.design import Module, Place, Sheet, Text, Zone
from r2ptools.kicad.modules import core as core_mod
from r2ptools.kicad.modules import drawing_of
from r2ptools.kicad.modules.common import (BUS_TAP_PLACE, bus_tap, bus_tap_track, core_tracks,
                                           frame_texts, tvs_track)

NAME = "motor"
TITLE = "R2P DC motor module"
REVISION = "A"
SIZE = (112.0, 50.0)
HOLES = [(4.0, 4.0), (56.0, 4.0), (108.0, 4.0), (4.0, 46.0), (56.0, 46.0), (108.0, 46.0)]
"""The bus grid's four holes and two more one 52 mm pitch to the right (calc/motor.py BOARD_MM)."""
FIDUCIALS = [(2.6, 20.2), (57.4, 14.5), (110.0, 25.0)]

PINS = {"PA8": "PWM_AH", "PB13": "PWM_AL", "PA9": "PWM_BH", "PB14": "PWM_BL",
        "PB12": "DRV_FAULT", "PA6": "ENC_A", "PA7": "ENC_B", "PA0": "MOTOR_CURRENT",
        "PA1": "VMOT_SENSE", "PB0": "DRV_EN"}
"""MCU pins → firmware/boards/motor.toml's signals (scripts/check-pins)."""

P = Place
PLACES = {
    # --- power input, protection, bulk (right section, x 60-112)
    "J101": P(96.0, 3.8, 270), "F102": P(84.0, 7.4, 0), "D101": P(72.0, 7.4, 180),
    "C101": P(64.5, 21.0, 0), "C102": P(64.5, 38.0, 0), "C103": P(82.5, 21.0, 0),
    "C104": P(82.5, 38.0, 0),
    # --- bridge: leg A top, leg B bottom, tabs (drains / phase nodes) facing the caps
    "Q101": P(104.0, 16.0, 180), "Q102": P(104.0, 27.0, 180),
    "Q103": P(104.0, 38.0, 180), "Q104": P(96.5, 48.0, 90),
    # ceramics along the legs (the commutation loop)
    "C105": P(96.0, 14.0, 90), "C106": P(96.0, 18.0, 90), "C107": P(96.0, 22.0, 90),
    "C108": P(96.0, 26.0, 90), "C109": P(96.0, 30.0, 90), "C110": P(96.0, 34.0, 90),
    "C111": P(93.0, 14.0, 90), "C112": P(93.0, 18.0, 90),
    # --- gate driver and its parts
    "U101": P(74.0, 30.0, 0), "R101": P(80.0, 26.0, 0), "R102": P(80.0, 28.0, 0),
    "R103": P(80.0, 32.0, 0), "R104": P(80.0, 34.0, 0),
    "C113": P(70.0, 25.0, 0), "C114": P(72.0, 25.0, 90), "C115": P(74.0, 25.0, 90),
    "C116": P(76.0, 25.0, 90), "C117": P(70.0, 35.0, 90), "C118": P(72.0, 35.0, 90),
    "R105": P(74.0, 35.0, 90), "R106": P(76.0, 35.0, 90),
    # --- current sensor between leg A and the motor connector
    "U102": P(88.0, 46.0, 0), "C119": P(84.0, 44.0, 90), "R107": P(80.0, 44.0, 0),
    "C120": P(80.0, 46.0, 0),
    "J102": P(108.0, 44.0, 270),
    # --- supervision (bottom band of the core area)
    "R108": P(62.0, 46.0, 90), "R109": P(63.8, 46.0, 90), "C121": P(65.6, 46.0, 90),
    "R110": P(52.0, 40.0, 90), "R111": P(53.8, 40.0, 90), "R112": P(55.6, 40.0, 90),
    "R113": P(57.4, 40.0, 90), "C122": P(59.2, 40.0, 90),
    "U103": P(47.0, 40.0, 0), "C123": P(44.0, 40.0, 90), "R114": P(41.0, 40.0, 90),
    "R115": P(39.0, 40.0, 90),
    # --- encoder input (bottom edge, left)
    "J103": P(12.0, 47.0, 90), "D102": P(19.0, 45.0, 0),
    "R116": P(23.0, 43.0, 0), "R117": P(23.0, 45.0, 0), "R118": P(26.5, 43.0, 0),
    "R119": P(26.5, 45.0, 0), "C124": P(30.0, 43.0, 0), "C125": P(30.0, 45.0, 0),
    "U104": P(34.5, 44.0, 0), "C126": P(34.5, 47.5, 0),
}


def build(core: Sheet) -> Module:
    s = Sheet(NAME, f"{TITLE}: 10-44 V, 20 A continuous H-bridge, encoder, Hall current sense")
    bus_tap(s, "+5V_MOD", at=BUS_TAP_PLACE)
    pins = {p: "" for p in core_mod.FREE_GPIO}
    pins.update(PINS)
    pins["V5_IN"] = "+5V_MOD"
    s.use(core, pins)
    s.flags += ["VMOT"]

    # input: XT60 male (pin 1 −, pin 2 +), fuse, TVS, bulk and the commutation-loop ceramics
    s.part("J101", "XT60_M", {"1": "GND", "2": "VBAT"}, value="BATTERY 10-44V")
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

    # gate driver: 6x PWM (MODE to AGND), phase C unused (inputs low, outputs open)
    s.part("U101", "DRV8350H", {
        "VM": "VMOT", "VDRAIN": "VMOT", "VCP": "DRV_VCP", "CPH": "DRV_CPH", "CPL": "DRV_CPL",
        "VGLS": "DRV_VGLS", "DVDD": "DRV_DVDD", "AGND": "GND", "GND": "GND", "PAD": "GND",
        "GHA": "GHA", "SHA": "SW_A", "GLA": "GLA", "SLA": "GND",
        "GHB": "GHB", "SHB": "MOT_B", "GLB": "GLB", "SLB": "GND", "SHC": "GND", "SLC": "GND",
        "INHA": "PWM_AH", "INLA": "PWM_AL", "INHB": "PWM_BH", "INLB": "PWM_BL",
        "INHC": "GND", "INLC": "GND", "ENABLE": "DRV_EN", "nFAULT": "DRV_FAULT",
        "MODE": "GND", "IDRIVE": "DRV_IDRIVE", "VDS": "DRV_VDS"}, nc=("GHC", "GLC"))
    s.part("C113", "C_100n_100V", {"1": "VMOT", "2": "GND"})        # VM
    s.part("C114", "C_1u", {"1": "DRV_VCP", "2": "VMOT"})            # VCP to VDRAIN
    s.part("C115", "C_100n_100V", {"1": "DRV_CPH", "2": "DRV_CPL"})  # flying cap (47 nF in SLVSDY6)
    s.part("C116", "C_100n_100V", {"1": "VMOT", "2": "GND"})        # VDRAIN
    s.part("C117", "C_1u", {"1": "DRV_VGLS", "2": "GND"})
    s.part("C118", "C_1u", {"1": "DRV_DVDD", "2": "GND"})
    # hardware-interface levels: one resistor each to AGND (level NOT VERIFIED, README errata)
    s.part("R105", "R_100k", {"1": "DRV_IDRIVE", "2": "GND"})
    s.part("R106", "R_100k", {"1": "DRV_VDS", "2": "GND"})

    # Hall sensor in leg A's output, ratiometric to the ADC's 3.3 V
    s.part("U102", "ACS725-30AB", {"IP+": "SW_A", "IP-": "MOT_A", "VCC": "+3V3", "GND": "GND",
                                   "VIOUT": "HALL_OUT"}, nc=("FILTER",))
    s.part("C119", "C_100n", {"1": "+3V3", "2": "GND"})
    s.part("R107", "R_1k", {"1": "HALL_OUT", "2": "MOTOR_CURRENT"})
    s.part("C120", "C_4n7", {"1": "MOTOR_CURRENT", "2": "GND"})
    s.part("J102", "XT60_F", {"1": "MOT_B", "2": "MOT_A"}, value="MOTOR")

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

    power = ["VBAT", "VMOT", "SW_A", "MOT_A", "MOT_B"]
    m = Module(NAME, TITLE, REVISION, s,
               tracks=[*core_mod.bus_tracks(), bus_tap_track(), tvs_track(), *core_tracks()],
               seed=19, size=SIZE, holes=HOLES, copper_layers=4,
               netclasses={"HV": power + ["GATE_AH", "GATE_BH", "GHA", "GHB", "DRV_VCP", "DRV_CPH",
                                          "DRV_CPL", "OV_A", "OV_B"]},
               netclass_defs={"HV": (0.6, 0.3, 0.8, 0.4)},
               solid_pads=("J101", "J102", "F102", "D101", "C101", "C102", "C103", "C104",
                           "Q101", "Q102", "Q103", "Q104", "U102"))
    m.fiducials = list(FIDUCIALS)
    m.texts = frame_texts(NAME, REVISION) + [
        Text("MOTOR SUPPLY 10-44V", 86.0, 24.0, 1.2, "B.SilkS")]
    return m
