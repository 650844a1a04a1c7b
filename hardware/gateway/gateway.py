"""hardware/gateway revision A: the Ethernet gateway, an STM32F407 with a LAN8742A RMII PHY.

    bus jacks J1/J2/J3 ─ CAN transceiver U3 (PB8/PB9) ─┐
    fused bus tap F101 ─► +5V_MOD ─► LDO U2 ─► +3V3    │
                             └─────► LDO U102 ─► +3V3_PHY (the PHY, its terminations, centre taps)
                                                       U1 STM32F407VGT6 ── SWD J4, NRST, BOOT0,
    J101 HR911105A (magnetics, LEDs) ◄─ MDI ─ U101 LAN8742A ◄─ RMII ─┘   LEDs PD12-PD15
                                         25 MHz Y101 (RS R112); REFCLKO ─► PA1 (50 MHz)

Not the F103 core: the gateway draws the core's blocks (bus jacks, CAN transceiver with ESD and
split termination, 3.3 V regulator, 8 MHz crystal, reset and boot straps, SWD, test pads) from
`modules/core.py`'s block functions on its own sheet, with the core's references (1-99), around
its own MCU; the Ethernet parts are numbered from 101. Pins and signals are
firmware/boards/gateway.toml's (scripts/check-pins).

The LAN8742A (Microchip DS00001989A, SMSC revision 1.1; its figures in calc/gateway.py): straps
latched at nRST's rising edge — MODE[2:0] = 111 (all capable, auto-negotiation) from the internal
pull-ups of RXD0/MODE0, RXD1/MODE1 and CRS_DV/MODE2 (the MCU's RMII pins are inputs in reset);
PHYAD0 = 0 from RXER/PHYAD0's internal pull-down (SMI address 0); REGOFF = 0 (the internal 1.2 V
regulator on, VDDCR decoupled with 1 uF + 470 pF) and nINTSEL = 0 (pin 14 is REFCLKO, the 50 MHz
reference into PA1) by 10 k pull-downs on LED1/REGOFF and LED2/nINTSEL, whose LEDs are therefore
lit high (anode on the pin side); 12.1 k RBIAS; 49.9 ohm from each MDI line to the 3.3 V that
also feeds the magnetics' centre taps. PHY_NRST (PE2) is held low by R111 until the firmware
releases it. MDIO has its 1.5 k pull-up. The 25 MHz crystal is the datasheet's 100 uW case
(Figure 5-8): RS (R112, 510 ohm, calc/gateway.py's drive level) between XTAL2 and the crystal.

Supply (issue 20, revision A fix): the PHY side — the LAN8742A's VDDIO, VDD1A and VDD2A, the MDI
terminations, the magnetics' centre taps and the MDIO pull-up, about 105 mA — has its own
AP2112K-3.3 (U102, 10 uF in and out, as U2) on +3V3_PHY, so neither SOT-23-5 carries the whole
217-273 mA (calc/gateway.py: each regulator's dissipation and junction temperature). Both run
from +5V_MOD with EN tied to VIN, so the rails rise together; the RMII, MDIO and reset lines
cross between two 3.3 V rails that agree within the regulators' output tolerance.

Board: 112 x 50 mm (the bus grid's 60 x 50 mm plus one 52 mm pitch, six holes on the grid: the
LQFP-100, the PHY and the 16 x 22 mm magnetics jack do not fit one pitch beside the bus jacks),
2 layers. Supply: calc/gateway.py (the stated exception to docs/bus.md's 200 mA).
"""
from __future__ import annotations

from r2ptools.kicad.design import Module, Place, Sheet, Text, Via
from r2ptools.kicad.modules import core as core_mod
from r2ptools.kicad.modules import drawing_of
from r2ptools.kicad.modules.common import (BUS_TAP_PLACE, bus_tap, bus_tap_track, frame_texts,
                                           tvs_track)

NAME = "gateway"
TITLE = "R2P Ethernet gateway"
REVISION = "A"
SIZE = (112.0, 50.0)
HOLES = [(x, y) for y in (4.0, 46.0) for x in (4.0, 56.0, 108.0)]
FIDUCIALS = [(2.6, 24.0), (62.0, 4.0), (110.0, 26.0)]

