"""The gateway board's design numbers: its current from the bus, the regulator's heat, both clocks.

Run `scripts/py -m r2ptools.kicad.calc.gateway` for them. `BOARD_VALUES` lists the component
values this file assumes (reference → value, SI units); tests/test_hardware.py checks them against
the gateway's KiCad schematic.

The supply decision (docs/bus.md §6): the gateway runs an STM32F407 at 168 MHz with its Ethernet
MAC and a LAN8742A PHY from the core's 3.3 V LDO on the fused bus tap. Worst case that is more
than the 200 mA a module may draw, so the gateway is a stated exception, like the proximity
module: count it as 250 mA in docs/bus.md §5 (the chain is planned with the gateway at one end,
next to the computer). Typically it draws about 150 mA.

Sources and their status:
- STM32F407 run current at 168 MHz, code from flash with the ART accelerator on, every peripheral
  clock enabled: 93 mA typical, 109 mA max at 85 °C (ST DS8626, table "Typical and maximum
  current consumption in Run mode ... from Flash memory"). NOT VERIFIED: figures recalled, the
  table was not re-read for this board; the firmware enables a handful of peripherals, so this
  bounds it from above.
- LAN8742A at 100BASE-TX with traffic, all supplies (VDD1A, VDD2A, VDDIO and the transmit
  current through the magnetics' centre tap): 55 mA max assumed (Microchip DS00001989A,
  "Power consumption"). NOT VERIFIED: recalled, to be measured.
- SN65HVD230 driving dominant into 60 ohm, LEDs, pull-ups: the core's share in docs/bus.md §6
  (transceiver ≤ 50 mA, regulator and pull-ups ≈ 5 mA); the LEDs from their resistors below.
- 8 MHz HSE on the F407: AN2867's criterion for parts whose datasheet gives Gm_crit_max is
  gm_crit < Gm_crit_max; DS8626's HSE table gives 1 mA/V for the STM32F407 (NOT VERIFIED:
  recalled). The crystal is the core's X32258MSB4SI (calc/core.py).
- 25 MHz PHY crystal: YXC X322525MOB4SI, CL 12 pF (LCSC C9006, as public JLC BOMs list it);
  the LAN8742A wants 25 MHz ± 50 ppm in total (DS00001989A, crystal specification; NOT VERIFIED).
"""
from __future__ import annotations

import sys

from . import core

V_BUS_MAX = 5.25            # docs/bus.md §6: a module must accept 4.00-5.25 V
V_3V3 = 3.3
MODULE_LIMIT_MA = 200.0     # docs/bus.md §6
COUNTED_AS_MA = 250.0       # what docs/bus.md §5 counts for the gateway

MCU_TYP_MA, MCU_MAX_MA = 93.0, 109.0       # STM32F407 at 168 MHz, all peripherals (NOT VERIFIED)
PHY_TYP_MA, PHY_MAX_MA = 45.0, 55.0        # LAN8742A 100BASE-TX with traffic (NOT VERIFIED)
CAN_TYP_MA, CAN_MAX_MA = 10.0, 50.0        # docs/bus.md §6, the core's transceiver share
MISC_MA = 5.0                              # regulator, pull-ups (docs/bus.md §6)
LED_R_OHM = 1000.0
LED_VF = {"green": 2.0, "yellow": 2.0, "red": 2.0, "blue": 2.8,      # board LEDs, lit high
          "jack green": 2.0, "jack yellow": 2.0}                      # the Ethernet jack's LEDs
"""Forward voltages at about 1 mA (KENTO KT-0603 series; the HR911105A's LEDs): approximate."""

LDO_THETA_JA = 150.0        # AP2112K SOT-23-5 on a GND pour, °C/W: assumed (NOT VERIFIED)

# the PHY's clock (C101, C102) and bias (R101): values per LAN8742A DS00001989A
XTAL25_CL_PF = 12.0
XTAL25_LOAD_PF = 15.0
RBIAS_OHM = 12.1e3          # DS00001989A: 12.1 kohm 1 % from RBIAS to GND
MDI_TERM_OHM = 49.9         # each of TXP, TXN, RXP, RXN to the 3.3 V centre-tap supply
VCAP_F = 2.2e-6             # STM32F407 VCAP_1, VCAP_2 (DS8626: 2.2 uF, ESR < 2 ohm)
F407_GM_CRIT_MAX_MA_PER_V = 1.0


def leds_ma() -> float:
    return sum((V_3V3 - vf) / LED_R_OHM * 1e3 for vf in LED_VF.values())


