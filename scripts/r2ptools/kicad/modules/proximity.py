"""hardware/proximity: four analog distance sensors (Sharp GP2Y0A21/0A02 IR, MaxBotix sonar).

Each sensor plugs into a JST PH 3-pin jack on the bottom edge, wired like the Sharp sensors'
own cable (pin 1 signal Vo, pin 2 GND, pin 3 +5 V) so a straight PH-PH cable fits. The sensors'
5 V comes from the bus through a current-limited switch (TPS2065C, 1 A class) that the firmware
turns on with SENSOR_PWR_EN (PB0; a 100 k pull-down keeps the sensors off through reset).

Per channel: an ESD clamp at the jack (one SRV05-4 array for the four signals), then a divider
56 k over 100 k into the ADC pin with 100 nF: 5 V full scale becomes 3.21 V (MaxBotix HRLV
analog output reaches ~0.98 Vcc), the 100 k is also the pull-down that makes an unplugged
channel read 0 V ("no sensor"), the source impedance is 36 k, and the pole is at
1 / (2 pi * 36 k * 100 nF) = 44 Hz: above the sensors' 26 Hz (Sharp, 38 ms) update rate and
settled to 0.1 % in 7 time constants (25 ms). The 56 k also limits the current a miswired 24 V
sensor could inject into the MCU's clamp diodes to 0.4 mA (the F103 allows 5 mA).
"""
from __future__ import annotations

from ..design import Module, Place, Sheet, Text
from . import core as core_mod
from .common import (BUS_TAP_PLACE, bus_tap, bus_tap_track, core_tracks, frame_texts,
                     tvs_track)

NAME = "proximity"
TITLE = "R2P proximity module"
REVISION = "B"

CHANNELS = 4
SIGNALS = [f"PROX_CH{i}" for i in range(CHANNELS)]
ADC_PINS = ["PA0", "PA1", "PA2", "PA3"]


def build(core: Sheet) -> Module:
    s = Sheet(NAME, f"{TITLE}: four analog sensor inputs")
    bus_tap(s, "+5V_MOD", at=BUS_TAP_PLACE)
    pins = {p: "" for p in core_mod.FREE_GPIO}
    pins.update(dict(zip(ADC_PINS, SIGNALS)))
    pins.update({"PB0": "SENSOR_PWR_EN", "V5_IN": "+5V_MOD"})
    s.use(core, pins)

    # sensor supply switch
    s.part("U101", "TPS2065C", {"IN": "+5V_MOD", "EN": "SENSOR_PWR_EN", "GND": "GND",
                                "OUT": "+5V_SENS"}, nc=("~{FLT}",), at=Place(39.4, 39.0, 0))
    s.part("R101", "R_100k", {"1": "SENSOR_PWR_EN", "2": "GND"}, at=Place(41.0, 35.8, 0))
    s.part("C101", "C_1u", {"1": "+5V_MOD", "2": "GND"}, at=Place(37.2, 35.8, 0))
    s.part("C102", "C_10u", {"1": "+5V_SENS", "2": "GND"}, at=Place(18.3, 38.6, 90))
    s.part("C103", "C_10u", {"1": "+5V_SENS", "2": "GND"}, at=Place(49.8, 39.0, 90))

    # ESD clamp for the four signals, referenced to the sensor supply
    s.part("U102", "SRV05-4", {"IO1": "SIG0", "IO2": "SIG1", "IO3": "SIG2", "IO4": "SIG3",
                               "VP": "+5V_SENS", "VN": "GND"}, at=Place(28.9, 39.0, 0))

    xs = [11.0, 21.6, 32.2, 42.8]        # pin 1 of each jack along the bottom edge
    for ch in range(CHANNELS):
        x = xs[ch]
        sig, net = f"SIG{ch}", SIGNALS[ch]
        s.part(f"J{101 + ch}", "JST_PH_3", {"1": sig, "2": "GND", "3": "+5V_SENS"},
               at=Place(x, 43.8, 0), value=f"SENSOR {ch}")
        s.part(f"R{102 + 2 * ch}", "R_56k", {"1": sig, "2": net}, at=Place(x + 0.2, 39.0, 90))
        s.part(f"R{103 + 2 * ch}", "R_100k", {"1": net, "2": "GND"}, at=Place(x + 2.0, 39.0, 90))
        s.part(f"C{104 + ch}", "C_100n", {"1": net, "2": "GND"}, at=Place(x + 3.8, 39.0, 90))

    m = Module(NAME, TITLE, REVISION, s,
               tracks=[*core_mod.bus_tracks(), bus_tap_track(), tvs_track(), *core_tracks()], seed=2)
    m.fiducials = list(core_mod.FIDUCIALS)
    m.texts = frame_texts(NAME, REVISION)
    for ch, x in enumerate(xs):
        m.texts.append(Text(f"S{ch}", x + 2.0, 41.6, 0.8))
        m.texts.append(Text("5V GND SIG", x + 2.0, 40.0, 0.8, "B.SilkS"))   # seen from the back
    return m