MCU = {
    "VDD": "+3V3", "VBAT": "+3V3", "VDDA": "+3V3", "VREF+": "+3V3",
    "VSS": "GND", "VSSA": "GND", "VCAP_1": "VCAP1", "VCAP_2": "VCAP2",
    "NRST": "NRST", "BOOT0": "BOOT0", "PH0": "OSC_IN", "PH1": "OSC_OUT",
    "PB8": "CAN_RX", "PB9": "CAN_TX", "PA13": "SWDIO", "PA14": "SWCLK", "PB2": "BOOT1",
    "PA1": "ETH_REF_CLK", "PA2": "ETH_MDIO", "PC1": "ETH_MDC", "PA7": "ETH_CRS_DV",
    "PC4": "ETH_RXD0", "PC5": "ETH_RXD1", "PB11": "ETH_TX_EN", "PB12": "ETH_TXD0",
    "PB13": "ETH_TXD1", "PE2": "PHY_NRST",
    "PD12": "LED_STATUS", "PD13": "LED_BUS", "PD14": "LED_FAULT", "PD15": "LED_LINK",
}
"""U1's pins → nets; every net on a GPIO is firmware/boards/gateway.toml's signal."""

P = Place
PLACES = {
    # the bus end keeps the core's places (J1, J2, J3, SW3, R3, R7, C12, D1, D5, U2, C7, C8, F101,
    # TP1-TP8); the transceiver moves beside the MCU's CAN pins
    "U3": P(20.5, 37.0, 0), "C9": P(15.3, 37.6, 90),
    # MCU, turned 90°: RMII on its right and lower right towards the PHY, the HSE pins at the
    # bottom, SWD top left
    "U1": P(36.0, 33.0, 90),
    "C16": P(32.5, 43.6, 90), "C13": P(34.5, 43.6, 90), "C14": P(39.0, 43.6, 90),
    "C6": P(40.8, 43.6, 90), "C11": P(42.6, 43.6, 90),
    "C15": P(46.4, 38.2, 0), "C18": P(46.4, 27.4, 0), "C19": P(46.4, 25.8, 0),
    "C20": P(31.0, 21.9, 90), "C21": P(29.2, 21.9, 90), "C22": P(25.7, 39.8, 90),
    "Y1": P(36.0, 47.3, 0), "C1": P(32.9, 47.4, 90), "C2": P(39.1, 47.4, 90),
    "C10": P(28.5, 44.6, 0), "R1": P(25.7, 35.6, 90), "R2": P(46.4, 32.4, 0),
    "J4": P(17.5, 28.0, 90),
    # status LEDs, lit high, under BUS OUT
    # (in the order of their pins, PD15 leftmost on the MCU's top side, so no two tracks cross;
    # 1.85 mm apart so each clears the case's stacking pads at (30, 13) and (45, 25) by the
    # lid's light hole and bar, enclosure/lidplan.py)
    **{d: P(34.3 + 1.85 * i, 19.4, 90) for i, d in enumerate(("D6", "D4", "D3", "D2"))},
    **{r: P(34.3 + 1.85 * i, 22.6, 90) for i, r in enumerate(("R8", "R6", "R5", "R4"))},
    # PHY, turned 270°: RMII on its left, MDI on its right towards the jack, the crystal above
    "U101": P(62.0, 35.0, 270),
    # (the crystal and its capacitors 1 mm higher than first placed, for R112 below them)
    "Y101": P(62.0, 27.0, 0), "C101": P(58.6, 27.0, 90), "C102": P(65.4, 27.0, 90),
    "R101": P(66.4, 30.8, 0), "C103": P(58.0, 31.4, 90), "C104": P(56.3, 31.4, 90),
    "C105": P(66.4, 39.2, 0), "C106": P(66.4, 41.0, 0), "C107": P(58.0, 40.0, 90),
    "R102": P(69.4, 31.0, 90), "R103": P(71.0, 31.0, 90), "R104": P(72.6, 31.0, 90),
    "R105": P(74.2, 31.0, 90), "C110": P(73.7, 27.6, 0), "C109": P(78.3, 27.6, 0),
    "R106": P(70.0, 42.0, 0), "R107": P(70.0, 44.0, 0), "R108": P(66.4, 42.8, 0),
    "R109": P(66.4, 44.6, 0),
    "R110": P(52.6, 36.6, 90), "R111": P(52.6, 40.4, 90),
    "J101": P(80.0, 33.2, 0),
    # revision A fix (issue 20), placed in the routed board by hand: the PHY's regulator in the
    # free corner above the jack (its heat away from U2's), RS between XTAL2 and the crystal
    "U102": P(70.0, 20.0, 0), "C111": P(66.2, 20.0, 90), "C112": P(73.8, 20.0, 90),
    "R112": P(63.0, 29.6, 0),
}


