"""hardware/proximity: four analog distance sensors (Sharp GP2Y0A21/0A02 IR, MaxBotix sonar).

Each sensor plugs into a JST PH 3-pin jack on the bottom edge, wired like the Sharp sensors'
own cable (pin 1 signal Vo, pin 2 GND, pin 3 +5 V) so a straight PH-PH cable fits.

Sensor supply (revision B). The sensors' 5 V comes from the module's fused bus tap through a
TPS2553 current-limited switch (SENSOR_PWR_EN, PB0, turns it on; a 100 k pull-down keeps the
sensors off through reset). Its limit is set by R_ILIM (TPS2553 datasheet SLVS841, RILIM
equations) so that four Sharp sensors at their typical draw always run (the limit's minimum, with
the 1 % resistor at its high end, is above 4 x 33 mA) and nothing more is fed: a shorted sensor
cable or a fifth load is held at the limit, and the switch pulls its open-drain fault flag low
after its 7.5 ms deglitch. The flag (SENSOR_PWR_FAULT, PB1, 10 k pull-up to 3.3 V) is read and
published by the firmware. `sensor_budget()` prints the numbers.

Budget exception (README, docs/bus.md §6): the bus allows a module 200 mA and the core takes up
to 115 mA worst case, which leaves 85 mA: not even three Sharp sensors. The switch's lowest
setting (ILIM tied to IN, 50-100 mA) would run one or two, and the reference robot (four Sharp
rangers, robots/triskar2.toml) would not work. So the proximity module may draw up to the
limit's maximum plus the core's worst case (about 300 mA, typically under 200 mA), counted as
such in the drop calculation (`sensor_budget()`, docs/bus.md §6).
Inrush: the 20 uF of the sensor rail charge behind the switch at its limit (>= 0.5 ms), so the
bus sees only the 11 uF ahead of it (docs/bus.md §6: <= 22 uF).

Per channel: an ESD clamp at the jack (one SRV05-4 array for the four signals), then a divider
56 k over 100 k into the ADC pin with 100 nF: 5 V full scale becomes 3.21 V (MaxBotix HRLV
analog output reaches ~0.98 Vcc), the 100 k is also the pull-down that makes an unplugged
channel read 0 V ("no sensor"), the source impedance is 36 k, and the pole is at
1 / (2 pi * 36 k * 100 nF) = 44 Hz: above the sensors' 26 Hz (Sharp, 38 ms) update rate and
settled to 0.1 % in 7 time constants (25 ms). The 56 k also limits the current a miswired 24 V
sensor could inject into the MCU's clamp diodes to 0.4 mA (the F103 allows 5 mA).

Test pads (no BOM, no placement) on the back: the sensor rail, each channel's ADC input and the
fault flag.
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

from ..calc.proximity import *  # noqa: F401,F403  (the supply budget, re-exported)
from ..calc.proximity import sensor_budget, switch_limit_ma  # noqa: F401


def build(core: Sheet) -> Module:
    s = Sheet(NAME, f"{TITLE}: four analog sensor inputs")
    bus_tap(s, "+5V_MOD", at=BUS_TAP_PLACE)
    pins = {p: "" for p in core_mod.FREE_GPIO}
    pins.update(dict(zip(ADC_PINS, SIGNALS)))
    pins.update({"PB0": "SENSOR_PWR_EN", "PB1": "SENSOR_PWR_FAULT", "V5_IN": "+5V_MOD"})
    s.use(core, pins)

    # sensor supply switch, its limit set by R111 (sensor_budget())
    s.part("U101", "TPS2553", {"IN": "+5V_MOD", "ILIM": "ILIM", "EN": "SENSOR_PWR_EN",
                               "GND": "GND", "~{OC}": "SENSOR_PWR_FAULT", "OUT": "+5V_SENS"},
           at=Place(39.4, 39.0, 0))
    # R_ILIM beside the ILIM pin (5, right side): channel 3's passives make room for it
    s.part("R111", "R_174k", {"1": "ILIM", "2": "GND"}, at=Place(42.35, 39.0, 90))
    s.part("R101", "R_100k", {"1": "SENSOR_PWR_EN", "2": "GND"}, at=Place(41.0, 35.8, 0))
    s.part("R110", "R_10k", {"1": "+3V3", "2": "SENSOR_PWR_FAULT"}, at=Place(44.6, 35.8, 0))
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
        px = x + (1.0 if ch == 3 else 0.0)          # the passives' row (channel 3: R111's room)
        s.part(f"R{102 + 2 * ch}", "R_56k", {"1": sig, "2": net}, at=Place(px + 0.2, 39.0, 90))
        s.part(f"R{103 + 2 * ch}", "R_100k", {"1": net, "2": "GND"}, at=Place(px + 2.0, 39.0, 90))
        s.part(f"C{104 + ch}", "C_100n", {"1": net, "2": "GND"}, at=Place(px + 3.8, 39.0, 90))

    # test pads on the back (bare copper): sensor rail, the four ADC inputs, the fault flag
    s.part("TP101", "TP", {"1": "+5V_SENS"}, at=Place(47.6, 38.2, 0, back=True), value="5V_SENS")
    s.part("TP106", "TP", {"1": "SENSOR_PWR_FAULT"}, at=Place(47.6, 35.6, 0, back=True),
           value="FAULT")
    for ch in range(CHANNELS):
        s.part(f"TP{102 + ch}", "TP", {"1": SIGNALS[ch]},
               at=Place(xs[ch] + 1.1, 37.4, 0, back=True), value=SIGNALS[ch])

    from . import proximity_sheet
    s.drawing, s.blocks = proximity_sheet.DRAWING, proximity_sheet.BLOCKS

    m = Module(NAME, TITLE, REVISION, s,
               tracks=[*core_mod.bus_tracks(), bus_tap_track(), tvs_track(), *core_tracks()], seed=2)
    m.fiducials = list(core_mod.FIDUCIALS)
    m.texts = frame_texts(NAME, REVISION)
    for ch, x in enumerate(xs):
        m.texts.append(Text(f"S{ch}", x + 2.0, 41.6, 0.8))
        m.texts.append(Text("5V GND SIG", x + 2.0, 40.0, 0.8, "B.SilkS"))   # seen from the back
    return m


if __name__ == "__main__":
    print(sensor_budget())
