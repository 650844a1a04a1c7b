"""The common core's design numbers: crystal load capacitors and split termination.

Run `scripts/py -m r2ptools.kicad.calc.core` for them. `BOARD_VALUES` lists the component values
this file assumes (reference → value, SI units); tests/test_hardware.py checks them against every
board's KiCad schematic, the source of the hardware, so calculation and boards cannot drift apart.

Sources: ST AN2867 (oscillator design: load capacitors, gain margin), AN2586 (VDDA decoupling),
YXC X32258MSB4SI (LCSC C2682774 listing: CL, ESR), docs/bus.md §4 (split termination).
"""
from __future__ import annotations

import math
import sys

# crystal and load capacitors (AN2867 §3): C1 = C2 = 2 (CL - Cstray)
CRYSTAL_CL_PF = 20.0          # X32258MSB4SI load capacitance (LCSC C2682774 listing)
CRYSTAL_ESR_MAX_OHM = 120.0   # the same listing's ESR maximum
CRYSTAL_C0_MAX_PF = 3.0       # shunt capacitance: assumed (3225 crystals: 1-3 pF); to confirm
STRAY_PF = 5.0                # OSC_IN/OSC_OUT pin capacitance + 3 mm of trace per side
STRAY_RANGE_PF = (3.0, 7.0)
LOAD_CAP_PF = 30.0            # the E24 value chosen (0603CG300J500NT, C0G 5 %)
HSE_GM_MA_PER_V = 25.0        # STM32F103 datasheet, HSE oscillator transconductance (startup)

# split termination (docs/bus.md §4)
TERM_R_OHM = 60.4
TERM_C_NF = 4.7


def crystal_load() -> dict[str, float]:
    """The load capacitor value from the crystal's CL and the stated stray capacitance, the
    effective CL the chosen value gives over the stray range and 5 % tolerance, and the
    oscillator's gain margin (AN2867: gm / gm_crit >= 5)."""
    ideal = 2 * (CRYSTAL_CL_PF - STRAY_PF)
    lo = LOAD_CAP_PF * 0.95 / 2 + STRAY_RANGE_PF[0]
    hi = LOAD_CAP_PF * 1.05 / 2 + STRAY_RANGE_PF[1]
    w = 2 * math.pi * 8e6
    gm_crit = 4 * CRYSTAL_ESR_MAX_OHM * w ** 2 * ((CRYSTAL_C0_MAX_PF + CRYSTAL_CL_PF) * 1e-12) ** 2
    return {"ideal_pf": ideal, "chosen_pf": LOAD_CAP_PF, "cl_min_pf": lo, "cl_max_pf": hi,
            "gm_crit_ma_per_v": gm_crit * 1e3, "gain_margin": HSE_GM_MA_PER_V / (gm_crit * 1e3)}


def termination() -> dict[str, float]:
    """Split termination: differential resistance and the common-mode filter's corner."""
    return {"differential_ohm": 2 * TERM_R_OHM,
            "common_mode_corner_mhz": 1 / (2 * math.pi * (TERM_R_OHM / 2) * TERM_C_NF * 1e-9) / 1e6}


def report() -> str:
    x, t = crystal_load(), termination()
    return "\n".join([
        f"crystal: C = 2 (CL - Cstray) = 2 ({CRYSTAL_CL_PF:g} - {STRAY_PF:g}) pF = {x['ideal_pf']:.1f} pF;"
        f" chosen {x['chosen_pf']:g} pF C0G 5 %",
        f"  effective CL over Cstray {STRAY_RANGE_PF[0]:g}-{STRAY_RANGE_PF[1]:g} pF and tolerance:"
        f" {x['cl_min_pf']:.1f}-{x['cl_max_pf']:.1f} pF (crystal wants {CRYSTAL_CL_PF:g} pF)",
        f"  gm_crit = 4 ESR (2 pi F)^2 (C0 + CL)^2 = {x['gm_crit_ma_per_v']:.2f} mA/V;"
        f" gain margin {HSE_GM_MA_PER_V:g} / {x['gm_crit_ma_per_v']:.2f} = {x['gain_margin']:.0f}"
        " (AN2867 asks >= 5)",
        f"termination: 2 x {TERM_R_OHM:g} ohm = {t['differential_ohm']:.1f} ohm differential;"
        f" {TERM_C_NF:g} nF common-mode filter corner {t['common_mode_corner_mhz']:.2f} MHz",
        "VDDA: 10 nF + 1 uF (AN2586 §2.1); VDD: 100 nF per pin + 10 uF at the LDO",
    ])



BOARD_VALUES = {
    "C1": LOAD_CAP_PF * 1e-12, "C2": LOAD_CAP_PF * 1e-12,     # crystal load capacitors
    "R3": TERM_R_OHM, "R7": TERM_R_OHM, "C12": TERM_C_NF * 1e-9,   # split termination
    "C6": 10e-9, "C11": 1e-6,                                # VDDA (AN2586 §2.1)
}


def main() -> int:
    print(report())
    x = crystal_load()
    return 0 if x["gain_margin"] >= 5 and x["cl_min_pf"] < CRYSTAL_CL_PF < x["cl_max_pf"] else 1


if __name__ == "__main__":
    sys.exit(main())
