"""The common module core (hardware/core/core.kicad_sch): the same sheet on every F103 module.

MCU STM32F103CBT6 with its decoupling and 8 MHz crystal, the 3.3 V LDO, the CAN transceiver with
ESD protection and switchable 120 ohm termination, the two RJ45 bus jacks and the 1x4 bus header
(wired in parallel: BUS IN and BUS OUT are electrically identical), SWD, reset and BOOT0 buttons,
the BOOT1 strap and three status LEDs.

Net names on MCU pins are the `signal` names of firmware/boards/core-f103.toml. Every other MCU
GPIO leaves the sheet as a hierarchical pin named after the pin (PA0…PB15) for the module sheet
to wire or mark no-connect. The LDO's input is the port V5_IN: a bus-powered module feeds it from
its fused bus tap, the PSU from its own buck (ahead of its bus output switch).

Reference designators 1–99 belong to the core; module sheets number their parts from 101.
Placement is in mm from the board's top-left corner; the bus edge (RJ45s, header) is the top.

Revision B (issue 14) changed or added these core references (a board that moves core parts,
such as the PSU, places them through `Module.places`):

    C6        VDDA 10 nF (was 100 nF), AN2586: 10 nF + 1 uF at VDDA
    C11       new: VDDA 1 uF
    C1, C2    crystal load capacitors 30 pF C0G (were 22 pF): `crystal_load()` below
    Y1        the 8 MHz crystal's MPN corrected: X32258MSB4SI (LCSC C2682774, CL 20 pF); the
              rev A row (X322508MSB4SI, C9002) named LCSC's 12 MHz X322512MSB4SI
    D5        new: SMAJ5.0A, +5V TVS to GND at the bus jacks (docs/bus.md §7 SHOULD)
    R3, R7    split termination 2 x 60.4 ohm 0805 (R3 was one 120 ohm), R7 new
    C12       new: 4.7 nF from the termination midpoint TERM_MID to GND
    SW3       now a 2-pole DIP switch (DSHP02TSGER): pole 1 CAN_H-TERM_H, pole 2 TERM_L-CAN_L,
              so "off" leaves nothing on the bus (was a 1-pole slide switch)
    TP1-TP8   new: bare 1 mm test pads (no BOM line, no placement): +5V, +3V3, GND, CAN_H,
              CAN_L, NRST, SWDIO, SWCLK
    FID1-FID3 board-only fiducials (no symbol), `FIDUCIALS` below, `Module.fiducials`
"""
from __future__ import annotations

from ..design import Place, Sheet, Track

FREE_GPIO = [f"PA{i}" for i in (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 15)] + \
            [f"PB{i}" for i in (0, 1, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15)]
"""MCU pins the core does not use, offered to the module sheet."""

FIDUCIALS = [(2.6, 20.2), (57.4, 14.5), (57.4, 39.5)]
"""Default fiducial places (mm), clear of the core's parts and of the bottom module area."""

from ..calc.core import *  # noqa: F401,F403  (the core's design numbers, re-exported)
from ..calc.core import crystal_load, report, termination  # noqa: F401


# RJ45 pinout of the R2P bus (docs/bus.md): CAN on pair 1-2, +5V on 4, 5, 7, GND on 3, 6, 8.
RJ45_PINS = {"1": "CAN_H", "2": "CAN_L", "3": "GND", "4": "+5V", "5": "+5V", "6": "GND",
             "7": "+5V", "8": "GND"}


