"""How the gateway's sheet is drawn (hardware/gateway/gateway.kicad_sch): one block per function.

Top row, along the bus, as on the core sheet (its blocks and places, `modules/core_sheet.py`, for
the blocks the gateway shares with it): BUS IN, BUS OUT, the header and +5V TVS, the CAN
transceiver with ESD and split termination; then the bus tap and the 3.3 V regulator, the status
LEDs. Second row: reset and boot straps and the 8 MHz clock on the left, the STM32F407 with its
decoupling, SWD and the test pads, the LAN8742A PHY with its straps, clock and bias, the Ethernet
jack with the MDI terminations. Third row, under the PHY: the PHY's own 3.3 V regulator (issue 20). The MCU's signals meet the other blocks by label. Grid units of
2.54 mm (drawing.py); the numbers in the notes are calc/gateway.py's and calc/core.py's.
"""
from __future__ import annotations

from r2ptools.kicad.calc import gateway as calc
from r2ptools.kicad.design import At, Block
from r2ptools.kicad.modules import core_sheet

A = At
SHARED = ("BUS IN", "BUS OUT", "Bus header and +5V TVS", "CAN transceiver, ESD, split termination")
"""The core sheet's blocks the gateway draws as the core does (same parts, same places)."""
_SHARED_REFS = ("J1", "J2", "J3", "D5", "U3", "C9", "D1", "SW3", "R3", "R7", "C12")

_b, _x, _h, _r, _d = calc.budget(), calc.phy_crystal(), calc.hse(), calc.rails(), calc.drive_level()

DRAWING = {
    **{r: core_sheet.DRAWING[r] for r in _SHARED_REFS},
    # bus tap and 3.3 V regulator
    "F101": A(112, 14, 90), "C8": A(124, 14.5), "U2": A(133, 14), "C7": A(142, 14.5),
    "flag:+5V": A(108, 20), "flag:GND": A(120, 20), "flag:+5V_MOD": A(146, 20),
    # SWD
    "J4": A(122, 39),
    # Ethernet jack and MDI terminations: the leftmost termination to the lowest jack pin, so
    # no two wires cross
    **{r: A(170 + 5 * i, 13.5) for i, r in enumerate(("R105", "R104", "R103", "R102"))},
    # the taps' capacitors right of the terminations: +3V3_PHY's wire then crosses no MDI line
    # under its name
    "C110": A(189, 40.5), "C109": A(195, 40.5),
    "J101": A(204, 27), "R107": A(221.5, 24, 270), "R106": A(221.5, 28, 270),
    # reset and boot straps, clock
    "C10": A(20, 59.5), "SW1": A(10, 60, 270), "SW2": A(10, 71, 270), "R1": A(20, 74.5),
    "R2": A(32, 74.5),
    "Y1": A(20, 94), "C1": A(12, 97.5), "C2": A(28, 97.5),
    # MCU and decoupling: caps 7 grid apart so each value reads clear of the next
    "U1": A(64, 88),
    **{c: A(92 + 7 * i, 62.5) for i, c in enumerate(("C16", "C13", "C14", "C15"))},
    **{c: A(92 + 7 * i, 74.5) for i, c in enumerate(("C19", "C21", "C22", "C6"))},
    "C11": A(92, 86.5),
    "C18": A(44, 113.5), "C20": A(50, 113.5),
    # PHY
    "U101": A(156, 84),
    # the +3V3_PHY pins' capacitors left of the VDDCR pin's, so neither wire crosses the other
    "C107": A(133, 62.5), "C105": A(140, 62.5), "C106": A(147, 62.5), "C103": A(165, 62.5),
    "C104": A(172, 62.5), "flag:PHY_VDDCR": A(168, 56),
    "R110": A(130, 76.5), "R111": A(132, 94.5),
    "R101": A(180, 85, 90), "R108": A(176, 90.5), "R109": A(170, 91.5),
    # its 25 MHz crystal
    "Y101": A(136, 114), "C101": A(128, 117.5), "C102": A(144, 117.5), "R112": A(152, 114, 90),
    # the PHY's 3.3 V regulator, drawn as U2's
    "C111": A(136, 134.5), "U102": A(145, 134), "C112": A(154, 134.5),
    # status LEDs, lit high
    **{r: A(202, y, 90) for r, y in (("R4", 58), ("R5", 65), ("R6", 72), ("R8", 79))},
    **{d: A(212, y + 2.5, 90) for d, y in (("D2", 58), ("D3", 65), ("D4", 72), ("D6", 79))},
    # test pads: rails with the pad up (the rail symbol points up), signals down
    "TP1": A(196, 106, 180), "TP2": A(202, 106, 180), "TP3": A(208, 104),
    "TP4": A(214, 104), "TP8": A(220, 104), "TP5": A(196, 116), "TP6": A(202, 116), "TP7": A(208, 116),
}