def build(core: Sheet) -> Module:
    s = Sheet(NAME, f"{TITLE}: STM32F407, LAN8742A RMII PHY, the bus on Ethernet")
    bus_tap(s, "+5V_MOD", at=BUS_TAP_PLACE)

    # the MCU and its supply pins (ST AN4488 / DS8626): 100 nF at each VDD (C13, C14, C15, C19,
    # C21, C22) and VBAT (C16), VDDA and VREF+ (tied, adjacent pins) 100 nF + 1 uF (C6, C11),
    # VCAP_1/VCAP_2 2.2 uF each (C18, C20), the LDO's 10 uF (C7) as the bulk capacitor
    s.part("U1", "STM32F407VGT6", MCU,
           nc=tuple(p for p in _free_gpio()))
    for ref, net in (("C13", "+3V3"), ("C14", "+3V3"), ("C15", "+3V3"), ("C16", "+3V3"),
                     ("C19", "+3V3"), ("C21", "+3V3"), ("C22", "+3V3"), ("C6", "+3V3")):
        s.part(ref, "C_100n", {"1": net, "2": "GND"})
    s.part("C11", "C_1u", {"1": "+3V3", "2": "GND"})
    s.part("C18", "C_2u2", {"1": "VCAP1", "2": "GND"})
    s.part("C20", "C_2u2", {"1": "VCAP2", "2": "GND"})

    # the core's blocks, with the core's references
    core_mod.hse_crystal(s)
    core_mod.regulator(s, "+5V_MOD")
    core_mod.reset_boot(s)
    core_mod.swd(s)
    core_mod.can_transceiver(s)
    core_mod.test_pads(s)
    core_mod.bus_jacks(s)

    # four LEDs on PD12-PD15, lit high (the board file): status, bus, fault, network link
    for led, res, key, sig in (("D2", "R4", "LED_G", "LED_STATUS"), ("D3", "R5", "LED_Y", "LED_BUS"),
                               ("D4", "R6", "LED_R", "LED_FAULT"), ("D6", "R8", "LED_B", "LED_LINK")):
        s.part(res, "R_1k", {"1": sig, "2": f"{sig}_A"})
        s.part(led, key, {"A": f"{sig}_A", "K": "GND"})

    # the PHY's own 3.3 V regulator (issue 20): the LAN8742A, its MDI terminations and the
    # magnetics' centre taps on +3V3_PHY, the rest of the board on U2's +3V3
    s.part("U102", "AP2112K-3.3", {"VIN": "+5V_MOD", "EN": "+5V_MOD", "GND": "GND",
                                   "VOUT": "+3V3_PHY"})
    s.part("C111", "C_10u", {"1": "+5V_MOD", "2": "GND"})
    s.part("C112", "C_10u", {"1": "+3V3_PHY", "2": "GND"})

    # the PHY (LAN8742A, DS00001989A), straps in the module docstring
    s.part("U101", "LAN8742A", {
        "TXD0": "ETH_TXD0", "TXD1": "ETH_TXD1", "TXEN": "ETH_TX_EN",
        "RXD0/MODE0": "ETH_RXD0", "RXD1/MODE1": "ETH_RXD1", "CRS_DV/MODE2": "ETH_CRS_DV",
        "MDIO": "ETH_MDIO", "MDC": "ETH_MDC", "~{RST}": "PHY_NRST", "~{INT}/REFCLKO": "ETH_REF_CLK",
        "XTAL1/CLKIN": "PHY_XI", "XTAL2": "PHY_XTAL2", "VDDIO": "+3V3_PHY",
        "VDDCR": "PHY_VDDCR", "VDD1A": "+3V3_PHY", "VDD2A": "+3V3_PHY", "VSS": "GND",
        "TXP": "ETH_TXP", "TXN": "ETH_TXN", "RXP": "ETH_RXP", "RXN": "ETH_RXN",
        "RBIAS": "PHY_RBIAS", "LED1/REGOFF": "PHY_LED1", "LED2/~{INTSEL}": "PHY_LED2"},
        nc=("RXER/PHYAD0",))
    s.flags += ["PHY_VDDCR"]                                 # the PHY's own 1.2 V regulator
    s.part("Y101", "XTAL_25M", {"1": "PHY_XI", "3": "PHY_XO", "G": "GND"})
    s.part("C101", "C_15p", {"1": "PHY_XI", "2": "GND"})
    s.part("C102", "C_15p", {"1": "PHY_XO", "2": "GND"})
    # RS: DS00001989A Figure 5-8's series resistor for a 100 uW crystal (calc/gateway.py)
    s.part("R112", "R_510", {"1": "PHY_XTAL2", "2": "PHY_XO"})
    s.part("R101", "R_12k1", {"1": "PHY_RBIAS", "2": "GND"})
    s.part("C103", "C_1u", {"1": "PHY_VDDCR", "2": "GND"})
    s.part("C104", "C_470p", {"1": "PHY_VDDCR", "2": "GND"})
    s.part("C105", "C_100n", {"1": "+3V3_PHY", "2": "GND"})    # VDD1A
    s.part("C106", "C_100n", {"1": "+3V3_PHY", "2": "GND"})    # VDD2A
    s.part("C107", "C_100n", {"1": "+3V3_PHY", "2": "GND"})    # VDDIO
    s.part("R110", "R_1k5", {"1": "+3V3_PHY", "2": "ETH_MDIO"})
    s.part("R111", "R_10k", {"1": "PHY_NRST", "2": "GND"})
    s.part("R108", "R_10k", {"1": "PHY_LED1", "2": "GND"})     # REGOFF = 0
    s.part("R109", "R_10k", {"1": "PHY_LED2", "2": "GND"})     # nINTSEL = 0: REFCLKO
    # MDI: 49.9 ohm to the centre-tap supply on each line, 22 nF at the terminations and the taps
    for ref, net in (("R102", "ETH_TXP"), ("R103", "ETH_TXN"), ("R104", "ETH_RXP"),
                     ("R105", "ETH_RXN")):
        s.part(ref, "R_49R9", {"1": "+3V3_PHY", "2": net})
    s.part("C110", "C_22n", {"1": "+3V3_PHY", "2": "GND"})
    s.part("C109", "C_22n", {"1": "+3V3_PHY", "2": "GND"})
    # the jack: TD± from TXP/TXN, RD± to RXP/RXN, centre taps on the PHY's 3.3 V, pin 8 (the Bob Smith
    # termination's capacitor) and the shield to GND; green LED (9 A, 10 K) = LED1 link/activity,
    # yellow (12 A, 11 K) = LED2 speed, both lit high through 1 k
    s.part("J101", "RJ45_MAG", {"1": "ETH_TXP", "2": "ETH_TXN", "3": "ETH_RXP", "6": "ETH_RXN",
                                "4": "+3V3_PHY", "5": "+3V3_PHY", "8": "GND", "SH": "GND",
                                "9": "ETH_LED_G", "10": "GND", "12": "ETH_LED_Y", "11": "GND"})
    s.part("R106", "R_1k", {"1": "PHY_LED1", "2": "ETH_LED_G"})
    s.part("R107", "R_1k", {"1": "PHY_LED2", "2": "ETH_LED_Y"})

    for p in s.parts:
        if p.ref in PLACES:
            p.place = PLACES[p.ref]
    sheet = drawing_of(__file__)
    s.drawing, s.blocks = sheet.DRAWING, sheet.BLOCKS

    m = Module(NAME, TITLE, REVISION, s,
               tracks=[*core_mod.bus_tracks(), bus_tap_track(), tvs_track()],
               vias=phy_pad_vias(),
               seed=20, size=SIZE, holes=HOLES)
    m.fiducials = list(FIDUCIALS)
    # BUS OUT moved right of its usual place, where the status LEDs sit on this board
    m.texts = [Text(t.text, 47.2, t.y, t.size, t.layer) if (t.text, t.layer) == ("BUS OUT", "F.SilkS")
               else t for t in frame_texts(NAME, REVISION)] + [Text("ETHERNET", 85.0, 26.0, 1.2, "B.SilkS")]
    return m


def phy_pad_vias() -> list[Via]:
    """Four GND vias in the PHY's exposed pad (2 x 2 at 1.2 mm): its ground and heat path to the
    back pour. The pad is enclosed by the package's own pins, so no track can leave it on F.Cu
    (the first route left it an island). KiCad's ThermalVias variant uses 0.2 mm drills, under
    the fab's 0.3 mm minimum."""
    x, y = PLACES["U101"].x, PLACES["U101"].y
    return [Via("GND", x + dx, y + dy, 0.6, 0.3) for dx in (-0.6, 0.6) for dy in (-0.6, 0.6)]


def _free_gpio() -> list[str]:
    """The F407's GPIOs the gateway leaves unconnected."""
    used = set(MCU)
    ports = {"A": 16, "B": 16, "C": 16, "D": 16, "E": 16}
    pins = [f"P{p}{i}" for p, n in ports.items() for i in range(n)] + ["PH0", "PH1"]
    return [p for p in pins if p not in used]
