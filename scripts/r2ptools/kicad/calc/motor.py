"""hardware/motor revision A: the power stage of the DC motor module, from the datasheets' equations.

Run `scripts/py -m r2ptools.kicad.calc.motor` for the table (value, limit, margin) and the list of
firmware constants the board disagrees with. There is no schematic yet: the component values are
in `DESIGN_VALUES`, keyed by their role; when hardware/motor/motor.kicad_sch exists they become
reference designators and tests/test_hardware.py checks them against it, as for the PSU.

Datasheet figures carry their source. A figure this file could not confirm from the datasheet
says NOT VERIFIED (and where it came from); estimates (thermal coefficients, board convection,
the MOSFET's recovery charge) say so: they are what the first board must measure.

Sources: TI CSD19536KTT SLPS540C (MOSFET; electrical characteristics read on ti.com), Renesas
HIP4082 FN3676 (gate driver: Rev 5.00's Absolute Maximum Ratings, Thermal Information, Operating
Conditions and Electrical Specifications read; the pin table is KiCad 9's Driver_FET:HIP4082xB
symbol),
NXP/Nexperia BCP56_BCX56_BC56PA Rev. 9 (Q106: Table 2 V_CEO, Table 3 SOT89 pinning 1 E 2 C 3 B,
Table 8 h_FE), TI LMV331 (over-current comparators: summary, NOT VERIFIED), Allegro ACS725 ACS725-DS Rev. 8
(sensitivity, errors, supply current, 1.2 mΩ, 120 kHz read),
TI TLV3011 SBOS300C (comparator with 1.242 V reference), Littelfuse SMCJ series (TVS), Littelfuse 456
Series (F102: Electrical Specifications, 30 A row, read), Amass XT60
(30 A), IPC-2221B §6.2 (conductor sizing equation), docs/bus.md §6 (200 mA per module, ground),
firmware/targets/f103/motor/src/bridge.rs (PWM, dead time, sign-magnitude drive),
firmware/apps/motor/src/frontend.rs and firmware/host/world/src/hbridge.rs (ADC, current scaling).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from . import heatsink

# --- what the module is for --------------------------------------------------------------------
VIN_NOM = 36.0                # the paper: "DC motors up to 36 V"
LIION_MAX = 4.20 * 10 * 1.01  # 10S Li-ion on a charger at +1 % (as calc/psu.py): 42.42 V
LEAD_ACID_MAX = 3 * 14.7      # 3 × 12 V lead-acid at absorption charge (14.7 V per block, cold)
VIN_MAX = max(LIION_MAX, LEAD_ACID_MAX)                  # 44.1 V: highest steady input
VIN_MIN = 15.0                # below: the HIP4082's VDD (from VMOT through Q106) falls under its
                              # 8.5 V recommended minimum (row "driver VDD at the minimum input");
                              # 12 V until Q106's h_FE was read (63, not 100, at ~10 mA), 13 V
                              # until the HIP4082's own currents were read (FN3676, below)
I_CONT = 20.0                 # the paper: "a continuous 20 A current"
I_PEAK = 23.0                 # peak: below the hardware over-current trip's lowest point (a cold
                              # sensor) less the ripple (below)
SENSE_RANGE_REQUIRED = 30.0   # issue 19: current sensor range ≥ ±30 A
PEAK_S = 10.0                 # how long the peak may last (heatsink heat capacity, below)
T_AMB = 40.0                  # issue 19: junction limit checked at 40 °C ambient
TJ_LIMIT = 110.0              # issue 19: junction ≤ 110 °C at 20 A (the KTT family's T_J max is 175 °C)
MOTOR_V_RATED = 36.0          # largest motor rating the module is for: back-EMF ≤ this at ≤ no-load speed
MOTOR_L = 0.2e-3              # armature inductance, H (assumption: 70 W brushed motors are 0.1–0.3 mH)

# --- firmware (targets/f103/motor/src/bridge.rs, host/world/src/hbridge.rs, apps/motor frontend.rs)
PWM_HZ = 20_000.0             # TIM1 PWM frequency (above hearing), centre-aligned
DEAD_TIME_S = 100e-9          # TIM1 dead time at each edge: a guard under the HIP4082's own DEL
                              # delay, which sets the dead time the FETs see (DRV_DEL_S)
ADC_FS = 3.3                  # VDDA = VREF+ = the 3.3 V rail
ADC_COUNTS = 4096
# The drive (firmware/targets/f103/motor/src/bridge.rs): sign-magnitude, centre-aligned. For a
# positive duty leg A switches at d and leg B's low side stays on (the reverse for a negative
# one); the current recirculates through the low sides between pulses. So one leg switches, the
# supply sees one pulse of height I and width d per period (input ripple I √(d(1 − d)) at the
# PWM frequency), and one low side carries I all the time. (Locked anti-phase, which the world
# model also offers, switches both legs: twice the switching loss, ripple at 2 f.)
SWITCHING_LEGS = 1
RIPPLE_HZ = PWM_HZ

# --- MOSFETs: TI CSD19536KTT, 100 V N-channel, D2PAK (SLPS540C) --------------------------------
FET = "CSD19536KTT"
FET_VDS = 100.0               # BV_DSS min (§4.1, read)
FET_RDS_TYP = 2.0e-3          # V_GS = 10 V, I_D = 100 A, 25 °C, typ (§4.1, read)
FET_RDS_MAX = 2.4e-3          # the same, max (§4.1, read)
FET_RDS_TC = 0.007            # 1/K: normalised R_DS(on) 1.7 at 125 °C (TI NexFET curves): estimate
FET_QG, FET_QGD, FET_QGS = 118e-9, 17e-9, 37e-9         # at 10 V, V_DS 50 V, typ (§4.1, read);
                              # Q_gs2 (plateau part of Q_gs) taken as half of Q_gs
FET_QRR = 548e-9              # body diode Q_rr typ at V_DS 50 V, I_F 100 A, 300 A/µs (SLPS540B
                              # §5.1, the revision read): at this board's 20 A it is lower, so high
FET_VSD = 0.9                 # body diode at 20 A, hot: estimate
FET_RTH_JC = 0.4              # °C/W max (SLPS540B §5.2 Thermal Information)
FET_ID_PULSE = 400.0          # I_DM, abs max, pulse ≤ 100 µs (SLPS540B Absolute Maximum Ratings)

# --- gate driver: Renesas HIP4082 (FN3676): four independent inputs, bootstrap high sides ------
DRV = "HIP4082IBZT"
DRV_VHS_ABS = 80.0            # V: "operation up to 80 V" (AHS/BHS), FN3676 front page (read)
DRV_VHB_ABS = 95.0            # V: "bootstrap supply max voltage to 95 VDC" (read)
DRV_I_PEAK = 1.25             # A: peak output current (the title, read); source and sink taken alike
DRV_DEAD_RANGE = (0.1e-6, 4.5e-6)   # s: programmable dead time by R_DEL (read)
DRV_DEL_S = (0.2e-6, 0.85e-6) # s: the turn-on delay T_DEAD with R105 = 10 kΩ, -55 to 150 °C (FN3676
                              # Rev 5.00, Switching Specifications); it adds to TIM1's
DRV_DEL_25C = (0.27e-6, 0.75e-6)  # s: the same at 25 °C; the world model takes the middle
DRV_VDD_RANGE = (8.5, 15.0)   # V: supply voltage VDD (FN3676 Rev 5.00, Operating Conditions)
DRV_VDD_UV = 8.5              # V: VDD rising under-voltage threshold V_DDUV+, max over T_J -55 to
                              # 150 °C (Electrical Specifications; 7.6 typ, 8.25 max at 25 °C)
DRV_IDD = 6.4e-3              # A: VDD operating current I_DDO, max at 25 °C, 50 kHz, no load,
                              # R_DEL = 10 k (Electrical Specifications; 4.0 typ, 6.6 max over T_J);
                              # at 20 kHz it lies between this and the quiescent 5.5 mA max
DRV_IHB = 1.5e-3              # A: each bootstrap (xHB) supply while its high side is off, I_AHBL
                              # max at 25 °C (1.0 typ): drawn from VDD through the bootstrap diode
DRV_IHB_ON = 0.24e-3          # A: the same while the high side is on, I_AHBH max at 25 °C (0.145
                              # typ): what discharges C_BS over an on-time
DRV_RTH_JA = 115.0            # °C/W, SOIC (FN3676 Rev 5.00, Thermal Information)
DRV_PROP = 0.1e-6             # s: upper turn-off propagation delay T_HPHL, max over T_J -55 to 150 °C
                              # (Switching Specifications; 55 typ, 80 max at 25 °C)
FET_VPLATEAU = 4.5            # V: CSD19536KTT Miller plateau at 20 A: estimate (from V_th and g_fs)
FET_RG_INT = 1.4              # Ω: CSD19536KTT series gate resistance R_G, typ (SLPS540B §5.1; 2.8 max)
BOOT_DIODE_VF = 0.9           # V: 1N4148W at the refresh current (its 1 V at 50 mA ... 1.25 V at 150 mA)
BOOT_DIODE_R = 3.0            # Ω: the refresh loop (diode's dynamic resistance, tracks): estimate
BOOT_DROOP_MAX = 1.0          # V: allowed gate-supply droop over one on-time (gate ≥ 10 V at 12 V VDD)
C_BS_DC_BIAS = 0.6            # 470 nF 25 V X7R 0603 at ~12 V keeps ~60 %: estimate
# VDD regulator: Q106 BCX56-16 (80 V NPN, SOT-89) emitter follower on D105 (BZT52C13), R120 feeds both
ZENER_V = (12.4, 13.0, 14.1)  # BZT52C13 V_Z (min, typ, max): NOT VERIFIED (the series' usual spread)
VBE = (0.60, 0.65, 0.75)      # V: Q106's base-emitter voltage at ~10 mA (min, typ, max): estimate
Q106_HFE_MIN = 63.0           # BCX56 h_FE min at V_CE 2 V, I_C 5 mA (NXP BCP56_BCX56_BC56PA Rev. 9,
                              # Table 8; the -16 selection's 100-250 is stated at 150 mA only)
Q106_RTH_JA = 150.0           # °C/W, SOT-89 on a small collector pad: NOT VERIFIED (estimate)
Q106_VCEO = 80.0              # V: BCX56 V_CEO, open base (NXP BCP56_BCX56_BC56PA Rev. 9, Table 2)
T_CORE_BAND = 60.0            # °C: board temperature at the core band at 20 A, 40 °C ambient: estimate
# over-current: U105/U106 LMV331 on the ACS725's output, window from +3V3 (ratiometric like it)
OC_SENS_TOL = 0.055           # ACS725-30AB sensitivity error over -40 to 150 °C: ±5.5 % from -40 to 25 °C
                              # (±1.5 % from 25 to 150 °C), ACS725-DS Rev. 8, xLLCTR-30AB performance
                              # characteristics: the trip must hold for a cold sensor too
OC_OFFSET_V = 0.030           # its offset voltage V_OE over -40 to 150 °C (the same table; ±10 mV warm)
CMP_VOS = 0.007               # LMV331 input offset, max: NOT VERIFIED
CMP_TPD = 0.5e-6              # LMV331 propagation delay: twice the 260 ns typical a summary gives; the
                              # datasheet's maximum at this overdrive NOT VERIFIED
HALL_T_RESPONSE = 4e-6        # ACS725 response time t_RESPONSE, typ, C_L 1 nF (ACS725-DS Rev. 8)
TIM1_BREAK_S = 0.1e-6         # TIM1 break input to outputs inactive (a few 72 MHz clocks, no filter)
L_SHORT = 0.5e-6              # H: a short across the motor leads at the end of ~1 m of cable: estimate
# The comparators' input filter and hysteresis: NOT ON THE REVISION A BOARD (its U105/U106 take
# HALL_OUT directly, and nothing feeds DRV_FAULT back); these are revision B's parts, sized here
# from values already on the board's BOM (no new LCSC line): the 1 k of R107/R118, the 100 pF
# C0G of C124, the 174 k of R110.
OC_FILTER_R = 1e3             # Ω, HALL_OUT → the comparators' inputs (the ADC keeps R107/C120)
OC_FILTER_C = 100e-12         # F, C0G, at the comparators' inputs to GND
OC_HYST_R = 174e3             # Ω, DRV_FAULT → OC_HI (U105's IN+): positive feedback on the high trip
RING_HZ = 30e6                # Hz: switch-node ringing picked up by the comparator inputs: estimate


def vdd(vin: float, load: float, worst: str = "min") -> float:
    """The driver's VDD from Q106 at supply `vin` and VDD load `load` A: the zener's voltage less
    V_BE while R120 carries the zener's and the base's current, else VMOT less R120's drop."""
    i = {"min": 0, "typ": 1, "max": 2}[worst]
    r = DESIGN_VALUES["R_VDD_BIAS"]
    i_b = load / Q106_HFE_MIN
    starved = vin - i_b * r - VBE[2 - i]
    return min(ZENER_V[i] - VBE[2 - i], starved)


