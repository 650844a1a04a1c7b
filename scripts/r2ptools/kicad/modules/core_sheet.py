"""How the core sheet is drawn (hardware/core/core.kicad_sch): one block per function.

Top row, along the bus: the two RJ45 jacks and the header (each its own block, their pins
labelled: the three are wired in parallel), the CAN transceiver with its ESD clamp and the
switchable split termination, the 3.3 V regulator. Below: reset and boot straps, the crystal,
the MCU with its decoupling (every MCU signal pin labelled; the free GPIOs leave the sheet as
hierarchical labels to the module's sheet), SWD, the status LEDs and the test pads.
Grid units of 2.54 mm (drawing.py); numbers in the notes come from core.py's `report()`.
"""
from __future__ import annotations

from ..design import At, Block
from . import core

A = At
DRAWING = {
    # bus connectors
    "J1": A(12, 14), "D5": A(30, 12, 270),
    "J2": A(12, 32),
    "J3": A(32, 29),
    # CAN transceiver, ESD, termination
    "U3": A(58, 20), "C9": A(50, 10), "D1": A(71, 29),
    "SW3": A(82, 21), "R3": A(94, 16.5), "R7": A(94, 25.5), "C12": A(99, 22.5),
    # 3.3 V regulator
    "C8": A(113, 14.5), "U2": A(122, 14), "C7": A(131, 14.5),
    # SWD
    "J4": A(120, 36),
    # status LEDs
    **{d: A(114, y, 180) for d, y in (("D2", 53), ("D3", 58), ("D4", 63))},
    **{r: A(128, y, 90) for r, y in (("R4", 53), ("R5", 58), ("R6", 63))},
    # test pads: rails with the pad up (the rail symbol points up), signals down
    "TP1": A(112, 82, 180), "TP2": A(118, 82, 180), "TP3": A(124, 80),
    "TP4": A(130, 80), "TP8": A(136, 80), "TP5": A(142, 80), "TP6": A(148, 80), "TP7": A(154, 80),
    # reset and boot
    "C10": A(20, 49.5), "SW1": A(10, 50, 270),
    "SW2": A(10, 61, 270), "R1": A(20, 64.5), "R2": A(32, 64.5),
    # clock
    "Y1": A(20, 84), "C1": A(14, 87.5), "C2": A(26, 87.5),
    # MCU and decoupling
    "U1": A(72, 76),
    "C3": A(86, 48.5), "C4": A(90, 48.5), "C5": A(94, 48.5), "C6": A(98, 48.5), "C11": A(102, 48.5),
}

_x = core.crystal_load()
_t = core.termination()
BLOCKS = [
    Block("BUS IN", 4, 4, 24, 22),
    Block("BUS OUT", 4, 24, 24, 40),
    Block("Bus header and +5V TVS", 26, 4, 42, 40, notes=[
        (27, 21, "D5 SMAJ5.0A: 5.0 V stand-off,\n6.4 V min. breakdown (above the\nbus's 6 V survival and the PSU's\n6.1 V cut-off), 9.2 V clamp\n(docs/bus.md §7)"),
        (27, 36, "BUS IN, BUS OUT and J3\nare wired in parallel:\nthe bus passes through.")]),
    Block("CAN transceiver, ESD, split termination", 44, 4, 104, 40, notes=[
        (46, 35, "SN65HVD230: Rs to GND = high speed (1 Mbit/s)."),
        (76, 35, f"Split termination (docs/bus.md §4): 2 x {core.TERM_R_OHM:g} ohm ="
                 f" {_t['differential_ohm']:.1f} ohm,\n{core.TERM_C_NF:g} nF to GND: common-mode"
                 f" corner {_t['common_mode_corner_mhz']:.2f} MHz.\nSW3 opens both legs:"
                 " only the two end modules terminate.")]),
    Block("3.3 V regulator", 106, 4, 160, 24, notes=[
        (108, 22, "AP2112K-3.3: 600 mA LDO, 10 uF ceramic in and out.\nV5_IN: the module's fused bus tap"
                  " (the PSU: its own buck).")]),
    Block("SWD (Cortex 10-pin, 1.27 mm)", 106, 26, 160, 46, notes=[
        (128, 44, "SWO not wired: PB3 stays a GPIO.")]),
    Block("Status LEDs", 106, 48, 160, 70, notes=[
        (138, 56, "LEDs sink into PC13-PC15\n(3 mA max there): 1 k gives\n~1.3 mA at Vf ~2 V.")]),
    Block("Test pads (bare 1 mm copper, no BOM line)", 106, 72, 160, 92),
    Block("Reset and boot straps", 4, 42, 40, 72, notes=[
        (22, 55, "NRST: 100 nF to GND (AN2586).\nBOOT0 low: boot from flash;\nhold SW2 through reset for\nthe ROM bootloader. BOOT1 low.")]),
    Block("Clock: 8 MHz crystal", 4, 74, 40, 108, notes=[
        (5, 96, f"C1 = C2 = 2 (CL - Cstray)\n= 2 ({core.CRYSTAL_CL_PF:g} - {core.STRAY_PF:g}) pF"
                f" = {_x['ideal_pf']:.0f} pF C0G 5 %.\nEffective CL {_x['cl_min_pf']:.1f}-"
                f"{_x['cl_max_pf']:.1f} pF\n(Cstray {core.STRAY_RANGE_PF[0]:g}-"
                f"{core.STRAY_RANGE_PF[1]:g} pF).\nGain margin gm / gm_crit = "
                f"{_x['gain_margin']:.0f}\n(AN2867 asks >= 5).")]),
    Block("MCU STM32F103CBT6 and decoupling", 42, 42, 104, 110, notes=[
        (82, 54, "100 nF at each VDD pin (C3-C5);\nVDDA: 10 nF + 1 uF (C6, C11), AN2586 §2.1."),
        (82, 100, "Pin names are the signals of\nfirmware/boards/core-f103.toml;\nfree GPIOs leave the sheet\n"
                  "(hierarchical labels)\nfor the module's sheet.")]),
]
