"""The IMU module's design numbers: its current from the bus with an external GNSS receiver, the
3.3 V regulator's extra heat when the receiver runs from it, the PPS input's protection, and the
magnetic field that the board's own currents put on the magnetometer.

Run `scripts/py -m r2ptools.kicad.calc.imu` for the numbers. `BOARD_VALUES` lists the component
values assumed (reference → value, SI units), checked against the board's KiCad schematic by
tests/test_hardware.py; `PLACES` the board positions the field estimates use (mm from the board's
top-left corner), checked against the board by the same test.

Sources: docs/bus.md §6 (200 mA per module, the core's ≤ 115 mA); LSM6DSO DS12140 (front page:
0.55 mA in combo high-performance mode); u-blox SAM-M8Q data sheet UBX-16012619 R04, Table 8
(indicative currents of a u-blox M8 receiver at 3.0 V: 67 mA maximum, 32 mA average in GPS +
GLONASS acquisition, 29 mA tracking); STM32F103xB datasheet DS5319, Table 7 (injected current
±5 mA on a pin that is not five-volt tolerant: PB1). The LIS3MDL draws 270 µA typical in its
ultrahigh-resolution mode at 20 Hz (DS9463 Rev 7, Table 4); the firmware's 80 Hz is not
tabulated, so its 0.3 mA allowance stays NOT VERIFIED, as does the LPS22HH's (DocID030890's
current table not read here): allowances, and still under 1 mA together.
"""
from __future__ import annotations

import math
import sys

MODULE_LIMIT_MA = 200.0                  # docs/bus.md §6
CORE_WORST_MA = 115.0                    # docs/bus.md §6, "The core's share"
SENSORS_MA = {"LSM6DSO (DS12140: 0.55 mA, combo high-performance)": 0.55,
              "LIS3MDL (allowance, NOT VERIFIED)": 0.3,
              "LPS22HH (allowance, NOT VERIFIED)": 0.1}
PULL_UP_MA = 3.3 / 10e3 * 1e3            # R105 holds GNSS_RX high: 0.33 mA while the line is low
RECEIVER_MA = {"peak (UBX-16012619 Table 8, I_CCP max)": 67.0,
               "acquisition, GPS + GLONASS (Table 8, typ.)": 32.0,
               "tracking, continuous (Table 8, typ.)": 29.0}
"""A u-blox M8 receiver's own current at 3.0 V. A module's LDO, LED and compass (and an active
antenna's LNA) come on top: the budget below says how much a module may add."""

BUS_V = (4.00, 5.10)                     # docs/bus.md §5-6: the lowest and highest bus voltage
LDO_V = 3.3
PPS_SERIES_OHM = 1e3                     # R104
PPS_PULLDOWN_OHM = 100e3                 # R106
RX_PULLUP_OHM = 10e3                     # R105
CS_PULLUP_OHM = 10e3                     # R101-R103
INJECTION_MAX_MA = 5.0                   # DS5319 Table 7, I_INJ(PIN) on a pin that is not FT
CLAMP_DROP_V = 0.3                       # the input's clamp diode at a few mA (conservative)

MU0_OVER_2PI = 2e-7                      # T·m/A
BUS_RAIL_MAX_A = 3.0                     # docs/bus.md §5: no cord or jack carries more per rail
PLACES = {"U102": (30.0, 46.0), "bus +5V band": (30.0, 12.8), "JP101": (16.3, 40.6),
          "H3": (4.0, 46.0), "H4": (56.0, 46.0), "M5 left": (15.0, 37.0), "M5 right": (45.0, 37.0)}
"""Where the magnetometer, the bus's +5V band (its closest run, core.bus_tracks) and the GNSS
supply's jumper are; the M3 holes (steel screws and standoffs) and the case's M5 floor screws
(docs/enclosures.md: board centre ± 15 mm, + 12 mm)."""
RETURN_GAP_MM = 3.0
"""The bus GND's return runs in the pours beside the +5V band, about 3 mm away at the jack pins:
a pair, whose field falls as 1/d², not a single wire (an estimate: NOT VERIFIED, measure it)."""


def _dist_mm(a: str, b: str) -> float:
    (x0, y0), (x1, y1) = PLACES[a], PLACES[b]
    return math.hypot(x1 - x0, y1 - y0)


def budget() -> dict[str, float]:
    """The module's worst case from the bus with the receiver at its peak, and what is left."""
    sensors = sum(SENSORS_MA.values())
    peak = RECEIVER_MA["peak (UBX-16012619 Table 8, I_CCP max)"]
    total = CORE_WORST_MA + sensors + PULL_UP_MA + peak
    return {"sensors_ma": sensors, "total_ma": total, "margin_ma": MODULE_LIMIT_MA - total,
            "receiver_allowed_ma": MODULE_LIMIT_MA - CORE_WORST_MA - sensors - PULL_UP_MA}


def ldo_extra_w() -> float:
    """The AP2112K's extra dissipation when the receiver runs from +3V3 (jumper on 2-3) at the
    highest bus voltage: (V_bus - 3.3 V) · I_receiver."""
    return (BUS_V[1] - LDO_V) * RECEIVER_MA["peak (UBX-16012619 Table 8, I_CCP max)"] / 1e3