def build() -> Sheet:
    s = Sheet("core", "R2P common module core: STM32F103, CAN, bus, SWD", revision="B")
    s.port("V5_IN", "input")
    for pin in FREE_GPIO:
        s.port(pin)

    mcu = {
        "VDD": "+3V3", "VBAT": "+3V3", "VDDA": "+3V3", "VSS": "GND", "VSSA": "GND",
        "NRST": "NRST", "BOOT0": "BOOT0",
        "PD0": "OSC_IN", "PD1": "OSC_OUT",
        "PA11": "CAN_RX", "PA12": "CAN_TX", "PA13": "SWDIO", "PA14": "SWCLK",
        "PB2": "BOOT1",
        "PC13": "LED_STATUS", "PC14": "LED_BUS", "PC15": "LED_FAULT",
    }
    mcu.update({p: p for p in FREE_GPIO})
    s.part("U1", "STM32F103CBT6", mcu, at=Place(30.0, 28.5, 0))
    # decoupling: one 100 nF per VDD pin, VDDA 10 nF + 1 uF (AN2586), 10 uF bulk at the LDO
    s.part("C3", "C_100n", {"1": "+3V3", "2": "GND"}, at=Place(25.3, 21.6, 0))     # VBAT (1), VDD 48
    s.part("C4", "C_100n", {"1": "+3V3", "2": "GND"}, at=Place(37.0, 25.0, 90))    # VDD 36
    s.part("C5", "C_100n", {"1": "+3V3", "2": "GND"}, at=Place(33.8, 35.0, 0))     # VDD 24
    s.part("C6", "C_10n", {"1": "+3V3", "2": "GND"}, at=Place(23.2, 31.0, 90))     # VDDA
    s.part("C11", "C_1u", {"1": "+3V3", "2": "GND"}, at=Place(21.6, 31.0, 90))     # VDDA
    hse_crystal(s)
    regulator(s, "V5_IN")
    reset_boot(s)
    swd(s)

    # status LEDs (AlInGaP, Vf ~2 V) sinking into PC13-15 (3 mA max there): 1 k gives ~1.3 mA
    for ref, rref, key, rkey, sig, y in (("D2", "R4", "LED_G", "R_1k", "LED_STATUS", 24.0),
                                         ("D3", "R5", "LED_Y", "R_1k", "LED_BUS", 26.0),
                                         ("D4", "R6", "LED_R", "R_1k", "LED_FAULT", 28.0)):
        s.part(ref, key, {"A": "+3V3", "K": f"{sig}_K"}, at=Place(2.8, y, 180))
        s.part(rref, rkey, {"1": f"{sig}_K", "2": sig}, at=Place(6.5, y, 0))

    can_transceiver(s)
    test_pads(s)
    bus_jacks(s)
    from . import core_sheet          # the drawing imports this module's numbers
    s.drawing, s.blocks = core_sheet.DRAWING, core_sheet.BLOCKS
    return s


# The core's blocks as functions: the F103 core sheet (build() above) and the gateway's own sheet
# (hardware/gateway/gateway.py, an STM32F407) draw the same circuits with the same references
# from them; the places are the core's defaults (a board moves them with its own places).

def hse_crystal(s: Sheet) -> None:
    """The 8 MHz HSE crystal on OSC_IN/OSC_OUT, load capacitors from CL and the stray
    capacitance (crystal_load())."""
    s.part("Y1", "XTAL_8M", {"1": "OSC_IN", "3": "OSC_OUT", "G": "GND"}, at=Place(21.3, 27.6, 0))
    s.part("C1", "C_30p", {"1": "OSC_IN", "2": "GND"}, at=Place(17.8, 28.4, 90))
    s.part("C2", "C_30p", {"1": "OSC_OUT", "2": "GND"}, at=Place(21.0, 24.4, 0))


def regulator(s: Sheet, vin: str) -> None:
    """3.3 V from the module's 5 V input `vin` (docs/bus.md §6: at most 0.4 V dropout)."""
    s.part("U2", "AP2112K-3.3", {"VIN": vin, "EN": vin, "GND": "GND", "VOUT": "+3V3"},
           at=Place(14.0, 20.5, 0))
    s.part("C8", "C_10u", {"1": vin, "2": "GND"}, at=Place(10.2, 20.5, 90))
    s.part("C7", "C_10u", {"1": "+3V3", "2": "GND"}, at=Place(17.8, 20.5, 90))


def reset_boot(s: Sheet) -> None:
    """NRST's 100 nF and reset button, the BOOT0 button with its pull-down, the BOOT1 strap."""
    s.part("C10", "C_100n", {"1": "NRST", "2": "GND"}, at=Place(20.0, 33.5, 0))
    s.part("SW1", "SW_TACT", {"1": "NRST", "2": "GND"}, at=Place(8.0, 32.6, 0))
    s.part("SW2", "SW_TACT", {"1": "+3V3", "2": "BOOT0"}, at=Place(6.0, 39.0, 0))
    s.part("R1", "R_10k", {"1": "BOOT0", "2": "GND"}, at=Place(29.5, 21.3, 0))
    s.part("R2", "R_10k", {"1": "BOOT1", "2": "GND"}, at=Place(29.5, 35.2, 0))


def swd(s: Sheet) -> None:
    """SWD: Cortex 10-pin, 1.27 mm; SWO is not wired."""
    s.part("J4", "SWD_2x5", {"1": "+3V3", "2": "SWDIO", "3": "GND", "4": "SWCLK", "5": "GND",
                             "9": "GND", "10": "NRST"}, nc=("6", "8"), at=Place(53.5, 32.0, 90))