def vdd_load() -> float:
    """What VDD supplies: the driver's own current, both bootstrap currents, and the gate charge of
    the switching leg's two FETs each period (sign-magnitude: one leg switches)."""
    return DRV_IDD + 2 * DRV_IHB + 2 * SWITCHING_LEGS * FET_QG * PWM_HZ


def gate_currents(v_drive: float) -> tuple[float, float]:
    """Turn-on and turn-off currents through the plateau: the driver's 1.25 A into a short taken as
    an output resistance V/I_peak, in series with the 10 Ω gate resistor and the FET's own."""
    r = v_drive / DRV_I_PEAK + DESIGN_VALUES["R_GATE"] + FET_RG_INT
    return (v_drive - FET_VPLATEAU) / r, FET_VPLATEAU / r


def high_side_drive() -> float:
    """The high side's gate supply: VDD (typical) less the bootstrap diode."""
    return vdd(VIN_NOM, vdd_load(), "typ") - BOOT_DIODE_VF


# --- current sensor: Allegro ACS725LLCTR-30AB-T, 3.3 V, ratiometric ------------------------------
HALL = "ACS725LLCTR-30AB-T"
HALL_RANGE = 30.0             # ± A, optimised range
HALL_MV_PER_A = 44.0          # at VCC = 3.3 V (ACS725-DS Rev. 8, selection guide and xLLCTR-30AB table)
HALL_BW_HZ = 120e3            # read (ACS725 features)
HALL_R = 1.2e-3               # primary conductor resistance, read
HALL_ICC_MAX = 14e-3          # ACS725-DS Rev. 8, common electrical characteristics (10 mA typ)
HALL_SWING = (0.3, 3.0)       # output range at 3.3 V: V_OL 0.3 V and V_OH V_CC - 0.3 V typ at its 4.7 kΩ
                              # minimum load (ACS725-DS Rev. 8); this board's load is lighter, so wider

# --- input protection ------------------------------------------------------------------------
TVS = "SMCJ45A"               # the JEDEC type whose figures follow, 1500 W (10/1000 µs)
TVS_MPN = "SMCJ45A-E3/57T"    # the part ordered (Vishay, C1973367)
TVS_VRWM, TVS_VBR_MIN, TVS_VBR_MAX = 45.0, 50.0, 55.3
TVS_VC, TVS_IPP = 72.7, 20.6  # clamp at the rated pulse; these four from the JEDEC SMCJ table as
                              # remembered: NOT VERIFIED (no SMCJ datasheet was read)
TVS_ALPHA = 0.001             # V_BR temperature coefficient, 1/K (as calc/psu.py)
TVS_E_PULSE = 1500 * 1.4e-3   # J: 10/1000 µs pulse energy ≈ P_pk × 1.4 ms
T_COLD = -20.0
OV_REF = (1.230, 1.242, 1.254)   # TLV3011 reference (min, typ, max): ±1 % NOT VERIFIED
RES_TOL = 0.01
RES_0603_VMAX = 75.0          # UNI-ROYAL 0603WAF working voltage (bom/parts.csv, as calc/psu.py)
LOOP_L = 10e-9                # commutation loop inductance, H: layout target (ceramics at the legs)

# --- input capacitors --------------------------------------------------------------------------
ELCAP = "Panasonic EEU-FS1J102, 63 V 1000 µF 16 × 25 mm, 105 °C"
ELCAP_V, ELCAP_SURGE = 63.0, 79.0       # rated / surge (IEC 60384-4: 1.25 × for ≤ 315 V)
# LCSC's fields for C407979 (JLC catalogue snapshot 2026-05-21, hardware/motor/parts-2026-11-28.md);
# Panasonic's FS-series table NOT VERIFIED (read it, and its impedance, before ordering)
ELCAP_RIPPLE = 2.988          # A rms at 100 kHz, 105 °C
ELCAP_FREQ_K = 0.95           # ripple multiplier at 40 kHz vs 100 kHz (typical tables): estimate
ELCAP_ESR = 0.024             # Ω at 100 kHz, 20 °C
ELCAP_LIFE_H = 10000.0        # at 105 °C and rated ripple
ELCAP_T_LOCAL = 65.0          # °C: board temperature at the capacitors at 20 A, 40 °C (estimate)
ELCAP_RIPPLE_RISE = 5.0       # °C core rise at rated ripple (usual maker rule)
CER = "CL32B225KCJSNNE"       # 2.2 µF 100 V X7R 1210 (Samsung, LCSC C55151, the PSU's)
CER_DC_BIAS = 0.45            # remaining capacitance at ~44 V (as calc/psu.py at 42 V): estimate
CER_ESR = 0.005
CER_RIPPLE = 2.0              # A rms per 1210 (self-heating ~15 °C, maker curves): estimate
LIFE_REQUIRED_H = 20_000.0    # at the worst continuous point (20 A, d = 0.5, 40 °C)

# --- fuse --------------------------------------------------------------------------------------
FUSE = "Littelfuse 0456030.ER (NANO2 456, 30 A)"
# Littelfuse 456 Series datasheet (Revised 12/14/17), Electrical Specifications, the 30 A row
FUSE_RATED = 30.0
FUSE_VDC = 72.0               # the highest DC voltage with an interrupting rating: 500 A at 72 VDC
FUSE_R = 1.32e-3              # nominal cold resistance
FUSE_I2T = 81.0               # nominal melting I²t, A²s (at 1 ms opening time)
FUSE_DERATE = 0.75 * 0.90     # Littelfuse: ≤ 75 % of rating; ×0.9 at 60 °C (as calc/psu.py)
FUSE_PULSE_FRACTION = 0.22
R_HOTPLUG = 0.05              # Ω: cable, connector, ESR: a low bound (as calc/psu.py)

# --- copper, thermal ---------------------------------------------------------------------------
BOARD_MM = (164.0, 50.0)      # the 60 × 50 mm outline extended by two 52 mm hole pitches (hardware/motor/motor.py SIZE)
CU_OUTER_UM, CU_INNER_UM = 70.0, 70.0   # 4-layer, 2 oz outer AND 2 oz inner: the In1/In2 planes
                              # carry the motor current (below); JLC's 1 oz inner would leave them short
CU_K = 390.0                  # W/(m·K)
H_CONV = 12.0                 # W/(m²·K): natural convection + radiation, horizontal board: estimate
VIA_DRILL, VIA_PLATING, BOARD_T = 0.3e-3, 25e-6, 1.6e-3
VIAS_PER_FET = 40             # thermal vias under each D2PAK tab (8 × 5 at 1.2 mm pitch)
PAD_K = 7.0                   # W/(m·K), the insulating pad under each tab: a requirement (the
                              # candidate, Honeywell TGP 8000PT, is 8.0 by CAPLINQ's text: NOT VERIFIED)
# The heat path under the tabs is the case's (enclosures/motor/motor.json `heat_path`, made by
# scripts/enclosures from the board: r2ptools/enclosure/heatpath.py): the pad's compressed
# thickness, the islands' and blocks' sizes come from there, never typed here.
# The pad pushes the board up between its standoffs; a firm pad bows it (and strains the tabs'
# joints) instead of being compressed. Requirement on the pad, like PAD_K: its pressure at the
# stack's most compression. The candidate is a putty pad, Shore 00 5 and "low stress" by
# CAPLINQ's listing, which flows rather than springs back; its compression-pressure chart is not
# read (NOT VERIFIED).
PAD_PRESSURE_MAX = 15e3       # Pa at the top of the compression range
BOW_LIMIT = 0.1e-3            # m: a third of the stack's ± 0.3 mm, so the pad stays in its window
FR4_E = 20e9                  # Pa, FR-4's flexural modulus (as remembered, NOT VERIFIED); copper
                              # ignored and the standoffs taken as simple supports: both make the
                              # board softer than it is, so the bow is an upper bound
BLOCK_K = heatsink.AL_K       # W/(m·K), the EN AW-6060 blocks: ~200 (as remembered, NOT VERIFIED)
GREASE_K = 1.0                # W/(m·K), block to sink: ARCTIC's "non-electrically conductive thermal
                              # paste offers 1 to 4 W/mK" (arctic.de, thermal interface page): the low end
GREASE_T = 50e-6              # m, its bond line: grease fills gaps under 0.05 mm (Assmann WSW's TIM
                              # tutorial on Digi-Key): the thickest of that, an estimate
