"""The gateway board's design numbers: its current from the bus, the two regulators' heat, both clocks.

Run `scripts/py -m r2ptools.kicad.calc.gateway` for them. `BOARD_VALUES` lists the component
values this file assumes (reference → value, SI units); tests/test_hardware.py checks them against
the gateway's KiCad schematic.

The supply decision (docs/bus.md §6): the gateway runs an STM32F407 at 168 MHz with its Ethernet
MAC and a LAN8742A PHY from the fused bus tap. Even typically that is more than the 200 mA a module
may draw (about 217 mA; 273 mA worst case, the PHY's 100BASE-TX current through the magnetics
alone being about 100 mA), so the gateway is a stated exception, like the proximity module: count
it as 300 mA in docs/bus.md §5 (the chain is planned with the gateway at one end, next to the
computer).

Two regulators (issue 20, revision A fix): one AP2112K-3.3 carrying all of it dissipated 0.53 W
worst case from 5.25 V, a 98 °C rise at the datasheet's θJA, 138 °C at 40 °C ambient. The PHY
side (the LAN8742A with its terminations and centre taps, the jack's LEDs) now has its own
AP2112K-3.3 (U102, +3V3_PHY); U2 keeps the MCU, the CAN transceiver, the board's LEDs and the
pull-ups. Each is held to TJ_LIMIT at T_AMB in the worst case, the motor board's convention.

Sources (each figure read from the document named; the datasheets' own table numbers):
- STM32F407 run current at 168 MHz, every peripheral clock enabled, code from flash with the ART
  accelerator disabled (embassy-stm32's RCC setup writes FLASH_ACR with the wait states only, so
  prefetch and both caches stay off, and the gateway firmware does not turn them on): 93 mA
  typical (25 °C, 3.3 V), 109 mA max (85 °C, 3.6 V) (ST DS8626 Rev 12, Table 21 "Typical and
  maximum current consumption in Run mode, code with data processing running from flash memory
  (ART accelerator disabled)"). With the ART on it would be 87 / 102 mA (Table 20). The firmware
  enables a handful of peripherals, so this bounds it from above.
- LAN8742A in REF_CLK Out mode (nINTSEL = 0) with its 1.2 V regulator on (REGOFF = 0), 100BASE-TX
  with traffic: 102 mA typical at 3.3 V including the transmit current through the magnetics'
  centre taps (Microchip DS00001989A, Table 5-5 "Current consumption and power dissipation
  (REF_CLK OUT, reg. enabled)": device 59 mA, device with magnetics 102 mA, 195 mW). The datasheet
  publishes typical values only: the worst case carries the same 102 mA (NOT VERIFIED as a bound:
  measure it on the first boards).
- SN65HVD230 driving dominant into 60 ohm, LEDs, pull-ups: the core's share in docs/bus.md §6
  (transceiver ≤ 50 mA, regulator and pull-ups ≈ 5 mA); the LEDs from their resistors below.
- AP2112K-3.3 in SOT-25: θJA 184 °C/W with no heatsink, junction 150 °C absolute maximum, thermal
  shutdown 160 °C typical (Diodes DS39724 Rev 2-2, "Absolute Maximum Ratings" and the electrical
  characteristics table). The GND pour lowers θJA by an amount not measured; the check uses the
  datasheet's figure at 40 °C ambient (the motor board's convention, issue 19).
- 8 MHz HSE on the F407: AN2867's criterion for parts whose datasheet gives Gm_crit_max is
  gm_crit < Gm_crit_max; 1 mA/V for the STM32F405/407 (DS8626 Rev 12, Table 32 "HSE 4-26 MHz
  oscillator characteristics": Gmcritmax 1 mA/V max, oscillator Gm 5 mA/V min at startup). The
  crystal is the core's X32258MSB4SI (calc/core.py).
- 25 MHz PHY crystal: YXC X322525MOB4SI, CL 12 pF (LCSC C9006, as public JLC BOMs list it); the
  LAN8742A allows ±50 ppm in all (tolerance, temperature and ageing: DS00001989A Tables 5-16 and
  5-17, "Total allowable PPM budget"). A 12 pF crystal is the datasheet's 100 µW case (Table 5-17:
  CL 8-12 pF, ESR ≤ 80 ohm, C0 ≤ 5 pF), whose circuit (Figure 5-8) puts RS = 500 ohm in series
  with XTAL2. The 300 µW case (Table 5-16) is a crystal that takes the oscillator's full drive,
  300 µW; the X322525MOB4SI is rated 100 µW (NOT VERIFIED: YXC's 3225 family figure; its LCSC
  page does not state it), so the board has RS (R112) and `drive_level` estimates what the
  crystal then sees: RS and the XO-side capacitance (C102 and the pin and trace stray, calc/core.py)
  divide the XTAL2 swing, and the drive level goes with the swing's square (P = ESR · I², I ∝ V).
  RS is 510 ohm, the E24 value next to the datasheet's 500 ohm.
"""
from __future__ import annotations