def budget() -> dict[str, float]:
    """Current from the bus (the LDO passes the 3.3 V current through), typical and worst."""
    led = leds_ma()
    typ = MCU_TYP_MA + PHY_TYP_MA + CAN_TYP_MA + led + MISC_MA
    worst = MCU_MAX_MA + PHY_MAX_MA + CAN_MAX_MA + led + MISC_MA
    return {"leds_ma": led, "typ_ma": typ, "worst_ma": worst,
            "ldo_w_typ": (V_BUS_MAX - V_3V3) * typ / 1e3,
            "ldo_w_worst": (V_BUS_MAX - V_3V3) * worst / 1e3}


def phy_crystal() -> dict[str, float]:
    """The 25 MHz crystal's effective load over the core's stray range and 5 % capacitors."""
    lo = XTAL25_LOAD_PF * 0.95 / 2 + core.STRAY_RANGE_PF[0]
    hi = XTAL25_LOAD_PF * 1.05 / 2 + core.STRAY_RANGE_PF[1]
    return {"ideal_pf": 2 * (XTAL25_CL_PF - core.STRAY_PF), "cl_min_pf": lo, "cl_max_pf": hi}


def hse() -> dict[str, float]:
    x = core.crystal_load()
    return {"gm_crit_ma_per_v": x["gm_crit_ma_per_v"],
            "ratio": F407_GM_CRIT_MAX_MA_PER_V / x["gm_crit_ma_per_v"]}


def report() -> str:
    b, p, h = budget(), phy_crystal(), hse()
    return "\n".join([
        f"bus current: MCU {MCU_TYP_MA:g}/{MCU_MAX_MA:g} + PHY {PHY_TYP_MA:g}/{PHY_MAX_MA:g} + CAN"
        f" {CAN_TYP_MA:g}/{CAN_MAX_MA:g} + LEDs {b['leds_ma']:.1f} + misc {MISC_MA:g} mA"
        f" = {b['typ_ma']:.0f} mA typical, {b['worst_ma']:.0f} mA worst case",
        f"  docs/bus.md §6 allows {MODULE_LIMIT_MA:g} mA: worst case exceeds it by"
        f" {b['worst_ma'] - MODULE_LIMIT_MA:.0f} mA -> stated exception, counted as"
        f" {COUNTED_AS_MA:g} mA in §5 ({COUNTED_AS_MA - b['worst_ma']:.0f} mA margin)",
        f"LDO (AP2112K-3.3) at {V_BUS_MAX:g} V in: {b['ldo_w_typ']:.2f} W typical,"
        f" {b['ldo_w_worst']:.2f} W worst; rise at {LDO_THETA_JA:g} C/W:"
        f" {b['ldo_w_typ'] * LDO_THETA_JA:.0f} / {b['ldo_w_worst'] * LDO_THETA_JA:.0f} C",
        f"PHY crystal 25 MHz: C = 2 (CL - Cstray) = 2 ({XTAL25_CL_PF:g} - {core.STRAY_PF:g}) pF"
        f" = {p['ideal_pf']:.0f} pF; chosen {XTAL25_LOAD_PF:g} pF C0G: effective CL"
        f" {p['cl_min_pf']:.1f}-{p['cl_max_pf']:.1f} pF",
        f"HSE 8 MHz on the F407: gm_crit {h['gm_crit_ma_per_v']:.2f} mA/V <"
        f" Gm_crit_max {F407_GM_CRIT_MAX_MA_PER_V:g} mA/V (ratio {h['ratio']:.2f})",
        f"PHY: RBIAS {RBIAS_OHM / 1e3:g} k 1 %, MDI terminations 4 x {MDI_TERM_OHM:g} ohm to 3.3 V;"
        f" F407 VCAP_1/VCAP_2 {VCAP_F * 1e6:g} uF",
    ])


BOARD_VALUES = {
    "C101": XTAL25_LOAD_PF * 1e-12, "C102": XTAL25_LOAD_PF * 1e-12,
    "R101": RBIAS_OHM, "R102": MDI_TERM_OHM, "R103": MDI_TERM_OHM, "R104": MDI_TERM_OHM,
    "R105": MDI_TERM_OHM, "C18": VCAP_F, "C20": VCAP_F,
    "C6": 100e-9, "C11": 1e-6,                   # VDDA = VREF+ (AN4488: 100 nF + 1 uF)
    "C1": core.LOAD_CAP_PF * 1e-12, "C2": core.LOAD_CAP_PF * 1e-12,
    "R3": core.TERM_R_OHM, "R7": core.TERM_R_OHM, "C12": core.TERM_C_NF * 1e-9,
}


def main() -> int:
    print(report())
    b, p, h = budget(), phy_crystal(), hse()
    ok = (b["worst_ma"] <= COUNTED_AS_MA and p["cl_min_pf"] < XTAL25_CL_PF < p["cl_max_pf"]
          and h["ratio"] > 1)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
