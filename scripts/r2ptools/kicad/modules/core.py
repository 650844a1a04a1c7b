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
"""
from __future__ import annotations

from ..design import Place, Sheet, Track

FREE_GPIO = [f"PA{i}" for i in (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 15)] + \
            [f"PB{i}" for i in (0, 1, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15)]
"""MCU pins the core does not use, offered to the module sheet."""

# RJ45 pinout of the R2P bus (docs/bus.md): CAN on pair 1-2, +5V on 4, 5, 7, GND on 3, 6, 8.
RJ45_PINS = {"1": "CAN_H", "2": "CAN_L", "3": "GND", "4": "+5V", "5": "+5V", "6": "GND",
             "7": "+5V", "8": "GND"}


def build() -> Sheet:
    s = Sheet("core", "R2P common module core: STM32F103, CAN, bus, SWD")
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
    # decoupling: one 100 nF per VDD pin, VDDA its own, 10 uF bulk at the LDO output
    s.part("C3", "C_100n", {"1": "+3V3", "2": "GND"}, at=Place(25.3, 21.6, 0))     # VBAT (1), VDD 48
    s.part("C4", "C_100n", {"1": "+3V3", "2": "GND"}, at=Place(37.0, 25.0, 90))    # VDD 36
    s.part("C5", "C_100n", {"1": "+3V3", "2": "GND"}, at=Place(33.8, 35.0, 0))     # VDD 24
    s.part("C6", "C_100n", {"1": "+3V3", "2": "GND"}, at=Place(23.2, 31.0, 90))    # VDDA
    s.part("Y1", "XTAL_8M", {"1": "OSC_IN", "3": "OSC_OUT", "G": "GND"}, at=Place(21.3, 27.6, 0))
    s.part("C1", "C_22p", {"1": "OSC_IN", "2": "GND"}, at=Place(17.8, 28.4, 90))
    s.part("C2", "C_22p", {"1": "OSC_OUT", "2": "GND"}, at=Place(21.0, 24.4, 0))

    # 3.3 V from the 5 V input
    s.part("U2", "AP2112K-3.3", {"VIN": "V5_IN", "EN": "V5_IN", "GND": "GND", "VOUT": "+3V3"},
           at=Place(14.0, 20.5, 0))
    s.part("C8", "C_10u", {"1": "V5_IN", "2": "GND"}, at=Place(10.2, 20.5, 90))
    s.part("C7", "C_10u", {"1": "+3V3", "2": "GND"}, at=Place(17.8, 20.5, 90))

    # reset, BOOT0 button, BOOT1 strap
    s.part("C10", "C_100n", {"1": "NRST", "2": "GND"}, at=Place(20.0, 33.5, 0))
    s.part("SW1", "SW_TACT", {"1": "NRST", "2": "GND"}, at=Place(8.0, 32.6, 0))
    s.part("SW2", "SW_TACT", {"1": "+3V3", "2": "BOOT0"}, at=Place(6.0, 39.0, 0))
    s.part("R1", "R_10k", {"1": "BOOT0", "2": "GND"}, at=Place(29.5, 21.3, 0))
    s.part("R2", "R_10k", {"1": "BOOT1", "2": "GND"}, at=Place(29.5, 35.2, 0))

    # SWD: Cortex 10-pin, 1.27 mm; SWO is not wired (PB3 stays a module GPIO)
    s.part("J4", "SWD_2x5", {"1": "+3V3", "2": "SWDIO", "3": "GND", "4": "SWCLK", "5": "GND",
                             "9": "GND", "10": "NRST"}, nc=("6", "8"), at=Place(53.5, 32.0, 90))

    # status LEDs (AlInGaP, Vf ~2 V) sinking into PC13-15 (3 mA max there): 1 k gives ~1.3 mA
    for ref, rref, key, rkey, sig, y in (("D2", "R4", "LED_G", "R_1k", "LED_STATUS", 24.0),
                                         ("D3", "R5", "LED_Y", "R_1k", "LED_BUS", 26.0),
                                         ("D4", "R6", "LED_R", "R_1k", "LED_FAULT", 28.0)):
        s.part(ref, key, {"A": "+3V3", "K": f"{sig}_K"}, at=Place(2.8, y, 180))
        s.part(rref, rkey, {"1": f"{sig}_K", "2": sig}, at=Place(6.5, y, 0))

    # CAN transceiver, slope control off (Rs to GND) for 1 Mbit/s
    s.part("U3", "SN65HVD230", {"D": "CAN_TX", "R": "CAN_RX", "VCC": "+3V3", "GND": "GND",
                                "CANH": "CAN_H", "CANL": "CAN_L", "Rs": "GND"}, nc=("Vref",),
           at=Place(42.0, 25.5, 0))
    s.part("C9", "C_100n", {"1": "+3V3", "2": "GND"}, at=Place(40.0, 30.0, 0))
    s.part("D1", "PESD2CAN", {"1": "CAN_H", "2": "CAN_L", "3": "GND"}, at=Place(32.4, 16.0, 0))
    # termination: 120 ohm across the pair when the slide switch is at "ON"
    s.part("R3", "R_120", {"1": "CAN_H", "2": "TERM"}, at=Place(26.6, 15.6, 0))
    s.part("SW3", "SW_SLIDE", {"B": "TERM", "A": "CAN_L"}, nc=("C",), at=Place(29.8, 4.6, 0))

    # the bus: two RJ45 jacks and the 1x4 header in parallel
    s.part("J1", "RJ45", RJ45_PINS, at=Place(20.2, 13.52, 180), value="BUS IN")
    s.part("J2", "RJ45", RJ45_PINS, at=Place(48.6, 13.52, 180), value="BUS OUT")
    s.part("J3", "HDR_1x4", {"1": "+5V", "2": "CAN_H", "3": "CAN_L", "4": "GND"},
           at=Place(26.0, 10.2, 90))
    return s


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