HEATSINK_RTH = 2.0            # °C/W, sink to air at the board's ~10 W: the requirement a bought sink
                              # MUST meet; calc/heatsink.py models the smallest extrusion that meets
                              # it with a margin, and the junction row below runs on that model
HEATSINK_J_PER_K = 90.0       # ~100 g of aluminium (0.9 J/(g·K)): the 10 s peak's heat capacity
XT60_R = 0.5e-3               # Ω per contact pair: NOT VERIFIED (Amass lists ≤ 0.5 mΩ)
XT60_RATED = 30.0             # A continuous (Amass)
# High-current copper AS DRAWN in hardware/motor/motor.py (power_tracks, power_zones, power_vias,
# planes): each path is a chain of segments, each segment a set of conductors in parallel, each
# conductor a series of pieces (a layer reached through vias is limited by the vias). A piece is
# ("F.Cu"/"B.Cu", width mm) on an outer layer, ("In1.Cu"/"In2.Cu", width mm) on an inner one,
# or ("vias", count) of the board's 0.3 mm vias. Widths are the narrowest cross-section.
Piece = tuple[str, float]
PATHS: tuple[tuple[str, float, tuple[tuple[str, float, tuple[tuple[Piece, ...], ...]], ...]], ...] = (
    ("VMOT", I_CONT, (
        ("XT60 + → fuse", 25.0, ((("F.Cu", 6.0),), (("B.Cu", 6.0), ("vias", 6)))),
        ("fuse → bulk", 15.0, ((("F.Cu", 6.0),), (("B.Cu", 6.0), ("vias", 6)))),
        # In2.Cu VMOT plane, narrowest between the x = 108 mm holes and the GND via antipads
        ("bulk → legs: In2.Cu plane", 45.0, ((("In2.Cu", 33.0),),)),
        ("In2.Cu → high-side tab", 1.6, ((("vias", 48),),)),
    )),
    ("GND", I_CONT, (
        # each low side's source lead onto the In1 plane through a 4 × 4 via field (and F.Cu pour)
        ("low-side source → In1.Cu", 4.0, ((("vias", 16),),)),
        ("legs → bulk → XT60 −: In1.Cu plane", 90.0, ((("In1.Cu", 33.0),),)),
    )),
    ("motor A", I_CONT, (
        # high side's source lead onto the low side's tab: pours on F.Cu and B.Cu, 15 vias
        ("high side's source → phase node", 6.0, ((("F.Cu", 4.4),), (("B.Cu", 4.4), ("vias", 15)))),
        # SW_A pours on F.Cu and B.Cu from Q102's tab to U102's IP+ leads, 15 vias between them
        ("phase node → ACS725 IP+", 7.0, ((("F.Cu", 4.2),), (("B.Cu", 4.2), ("vias", 15)))),
        # MOT_A pours on both layers from the IP− leads into the XT60's pin, 12 vias
        ("ACS725 IP− → XT60", 7.0, ((("F.Cu", 4.8),), (("B.Cu", 4.8), ("vias", 12)))),
    )),
    ("motor B", I_CONT, (
        ("high side's source → phase node", 6.0, ((("F.Cu", 4.4),), (("B.Cu", 4.4), ("vias", 15)))),
        ("leg B → XT60", 8.0, ((("F.Cu", 5.0),), (("B.Cu", 5.0),))),
    )),
)
ACS725_NECK_MM = (2.3, 1.2)   # the sensor's IP+/IP− lead rows: 2.3 mm of F.Cu for ~1.2 mm, no room for more
PATH_RISE = 10.0              # °C allowed per path above the board (it is already warm)

# --- sensing and logic -------------------------------------------------------------------------
DESIGN_VALUES = {
    "R_VMOT_TOP": 150e3, "R_VMOT_BOT": 10e3,           # VMOT_SENSE divider: the PSU's VIN_SENSE parts
    "R_OV_TOP": 375e3, "R_OV_BOT": 10e3,               # over-voltage divider: 174k + 174k + 27k in series
    "C_BULK_EACH": 1000e-6, "N_BULK": 4,
    "C_CER_EACH": 2.2e-6, "N_CER": 8,
    "C_BS": 470e-9, "C_VDD": 10e-6,                     # bootstrap capacitors, VDD reservoir
    "R_GATE": 10.0, "R_DEL": 10e3, "R_VDD_BIAS": 24.9e3,
    "R_OC_OUTER": 10e3, "R_OC_MID": 56e3,              # OC window ladder: 10 k / 56 k / 10 k from +3V3
    "R_ENC_SERIES": 1e3, "C_ENC": 100e-12, "R_ENC_PULLUP": 2.2e3,
    "R_FAULT_PULLUP": 10e3,
}
CORE_WORST_MA = 115.0         # docs/bus.md §6: the common core's share
BUS_LIMIT_MA = 200.0
ENCODER_MA = 60.0             # budget for a 5 V encoder (HEDS-5540 57 mA typ)
ENCODER_MAX_HZ = 500 * 7000 / 60        # 500-line encoder at 7000 rpm motor speed, per channel
LOGIC_MISC_MA = 2.0           # TLV3011, 74LVC2G17, pull-ups' share


@dataclass
class Row:
    what: str
    value: str
    limit: str
    ok: bool
    note: str = ""


def rds(tj: float, r25: float | None = None) -> float:
    """R_DS(on) at junction temperature `tj` (linear in T, 1.7 × at 125 °C), from the 25 °C
    maximum unless `r25` is given."""
    return (FET_RDS_MAX if r25 is None else r25) * (1 + FET_RDS_TC * (tj - 25.0))


def switching_times() -> tuple[float, float]:
    """Turn-on and turn-off voltage transition times: (Q_gs2 + Q_gd) / I_gate through the plateau,
    the high side's gate currents (its drive is the lower, VDD less the bootstrap diode)."""
    q = FET_QGS / 2 + FET_QGD
    i_on, i_off = gate_currents(high_side_drive())
    return q / i_on, q / i_off


def world_dead_time() -> float:
    """The one dead time the world model takes: TIM1's plus the middle of the driver's at 25 °C."""
    return DEAD_TIME_S + sum(DRV_DEL_25C) / 2


def dead_time() -> tuple[float, float]:
    """The dead time the FETs see (min, max): TIM1's, then the driver delays each turn-on by its
    DEL time (R105)."""
    return DEAD_TIME_S + DRV_DEL_S[0], DEAD_TIME_S + DRV_DEL_S[1]


def leg_switching_loss(v: float, i: float) -> dict[str, float]:
    """One leg per PWM period: one hard turn-on and one turn-off, the body diode's recovery
    and its conduction during both dead times."""
    t_on, t_off = switching_times()
    return {
        "edges": 0.5 * v * i * (t_on + t_off) * PWM_HZ,
        "recovery": FET_QRR * v * PWM_HZ,
        "dead time": FET_VSD * i * 2 * dead_time()[1] * PWM_HZ,
    }


def losses(i: float, v: float, tj: float) -> dict[str, float]:
    """Power stage losses at motor current `i`, supply `v`, FET junctions at `tj`.

    Conduction: at any time one FET of each leg carries i, so 2 i² R in all. Switching: the
    switching leg(s). The worst FET is taken as carrying i² R (the non-switching leg's low side
    does) plus all of a switching leg's losses (its high side at d → 1): pessimistic.
    """
    r = rds(tj)
    sw = leg_switching_loss(v, i)
    leg = sum(sw.values())
    i_cap = ripple_current(i)
    return {
        "conduction (4 FETs)": 2 * i * i * r,
        f"switching ({SWITCHING_LEGS} leg{'s' if SWITCHING_LEGS > 1 else ''})": SWITCHING_LEGS * leg,
        "worst FET": i * i * r + leg,
        "gate drive (driver, VDD regulator)": v * vdd_load(),
        "ACS725": i * i * HALL_R,
        "fuse": (i ** 2) * FUSE_R,   # input current ≤ motor current (its rms, pessimistic)
        "connectors (2 × XT60)": 2 * i * i * XT60_R,
        "copper": sum(path_loss(segs, a) for _, a, segs in PATHS) * (i / I_CONT) ** 2,
        "capacitor ESR": electrolytic_share(i_cap) ** 2 * ELCAP_ESR / DESIGN_VALUES["N_BULK"],
    }


def ripple_current(i: float, d: float = 0.5) -> float:
    """Input capacitors' rms ripple: pulses of height i, duty |d| → i √(d (1 − d))."""
    return i * math.sqrt(d * (1 - d))


def bank_impedances(f: float = RIPPLE_HZ) -> tuple[complex, complex]:
    """Electrolytic and ceramic banks at the ripple's fundamental."""
    v = DESIGN_VALUES
    w = 2 * math.pi * f
    z_el = complex(ELCAP_ESR, -1 / (w * v["C_BULK_EACH"] * 0.8)) / v["N_BULK"]   # −20 % tolerance
    c_cer = v["C_CER_EACH"] * CER_DC_BIAS
    z_cer = complex(CER_ESR, -1 / (w * c_cer)) / v["N_CER"]
    return z_el, z_cer


def electrolytic_share(i_rms: float) -> float:
    """The electrolytics' part of `i_rms`, all of it taken at the fundamental: pessimistic for
    them (the ceramics take more of every harmonic)."""
    z_el, z_cer = bank_impedances()
    return i_rms * abs(z_cer / (z_el + z_cer))


def ipc2221_amps(area_mil2: float, rise: float, internal: bool = False) -> float:
    """IPC-2221B: I = k ΔT^0.44 A^0.725 (A in mil²), k 0.048 external, 0.024 internal."""
    return (0.024 if internal else 0.048) * rise ** 0.44 * area_mil2 ** 0.725


def ipc2221_external_amps(width_mm: float, thick_um: float, rise: float) -> float:
    """IPC-2221B external conductor of `width_mm` × `thick_um`."""
    return ipc2221_amps((width_mm / 0.0254) * (thick_um / 25.4), rise)


def piece_amps(piece: Piece, rise: float) -> float:
    """What one piece of a conductor carries at `rise`: a trace or plane by IPC-2221B (inner layers
    by its internal curve), a via field by its barrels' cross-section (π d t each) taken as an
    external conductor (IPC-2221B has no via equation; the usual reading)."""
    kind, size = piece
    if kind == "vias":
        barrel_mil2 = math.pi * (VIA_DRILL / 25.4e-6) * (VIA_PLATING / 25.4e-6)
        return size * ipc2221_amps(barrel_mil2, rise)
    inner = kind.startswith("In")
    thick = CU_INNER_UM if inner else CU_OUTER_UM
    return ipc2221_amps((size / 0.0254) * (thick / 25.4), rise, internal=inner)