import sys

from . import core
from .proximity import FIRST_HOP_MOHM, HOP_MOHM   # docs/bus.md §5.2, loop resistance per hop

V_BUS_MAX = 5.25            # docs/bus.md §6: a module must accept 4.00-5.25 V
V_3V3 = 3.3
MODULE_LIMIT_MA = 200.0     # docs/bus.md §6
COUNTED_AS_MA = 300.0       # what docs/bus.md §5 counts for the gateway (as the proximity module)

MCU_TYP_MA, MCU_MAX_MA = 93.0, 109.0       # STM32F407, 168 MHz, all peripherals, ART off: DS8626 Table 21
PHY_TYP_MA = 102.0                         # LAN8742A 100BASE-TX, traffic, with magnetics: DS00001989A Table 5-5
PHY_MAX_MA = PHY_TYP_MA                    # no maximum published (NOT VERIFIED as a bound)
CAN_TYP_MA, CAN_MAX_MA = 10.0, 50.0        # docs/bus.md §6, the core's transceiver share
MISC_MA = 5.0                              # regulators' quiescent current, pull-ups (docs/bus.md §6)
LED_R_OHM = 1000.0
LED_VF = {"green": 2.0, "yellow": 2.0, "red": 2.0, "blue": 2.8,      # board LEDs, lit high
          "jack green": 2.0, "jack yellow": 2.0}                      # the Ethernet jack's LEDs
"""Forward voltages at about 1 mA (KENTO KT-0603 series; the HR911105A's LEDs): approximate."""
PHY_LEDS = ("jack green", "jack yellow")   # driven by the PHY's LED pins, from VDDIO (+3V3_PHY)

LDO_THETA_JA = 184.0        # AP2112K SOT-25, no heatsink, °C/W: DS39724 Absolute Maximum Ratings
LDO_TJ_MAX = 150.0          # °C, the same table (thermal shutdown at 160 °C typical)
T_AMB = 40.0                # °C ambient for the junction check (calc/motor.py's, issue 19)
TJ_LIMIT = 110.0            # °C, each regulator's worst case at T_AMB (calc/motor.py's, issue 19)
REGULATORS = ("U2", "U102")
"""U2: +3V3 (MCU, CAN transceiver, board LEDs, pull-ups); U102: +3V3_PHY (LAN8742A, MDI
terminations and centre taps, the jack's LEDs). Both AP2112K-3.3 from +5V_MOD."""

# the PHY's clock (C101, C102) and bias (R101): values per LAN8742A DS00001989A
XTAL25_CL_PF = 12.0
XTAL25_LOAD_PF = 15.0
XTAL25_F_HZ = 25e6
XTAL25_DRIVE_UW = 300.0     # the oscillator's drive with no RS: DS00001989A Table 5-16 (300 µW case)
XTAL25_RATED_UW = 100.0     # X322525MOB4SI drive level rating (NOT VERIFIED, see the docstring)
XTAL25_RS_DATASHEET_OHM = 500.0   # DS00001989A Figure 5-8, the 100 µW case
XTAL25_RS_OHM = 510.0       # R112, 0603WAF5100T5E (E24)
RBIAS_OHM = 12.1e3          # DS00001989A: 12.1 kohm 1 % from RBIAS to GND
MDI_TERM_OHM = 49.9         # each of TXP, TXN, RXP, RXN to the 3.3 V centre-tap supply
VCAP_F = 2.2e-6             # STM32F407 VCAP_1, VCAP_2 (DS8626: 2.2 uF, ESR < 2 ohm)
F407_GM_CRIT_MAX_MA_PER_V = 1.0   # DS8626 Rev 12, Table 32


def leds_ma() -> float:
    return sum((V_3V3 - vf) / LED_R_OHM * 1e3 for vf in LED_VF.values())


def led_ma(names) -> float:
    return sum((V_3V3 - LED_VF[n]) / LED_R_OHM * 1e3 for n in names)