def can_transceiver(s: Sheet) -> None:
    """The CAN transceiver on CAN_TX/CAN_RX, its ESD clamp, the +5V TVS and the switchable split
    termination (docs/bus.md §4, §7)."""
    # CAN transceiver, slope control off (Rs to GND) for 1 Mbit/s
    s.part("U3", "SN65HVD230", {"D": "CAN_TX", "R": "CAN_RX", "VCC": "+3V3", "GND": "GND",
                                "CANH": "CAN_H", "CANL": "CAN_L", "Rs": "GND"}, nc=("Vref",),
           at=Place(42.0, 25.5, 0))
    s.part("C9", "C_100n", {"1": "+3V3", "2": "GND"}, at=Place(40.0, 30.0, 0))
    s.part("D1", "PESD2CAN", {"1": "CAN_H", "2": "CAN_L", "3": "GND"}, at=Place(32.4, 16.0, 0))
    # +5V TVS at the jacks (docs/bus.md §7): 5.0 V standoff, 6.4 V minimum breakdown (above the
    # bus's 6 V survival voltage and the PSU's 6.1 V overvoltage cut-off), 9.2 V clamp at 43.5 A
    # pin 1 is the cathode (band; D_SMA pad 1)
    s.part("D5", "SMAJ5.0A", {"1": "+5V", "2": "GND"}, at=Place(4.2, 12.6, 90))
    # split termination (docs/bus.md §4): 2 x 60.4 ohm with 4.7 nF from the midpoint to GND.
    # Both legs go through the 2-pole switch, so "off" leaves neither resistor nor capacitor on
    # the pair (one pole would leave 60 ohm + 4.7 nF hanging on CAN_H).
    s.part("SW3", "SW_DIP_2", {"1": "CAN_H", "4": "TERM_H", "2": "CAN_L", "3": "TERM_L"},
           at=Place(29.8, 4.4, 0))
    s.part("R3", "R_60R4", {"1": "TERM_H", "2": "TERM_MID"}, at=Place(25.4, 15.4, 90))
    s.part("R7", "R_60R4", {"1": "TERM_MID", "2": "TERM_L"}, at=Place(27.4, 15.4, 90))
    s.part("C12", "C_4n7", {"1": "TERM_MID", "2": "GND"}, at=Place(29.3, 15.4, 90))


def test_pads(s: Sheet) -> None:
    """Bare 1 mm copper pads (no BOM line, no placement) for a probe: rails, bus, reset, SWD."""
    # test pads (bare copper, no BOM line, no placement): the right edge, beside U3 and J4
    for ref, net, x, y in (("TP1", "+5V", 48.6, 20.2), ("TP2", "+3V3", 51.1, 20.2),
                           ("TP3", "GND", 53.6, 20.2), ("TP4", "CAN_H", 56.1, 20.2),
                           ("TP5", "NRST", 48.6, 23.4), ("TP6", "SWDIO", 51.1, 23.4),
                           ("TP7", "SWCLK", 53.6, 23.4), ("TP8", "CAN_L", 56.1, 23.4)):
        s.part(ref, "TP", {"1": net}, at=Place(x, y, 0), value=net)


def bus_jacks(s: Sheet) -> None:
    """The bus: BUS IN and BUS OUT RJ45 jacks and the 1x4 header, in parallel (docs/bus.md)."""
    # the bus: two RJ45 jacks and the 1x4 header in parallel
    s.part("J1", "RJ45", RJ45_PINS, at=Place(20.2, 13.52, 180), value="BUS IN")
    s.part("J2", "RJ45", RJ45_PINS, at=Place(48.6, 13.52, 180), value="BUS OUT")
    s.part("J3", "HDR_1x4", {"1": "+5V", "2": "CAN_H", "3": "CAN_L", "4": "GND"},
           at=Place(26.0, 10.2, 90))


def bus_tracks(extend_to: float | None = None) -> list[Track]:
    """The bus +5V between BUS IN, BUS OUT and the header, drawn on B.Cu under the jack bodies.

    The bus passes through every module, so this copper carries the whole chain's current (4 A
    design maximum, docs/bus.md): 3.0 mm beside the jack pins and 2.5 mm across the middle
    (IPC-2221 asks 2.0 mm for 4 A on 1 oz outer copper at a 10 °C rise, docs/hardware.md), with a
    stub to each jack's three +5V pins and to the header. GND returns through both pours. Drawn
    as tracks, not a pour, so signals may still cross the band on B.Cu beside it. `extend_to`
    carries the line further right (the PSU feeds the bus there)."""
    right = 44.79 if extend_to is None else extend_to
    out = [Track("+5V", [(12.58, 10.9), (22.0, 10.9), (23.5, 12.8), (38.0, 12.8), (39.5, 10.9),
                         (right, 10.9)], 3.0, "B.Cu")]
    for x, y, w in ((12.58, 13.52, 1.2), (15.12, 13.52, 1.2), (16.39, 16.06, 0.5),
                    (40.98, 13.52, 1.2), (43.52, 13.52, 1.2), (44.79, 16.06, 0.5)):
        out.append(Track("+5V", [(x, 10.9), (x, y)], w, "B.Cu"))
    out.append(Track("+5V", [(26.0, 12.8), (26.0, 10.2)], 1.2, "B.Cu"))     # header pin 1
    return out


if __name__ == "__main__":
    print(report())          # the numbers: scripts/py -m r2ptools.kicad.calc.core