def segment_amps(conductors, rise: float) -> float:
    """Conductors in parallel, each limited by its weakest piece."""
    return sum(min(piece_amps(p, rise) for p in pieces) for pieces in conductors)


def segment_loss(conductors, length_mm: float, amps: float, t: float = 70.0) -> float:
    """I²R of a segment at `t` °C: its traces and planes, or, for a segment of vias only, the
    barrels through the board (vias beside copper are left out: a few mm of barrel)."""
    rho = 1.72e-8 * (1 + 0.00393 * (t - 20))
    area = sum(size * 1e-3 * (CU_INNER_UM if kind.startswith("In") else CU_OUTER_UM) * 1e-6
               for pieces in conductors for kind, size in pieces if kind != "vias")
    if area:
        return amps ** 2 * rho * length_mm * 1e-3 / area
    n = sum(size for pieces in conductors for kind, size in pieces)
    return amps ** 2 * rho * BOARD_T / (n * math.pi * VIA_DRILL * VIA_PLATING)


def path_loss(segments, amps: float) -> float:
    return sum(segment_loss(c, length, amps) for _, length, c in segments)


def rth_vias() -> float:
    one = BOARD_T / (CU_K * math.pi * ((VIA_DRILL / 2 + VIA_PLATING) ** 2 - (VIA_DRILL / 2) ** 2))
    return one / VIAS_PER_FET


def rth_board_to_air() -> float:
    """The board alone as a fin: both faces, efficiency tanh(mL)/(mL) over the half length."""
    w, h = (x * 1e-3 for x in BOARD_MM)
    kt = CU_K * (2 * CU_OUTER_UM + 2 * CU_INNER_UM) * 1e-6
    m = math.sqrt(2 * H_CONV / kt)
    half = w / 2
    eta = math.tanh(m * half) / (m * half)
    return 1 / (H_CONV * 2 * w * h * eta)


def heat_path() -> dict:
    """The case's heat path (enclosures/motor/motor.json), as scripts/enclosures made it."""
    return heatsink.case_heat_path()


def stack_rth() -> dict[str, float]:
    """The worst FET's junction-to-sink stack, °C/W, in series: its θ_JC, the thermal vias, the
    gap pad over the smallest tab island (1-D, at its least compression: the stack's tolerance
    all the other way), its share of the block (the block's footprint over the tabs it carries,
    1-D through its height: the heat stays under its tab more than this, so the figure is low by
    the block's spreading) and the grease film under that share."""
    hp = heat_path()
    island = min((t[3] - t[1]) * (t[4] - t[2]) for t in hp["tabs"]) * 1e-6
    share = min((b["box"][3] - b["box"][0]) * (b["box"][4] - b["box"][1]) / len(b["tabs"])
                for b in hp["blocks"]) * 1e-6
    h = max(b["box"][5] - b["box"][2] for b in hp["blocks"]) * 1e-3
    return {"θ_JC": FET_RTH_JC, "vias": rth_vias(), "pad": hp["pad_thickest"] * 1e-3 / (PAD_K * island),
            "block": h / (BLOCK_K * share), "grease": GREASE_T / (GREASE_K * share)}


def pad_force_row() -> Row:
    """The pads' force at the stack's most compression bowing the board between the standoff
    columns either side of the blocks: a beam of the board's width, simply supported, the force
    at mid-span (48 E I / L^3)."""
    import json
    case = json.loads(heatsink.CASE_JSON.read_text())["case"]
    hp = case["heat_path"]
    x0, x1 = min(b["box"][0] for b in hp["blocks"]), max(b["box"][3] for b in hp["blocks"])
    cols = sorted({h[0] for h in case["holes"]})
    left, right = max(c for c in cols if c <= x0), min(c for c in cols if c >= x1)
    span = (right - left) * 1e-3
    width = BOARD_MM[1] * 1e-3
    k = 48 * FR4_E * (width * BOARD_T ** 3 / 12) / span ** 3
    area = sum((p[3] - p[0]) * (p[4] - p[1]) for p in hp["pads"]) * 1e-6
    force = PAD_PRESSURE_MAX * area
    bow = force / k
    return Row(f"board bow under the pads at {hp['compression_range'][1]:.1%} compression",
               f"{bow * 1e3:.2f} mm", f"≤ {BOW_LIMIT * 1e3:g} mm", bow <= BOW_LIMIT,
               f"{force:.1f} N: the pad required to need ≤ {PAD_PRESSURE_MAX / 1e3:.0f} kPa there "
               f"(PAD_PRESSURE_MAX) over {area * 1e6:.0f} mm²; the board {BOARD_MM[1]:g} × {BOARD_T * 1e3:g} mm "
               f"across the {span * 1e3:.0f} mm between the standoffs at x {left:g} and {right:g} mm, "
               f"{k / 1e3:.0f} N/mm (FR-4 {FR4_E / 1e9:.0f} GPa, NOT VERIFIED; copper ignored); a firm pad at "
               f"100 kPa would bow it {100e3 * area / k * 1e3:.2f} mm")


def heat_path_row(st: dict[str, float]) -> Row:
    """The case's stack under a tab against what it replaces: a pad as thick as the gap it
    spans (no block), and a block 2 mm shorter (no floor under the power stage)."""
    import json
    hp = heat_path()
    floor = json.loads(heatsink.CASE_JSON.read_text())["design"]["floor"]
    added = st["block"] + st["grease"]
    h = max(b["box"][5] - b["box"][2] for b in hp["blocks"])
    thick_pad = st["pad"] * (h + hp["pad_compressed"]) / hp["pad_thickest"]
    no_floor = st["block"] * (h - floor) / h
    return Row("heat path under each tab (the case's: pad, block, grease)",
               f"{st['pad'] + added:.2f} °C/W", f"< {thick_pad:.0f} °C/W (a pad filling the gap)", st["pad"] + added < thick_pad,
               f"pad {st['pad']:.2f} + block {st['block']:.2f} + grease {st['grease']:.2f}: the block and its film add "
               f"{added:.2f} °C/W to the pad's {st['pad']:.2f} ({added / st['pad']:.0%}); with no floor under the power "
               f"stage the block would be {h - floor:.2f} mm: {no_floor:.2f} °C/W, {st['block'] - no_floor:.2f} less. "
               "A flat sink base cannot reach: the board is "
               f"{h + hp['pad_compressed']:.1f} mm above the case's underside and J102's leads stand between the legs")


def junction(i: float, v: float, rth_sink: float | Callable[[float], float],
             pad: bool = True) -> tuple[float, dict[str, float]]:
    """Worst FET junction at ambient T_AMB, iterating R_DS(on)(T_J): every loss on the board goes
    through `rth_sink` (heatsink or board copper; a function of the total loss for a modelled
    sink, whose resistance falls as it warms) to air, the worst FET's own through its stack (with
    the gap pad when `pad`: on a heatsink)."""
    st = stack_rth()
    stack = st["θ_JC"] + st["vias"] + (st["pad"] + st["block"] + st["grease"] if pad else 0)
    tj = 100.0
    for _ in range(50):
        p = losses(i, v, tj)
        total = sum(x for k, x in p.items() if k != "worst FET")
        r = rth_sink(total) if callable(rth_sink) else rth_sink
        tj = T_AMB + total * r + p["worst FET"] * stack
    return tj, p


def board_loss() -> float:
    """The board's total loss at 20 A and the highest input, on a sink at the requirement: what
    the heatsink sheds (calc/heatsink.py designs for it)."""
    _, p = junction(I_CONT, VIN_MAX, HEATSINK_RTH)
    return sum(x for k, x in p.items() if k != "worst FET")


def required_heatsink() -> heatsink.Result:
    """calc/heatsink.py's smallest extrusion meeting HEATSINK_RTH (with its margin) and
    HEATSINK_J_PER_K at the board's loss."""
    return heatsink.smallest(round(board_loss(), 6), HEATSINK_RTH, HEATSINK_J_PER_K, T_AMB)


def modelled_sink(sink: heatsink.Sink) -> Callable[[float], float]:
    """`sink`'s modelled resistance as a function of the power it sheds."""
    return lambda total: heatsink.resistance(sink, total, T_AMB).r


def largest_sink_rth() -> float:
    """The sink-to-air resistance at which the worst junction reaches TJ_LIMIT at 20 A."""
    lo, hi = 0.0, 20.0
    for _ in range(20):           # ±20 µK/W
        mid = (lo + hi) / 2
        if junction(I_CONT, VIN_MAX, mid)[0] <= TJ_LIMIT:
            lo = mid
        else:
            hi = mid
    return lo


def firmware_assumptions(root: Path | None = None) -> dict[str, float]:
    """The constants the motor firmware and the world model assume, read from their sources."""
    root = root or Path(__file__).resolve().parents[4]
    fe = (root / "firmware/apps/motor/src/frontend.rs").read_text()
    hb = (root / "firmware/host/world/src/hbridge.rs").read_text()
    pr = (root / "firmware/apps/motor/src/params.rs").read_text()
    br = (root / "firmware/targets/f103/motor/src/bridge.rs").read_text()

    def num(pattern: str, text: str) -> float:
        m = re.search(pattern, text)
        if not m:
            raise ValueError(f"firmware constant not found: {pattern!r}")
        return float(m.group(1).replace("_", ""))
    return {
        "HALL_MV_PER_A": num(r"HALL_MV_PER_A: f32 = ([\d_.]+)", fe),
        "VMOT_DIVIDER_TOP_OHM": num(r"VMOT_DIVIDER_TOP_OHM: f32 = ([\d_.]+)", fe),
        "VMOT_DIVIDER_BOTTOM_OHM": num(r"VMOT_DIVIDER_BOTTOM_OHM: f32 = ([\d_.]+)", fe),
        "pwm_hz": num(r"pwm_hz: ([\d_.]+)", hb),
        "dead_time_s": num(r"dead_time_s: ([\d_.e-]+)", hb),
        "current_limit max": num(r"current_limit: f32 = [\d.]+, [\d.]+, ([\d.]+)", pr),
        "duty_limit max": num(r"duty_limit: f32 = [\d.]+, [\d.]+, ([\d.]+)", pr),
        "bridge.rs PWM_HZ": num(r"const PWM_HZ: u32 = ([\d_]+)", br),
        "bridge.rs DEAD_TIME_NS": num(r"const DEAD_TIME_NS: u32 = ([\d_]+)", br) * 1e-9,
    }