_LEDS = ("Lit high from PD12-PD15: status green,\nbus yellow, fault red, link blue (the\n"
         "F4DISCOVERY's four). 1 k: ~1.3 mA.")

BLOCKS = [
    *[b for b in core_sheet.BLOCKS if b.title in SHARED],
    Block("Bus tap and 3.3 V regulator", 106, 4, 160, 26, notes=[
        (107, 24, "F101 0.5 A hold: the gateway's own fuse.\nAP2112K-3.3, 10 uF in and out.")]),
    Block("SWD (Cortex 10-pin, 1.27 mm)", 106, 28, 160, 50, notes=[
        (132, 48, "SWO not wired: PB3 unused.")]),
    Block("Ethernet jack (HR911105A: magnetics, LEDs)", 162, 4, 228, 50, notes=[
        (163, 48, f"MDI: {calc.MDI_TERM_OHM:g} ohm from each line to +3V3_PHY,\nthe centre-tap supply,"
                  " 22 nF at the taps\n(LAN8742A reference design).")]),
    Block("Reset and boot straps", 4, 52, 40, 82, notes=[
        (22, 68, "NRST: 100 nF to GND (AN4488).\nBOOT0 low: boot from flash;\nhold SW2 through reset for\n"
                 "the ROM bootloader.\nBOOT1 (PB2) low.")]),
    Block("Clock: 8 MHz crystal", 4, 84, 40, 125, notes=[
        (5, 122, f"C1 = C2 = 30 pF C0G (calc/core.py).\nF407: gm_crit {_h['gm_crit_ma_per_v']:.2f} mA/V\n"
                 f"< Gm_crit_max {calc.F407_GM_CRIT_MAX_MA_PER_V:g} mA/V\n(AN2867; DS8626\nRev 12, Table 32).")]),
    Block("MCU STM32F407VGT6 and decoupling", 42, 52, 122, 125, notes=[
        (90, 100, "100 nF at each VDD and VBAT;\nVDDA = VREF+: 100 nF + 1 uF\n(AN4488); VCAP_1, VCAP_2\n"
                 f"{calc.VCAP_F * 1e6:g} uF (ESR < 2 ohm)."),
        (90, 123, "Pin names are the signals of\nfirmware/boards/gateway.toml;\nunused GPIOs no-connect.")]),
    Block("Ethernet PHY LAN8742A (RMII)", 124, 52, 190, 106, notes=[
        (150, 105, "Straps at nRST: MODE = 111 (internal pull-ups),\n"
                   "PHYAD = 0 (internal pull-down), REGOFF = 0 and\n"
                   "nINTSEL = 0 (R108, R109): 1.2 V regulator on,\n"
                   f"pin 14 = REFCLKO, 50 MHz into PA1. RBIAS {calc.RBIAS_OHM / 1e3:g} k 1 %.\n"
                   "LEDs lit high (straps low): green link/activity,\nyellow speed.")]),
    Block("PHY clock: 25 MHz crystal", 124, 108, 190, 125, notes=[
        (158, 112, f"RS = R112: the 100 uW crystal's series\nresistor (DS00001989A Figure 5-8,"
                   f" {calc.XTAL25_RS_DATASHEET_OHM:g} ohm):\n{_d['no_rs_uw']:.0f} uW of drive -> about"
                   f" {_d['nom_uw']:.0f} uW."),
        (150, 122, f"C101 = C102 = 2 (CL - Cstray) = 2 ({calc.XTAL25_CL_PF:g} - 5) pF\n"
                   f"-> {calc.XTAL25_LOAD_PF:g} pF C0G: CL {_x['cl_min_pf']:.1f}-{_x['cl_max_pf']:.1f} pF"
                   " (X322525MOB4SI: 12 pF).")]),
    Block("PHY supply: its own 3.3 V regulator", 124, 127, 190, 146, notes=[
        (126, 143, f"AP2112K-3.3, 10 uF in and out: the PHY, its MDI terminations and the\n"
                   f"centre taps on +3V3_PHY ({_r['U102']['typ_ma']:.0f} mA); U2 keeps the MCU side"
                   f" ({_r['U2']['typ_ma']:.0f}-{_r['U2']['worst_ma']:.0f} mA).\n"
                   f"Worst case at {calc.T_AMB:g} C ambient: U2 {_r['U2']['tj_worst']:.0f} C, U102"
                   f" {_r['U102']['tj_worst']:.0f} C junction (one LDO: {calc.single_ldo()['tj_worst']:.0f} C).")]),
    Block("Status LEDs", 192, 52, 228, 90, notes=[(193, 88, _LEDS)]),
    Block("Test pads (bare 1 mm copper)", 192, 92, 228, 125),
]