def rails() -> dict[str, dict[str, float]]:
    """Each regulator's load (mA, typical and worst), what it dissipates from V_BUS_MAX (W), its
    junction at T_AMB and the ambient at which its worst case reaches TJ_LIMIT and LDO_TJ_MAX."""
    board_leds = led_ma(n for n in LED_VF if n not in PHY_LEDS)
    loads = {"U2": (MCU_TYP_MA + CAN_TYP_MA + board_leds + MISC_MA,
                    MCU_MAX_MA + CAN_MAX_MA + board_leds + MISC_MA),
             "U102": (PHY_TYP_MA + led_ma(PHY_LEDS), PHY_MAX_MA + led_ma(PHY_LEDS))}
    out = {}
    for ref, (typ, worst) in loads.items():
        w_typ, w_worst = (V_BUS_MAX - V_3V3) * typ / 1e3, (V_BUS_MAX - V_3V3) * worst / 1e3
        out[ref] = {"typ_ma": typ, "worst_ma": worst, "w_typ": w_typ, "w_worst": w_worst,
                    "tj_typ": T_AMB + w_typ * LDO_THETA_JA, "tj_worst": T_AMB + w_worst * LDO_THETA_JA,
                    "amb_limit": TJ_LIMIT - w_worst * LDO_THETA_JA,
                    "amb_max": LDO_TJ_MAX - w_worst * LDO_THETA_JA}
    return out


def budget() -> dict[str, float]:
    """Current from the bus (the regulators pass the 3.3 V current through), typical and worst,
    and the hottest regulator's junction."""
    r = rails()
    typ = sum(x["typ_ma"] for x in r.values())
    worst = sum(x["worst_ma"] for x in r.values())
    return {"leds_ma": leds_ma(), "typ_ma": typ, "worst_ma": worst,
            "tj_typ": max(x["tj_typ"] for x in r.values()),
            "tj_worst": max(x["tj_worst"] for x in r.values())}


def single_ldo() -> dict[str, float]:
    """Revision A as first drawn: one AP2112K-3.3 for the whole board (the figures issue 20 fixed)."""
    b = budget()
    w_typ, w_worst = (V_BUS_MAX - V_3V3) * b["typ_ma"] / 1e3, (V_BUS_MAX - V_3V3) * b["worst_ma"] / 1e3
    return {"w_typ": w_typ, "w_worst": w_worst, "tj_typ": T_AMB + w_typ * LDO_THETA_JA,
            "tj_worst": T_AMB + w_worst * LDO_THETA_JA}


def drive_level(rs_ohm: float | None = None) -> dict[str, float]:
    """What the 25 MHz crystal dissipates: the oscillator's 300 µW drive (Table 5-16), the XTAL2
    swing divided by RS and the XO-side capacitance (C102 and the stray), the power with the
    swing's square. `worst` takes the smallest capacitance (C102 -5 %, the least stray): the
    largest reactance, the least attenuation."""
    rs_ohm = XTAL25_RS_OHM if rs_ohm is None else rs_ohm

    def atten(c_pf: float) -> float:
        xc = 1 / (2 * 3.141592653589793 * XTAL25_F_HZ * c_pf * 1e-12)
        return xc ** 2 / (rs_ohm ** 2 + xc ** 2)
    c_nom = XTAL25_LOAD_PF + core.STRAY_PF
    c_min = XTAL25_LOAD_PF * 0.95 + core.STRAY_RANGE_PF[0]
    return {"no_rs_uw": XTAL25_DRIVE_UW, "c_nom_pf": c_nom, "c_min_pf": c_min,
            "nom_uw": XTAL25_DRIVE_UW * atten(c_nom), "worst_uw": XTAL25_DRIVE_UW * atten(c_min)}