def firmware_changes(fw: dict[str, float] | None = None) -> list[str]:
    """What the firmware must change to match this board (empty when it agrees)."""
    fw = fw or firmware_assumptions()
    v = DESIGN_VALUES
    want = {
        "HALL_MV_PER_A": HALL_MV_PER_A,
        "VMOT_DIVIDER_TOP_OHM": v["R_VMOT_TOP"],
        "VMOT_DIVIDER_BOTTOM_OHM": v["R_VMOT_BOT"],
        "pwm_hz": PWM_HZ,
        "dead_time_s": world_dead_time(),
        "current_limit max": I_PEAK,
        "bridge.rs PWM_HZ": PWM_HZ,
        "bridge.rs DEAD_TIME_NS": DEAD_TIME_S,
    }
    return [f"{k}: firmware {fw[k]:g}, board {x:g}" for k, x in want.items()
            if not math.isclose(fw[k], x, rel_tol=1e-6)]


def rows() -> list[Row]:
    v = DESIGN_VALUES
    out: list[Row] = []
    add = out.append

    # --- voltages: steady, regeneration, ringing
    add(Row("input range", f"{VIN_MIN:.0f}–{VIN_MAX:.1f} V", f"{VIN_NOM:.0f} V nominal", True,
            f"10S Li-ion {LIION_MAX:.1f} V, 3 × 12 V lead-acid charging {LEAD_ACID_MAX:.1f} V"))
    ov = v["R_OV_TOP"] / v["R_OV_BOT"]
    ov_lo = OV_REF[0] * (1 + ov * (1 - RES_TOL) / (1 + RES_TOL))
    ov_hi = OV_REF[2] * (1 + ov * (1 + RES_TOL) / (1 - RES_TOL))
    add(Row("over-voltage trip (TLV3011 → DRV_FAULT: coast)", f"{ov_lo:.1f}–{ov_hi:.1f} V",
            f"> {VIN_MAX:.1f} V and < TVS V_BR min {TVS_VBR_MIN:.1f} V",
            ov_lo > VIN_MAX and ov_hi < TVS_VBR_MIN,
            f"{ov_lo - VIN_MAX:+.1f} V over the input, {TVS_VBR_MIN - ov_hi:+.1f} V under the TVS at 25 °C "
            f"(at {T_COLD:.0f} °C its V_BR may be {TVS_VBR_MIN * (1 + TVS_ALPHA * (T_COLD - 25)):.1f} V: "
            "it then takes mA before the trip, harmlessly)"))
    vbr_cold = TVS_VBR_MIN * (1 + TVS_ALPHA * (T_COLD - 25))
    add(Row(f"TVS {TVS} min breakdown at {T_COLD:.0f} °C", f"{vbr_cold:.1f} V", f"> {VIN_MAX:.1f} V",
            vbr_cold > VIN_MAX, f"{vbr_cold - VIN_MAX:+.1f} V; stand-off {TVS_VRWM:.0f} V"))
    t_on, t_off = switching_times()
    ring = LOOP_L * I_PEAK / t_off
    add(Row("switch-node overshoot L_loop · I / t_off", f"{ring:.1f} V", "(added below)", True,
            f"{LOOP_L * 1e9:.0f} nH loop, {I_PEAK:.0f} A in {t_off * 1e9:.0f} ns"))
    add(Row("MOSFET V_DS at the over-voltage trip + overshoot", f"{ov_hi + ring:.1f} V",
            f"≤ 80 % of {FET_VDS:.0f} V", ov_hi + ring <= 0.8 * FET_VDS, f"{(ov_hi + ring) / FET_VDS:.0%} of rating"))
    add(Row("MOSFET V_DS at the TVS clamp + overshoot (a fault)", f"{TVS_VC + ring:.1f} V",
            f"≤ {FET_VDS:.0f} V", TVS_VC + ring <= FET_VDS,
            f"{(TVS_VC + ring) / FET_VDS:.0%} of rating; reached only when the trip has failed"))
    vhb = TVS_VC + vdd(TVS_VC, vdd_load(), "max")
    add(Row("HIP4082 AHS/BHS at the TVS clamp", f"{TVS_VC:.1f} V", f"≤ {DRV_VHS_ABS:.0f} V (FN3676)",
            TVS_VC <= DRV_VHS_ABS and vhb <= DRV_VHB_ABS,
            f"{DRV_VHS_ABS - TVS_VC:.1f} V margin; AHB/BHB {vhb:.1f} V ≤ {DRV_VHB_ABS:.0f} V"))
    add(Row(f"Q106 {'BCX56-16'} V_CE at the TVS clamp", f"{TVS_VC - vdd(TVS_VC, vdd_load(), 'min'):.1f} V",
            f"≤ V_CEO {Q106_VCEO:.0f} V (NXP Table 2)", TVS_VC - vdd(TVS_VC, vdd_load(), "min") <= Q106_VCEO,
            f"R120's 0603 then {TVS_VC - ZENER_V[0]:.0f} V (≤ {RES_0603_VMAX:.0f} V)"))
    add(Row("electrolytics at the TVS clamp", f"{TVS_VC:.1f} V", f"≤ surge {ELCAP_SURGE:.0f} V ({ELCAP_V:.0f} V rated)",
            TVS_VC <= ELCAP_SURGE and ov_hi <= ELCAP_V, f"at the trip {ov_hi / ELCAP_V:.0%} of rated"))
    c_bulk = v["C_BULK_EACH"] * v["N_BULK"] * 0.8
    e_l = 0.5 * MOTOR_L * I_PEAK ** 2
    v_dump = math.sqrt(ov_hi ** 2 + 2 * e_l / c_bulk)
    add(Row("coast at 30 A: winding energy into the bulk", f"{e_l * 1e3:.0f} mJ → {v_dump:.1f} V",
            f"< TVS V_BR min {TVS_VBR_MIN:.0f} V", v_dump < TVS_VBR_MIN,
            f"from the trip's {ov_hi:.1f} V into {c_bulk * 1e3:.1f} mF (−20 %); the TVS ({TVS_E_PULSE:.1f} J "
            "rated) is for what this misses"))
    add(Row("back-EMF when coasting (regeneration stops)", f"≤ {MOTOR_V_RATED:.0f} V",
            f"< trip {ov_lo:.1f} V", MOTOR_V_RATED < ov_lo,
            "motor rated ≤ 36 V, at most at its no-load speed: coasting diodes then cannot charge the bus"))

    # --- MOSFETs and their heat
    tj_cold, _ = junction(I_CONT, VIN_MAX, rth_board_to_air(), pad=False)
    tj, p = junction(I_CONT, VIN_MAX, HEATSINK_RTH)
    total = sum(x for k, x in p.items() if k != "worst FET")
    add(Row(f"R_DS(on) max, {FET}", f"{FET_RDS_MAX * 1e3:.1f} mΩ at 25 °C", "SLPS540C §4.1", True,
            f"{rds(tj) * 1e3:.1f} mΩ at T_J {tj:.0f} °C (×{1 + FET_RDS_TC * (tj - 25):.2f}, estimate)"))
    i_on, i_off = gate_currents(high_side_drive())
    add(Row("switching times (Q_gs/2 + Q_gd) / I_gate", f"on {t_on * 1e9:.0f} ns, off {t_off * 1e9:.0f} ns",
            f"I_gate {i_on * 1e3:.0f}/{i_off * 1e3:.0f} mA", t_on < 0.01 / PWM_HZ,
            f"HIP4082 1.25 A peak as {high_side_drive() / DRV_I_PEAK:.1f} Ω + R_gate "
            f"{v['R_GATE']:.0f} Ω + R_G {FET_RG_INT} Ω, from {high_side_drive():.1f} V to the "
            f"{FET_VPLATEAU} V plateau; dv/dt {VIN_MAX / (FET_QGD / i_on) / 1e9:.2f} V/ns at turn-on"))
    dead_need = t_off + 50e-9
    dt_min, dt_max = dead_time()
    add(Row("dead time vs turn-off + driver skew (50 ns)", f"{dt_min * 1e9:.0f}–{dt_max * 1e9:.0f} ns",
            f"≥ {dead_need * 1e9:.0f} ns", dt_min >= dead_need,
            f"TIM1 {DEAD_TIME_S * 1e9:.0f} ns + HIP4082 DEL {DRV_DEL_S[0] * 1e9:.0f}–{DRV_DEL_S[1] * 1e9:.0f} ns "
            f"(R105 {v['R_DEL'] / 1e3:.0f} k, FN3676 over -55 to 150 °C); "
            f"body diode conducts the rest: {leg_switching_loss(VIN_MAX, I_CONT)['dead time']:.2f} W per leg"
            f" at 20 A; 300 ns in all would leave {FET_VSD * I_CONT * 2 * 300e-9 * PWM_HZ:.2f} W"))
    for k, x in p.items():
        add(Row(f"loss at {I_CONT:.0f} A, {VIN_MAX:.1f} V: {k}", f"{x:.2f} W", "", True))
    add(Row("board total at 20 A", f"{total:.1f} W", f"η {1 - total / (VIN_MAX * I_CONT * 0.95):.1%} at full duty",
            True))
    add(Row("T_J on board copper alone (no heatsink)", f"{tj_cold:.0f} °C",
            f"≤ {TJ_LIMIT:.0f} °C: needs the heatsink", True,
            f"board {BOARD_MM[0]:.0f} × {BOARD_MM[1]:.0f} mm as a fin, θ {rth_board_to_air():.1f} °C/W; "
            f"continuous on copper alone {copper_only_rating():.1f} A"))
    loss = round(board_loss(), 6)
    try:
        req = required_heatsink()
    except ValueError as e:      # no extrusion of the search meets the requirement: say so, go on
        req = None
        add(Row(f"heatsink: smallest extrusion for ≤ {HEATSINK_RTH} °C/W (model)", "none",
                f"≤ {HEATSINK_RTH * (1 - heatsink.MARGIN):.2f} °C/W ({heatsink.MARGIN:.0%} under)", False, str(e)))
    if req is not None:
        add(Row(f"heatsink: smallest extrusion for ≤ {HEATSINK_RTH} °C/W (model)",
                f"{req.r:.2f} °C/W, {req.sink.heat_capacity:.0f} J/K",
                f"≤ {HEATSINK_RTH * (1 - heatsink.MARGIN):.2f} °C/W ({heatsink.MARGIN:.0%} under), "
                f"≥ {HEATSINK_J_PER_K:.0f} J/K",
                req.r <= HEATSINK_RTH * (1 - heatsink.MARGIN) and req.sink.heat_capacity >= HEATSINK_J_PER_K,
                f"{req.sink.describe()}, {req.sink.mass * 1e3:.0f} g, fins vertical; at {req.power:.1f} W: "
                f"fins to air {req.r_fins:.2f} + spreading {req.r_spread:.2f} °C/W (Bar-Cohen & Rohsenow "
                f"channels, ε {heatsink.EMISSIVITY} radiation, calc/heatsink.py)"))
    cand = heatsink.best_in_envelope(*heatsink.CANDIDATE_MM, loss, T_AMB)
    margin_met = cand.r <= HEATSINK_RTH * (1 - heatsink.MARGIN)
    tj_cand, _ = junction(I_CONT, VIN_MAX, modelled_sink(cand.sink))
    add(Row(f"heatsink candidate {heatsink.CANDIDATE} (model of its envelope)", f"{cand.r:.2f} °C/W",
            f"≤ {HEATSINK_RTH} °C/W", cand.r <= HEATSINK_RTH,
            f"T_J {tj_cand:.0f} °C on it; {1 - cand.r / HEATSINK_RTH:.0%} under the requirement ("
            f"{'with' if margin_met else 'without'} the {heatsink.MARGIN:.0%} margin): the best plate-fin "
            f"profile of its {' × '.join(f'{x:g}' for x in heatsink.CANDIDATE_MM)} mm envelope "
            f"({cand.sink.fins} fins {cand.sink.fin_t * 1e3:g} mm); its own profile NOT VERIFIED; the "
            f"distributors' fields {heatsink.CANDIDATE_DISTRIBUTOR_RTH[0]} / "
            f"{heatsink.CANDIDATE_DISTRIBUTOR_RTH[1]} °C/W (NOT VERIFIED) are at a rise not read"))
    r_max = largest_sink_rth()
    st = stack_rth()
    add(heat_path_row(st))
    add(pad_force_row())
    add(Row(f"T_J worst FET at {I_CONT:.0f} A, {T_AMB:.0f} °C, heatsink {HEATSINK_RTH} °C/W", f"{tj:.0f} °C",
            f"≤ {TJ_LIMIT:.0f} °C", tj <= TJ_LIMIT,
            f"{TJ_LIMIT - tj:.0f} °C margin on any sink that meets the requirement (the model's extrusion "
            f"meets it {heatsink.MARGIN:.0%} under: rows above); {TJ_LIMIT:.0f} °C is reached at "
            f"{r_max:.1f} °C/W; stack θ_JC {st['θ_JC']} + vias {st['vias']:.1f} + pad {st['pad']:.2f} + block "
            f"{st['block']:.2f} + grease {st['grease']:.2f} °C/W (the case's heat path: hardware/motor/README.md "
            f"\"Heatsink\"); "
            f"sink at {T_AMB + total * HEATSINK_RTH:.0f} °C"))
    if req is None:
        add(Row(f"T_J worst FET on the required extrusion at {I_CONT:.0f} A, {T_AMB:.0f} °C (model)", "none",
                f"≤ {TJ_LIMIT:.0f} °C", False, "no extrusion of calc/heatsink.py's search meets the requirement"))
    else:
        tj_model, _ = junction(I_CONT, VIN_MAX, modelled_sink(req.sink))
        add(Row(f"T_J worst FET on the required extrusion at {I_CONT:.0f} A, {T_AMB:.0f} °C (model)",
                f"{tj_model:.0f} °C", f"≤ {TJ_LIMIT:.0f} °C", tj_model <= TJ_LIMIT,
                f"{TJ_LIMIT - tj_model:.0f} °C margin; the sink's modelled {req.r:.2f} °C/W at this loss"))
    tj_pk, p_pk = peak_junction(tj, p)
    add(Row(f"T_J at the {I_PEAK:.0f} A peak for {PEAK_S:.0f} s", f"{tj_pk:.0f} °C", f"≤ {TJ_LIMIT:.0f} °C",
            tj_pk <= TJ_LIMIT, f"sink +{(sum(x for k, x in p_pk.items() if k != 'worst FET') - total) * PEAK_S / HEATSINK_J_PER_K:.1f} °C "
            f"in {PEAK_S:.0f} s ({HEATSINK_J_PER_K:.0f} J/K); stack settles in < 1 s"))
    # --- over-current: the Hall sensor's output against a window from +3V3 (U105/U106, LMV331)
    oc_lo_a, oc_nom, oc_hi_a = oc_trip()
    swing_a = (HALL_SWING[1] - ADC_FS / 2) / (HALL_MV_PER_A / 1e3)
    ripple_half = VIN_MAX * 0.25 / (MOTOR_L * RIPPLE_HZ) / 2
    add(Row("over-current trip (U105/U106 → DRV_FAULT → TIM1_BKIN)", f"±{oc_lo_a:.1f}–{oc_hi_a:.1f} A",
            f"> peak {I_PEAK:.0f} A + ripple {ripple_half:.1f} A, < sensor swing {swing_a:.1f} A",
            oc_lo_a > I_PEAK + ripple_half and oc_hi_a < swing_a,
            f"±{oc_nom:.2f} A nominal: {v['R_OC_OUTER'] / 1e3:.0f} k / {v['R_OC_MID'] / 1e3:.0f} k / "
            f"{v['R_OC_OUTER'] / 1e3:.0f} k from 3.3 V, {oc_window()[1]:.3f} V and {oc_window()[0]:.3f} V "
            f"(ratiometric like the sensor); sensitivity ±{OC_SENS_TOL:.1%}, offsets "
            f"{OC_OFFSET_V * 1e3:.0f} + {CMP_VOS * 1e3:.0f} mV (ACS725 over -40 to 150 °C; LMV331's NOT "
            "VERIFIED), 1 % resistors"))
    delay = HALL_T_RESPONSE + CMP_TPD + TIM1_BREAK_S + DRV_PROP + t_off
    # Shorted leads are survived up to the rated motor voltage; above it (a full 10S Li-ion pack, a
    # lead-acid battery on charge) the current at switch-off passes I_DM: stated, revision B's
    # desaturation sensing (hardware/motor/README.md, decisions)
    i_short = oc_hi_a + MOTOR_V_RATED / L_SHORT * delay
    i_short_max = oc_hi_a + VIN_MAX / L_SHORT * delay
    add(Row(f"current at switch-off, motor leads shorted, {MOTOR_V_RATED:.0f} V supply", f"{i_short:.0f} A",
            f"≤ I_DM {FET_ID_PULSE:.0f} A", i_short <= FET_ID_PULSE,
            f"at {VIN_MAX:.1f} V {i_short_max:.0f} A: not covered (README). "
            f"{MOTOR_V_RATED / L_SHORT / 1e6:.0f} A/µs ({L_SHORT * 1e6:.1f} µH of cable, estimate) for "
            f"{delay * 1e6:.1f} µs: sensor {HALL_T_RESPONSE * 1e6:.1f} + comparator {CMP_TPD * 1e6:.1f} + "
            f"break {TIM1_BREAK_S * 1e6:.1f} + driver {DRV_PROP * 1e6:.1f} + turn-off {t_off * 1e6:.2f} µs. "
            "Leg B's own shorts (MOT_B to a rail) bypass the sensor: the fuse"))
    # the comparators' input filter: every ns it adds lets a short's current rise further (a ramp
    # lags a one-pole filter by τ), so τ is bounded by what the switch-off current leaves to I_DM
    tau = OC_FILTER_R * OC_FILTER_C
    budget = (FET_ID_PULSE - i_short) / (MOTOR_V_RATED / L_SHORT)
    ring_gain = 1 / math.sqrt(1 + (RING_HZ * 2 * math.pi * tau) ** 2)
    add(Row("over-current input filter (revision B: R_f + C_f before U105/U106)",
            f"{OC_FILTER_R / 1e3:g} k + {OC_FILTER_C * 1e12:.0f} pF: τ {tau * 1e9:.0f} ns, "
            f"{1 / (2 * math.pi * tau) / 1e6:.1f} MHz", f"τ ≤ {budget * 1e9:.0f} ns (short-circuit budget to I_DM)",
            tau <= budget,
            f"a short then reaches {i_short + MOTOR_V_RATED / L_SHORT * tau:.0f} A at switch-off; a "
            f"{RING_HZ / 1e6:.0f} MHz ring (estimate) passes at {ring_gain:.0%}. NOT ON THE REVISION A "
            "BOARD: its comparators see HALL_OUT as the sensor drives it (120 kHz), with no filter for "
            "what the layout picks up after it"))
    # hysteresis: U105 (HALL on IN−, OC_HI on IN+) trips when HALL_OUT rises above OC_HI; DRV_FAULT
    # low through R_h pulls OC_HI down (positive feedback); OC_HI's source is R121 ∥ (R122 + R123)
    r_src = 1 / (1 / v["R_OC_OUTER"] + 1 / (v["R_OC_MID"] + v["R_OC_OUTER"]))
    v_hi = oc_window()[1]
    dv_trip = v_hi * r_src / (r_src + OC_HYST_R)
    dv_idle = (ADC_FS - v_hi) * r_src / (r_src + OC_HYST_R)
    lift_a = dv_idle / (HALL_MV_PER_A / 1e3)
    add(Row("over-current hysteresis (revision B: R_h from DRV_FAULT to OC_HI)",
            f"{dv_trip * 1e3:.0f} mV = {dv_trip / (HALL_MV_PER_A / 1e3):.1f} A",
            f"> offsets {CMP_VOS * 1e3:.0f} mV; high trip + idle lift < swing {swing_a:.1f} A",
            dv_trip > CMP_VOS and oc_hi_a + lift_a < swing_a,
            f"R_h {OC_HYST_R / 1e3:.0f} k against OC_HI's {r_src / 1e3:.2f} k; idle (DRV_FAULT pulled up) it "
            f"lifts the high trip by {dv_idle * 1e3:.1f} mV ({lift_a:.2f} A: {oc_hi_a + lift_a:.1f} A at most). "
            "The low trip (U106, OC_LO on "
            "IN−) cannot take hysteresis from an open-drain low. NOT ON THE REVISION A BOARD: there, and "
            "for both trips, TIM1's break latches (MOE stays cleared until the firmware re-arms), so a "
            "chattering comparator cannot switch the bridge back on"))

    # --- gate drive: HIP4082 from VDD (Q106), bootstrap high sides
    load = vdd_load()
    v_lo = vdd(VIN_MIN, load, "min")
    add(Row(f"driver VDD at the {VIN_MIN:.0f} V minimum input", f"{v_lo:.1f} V",
            f"≥ {DRV_VDD_RANGE[0]} V (HIP4082), ≥ UV {DRV_VDD_UV} V max", v_lo >= max(DRV_VDD_RANGE[0], DRV_VDD_UV),
            f"VMOT − I_B R120 − V_BE with {load * 1e3:.1f} mA at h_FE {Q106_HFE_MIN:.0f}; the high-side "
            f"gate then {v_lo - BOOT_DIODE_VF:.1f} V (R_DS(on) specified at 10 V: below ~14 V input the "
            "losses above are optimistic)"))
    v_hi = max(vdd(x, load, "max") for x in (VIN_MAX, TVS_VC))
    add(Row("driver VDD (zener − V_BE), worst high", f"{vdd(VIN_MAX, load, 'min'):.1f}–{v_hi:.1f} V",
            f"≤ {DRV_VDD_RANGE[1]} V (HIP4082)", v_hi <= DRV_VDD_RANGE[1],
            f"D105 BZT52C13 {ZENER_V[0]}–{ZENER_V[2]} V, V_BE {VBE[0]}–{VBE[2]} V; the gates see ≤ {v_hi:.1f} V (±20 V rated)"))
    p_q = (ov_hi - vdd(ov_hi, load, "min")) * load
    t_q = T_CORE_BAND + p_q * Q106_RTH_JA
    add(Row("Q106 dissipation at the over-voltage trip", f"{p_q:.2f} W, T_J {t_q:.0f} °C", "T_J ≤ 150 °C",
            t_q <= 150.0, f"{load * 1e3:.1f} mA through {ov_hi - vdd(ov_hi, load, 'min'):.0f} V; θ_JA "
            f"{Q106_RTH_JA:.0f} °C/W (SOT-89, NOT VERIFIED) from the core band at {T_CORE_BAND:.0f} °C (estimate)"))
    p_r = (ov_hi - ZENER_V[0]) ** 2 / v["R_VDD_BIAS"]
    add(Row("R120 (0603) at the over-voltage trip", f"{p_r * 1e3:.0f} mW", "≤ 100 mW (0603)", p_r <= 0.1,
            f"{(ov_hi - ZENER_V[0]) / v['R_VDD_BIAS'] * 1e3:.2f} mA into D105 and Q106's base"))
    q_bs = FET_QG * high_side_drive() / 10.0
    d_max = max_duty()
    t_hi = d_max / PWM_HZ
    droop = (q_bs + DRV_IHB_ON * t_hi) / (v["C_BS"] * C_BS_DC_BIAS)
    add(Row("bootstrap droop over the longest on-time", f"{droop:.2f} V", f"≤ {BOOT_DROOP_MAX} V",
            droop <= BOOT_DROOP_MAX,
            f"(Q_g {q_bs * 1e9:.0f} nC + I_HB {DRV_IHB_ON * 1e3:.2f} mA × {t_hi * 1e6:.1f} µs) / "
            f"({v['C_BS'] * 1e9:.0f} nF × {C_BS_DC_BIAS:.0%} at 12 V)"))
    t_ref = refresh_time()
    g_min = high_side_drive() - droop - boot_deficit()
    add(Row(f"bootstrap refresh at the firmware's maximum duty {d_max:.2f}",
            f"{t_ref * 1e6:.2f} µs, gate ≥ {g_min:.1f} V", "gate ≥ 10 V (R_DS(on) as specified)",
            t_ref > 0 and g_min >= 10.0,
            f"(1 − d)/f − 2 × dead time {dead_time()[1] * 1e9:.0f} ns of low-side conduction each period "
            f"refills C_BS with τ {BOOT_DIODE_R * v['C_BS'] * C_BS_DC_BIAS * 1e6:.2f} µs ({BOOT_DIODE_R:.0f} Ω, "
            f"estimate): steady deficit {boot_deficit():.2f} V before each turn-on, plus the droop. "
            "No charge pump: 100 % duty would starve the bootstrap, so duty_limit's maximum "
            "(firmware/apps/motor/src/params.rs) is 0.95"))
    add(Row("C_VDD vs the bootstrap capacitors", f"{v['C_VDD'] * 1e6:.0f} µF",
            f"≥ 10 × {v['C_BS'] * 1e9:.0f} nF", v["C_VDD"] >= 10 * v["C_BS"],
            "C113 refills both bootstrap capacitors and the low sides' gates"))
    p_drv = vdd(VIN_NOM, load, "typ") * (DRV_IDD + 2 * DRV_IHB) + 2 * SWITCHING_LEGS * FET_QG * \
        vdd(VIN_NOM, load, "typ") * PWM_HZ * (vdd(VIN_NOM, load, "typ") / DRV_I_PEAK) / \
        (vdd(VIN_NOM, load, "typ") / DRV_I_PEAK + v["R_GATE"] + FET_RG_INT)
    t_drv = T_CORE_BAND + 20 + p_drv * DRV_RTH_JA
    add(Row("HIP4082 dissipation", f"{p_drv * 1e3:.0f} mW, T_J {t_drv:.0f} °C", "T_J ≤ 125 °C", t_drv <= 125,
            f"VDD × (I_DD + 2 I_HB) + the gate charge's share in its output stage "
            f"(R_out / (R_out + R_gate + R_G)); θ_JA {DRV_RTH_JA:.0f} °C/W (FN3676, SOIC), among the FETs at "
            f"{T_CORE_BAND + 20:.0f} °C (estimate)"))
    add(Row("driver supply", f"VDD from VMOT, {load * 1e3:.1f} mA", "not from the bus", True,
            "Q106 + D105 + R120: 12.4 V nominal"))

    # --- input capacitors
    i_rip = ripple_current(I_CONT)
    i_el = electrolytic_share(i_rip)
    i_each = i_el / v["N_BULK"]
    rated = ELCAP_RIPPLE * ELCAP_FREQ_K
    add(Row(f"input ripple at {I_CONT:.0f} A, d = 0.5", f"{i_rip:.1f} A rms at {RIPPLE_HZ / 1e3:.0f} kHz",
            "I √(d(1 − d)), worst d", True, "sign-magnitude: one pulse per period (bipolar drive: up to 20 A rms)"))
    add(Row("per electrolytic", f"{i_each:.2f} A rms", f"≤ {rated:.2f} A ({ELCAP_RIPPLE} A × {ELCAP_FREQ_K})",
            i_each <= rated, f"{v['N_BULK']} × {ELCAP}; bank takes {i_el / i_rip:.0%}"))
    t_core = ELCAP_T_LOCAL + ELCAP_RIPPLE_RISE * (i_each / rated) ** 2
    life = ELCAP_LIFE_H * 2 ** ((105 - t_core) / 10)
    add(Row("electrolytic life at that point", f"{life:,.0f} h", f"≥ {LIFE_REQUIRED_H:,.0f} h", life >= LIFE_REQUIRED_H,
            f"core {t_core:.0f} °C ({ELCAP_T_LOCAL:.0f} °C board, estimate); {ELCAP_LIFE_H:.0f} h at 105 °C, ×2 per 10 °C"))
    z_el, z_cer = bank_impedances()
    i_cer = i_rip * abs(z_el / (z_el + z_cer)) / v["N_CER"]
    add(Row("per ceramic (fundamental share)", f"{i_cer:.2f} A rms", f"≤ {CER_RIPPLE} A (estimate)",
            i_cer <= CER_RIPPLE, f"{v['N_CER']} × {CER}, {v['C_CER_EACH'] * CER_DC_BIAS * 1e6:.1f} µF each at 44 V: they close "
            "the edges' loop (L_loop), the electrolytics store the ripple"))
    dv = I_CONT * 0.25 / (c_bulk * RIPPLE_HZ) + I_CONT * abs(z_el)
    add(Row("input voltage ripple", f"{dv:.2f} V p-p", "≤ 1 V", dv <= 1.0, "charge + ESR, bank alone"))

    # --- fuse and hot-plug
    add(Row(f"fuse {FUSE}", f"{I_CONT:.0f} A continuous", f"≤ {FUSE_RATED * FUSE_DERATE:.2f} A (75 %, 60 °C)",
            I_CONT <= FUSE_RATED * FUSE_DERATE and FUSE_VDC >= VIN_MAX,
            f"DC interrupting rating at {FUSE_VDC:.0f} V (500 A) vs {VIN_MAX:.1f} V"))
    i2t = c_bulk / 0.8 * VIN_MAX ** 2 / (2 * R_HOTPLUG)
    lim = FUSE_I2T * FUSE_PULSE_FRACTION
    add(Row("hot-plug inrush I²t into the bulk", f"{i2t:.0f} A²s", f"≤ {lim:.0f} A²s (22 % of melting)",
            i2t <= lim, "" if i2t <= lim else
            f"traded: a hot plug can open the fuse (melting I²t {FUSE_I2T:.0f} A²s): plug the module in "
            "with the robot's main switch off (README errata)"))
    add(Row("XT60 (battery male, motor female)", f"{I_CONT:.0f} A", f"≤ {XT60_RATED:.0f} A continuous",
            I_CONT <= XT60_RATED, f"peak {I_PEAK:.0f} A at the rating"))
    add(Row("ACS725 primary at 20 A", f"{I_CONT ** 2 * HALL_R:.2f} W", "≤ 0.5 W in SOIC-8 on 2 oz pours",
            I_CONT ** 2 * HALL_R <= 0.5, "continuous 20 A through the leads: NOT VERIFIED (Allegro thermal curves)"))

    # --- copper as drawn (IPC-2221B; planes on the 2 oz inner layers, via fields by their barrels)
    for name, amps, segs in PATHS:
        for seg, length, conductors in segs:
            cap = segment_amps(conductors, PATH_RISE)
            cap_pk = segment_amps(conductors, 2 * PATH_RISE)
            drawn = " + ".join(" via ".join(f"{k} {v:g} mm" if k != "vias" else f"{v:g} vias"
                                            for k, v in pieces) for pieces in conductors)
            add(Row(f"copper {name}: {seg}", f"{cap:.0f} A", f"≥ {amps:.0f} A at +{PATH_RISE:.0f} °C",
                    cap >= amps and cap_pk >= I_PEAK,
                    f"{drawn}; {cap_pk:.0f} A at +{2 * PATH_RISE:.0f} °C (peak {I_PEAK:.0f} A); "
                    f"{segment_loss(conductors, length, amps) * 1e3:.0f} mW over {length:.0f} mm"))
    neck = ipc2221_external_amps(ACS725_NECK_MM[0], CU_OUTER_UM, PATH_RISE)
    add(Row("copper motor A: ACS725 lead rows (F.Cu only)", f"{neck:.0f} A by IPC-2221B",
            f"≥ {I_CONT:.0f} A at +{PATH_RISE:.0f} °C", neck >= I_CONT,
            f"traded: {ACS725_NECK_MM[0]} mm for {ACS725_NECK_MM[1]} mm at the SOIC-8's two-lead rows, "
            "pours on both sides; IPC-2221B's long-conductor curve does not describe a 1 mm neck, and "
            "Allegro's continuous-current rating of the package on a 2 oz board was NOT read: measure "
            "the lead temperature on the first board (revision B: a sensor with a larger primary)"))

    # --- current sense
    span = HALL_RANGE * HALL_MV_PER_A / 1e3
    lo, hi = ADC_FS / 2 - span, ADC_FS / 2 + span
    add(Row(f"{HALL} ±{HALL_RANGE:.0f} A into the ADC", f"{lo:.2f}–{hi:.2f} V",
            f"within the output swing {HALL_SWING[0]}–{HALL_SWING[1]} V", HALL_SWING[0] <= lo and hi <= HALL_SWING[1],
            f"{HALL_MV_PER_A:.0f} mV/A at 3.3 V (ACS725-DS Rev. 8); 0 A = VDDA/2 (ratiometric)"))
    lsb = ADC_FS / ADC_COUNTS / (HALL_MV_PER_A / 1e3)
    add(Row("current resolution", f"{lsb * 1e3:.1f} mA/count", f"range ≥ ±{SENSE_RANGE_REQUIRED:.0f} A (issue 19)",
            HALL_RANGE >= SENSE_RANGE_REQUIRED, f"clips at ±{(ADC_FS / 2) / (HALL_MV_PER_A / 1e3):.1f} A"))
    di_motor = VIN_MAX * 0.25 / (MOTOR_L * RIPPLE_HZ)
    extra = (di_motor / math.sqrt(12) / I_CONT) ** 2
    add(Row("motor current ripple at d = 0.5", f"{di_motor:.2f} A p-p", "extra copper loss ≤ 1 %",
            extra <= 0.01, f"V d(1 − d) / (L f), L {MOTOR_L * 1e3:.1f} mH (assumed): +{extra:.2%} I²R in the "
            f"winding; an unsynchronised sample errs by up to ±{di_motor / 2:.2f} A (sample at the PWM centre)"))
    add(Row("sensor bandwidth vs PWM", f"{HALL_BW_HZ / 1e3:.0f} kHz", f"> ripple {RIPPLE_HZ / 1e3:.0f} kHz",
            HALL_BW_HZ > RIPPLE_HZ, "it follows the ripple: sample at the PWM centre (TIM1 trigger)"))

    # --- VMOT sense
    g = (v["R_VMOT_TOP"] + v["R_VMOT_BOT"]) / v["R_VMOT_BOT"]
    fs = ADC_FS * g
    add(Row("VMOT_SENSE full scale", f"{fs:.1f} V (×1/{g:.0f})", f"> over-voltage trip {ov_hi:.1f} V",
            fs > ov_hi, f"{VIN_MAX / g:.2f} V at {VIN_MAX:.1f} V; {fs / ADC_COUNTS * 1e3:.1f} mV/count"))
    inj = (TVS_VC - 3.6) / v["R_VMOT_TOP"] - 3.6 / v["R_VMOT_BOT"]
    add(Row("ADC pin injection at the TVS clamp", f"{max(inj, 0) * 1e3:.2f} mA", "≤ 5 mA (STM32F103)", inj < 5e-3))
    add(Row("0603 VMOT_SENSE top resistor at the TVS clamp", f"{TVS_VC - 3.3:.1f} V", f"≤ {RES_0603_VMAX:.0f} V working",
            TVS_VC - 3.3 <= RES_0603_VMAX, f"UNI-ROYAL 0603WAF; the over-voltage divider's three parts "
            f"{(TVS_VC - OV_REF[0]) / 3:.0f} V each"))

    # --- encoder (PA6/PA7 are not 5 V tolerant)
    fc = 1 / (2 * math.pi * v["R_ENC_SERIES"] * v["C_ENC"])
    add(Row("encoder filter corner", f"{fc / 1e6:.2f} MHz", f"≥ 10 × {ENCODER_MAX_HZ / 1e3:.0f} kHz",
            fc >= 10 * ENCODER_MAX_HZ, "1 kΩ + 100 pF into a 74LVC2G17 at 3.3 V (inputs 5.5 V tolerant)"))
    add(Row("encoder pin at a 5 V encoder", "3.3 V at PA6/PA7", "≤ VDD + 0.3 V (not FT pins)", True,
            "the buffer, not the MCU, sees 5 V; SRV05-4 at the connector"))

    # --- bus budget
    pullups = 2 * 5.0 / v["R_ENC_PULLUP"] * 1e3
    bus = CORE_WORST_MA + HALL_ICC_MAX * 1e3 + ENCODER_MA + LOGIC_MISC_MA + pullups
    add(Row("from the bus (core, ACS725, encoder, pull-ups)", f"{bus:.0f} mA", f"≤ {BUS_LIMIT_MA:.0f} mA (docs/bus.md §6)",
            bus <= BUS_LIMIT_MA, f"encoder budget {ENCODER_MA:.0f} mA (5 V); the driver runs from VMOT"))
    return out