def pps_injection_ma(v_pps: float = 5.0) -> float:
    """Current into PB1's clamp if a receiver drives PPS at `v_pps` (a 5 V breakout) through R104."""
    return max(0.0, (v_pps - LDO_V - CLAMP_DROP_V) / PPS_SERIES_OHM * 1e3)


def field_ut(current_a: float, d_mm: float, pair_gap_mm: float | None = None) -> float:
    """Field of a long straight conductor (μ0 I / 2π d), or of a pair carrying I out and back
    `pair_gap_mm` apart (μ0 I s / 2π d²), in µT."""
    d = d_mm / 1e3
    if pair_gap_mm is None:
        return MU0_OVER_2PI * current_a / d * 1e6
    return MU0_OVER_2PI * current_a * (pair_gap_mm / 1e3) / d ** 2 * 1e6


def report() -> str:
    b = budget()
    d_bus = _dist_mm("U102", "bus +5V band")
    d_gnss = _dist_mm("U102", "JP101")
    screws = {k: _dist_mm("U102", k) for k in ("H3", "H4", "M5 left", "M5 right")}
    lines = [
        "current from the bus (docs/bus.md §6: 200 mA per module):",
        f"  core worst case {CORE_WORST_MA:g} mA + sensors {b['sensors_ma']:.2f} mA + GNSS_RX"
        f" pull-up {PULL_UP_MA:.2f} mA + receiver peak {RECEIVER_MA['peak (UBX-16012619 Table 8, I_CCP max)']:g} mA"
        f" = {b['total_ma']:.1f} mA: {b['margin_ma']:+.1f} mA against {MODULE_LIMIT_MA:g} mA",
        f"  a receiver module (with its LDO, LED, compass, active antenna) may draw up to"
        f" {b['receiver_allowed_ma']:.0f} mA; u-blox M8 alone: acquisition"
        f" {RECEIVER_MA['acquisition, GPS + GLONASS (Table 8, typ.)']:g} mA, tracking"
        f" {RECEIVER_MA['tracking, continuous (Table 8, typ.)']:g} mA (UBX-16012619 Table 8)",
        f"receiver on +3V3 (JP101 2-3): AP2112K dissipates {ldo_extra_w():.2f} W more at"
        f" {BUS_V[1]:.2f} V in (its 600 mA rating: {CORE_WORST_MA + RECEIVER_MA['peak (UBX-16012619 Table 8, I_CCP max)']:.0f} mA);"
        " default +5V_MOD (JP101 1-2, the receiver's own regulator takes the heat)",
        f"PPS into PB1 (not 5 V tolerant): a 5 V PPS through R104 {PPS_SERIES_OHM / 1e3:g} k injects"
        f" {pps_injection_ma():.1f} mA (DS5319 Table 7: <= {INJECTION_MAX_MA:g} mA);"
        f" R106 {PPS_PULLDOWN_OHM / 1e3:g} k holds it low with no receiver",
        f"magnetometer U102 at {PLACES['U102']}: {d_bus:.1f} mm from the bus +5V band;"
        f" {BUS_RAIL_MAX_A:g} A through the module (docs/bus.md §5 maximum) gives at most"
        f" {field_ut(BUS_RAIL_MAX_A, d_bus):.1f} uT as one wire, ~{field_ut(BUS_RAIL_MAX_A, d_bus, RETURN_GAP_MM):.1f} uT"
        f" with its return {RETURN_GAP_MM:g} mm away (NOT VERIFIED: measure); 1 A: "
        f"{field_ut(1.0, d_bus, RETURN_GAP_MM):.2f} uT",
        f"  GNSS supply at JP101, {d_gnss:.1f} mm away: {RECEIVER_MA['peak (UBX-16012619 Table 8, I_CCP max)']:g} mA"
        f" -> at most {field_ut(0.067, d_gnss):.2f} uT; acquisition to tracking changes it by"
        f" {field_ut(0.003, d_gnss):.3f} uT (hard iron: calibrated out)",
        "  steel nearby: M3 holes " + ", ".join(f"{k} {v:.1f} mm" for k, v in screws.items()
                                                 if k.startswith("H")) +
        "; the case's M5 floor screws " + ", ".join(f"{v:.1f} mm" for k, v in screws.items()
                                                    if k.startswith("M5")) +
        " (soft iron fixed to the board: the calibration's soft-iron fit removes it); no inductor,"
        " no magnetics jack on the board",
    ]
    return "\n".join(lines)


BOARD_VALUES = {"R104": PPS_SERIES_OHM, "R105": RX_PULLUP_OHM, "R106": PPS_PULLDOWN_OHM,
                "R101": CS_PULLUP_OHM, "R102": CS_PULLUP_OHM, "R103": CS_PULLUP_OHM}


def main() -> int:
    print(report())
    b = budget()
    ok = b["margin_ma"] >= 0 and pps_injection_ma() <= INJECTION_MAX_MA
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