def chain_drop() -> list[tuple[str, float, float, float]]:
    """The worst case's current above a module's 200 mA crosses every hop between the PSU and the
    gateway (worst when the gateway is the last module): docs/bus.md §5.4's two allowed
    configurations, (where, extra drop mV, lowest module V before, after)."""
    extra_a = (budget()["worst_ma"] - MODULE_LIMIT_MA) / 1000
    rows = []
    for n, where, lowest_v in ((10, "PSU in the middle, 10 modules per side", 4.45),
                               (14, "PSU at one end, 14 modules", 4.03)):
        dv_mv = extra_a * (FIRST_HOP_MOHM + (n - 1) * HOP_MOHM)     # A x mohm = mV
        rows.append((where, dv_mv, lowest_v, lowest_v - dv_mv / 1000))
    return rows


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
    b, p, h, r, one, d = budget(), phy_crystal(), hse(), rails(), single_ldo(), drive_level()
    return "\n".join([
        f"bus current: MCU {MCU_TYP_MA:g}/{MCU_MAX_MA:g} + PHY {PHY_TYP_MA:g}/{PHY_MAX_MA:g} + CAN"
        f" {CAN_TYP_MA:g}/{CAN_MAX_MA:g} + LEDs {b['leds_ma']:.1f} + misc {MISC_MA:g} mA"
        f" = {b['typ_ma']:.0f} mA typical, {b['worst_ma']:.0f} mA worst case",
        f"  docs/bus.md §6 allows {MODULE_LIMIT_MA:g} mA: worst case exceeds it by"
        f" {b['worst_ma'] - MODULE_LIMIT_MA:.0f} mA -> stated exception, counted as"
        f" {COUNTED_AS_MA:g} mA in §5 ({COUNTED_AS_MA - b['worst_ma']:.0f} mA margin)",
        *[f"  extra drop with the gateway last ({where}): +{dv:.0f} mV, lowest module {v0:.2f} ->"
          f" {v1:.2f} V ({'>=' if v1 >= 4.0 else '< '} 4.00 V)" for where, dv, v0, v1 in chain_drop()],
        f"LDOs (AP2112K-3.3, {LDO_THETA_JA:g} C/W) at {V_BUS_MAX:g} V in, typical / worst, junction at"
        f" {T_AMB:g} C ambient (limit {TJ_LIMIT:g} C, absolute max {LDO_TJ_MAX:g} C):",
        *[f"  {ref} {'+3V3 (MCU, CAN, LEDs)' if ref == 'U2' else '+3V3_PHY (PHY, MDI, jack)'}:"
          f" {x['typ_ma']:.0f} / {x['worst_ma']:.0f} mA, {x['w_typ']:.2f} / {x['w_worst']:.2f} W,"
          f" junction {x['tj_typ']:.0f} / {x['tj_worst']:.0f} C; worst case reaches {TJ_LIMIT:g} C at"
          f" {x['amb_limit']:.0f} C ambient, {LDO_TJ_MAX:g} C at {x['amb_max']:.0f} C"
          for ref, x in r.items()],
        f"  (one LDO for all, as first drawn: {one['w_typ']:.2f} / {one['w_worst']:.2f} W,"
        f" junction {one['tj_typ']:.0f} / {one['tj_worst']:.0f} C)",
        f"PHY crystal 25 MHz: C = 2 (CL - Cstray) = 2 ({XTAL25_CL_PF:g} - {core.STRAY_PF:g}) pF"
        f" = {p['ideal_pf']:.0f} pF; chosen {XTAL25_LOAD_PF:g} pF C0G: effective CL"
        f" {p['cl_min_pf']:.1f}-{p['cl_max_pf']:.1f} pF",
        f"  drive level: no RS {d['no_rs_uw']:.0f} uW (DS00001989A Table 5-16) > {XTAL25_RATED_UW:g} uW"
        f" rated -> RS {XTAL25_RS_OHM:g} ohm (Figure 5-8: {XTAL25_RS_DATASHEET_OHM:g}) into"
        f" C102 + stray {d['c_nom_pf']:g} pF: {d['nom_uw']:.0f} uW"
        f" ({d['worst_uw']:.0f} uW at {d['c_min_pf']:.2f} pF; measure it)",
        f"HSE 8 MHz on the F407: gm_crit {h['gm_crit_ma_per_v']:.2f} mA/V <"
        f" Gm_crit_max {F407_GM_CRIT_MAX_MA_PER_V:g} mA/V (ratio {h['ratio']:.2f})",
        f"PHY: RBIAS {RBIAS_OHM / 1e3:g} k 1 %, MDI terminations 4 x {MDI_TERM_OHM:g} ohm to +3V3_PHY;"
        f" F407 VCAP_1/VCAP_2 {VCAP_F * 1e6:g} uF",
    ])


BOARD_VALUES = {
    "C101": XTAL25_LOAD_PF * 1e-12, "C102": XTAL25_LOAD_PF * 1e-12,
    "R101": RBIAS_OHM, "R102": MDI_TERM_OHM, "R103": MDI_TERM_OHM, "R104": MDI_TERM_OHM,
    "R105": MDI_TERM_OHM, "C18": VCAP_F, "C20": VCAP_F, "R112": XTAL25_RS_OHM,
    "C6": 100e-9, "C11": 1e-6,                   # VDDA = VREF+ (AN4488: 100 nF + 1 uF)
    "C1": core.LOAD_CAP_PF * 1e-12, "C2": core.LOAD_CAP_PF * 1e-12,
    "R3": core.TERM_R_OHM, "R7": core.TERM_R_OHM, "C12": core.TERM_C_NF * 1e-9,
}


def main() -> int:
    print(report())
    b, p, h, d = budget(), phy_crystal(), hse(), drive_level()
    ok = (b["worst_ma"] <= COUNTED_AS_MA and b["tj_worst"] <= TJ_LIMIT
          and p["cl_min_pf"] < XTAL25_CL_PF < p["cl_max_pf"] and h["ratio"] > 1
          and d["nom_uw"] <= XTAL25_RATED_UW < d["no_rs_uw"])
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