def oc_window() -> tuple[float, float]:
    """(OC_LO, OC_HI) in volts: the 10 k / 100 k / 10 k ladder from ADC_FS (the +3V3 rail)."""
    v = DESIGN_VALUES
    total = 2 * v["R_OC_OUTER"] + v["R_OC_MID"]
    return ADC_FS * v["R_OC_OUTER"] / total, ADC_FS * (v["R_OC_OUTER"] + v["R_OC_MID"]) / total


def oc_trip() -> tuple[float, float, float]:
    """The over-current trip magnitude (min, nominal, max) in amperes, either direction: the window's
    distance from the sensor's zero over its gain, with the sensitivity error, the offsets and the
    ladder's 1 % resistors."""
    lo, hi = oc_window()
    nom = (hi - ADC_FS / 2) / (HALL_MV_PER_A / 1e3)
    v = DESIGN_VALUES
    total = 2 * v["R_OC_OUTER"] + v["R_OC_MID"]
    # 1 % resistors, worst case: the outer one 1 % low, the others 1 % high (and back)
    ladder = ADC_FS * v["R_OC_OUTER"] * RES_TOL * 2 * (1 - v["R_OC_OUTER"] / total) / total
    spread = (OC_OFFSET_V + CMP_VOS + ladder) / (HALL_MV_PER_A / 1e3)
    return nom * (1 - OC_SENS_TOL) - spread, nom, nom * (1 + OC_SENS_TOL) + spread


