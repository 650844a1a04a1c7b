"""The proximity module's sensor supply: the TPS2553 current limit against the sensors' draw,
the bus budget exception it makes, and the inrush behind the switch.

Run `scripts/py -m r2ptools.kicad.calc.proximity` for the numbers. `BOARD_VALUES` lists the
component values assumed (reference → value, SI units), checked against the board's KiCad
schematic by tests/test_hardware.py.

Sources: TPS2553 SLVS841 (RILIM equations), Sharp GP2Y0A21/GP2Y0A02 and MaxBotix HRLV
datasheets (supply current), docs/bus.md §5-6 (module budget, loop resistance per hop).
"""
from __future__ import annotations

import sys

# sensor supply budget (docs/bus.md §5-6; TPS2553 datasheet SLVS841, RILIM equations)
MODULE_LIMIT_MA = 200.0
CORE_WORST_MA = 115.0
R_ILIM_KOHM = 174.0                        # 1 %, R111
R_TOL = 0.01
SENSOR_RAIL_UF = 20.0                      # C102 + C103 behind the switch
BUS_SIDE_UF = 11.0                         # C8 (LDO input) + C101 (switch input)
SENSORS_MA = {"Sharp GP2Y0A21": 30.0, "Sharp GP2Y0A02": 33.0, "MaxBotix HRLV": 3.1}
"""Typical average supply currents (datasheets); four GP2Y0A02 are the largest set."""
HOP_MOHM, FIRST_HOP_MOHM = 42.93, 32.93   # docs/bus.md §5.2, loop resistance per hop


def switch_limit_ma(r_kohm: float = R_ILIM_KOHM) -> tuple[float, float, float]:
    """TPS2553 short-circuit current limit (min, nominal, max) in mA for R_ILIM in kohm, the
    1 % tolerance applied the way that widens the range (datasheet: IOS equations)."""
    lo = 25230 / (r_kohm * (1 + R_TOL)) ** 1.016
    nom = 23950 / r_kohm ** 0.977
    hi = 22980 / (r_kohm * (1 - R_TOL)) ** 0.94
    return lo, nom, hi


def sensor_budget() -> str:
    """The switch's limit against the sensors' draw and the module's share of the bus."""
    lo, nom, hi = switch_limit_ma()
    four = 4 * max(SENSORS_MA.values())
    worst = hi + CORE_WORST_MA
    lines = [
        f"TPS2553, R_ILIM {R_ILIM_KOHM:g} k 1 %: limit {lo:.0f} / {nom:.0f} / {hi:.0f} mA"
        " (min / nominal / max)",
        f"four GP2Y0A02 draw {four:.0f} mA typ: at or below the minimum limit ({lo - four:+.1f} mA);"
        f" robots/triskar2.toml's set (one GP2Y0A02, three GP2Y0A21) {33 + 3 * 30:.0f} mA:"
        f" {lo - 123:+.0f} mA ({(lo - 123) / 123:.0%})",
        f"module worst case: {hi:.0f} + {CORE_WORST_MA:g} (core) = {worst:.0f} mA, "
        f"{worst - MODULE_LIMIT_MA:+.0f} mA against the {MODULE_LIMIT_MA:g} mA of docs/bus.md §6"
        " (stated exception)",
    ]
    extra = (worst - MODULE_LIMIT_MA) / 1000
    # lowest module voltages of docs/bus.md §5.4's two allowed configurations (200 mA each)
    for n, where, lowest_v in ((10, "PSU in the middle, 10 modules per side", 4.45),
                               (14, "PSU at one end, 14 modules", 4.03)):
        # the exception's extra current crosses every hop between the PSU and the module; worst
        # when the proximity module is the last one
        dv_mv = extra * (FIRST_HOP_MOHM + (n - 1) * HOP_MOHM)     # A x mohm = mV
        v = lowest_v - dv_mv / 1000
        lines.append(f"  extra drop with the proximity module last ({where}): +{dv_mv:.0f} mV,"
                     f" lowest module {lowest_v:.2f} -> {v:.2f} V"
                     f" ({'>=' if v >= 4.0 else '< '} 4.00 V)")
    lines.append(f"inrush: {SENSOR_RAIL_UF:g} uF behind the switch charge at <= {hi:.0f} mA in"
                 f" >= {SENSOR_RAIL_UF * 5.0 / hi:.2f} ms; {BUS_SIDE_UF:g} uF on the bus side"
                 " (SHOULD <= 22 uF)")
    return "\n".join(lines)


BOARD_VALUES = {"R111": R_ILIM_KOHM * 1e3}
"""R_ILIM sets the switch's limit."""


def main() -> int:
    print(sensor_budget())
    lo, _, hi = switch_limit_ma()
    return 0 if lo >= 4 * max(SENSORS_MA.values()) and hi < MODULE_LIMIT_MA else 1


if __name__ == "__main__":
    sys.exit(main())
