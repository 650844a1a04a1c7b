"""hardware/psu revision B: every design value of the power path, from the datasheets' equations.

Run `scripts/py -m r2ptools.kicad.calc.psu` for the table (value, limit, margin). The component
values this file assumes are listed in `BOARD_VALUES` (reference → value); tests/test_hardware.py
checks them against the board's KiCad schematic (hardware/psu/psu.kicad_sch), so the calculation and the board
cannot drift apart. Datasheet figures carry their source; figures that are estimates say so.

Sources: LM76005 SNVSBK5 (buck), TPS1663 SLVSET9 (eFuse TPS16630), INA293 SBOSA06, SMBJ40A
(BORN/JEDEC SMBJ table), Littelfuse NANO2 452 series (fuse), IPC-2221B table 6-1 (spacing),
docs/bus.md (3.0 A per jack).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

# --- the input range --------------------------------------------------------------------------
CELL_MAX_V = 4.20             # Li-ion, fully charged
CELLS_MAX = 10                # "36 V" 10S pack
CHARGER_TOL = 0.01            # a CC/CV charger's set point, ±1 % (a charger may stay connected)
VIN_MAX = CELL_MAX_V * CELLS_MAX * (1 + CHARGER_TOL)       # 42.42 V
VIN_MIN = 6.0                 # 2S Li-ion at 3.0 V/cell
T_AMB_MIN, T_AMB_MAX = -20.0, 60.0   # operating ambient, °C (charging happens above 0 °C)

# --- LM76005 (SNVSBK5, typical unless noted) --------------------------------------------------
BUCK_VIN_ABS_MAX = 65.0       # §6.1 PVIN/VIN
BUCK_VIN_MAX = 60.0           # §6.3 recommended
BUCK_VFB = 1.006              # §6.5 feedback reference, typ (README errata: source)
BUCK_VFB_RANGE = (0.987, 1.017)         # §6.5 min/max over temperature
BUCK_EN_RISE = 2.1            # §6.5 V_EN-VOUT-H, precision enable (typ): NOT VERIFIED (README)
BUCK_EN_HYS = 0.38            # §6.5 V_EN-VOUT-HYS (typ): NOT VERIFIED
BUCK_EN_READINGS = {          # EN (rising, falling) thresholds: the LM76005's own figure was not
    # found (SNVSBK5A §6.5 unreachable); the design must be safe under both readings
    "A (2.1 V / 1.72 V, this file's)": (BUCK_EN_RISE, BUCK_EN_RISE - BUCK_EN_HYS),
    "B (1.218 V / 0.99 V, LM76002/3 SNVSAK0)": (1.218, 0.99),
}
BUCK_DROPOUT_V = 5.3          # input below which the 5 V output falls out of regulation (estimate)
BUCK_ISS = 2.0e-6             # §6.5 soft-start charging current (typ)
BUCK_FSW, BUCK_FSW_MIN = 400e3, 350e3   # §6.5 RT open: 400 kHz typ, 350 kHz min
BUCK_IOUT_RATED = 5.0
BUCK_ISD = 5e-6               # §6.5 shutdown supply current, EN low (max, rounded up)
STORAGE_PACK_AH = 5.0
BUCK_CBOOT_RECOMMENDED = 0.47e-6        # §7.3.9 / §8.2.2: 0.47 µF from BOOT to SW
BIAS_TO_VOUT = (3.3, 18.0)    # §5 BIAS: tie to VOUT in this output range (else GND)
THETA_JA_BOARD = 35.0         # °C/W: estimate for this 2-layer board with the pad's 0.3 mm vias
                              # (SNVSBK5 §6.4 gives 21 °C/W on the 4-layer JEDEC/EVM board)
EFF_LOW_VIN = 0.85            # assumed worst-case efficiency at full load (5 V out, 6 V in)
EFF_THERMAL = ((6.0, 0.91), (42.4, 0.87))   # estimated efficiency at 3 A for the thermal rows
                              # (SNVSBK5 §8.2.3 curves, 5 V out, 400 kHz, read as about 89-93 %)
T_J_MAX = 125.0

# --- TPS16630 (SLVSET9) -----------------------------------------------------------------------
EFUSE_ILIM_K = 18.0           # §10.2.2.1: I_LIM(A) = 18 / R_ILIM(kΩ)
EFUSE_ILIM_TOL = 0.08         # §7.5 I_OL: 1.84–2.16 A at 9 kΩ (±8 %), 4.185–4.815 A at 4.02 kΩ (±7 %)
EFUSE_VTH = (1.176, 1.200, 1.224)       # §7.5 UVLO and OVP rising thresholds (min, typ, max)
EFUSE_SHDN_SOURCE_MAX = 10e-6           # §7.5 I(SHDN) at 0 V: sources up to 10 µA
EFUSE_SHDN_OFF_MAX = 0.8                # §7.5 V(SHUTF): below this SHDN shuts the part down
EFUSE_SHDN_ON = 2.0                     # §7.5 V(SHUTR) typ
EFUSE_IDVDT, EFUSE_GAIN_DVDT = 2.0e-6, 25.0   # §7.5 dVdT current and gain
EFUSE_ABS_MAX = 67.0                    # §7.1 IN, OUT
EFUSE_RON_MAX = 0.053                   # §7.5 over temperature
BUS_JACK_MAX = 3.0            # docs/bus.md: ≤ 3.0 A out of either jack (both jacks are in parallel)
V_BUS = 5.10                  # bus voltage at the eFuse, for power (FB tolerance included)
BUS_V_BAND = (4.90, 5.10)     # docs/bus.md: 5.00 V ± 2 % at the PSU's output
FB_RES_TOL = 0.001            # R108/R109: YAGEO RT0603BRD 0.1 %, 25 ppm/K thin film
MODULE_5V_A = 0.10            # the PSU's own draw from +5V_BUCK (MCU, CAN, LEDs, LDO), generous

# --- input protection -------------------------------------------------------------------------
TVS_VRWM = 40.0               # SMBJ40A stand-off (leakage ≤ 1 µA)
TVS_VBR_MIN = 44.4            # at 1 mA, 25 °C (JEDEC SMBJ40A; BORN lists 44.4–51.1 V)
TVS_VBR_MAX = 51.1
TVS_VC, TVS_IPP = 64.5, 9.3   # clamp at the rated 10/1000 µs pulse (600 W)
TVS_ALPHA = 0.001             # VBR temperature coefficient, 1/K (SMBJ family, 40 V: ~0.1 %/K)
Q101_VDS = 60.0               # SQD50P06-15L: -60 V
CIN_RATED = 100.0             # CL32B225KCJSNNE and CL10B104KC8NNNC: 100 V
CIN_DC_BIAS_FACTOR = 0.45     # estimate: remaining capacitance of the 100 V 1210 X7R at 42 V
                              # (Samsung curve: -77 % at 80 V; about -55 % at 42 V)
INA293_CM_MAX = 110.0         # SBOSA06 §6.3 common mode
RES_0603_VMAX = 75.0          # UNI-ROYAL 0603WAF: 75 V working voltage
COUT_DC_BIAS_FACTOR = 0.65    # estimate: 25 V 1210 X7R at 5 V keeps about 65 %
L_ISAT, L_DCR = 12.0, 0.024   # SRP1038A-100M: 12 A saturation, 24 mΩ DCR max (Bourns)

# --- fuse (Littelfuse 0452005.MRL) ------------------------------------------------------------
FUSE_RATED = 5.0
FUSE_VRATED = 125.0
FUSE_I2T = 53.7               # nominal melting I²t, A²s (452 series table, 5 A)
FUSE_DERATE = 0.75 * 0.90     # Littelfuse: run at ≤ 75 % of rating; ×0.9 re-rating at 60 °C
FUSE_PULSE_FRACTION = 0.22    # Littelfuse pulse guideline: ≤ 22 % of melting I²t for 100 k pulses
R_HOTPLUG_MIN = 0.05          # Ω: Q101 + shunt + connector + cable + ESR, a low bound

# --- IPC-2221B table 6-1, B2 (external conductors, uncoated, sea level to 3050 m) --------------
IPC2221B_B2 = [(15, 0.1), (30, 0.1), (50, 0.6), (100, 0.6), (150, 0.6), (170, 1.25)]

# --- the values on the board (reference → value, SI units); checked against psu.kicad_sch ------
BOARD_VALUES = {
    "R102": 0.010,            # shunt
    "R104": 150e3, "R105": 10e3,          # VIN_SENSE divider
    "R106": 100e3, "R107": 56e3,          # buck EN/UVLO divider
    "R108": 102e3, "R109": 25.5e3,        # buck FB divider, 0.1 %
    "C110": 22e-9,            # soft start
    "C109": 470e-9,           # bootstrap
    "C116": 1e-6,             # BIAS
    "L101": 10e-6,
    "C101": 2.2e-6, "C102": 2.2e-6, "C103": 100e-9,     # buck input
    "C111": 22e-6, "C112": 22e-6, "C113": 22e-6, "C114": 22e-6,
    "R116": 6.8e3,            # eFuse ILIM
    "R112": 100e3, "R113": 10e3, "R114": 27e3,           # eFuse UVLO/OVP chain
    "R110": 10e3,             # SHDN pull-down
    "C115": 22e-9,            # dV/dt
    "R117": 10e3, "R118": 10e3,           # VOUT_SENSE divider
}
INA_GAIN = 50.0               # INA293A2
ADC_FS = 3.3
BUS_C_LOAD = 200e-6           # estimate: capacitance a full bus hangs on the eFuse at turn-on


@dataclass
class Row:
    what: str
    value: str
    limit: str
    ok: bool
    note: str = ""


def ipc2221b_b2(volts: float) -> float:
    """Minimum spacing (mm) for external uncoated conductors at `volts` peak (table 6-1, B2)."""
    for top, mm in IPC2221B_B2:
        if volts <= top:
            return mm
    raise ValueError(f"{volts} V is above the table rows this board uses")


def vout_band(r_top: float, r_bottom: float, tol: float) -> tuple[float, float]:
    """The buck's output over the reference's min–max and both resistors at their tolerance."""
    return (BUCK_VFB_RANGE[0] * (1 + r_top * (1 - tol) / (r_bottom * (1 + tol))),
            BUCK_VFB_RANGE[1] * (1 + r_top * (1 + tol) / (r_bottom * (1 - tol))))


def rows() -> list[Row]:
    v = BOARD_VALUES
    out: list[Row] = []
    add = out.append

    # --- input protection: the TVS between the charged pack and the buck's absolute maximum
    vbr_0 = TVS_VBR_MIN * (1 + TVS_ALPHA * (0 - 25))
    vbr_cold = TVS_VBR_MIN * (1 + TVS_ALPHA * (T_AMB_MIN - 25))
    vpack = CELL_MAX_V * CELLS_MAX
    add(Row("input range", f"{VIN_MIN:.1f}–{VIN_MAX:.2f} V", "2S–10S Li-ion, charger ±1 %", True,
            f"10S charged {CELL_MAX_V * CELLS_MAX:.1f} V"))
    add(Row("TVS stand-off vs max input", f"{TVS_VRWM:.1f} V", f"≥ {VIN_MAX:.2f} V", False,
            "traded: see the two rows below"))
    add(Row("TVS min breakdown at 0 °C vs charger max", f"{vbr_0:.2f} V", f"> {VIN_MAX:.2f} V",
            vbr_0 > VIN_MAX, f"{vbr_0 - VIN_MAX:+.2f} V; below V_BR the TVS leaks < 1 mA (< 45 mW); "
            "Li-ion is not charged below 0 °C"))
    add(Row(f"TVS min breakdown at {T_AMB_MIN:.0f} °C vs charged pack", f"{vbr_cold:.2f} V",
            f"> {vpack:.2f} V", vbr_cold > vpack, f"{vbr_cold - vpack:+.2f} V"))
    add(Row("TVS clamp at rated pulse vs LM76005 abs max", f"{TVS_VC:.1f} V @ {TVS_IPP} A",
            f"≤ {BUCK_VIN_ABS_MAX:.1f} V", TVS_VC <= BUCK_VIN_ABS_MAX,
            f"{BUCK_VIN_ABS_MAX - TVS_VC:.1f} V margin (SMBJ43A would clamp 69.4 V)"))
    r_dyn = (TVS_VC - TVS_VBR_MAX) / TVS_IPP
    add(Row("TVS clamp at a 2 A hot-plug surge", f"{TVS_VBR_MAX + 2 * r_dyn:.1f} V",
            f"≤ {BUCK_VIN_MAX:.0f} V (recommended)", TVS_VBR_MAX + 2 * r_dyn <= BUCK_VIN_MAX,
            f"dynamic resistance {r_dyn:.2f} Ω"))
    for what, rating in (("input capacitors (100 V X7R)", CIN_RATED), ("INA293 common mode", INA293_CM_MAX),
                         ("eFuse abs max (if the buck's high side shorts)", EFUSE_ABS_MAX)):
        add(Row(f"{what} at the clamp", f"{TVS_VC:.1f} V", f"≤ {rating:.0f} V", TVS_VC <= rating,
                f"{TVS_VC / rating:.0%} of rating"))
    add(Row("Q101 V_DS, battery reversed", f"{VIN_MAX:.1f} V", f"≤ {Q101_VDS:.0f} V",
            VIN_MAX <= 0.8 * Q101_VDS, f"{VIN_MAX / Q101_VDS:.0%} of rating"))
    vdiv_top = TVS_VC - 3.6
    add(Row("VIN divider top (R104) voltage at the clamp", f"{vdiv_top:.1f} V",
            f"≤ {RES_0603_VMAX:.0f} V working", vdiv_top <= RES_0603_VMAX))

    # --- battery voltage sense
    gain = (v["R104"] + v["R105"]) / v["R105"]
    fs = ADC_FS * gain
    add(Row("VIN_SENSE scale", f"×1/{gain:.0f}", f"full scale {fs:.1f} V", fs > VIN_MAX,
            f"{VIN_MAX / gain:.2f} V at {VIN_MAX:.2f} V: {VIN_MAX / fs:.0%} of full scale"))
    inj = (TVS_VC - 3.6) / v["R104"] - 3.6 / v["R105"]
    add(Row("ADC pin injection at the clamp", f"{max(inj, 0) * 1e3:.2f} mA", "≤ 5 mA (STM32F103)",
            inj < 5e-3))

    # --- buck: output, enable, soft start
    vout = BUCK_VFB * (1 + v["R108"] / v["R109"])
    add(Row("VOUT typical = VFB (1 + R108/R109)", f"{vout:.3f} V", "5.0 V ± 2 % (bus)",
            BUS_V_BAND[0] <= vout <= BUS_V_BAND[1], f"reference typ {BUCK_VFB:.3f} V"))
    lo, hi = vout_band(v["R108"], v["R109"], FB_RES_TOL)
    add(Row("VOUT worst case (reference range, resistor tolerance)", f"{lo:.3f}–{hi:.3f} V",
            f"{BUS_V_BAND[0]:.2f}–{BUS_V_BAND[1]:.2f} V (docs/bus.md)",
            BUS_V_BAND[0] <= lo and hi <= BUS_V_BAND[1],
            f"reference {BUCK_VFB_RANGE[0]:.3f}–{BUCK_VFB_RANGE[1]:.3f} V, R108/R109 ±{FB_RES_TOL:.1%}; "
            f"centre {(lo + hi) / 2:.3f} V"))
    en = 1 + v["R106"] / v["R107"]
    vstart, vstop = BUCK_EN_RISE * en, (BUCK_EN_RISE - BUCK_EN_HYS) * en
    # EN thresholds not verified: start/stop under both readings (README errata: measure them)
    efuse_uv_min = EFUSE_VTH[0] * (v["R112"] + v["R113"] + v["R114"]) / (v["R113"] + v["R114"])
    for reading, (rise, fall) in BUCK_EN_READINGS.items():
        start, stop = rise * en, fall * en
        add(Row(f"buck start, EN reading {reading}", f"{start:.2f} V", f"≤ VIN_MIN {VIN_MIN:.1f} V",
                start <= VIN_MIN, "starts from the emptiest 2S pack"))
        below = start < BUCK_DROPOUT_V
        add(Row(f"buck stop, EN reading {reading}", f"{stop:.2f} V ({stop / 2:.2f} V/cell on 2S)",
                f"< dropout ~{BUCK_DROPOUT_V} V and < start", stop < min(BUCK_DROPOUT_V, start),
                ("starts in dropout: +5V_BUCK follows VIN; " if below else "") +
                f"the eFuse's UVLO holds the bus off until +5V_BUCK ≥ {efuse_uv_min:.2f} V; below "
                "VIN_MIN the firmware's UNDER_VOLTAGE (6.0 V) flags the pack"))
    add(Row("EN pin at max input", f"{VIN_MAX / en:.1f} V", "≤ VIN (EN is VIN-rated)", True))
    tss = v["C110"] * BUCK_VFB / BUCK_ISS
    add(Row("soft start t = C_SS V_FB / I_SS", f"{tss * 1e3:.1f} ms", "≥ 2 ms", tss >= 2e-3))
    add(Row("BIAS", "to +5V_BUCK, 1 µF", f"VOUT in {BIAS_TO_VOUT[0]}–{BIAS_TO_VOUT[1]} V",
            BIAS_TO_VOUT[0] <= vout <= BIAS_TO_VOUT[1]))
    add(Row("bootstrap capacitor", f"{v['C109'] * 1e9:.0f} nF 25 V", "0.47 µF recommended",
            math.isclose(v["C109"], BUCK_CBOOT_RECOMMENDED)))

    # --- currents
    ilim_nom = EFUSE_ILIM_K / (v["R116"] / 1e3)
    ilim_min = EFUSE_ILIM_K / (v["R116"] * 1.01 / 1e3) * (1 - EFUSE_ILIM_TOL)
    ilim_max = EFUSE_ILIM_K / (v["R116"] * 0.99 / 1e3) * (1 + EFUSE_ILIM_TOL)
    add(Row("eFuse limit 18/R_ILIM", f"{ilim_min:.2f}–{ilim_nom:.2f}–{ilim_max:.2f} A",
            f"max ≤ {BUS_JACK_MAX:.1f} A (either jack)", ilim_max <= BUS_JACK_MAX,
            f"{BUS_JACK_MAX - ilim_max:.2f} A margin; rated bus output {math.floor(ilim_min * 10) / 10:.1f} A"))
    iout = ilim_max + MODULE_5V_A
    pout = V_BUS * iout
    add(Row("buck output, worst case", f"{iout:.2f} A, {pout:.1f} W", f"≤ {BUCK_IOUT_RATED:.0f} A",
            iout <= BUCK_IOUT_RATED))
    iin_reg = pout / (EFF_LOW_VIN * VIN_MIN)
    iin_drop = iout / 0.95          # below ~5.3 V in: dropout, input current ≈ output current
    iin_max = max(iin_reg, iin_drop)
    add(Row("max input current", f"{iin_max:.2f} A", f"at {VIN_MIN:.0f} V, η {EFF_LOW_VIN:.0%}; "
            "or in dropout", True))
    fuse_ok = iin_max <= FUSE_RATED * FUSE_DERATE
    add(Row("fuse F101 5 A T (0452005.MRL)", f"{iin_max:.2f} A continuous",
            f"≤ {FUSE_RATED * FUSE_DERATE:.2f} A (75 %, 60 °C)", fuse_ok,
            f"{FUSE_VRATED:.0f} V DC rating vs {VIN_MAX:.1f} V"))
    c_in = (v["C101"] + v["C102"]) * CIN_DC_BIAS_FACTOR + v["C103"]
    i2t = c_in * VIN_MAX ** 2 / (2 * R_HOTPLUG_MIN)
    add(Row("hot-plug inrush I²t into C_in", f"{i2t:.3f} A²s",
            f"≤ {FUSE_I2T * FUSE_PULSE_FRACTION:.1f} A²s (22 % of melting)",
            i2t <= FUSE_I2T * FUSE_PULSE_FRACTION, f"C_in {c_in * 1e6:.2f} µF at {VIN_MAX:.0f} V"))
    add(Row("shunt R102 dissipation", f"{iin_max ** 2 * v['R102'] * 1e3:.0f} mW", "≤ 500 mW (1206)",
            iin_max ** 2 * v["R102"] <= 0.25))
    vps = v["R102"] * INA_GAIN
    add(Row("IIN_SENSE scale", f"{vps:.2f} V/A", f"full scale {ADC_FS / vps:.1f} A",
            ADC_FS / vps > iin_max * 1.5, f"{iin_max * vps:.2f} V at {iin_max:.2f} A"))

    # --- inductor, output and input capacitors at the new maximum input
    d = 5.0 / VIN_MAX
    di = (VIN_MAX - 5.0) * d / (BUCK_FSW_MIN * v["L101"])
    ipk = iout + di / 2
    add(Row("inductor ripple at max input, f min", f"{di:.2f} A p-p", "20–45 % of 3 A",
            0.2 * 3 <= di <= 0.45 * 3, f"{di / iout:.0%} of {iout:.2f} A"))
    add(Row("inductor peak", f"{ipk:.2f} A", f"< I_sat {L_ISAT:.0f} A", ipk < L_ISAT))
    cout = sum(v[f"C11{i}"] for i in range(1, 5)) * COUT_DC_BIAS_FACTOR
    dv = di / (8 * BUCK_FSW_MIN * cout)
    add(Row("output capacitance at 5 V DC bias", f"{cout * 1e6:.0f} µF", "≥ 40 µF", cout >= 40e-6,
            f"ripple ΔI/(8 f C) = {dv * 1e3:.1f} mV p-p"))
    i_rated = math.floor(ilim_min * 10) / 10 + MODULE_5V_A
    i_rms = iout / 2
    dvin = i_rated * 0.25 / (BUCK_FSW_MIN * c_in)
    add(Row(f"input ripple at duty 0.5, {i_rated:.1f} A rated", f"{dvin:.2f} V p-p, {i_rms:.2f} A rms",
            "≤ 1 V; ≤ 2 A rms per 1210", dvin <= 1.0 and i_rms / 2 <= 2.0,
            f"C_in effective {c_in * 1e6:.2f} µF"))

    # --- thermal (estimates)
    for vin, eff in EFF_THERMAL:
        p_loss = pout * (1 / eff - 1) - iout ** 2 * L_DCR
        rise = p_loss * THETA_JA_BOARD
        add(Row(f"U102 rise at {vin:.0f} V, {iout:.1f} A (estimate)", f"{p_loss:.2f} W → +{rise:.0f} °C",
                "full load up to ≥ 40 °C ambient", T_J_MAX - rise >= 40,
                f"T_J 125 °C reached at {T_J_MAX - rise:.0f} °C ambient; θ_JA {THETA_JA_BOARD:.0f} °C/W"))
    p_efuse = ilim_max ** 2 * EFUSE_RON_MAX
    add(Row("U103 dissipation at the limit", f"{p_efuse:.2f} W", "≤ 1 W (HTSSOP pad)", p_efuse <= 1))

    # --- eFuse set-up
    chain = v["R112"] + v["R113"] + v["R114"]
    uv = EFUSE_VTH[1] * chain / (v["R113"] + v["R114"])
    ov_lo, ov_hi = EFUSE_VTH[0] * chain / v["R114"], EFUSE_VTH[2] * chain / v["R114"]
    add(Row("eFuse UVLO on +5V_BUCK", f"{uv:.2f} V", "< 4.75 V", uv < 4.75))
    add(Row("eFuse OVP on +5V_BUCK", f"{ov_lo:.2f}–{ov_hi:.2f} V", "> 5.25 V, < 6.5 V (LDO abs max)",
            ov_lo > 5.25 and ov_hi < 6.5))
    v_shdn_off = EFUSE_SHDN_SOURCE_MAX * v["R110"]
    add(Row("SHDN held off by R110 (10 µA source)", f"{v_shdn_off:.2f} V", f"< {EFUSE_SHDN_OFF_MAX} V",
            v_shdn_off < EFUSE_SHDN_OFF_MAX, "MCU pin floating (reset): bus stays off"))
    add(Row("SHDN driven by BUS_EN", "3.3 V", f"> {EFUSE_SHDN_ON} V, ≤ 5.5 V", True))
    slew = EFUSE_IDVDT * EFUSE_GAIN_DVDT / v["C115"]
    add(Row("bus turn-on slew", f"{slew / 1e3:.2f} V/ms", f"inrush {BUS_C_LOAD * slew:.2f} A "
            f"into {BUS_C_LOAD * 1e6:.0f} µF", BUS_C_LOAD * slew < ilim_min))

    # --- no power switch: what a switch on EN would leave drawn from the pack
    i_div = VIN_MAX / (v["R104"] + v["R105"]) + VIN_MAX / (v["R106"] + v["R107"])
    i_gate = (VIN_MAX - 15.0) / 100e3
    i_off = i_div + i_gate + BUCK_ISD
    add(Row("pack drain with the buck off (an EN switch)", f"{i_off * 1e3:.2f} mA",
            "not a storage disconnect", True,
            f"{STORAGE_PACK_AH / i_off / 24:.0f} days to empty a {STORAGE_PACK_AH:.0f} Ah pack: "
            "unplug the XT30"))

    # --- clearance rule (IPC-2221B B2) for the battery-side nets
    add(Row("battery-side spacing (IPC-2221B B2)", f"{ipc2221b_b2(TVS_VC):.1f} mm",
            f"nets up to {TVS_VC:.1f} V (31–100 V row)", True, "psu.kicad_dru rule 'ipc2221b'"))
    return out


def main() -> int:
    rs = rows()
    w = max(len(r.what) for r in rs)
    wv = max(len(r.value) for r in rs)
    wl = max(len(r.limit) for r in rs)
    print(f"hardware/psu revision B design values (r2ptools/kicad/calc/psu.py)\n")
    for r in rs:
        print(f"{'ok ' if r.ok else 'TRADE' if 'traded' in r.note else 'FAIL'}  {r.what:<{w}}  "
              f"{r.value:<{wv}}  {r.limit:<{wl}}  {r.note}")
    return 0 if all(r.ok or "traded" in r.note for r in rs) else 1


if __name__ == "__main__":
    raise SystemExit(main())