def max_duty() -> float:
    """The largest duty the firmware may command (duty_limit's maximum, params.rs)."""
    return firmware_assumptions()["duty_limit max"]


def refresh_time() -> float:
    """The low side's conduction each period at the maximum duty: the bootstrap's refresh window."""
    return (1 - max_duty()) / PWM_HZ - 2 * dead_time()[1]


def boot_deficit() -> float:
    """Steady bootstrap deficit before each turn-on: the droop recovered by e^(−t/τ) each refresh,
    D = ΔV k / (1 − k), k = e^(−t_refresh/τ)."""
    v = DESIGN_VALUES
    tau = BOOT_DIODE_R * v["C_BS"] * C_BS_DC_BIAS
    t = max(refresh_time(), 0.0)
    k = math.exp(-t / tau)
    droop = (FET_QG * high_side_drive() / 10.0 + DRV_IHB_ON * max_duty() / PWM_HZ) / (v["C_BS"] * C_BS_DC_BIAS)
    return droop * k / (1 - k) if k < 1 else float("inf")


def copper_only_rating() -> float:
    """The continuous current at which T_J reaches the limit on board copper alone."""
    lo, hi = 1.0, I_CONT
    for _ in range(40):
        mid = (lo + hi) / 2
        if junction(mid, VIN_MAX, rth_board_to_air(), pad=False)[0] <= TJ_LIMIT:
            lo = mid
        else:
            hi = mid
    return lo


def peak_junction(tj20: float, p20: dict[str, float]) -> tuple[float, dict[str, float]]:
    """T_J after PEAK_S at I_PEAK starting from the 20 A steady state: the heatsink warms by its
    heat capacity, the junction-to-sink stack is at its new steady state."""
    stack = sum(stack_rth().values())
    total20 = sum(x for k, x in p20.items() if k != "worst FET")
    t_sink = T_AMB + total20 * HEATSINK_RTH
    tj = tj20
    for _ in range(50):
        p = losses(I_PEAK, VIN_MAX, tj)
        extra = sum(x for k, x in p.items() if k != "worst FET") - total20
        tj = t_sink + extra * PEAK_S / HEATSINK_J_PER_K + p["worst FET"] * stack
    return tj, p


README_BEGIN = "<!-- BEGIN generated by scripts/py -m r2ptools.kicad.calc.motor --markdown: do not edit -->"
README_END = "<!-- END generated -->"


def markdown() -> str:
    """The table as hardware/motor/README.md embeds it (tests/test_motor_calc.py keeps it current)."""
    out = [README_BEGIN, "", "| | what | value | limit | note |", "|---|---|---|---|---|"]
    for r in rows():
        tag = "ok" if r.ok else "**traded**" if "traded" in r.note else "**FAIL**"
        cells = (c.replace("|", "\\|") for c in (r.what, r.value, r.limit, r.note))
        out.append(f"| {tag} | " + " | ".join(cells) + " |")
    changes = firmware_changes()
    out += ["", "Firmware constants this board changes: " +
            ("; ".join(f"`{c}`" for c in changes) if changes else "none.")]
    return "\n".join(out + ["", README_END])


README = Path(__file__).resolve().parents[4] / "hardware/motor/README.md"


def readme_with_table(text: str) -> str:
    """`text` (the README) with its generated block replaced by the current table."""
    try:
        head, rest = text.split(README_BEGIN, 1)
        _, tail = rest.split(README_END, 1)
    except ValueError:
        raise ValueError(f"{README}: the markers {README_BEGIN!r} … {README_END!r} are missing: "
                         "put them where the table goes") from None
    return head + markdown() + tail


def write_readme() -> None:
    README.write_text(readme_with_table(README.read_text()))


def main(argv: list[str] | None = None) -> int:
    import sys
    argv = sys.argv[1:] if argv is None else argv
    if argv == ["--markdown"]:
        print(markdown())
        return 0
    if argv == ["--readme"]:
        write_readme()
        return 0
    if argv:
        print("usage: scripts/py -m r2ptools.kicad.calc.motor [--markdown | --readme]", file=sys.stderr)
        return 2
    rs = rows()
    w = max(len(r.what) for r in rs)
    wv = max(len(r.value) for r in rs)
    wl = max(len(r.limit) for r in rs)
    print("hardware/motor revision A power stage (r2ptools/kicad/calc/motor.py)\n")
    for r in rs:
        tag = "ok " if r.ok else "TRADE" if "traded" in r.note else "FAIL"
        print(f"{tag:<5} {r.what:<{w}}  {r.value:<{wv}}  {r.limit:<{wl}}  {r.note}".rstrip())
    changes = firmware_changes()
    print("\nfirmware constants this board changes (firmware/apps/motor, firmware/host/world):")
    print("\n".join(f"  {c}" for c in changes) if changes else "  none: the firmware agrees")
    return 0 if all(r.ok or "traded" in r.note for r in rs) else 1


if __name__ == "__main__":
    raise SystemExit(main())
