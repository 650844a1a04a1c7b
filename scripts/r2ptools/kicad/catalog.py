"""Every part a board may use: how KiCad draws it (symbol, footprint) and what it is (MPN).

The electrical and commercial facts about an MPN (manufacturer, LCSC number, package, price,
datasheet, description) live once, in `bom/parts.csv`, the project's parts database; this table
only binds a short key used by the module descriptions (`"R_10k"`) to a KiCad symbol, footprint,
displayed value and MPN. Every symbol the generator writes carries the MPN, Manufacturer and LCSC
fields copied from `bom/parts.csv`, so the schematic, the BOM and the database cannot disagree.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

from .. import ROOT, bom

PARTS_CSV = ROOT / "bom" / "parts.csv"


@dataclass(frozen=True)
class Item:
    key: str
    symbol: str
    footprint: str
    value: str
    mpn: str                          # "" for board features that are not parts (test pads)

    @property
    def on_bom(self) -> bool:
        """False for copper-only features: not ordered, not placed, no row in bom/parts.csv."""
        return bool(self.mpn)

    @property
    def row(self) -> dict[str, str]:
        if not self.on_bom:
            raise KeyError(f"catalogue entry {self.key!r} is a board feature, not a part: no BOM row")
        rows = database()
        if self.mpn not in rows:
            raise KeyError(f"catalogue entry {self.key!r}: MPN {self.mpn!r} has no row in {PARTS_CSV}")
        return rows[self.mpn]


R = "Device:R"
C = "Device:C"
R0603 = "Resistor_SMD:R_0603_1608Metric"
R0805 = "Resistor_SMD:R_0805_2012Metric"
C0603 = "Capacitor_SMD:C_0603_1608Metric"
C0805 = "Capacitor_SMD:C_0805_2012Metric"
C1206 = "Capacitor_SMD:C_1206_3216Metric"
C1210 = "Capacitor_SMD:C_1210_3225Metric"

_ITEMS = [
    # key, symbol, footprint, value, MPN
    # --- resistors, 0603 1 % thick film (UNI-ROYAL 0603WAF), JLCPCB basic parts
    ("R_1k", R, R0603, "1k", "0603WAF1001T5E"),
    ("R_10k", R, R0603, "10k", "0603WAF1002T5E"),
    ("R_47k", R, R0603, "47k", "0603WAF4702T5E"),
    ("R_56k", R, R0603, "56k", "0603WAF5602T5E"),
    ("R_3k9", R, R0603, "3.9k", "0603WAF3901T5E"),
    ("R_24k9", R, R0603, "24.9k", "0603WAF2492T5E"),
    ("R_27k", R, R0603, "27k", "0603WAF2702T5E"),
    ("R_100k", R, R0603, "100k", "0603WAF1003T5E"),
    ("R_150k", R, R0603, "150k", "0603WAF1503T5E"),
    ("R_6k8", R, R0603, "6.8k", "0603WAF6801T5E"),
    ("R_174k", R, R0603, "174k", "0603WAF1743T5E"),
    ("R_60R4", R, R0805, "60.4", "0805W8F604JT5E"),        # split CAN termination, 0.125 W
    # --- resistors, 0603 0.1 % 25 ppm/K thin film (YAGEO RT0603BRD), JLCPCB extended parts: the
    # buck's feedback divider, where 1 % parts alone would take VOUT out of the bus's 5.00 V ± 2 %
    # (calc/psu.py, "VOUT worst case"); LCSC numbers as public JLC BOMs give them (README errata)
    ("R_102k_0.1%", R, R0603, "102k 0.1%", "RT0603BRD07102KL"),
    ("R_25k5_0.1%", R, R0603, "25.5k 0.1%", "RT0603BRD0725K5L"),
    # --- capacitors
    ("C_30p", C, C0603, "30pF C0G", "0603CG300J500NT"),
    ("C_4n7", C, C0603, "4.7nF", "0603B472K500NT"),
    ("C_10n", C, C0603, "10nF", "0603B103K500NT"),
    ("C_100n", C, C0603, "100nF", "CC0603KRX7R9BB104"),
    ("C_1u", C, C0603, "1uF", "CL10A105KB8NNNC"),
    ("C_10u", C, C0805, "10uF 25V", "CL21A106KAYNNNE"),
    ("C_22n", C, C0603, "22nF", "CL10B223KB8NNNC"),
    ("C_470n", C, C0603, "470nF 25V", "CL10B474KA8NNNC"),
    ("C_10u_50V", C, C1206, "10uF 50V", "CL31B106KBHNNNE"),
    ("C_100n_100V", C, C0603, "100nF 100V", "CL10B104KC8NNNC"),
    ("C_2u2_100V", C, C1210, "2.2uF 100V", "CL32B225KCJSNNE"),
    ("C_22u_25V", C, C1210, "22uF 25V", "CS3225X7R226K250NRL"),
    # --- core actives and electromechanics
    ("STM32F103CBT6", "MCU_ST_STM32F1:STM32F103CBTx", "Package_QFP:LQFP-48_7x7mm_P0.5mm",
     "STM32F103CBT6", "STM32F103CBT6"),
    ("AP2112K-3.3", "Regulator_Linear:AP2112K-3.3", "Package_TO_SOT_SMD:SOT-23-5",
     "AP2112K-3.3", "AP2112K-3.3TRG1"),
    ("SN65HVD230", "Interface_CAN_LIN:SN65HVD230", "Package_SO:SOIC-8_3.9x4.9mm_P1.27mm",
     "SN65HVD230", "SN65HVD230DR"),
    ("PESD2CAN", "Power_Protection:NUP2105L", "Package_TO_SOT_SMD:SOT-23",
     "PESD2CAN", "PESD2CAN,215"),
    ("XTAL_8M", "Device:Crystal_GND24", "Crystal:Crystal_SMD_3225-4Pin_3.2x2.5mm",
     "8MHz", "X32258MSB4SI"),
    ("RJ45", "Connector:RJ45", "R2P:RJ45_Amphenol_54602-x08_Horizontal",
     "RJ45", "54602-908LF"),
    ("HDR_1x4", "Connector_Generic:Conn_01x04",
     "Connector_PinHeader_2.54mm:PinHeader_1x04_P2.54mm_Vertical", "BUS", "PZ254V-11-04P"),
    ("SWD_2x5", "Connector:Conn_ARM_JTAG_SWD_10",
     "Connector_PinHeader_1.27mm:PinHeader_2x05_P1.27mm_Vertical_SMD", "SWD", "FTSH-105-01-L-DV-K"),
    ("SW_TACT", "Switch:SW_Push", "Button_Switch_SMD:SW_Push_1P1T_XKB_TS-1187A",
     "TS-1187A", "TS-1187A-B-A-B"),
    ("SW_DIP_2", "Switch:SW_DIP_x02",
     "Button_Switch_SMD:SW_DIP_SPSTx02_Slide_KingTek_DSHP02TS_W7.62mm_P1.27mm", "DSHP02TS",
     "DSHP02TSGER"),
    ("SMAJ5.0A", "Diode:SMAJ5.0A", "Diode_SMD:D_SMA", "SMAJ5.0A", "SMAJ5.0A"),
    # a bare copper test pad: part of the board, not of the BOM or the placement file
    ("TP", "Connector:TestPoint", "TestPoint:TestPoint_Pad_D1.0mm", "TP", ""),
    ("LED_G", "Device:LED", "LED_SMD:LED_0603_1608Metric", "yellow-green", "KT-0603YG"),
    ("LED_Y", "Device:LED", "LED_SMD:LED_0603_1608Metric", "yellow", "KT-0603Y"),
    ("LED_R", "Device:LED", "LED_SMD:LED_0603_1608Metric", "red", "KT-0603R"),
    ("PTC_500mA", "Device:Polyfuse", "Fuse:Fuse_1206_3216Metric", "0.5A", "BSMD1206-050-6V"),
    # --- psu
    ("XT30", "Connector_Generic:Conn_01x02", "R2P:AMASS_XT30PW-M_1x02_P2.50mm_Horizontal",
     "XT30 IN", "XT30PW-M"),
    # Vishay's SQD50P06-15L (AEC-Q101) on KiCad's SUD50P06-15 symbol: the same TO-252 part family
    # and pinout (1 G, 2 D tab, 3 S), -60 V, 15.5/20 mohm at -10/-4.5 V, +-20 V gate; LCSC C3281500
    # is the number other public JLC BOMs give for it (README errata)
    ("SQD50P06-15L", "Transistor_FET:SUD50P06-15", "Package_TO_SOT_SMD:TO-252-2", "SQD50P06-15L",
     "SQD50P06-15L_GE3"),
    ("FUSE_5A_SLOW", "Device:Fuse", "Fuse:Fuse_Littelfuse-NANO2-451_453", "5A T 125V", "0452005.MRL"),
    ("Z_15V", "Device:D_Zener", "Diode_SMD:D_SOD-123", "15V", "BZT52C15"),
    ("SMBJ40A", "Device:D_TVS", "Diode_SMD:D_SMB", "SMBJ40A", "SMBJ40A"),
    ("R_10m", R, "Resistor_SMD:R_1206_3216Metric", "10m 1%", "RL1206FR-7W0R01L"),
    ("INA293A2", "Amplifier_Current:INA293A2", "Package_TO_SOT_SMD:SOT-23-5", "INA293A2",
     "INA293A2IDBVR"),
    ("LM76005", "Regulator_Switching:LM76005",
     "Package_DFN_QFN:Texas_RNP0030B_WQFN-30-1EP_4x6mm_P0.5mm_EP1.8x4.5mm", "LM76005", "LM76005RNPR"),
    ("L_10u", "Device:L", "Inductor_SMD:L_Bourns_SRP1038C_10.0x10.0mm", "10uH 7.5A", "SRP1038A-100M"),
    # TPS16630PWPR on KiCad's TPS26631PWP symbol: KiCad has no TPS1663 symbol; the HTSSOP-20
    # pinouts agree pin for pin (SLVSET9 table 6-1 vs SLVSDO8) except that the TPS16630 has no
    # B_GATE/DRV (its pins 4, 5 and 17 are NC), calls IN_SYS P_IN (6) and has PGOOD on 16 (the
    # symbol's PGTH). hardware/psu/psu.kicad_sch wires the pins by what the TPS16630 has there.
    ("TPS16630", "Power_Management:TPS26631PWP",
     "R2P:HTSSOP-20-1EP_4.4x6.5mm_P0.65mm_EP3.4x6.5mm", "TPS16630", "TPS16630PWPR"),
    # --- proximity
    ("JST_PH_3", "Connector_Generic:Conn_01x03",
     "R2P:JST_PH_S3B-PH-K_1x03_P2.00mm_Horizontal", "PH 3p", "S3B-PH-K-S(LF)(SN)"),
    ("SRV05-4", "Power_Protection:SRV05-4", "Package_TO_SOT_SMD:SOT-23-6", "SRV05-4",
     "SRV05-4-P-T7"),
    # KiCad has no TPS2553 symbol; ROHM's BD2222G is pin for pin the same SOT-23-6 switch
    # (1 IN, 2 GND, 3 EN active high, 4 open-drain fault, 5 ILIM, 6 OUT)
    ("TPS2553", "Power_Management:BD2222G", "Package_TO_SOT_SMD:SOT-23-6", "TPS2553",
     "TPS2553DBVR"),
    # --- motor (hardware/motor/motor.py; design numbers in calc/motor.py)
    ("R_2k2", R, R0603, "2.2k", "0603WAF2201T5E"),
    ("R_10R", R, R0603, "10", "0603WAF100JT5E"),
    ("C_100p", C, C0603, "100pF C0G", "0603CG101J500NT"),
    ("C_1000u_63V", "Device:C_Polarized", "Capacitor_THT:CP_Radial_D16.0mm_P7.50mm", "1000uF 63V",
     "EEU-FS1J102"),
    ("CSD19536KTT", "Transistor_FET:Q_NMOS_GDS", "Package_TO_SOT_SMD:TO-263-2", "CSD19536KTT",
     "CSD19536KTT"),
    # the gate driver: KiCad 9's own symbol and pin table (Renesas FN3676's SOIC-16 pinout)
    ("HIP4082", "Driver_FET:HIP4082xB", "Package_SO:SOIC-16_3.9x9.9mm_P1.27mm", "HIP4082",
     "HIP4082IBZT"),
    ("1N4148W", "Diode:1N4148W", "Diode_SMD:D_SOD-123", "1N4148W", "1N4148W"),
    # BCX56 in SOT89 is pin 1 emitter, 2 collector, 3 base (NXP BCP56_BCX56_BC56PA Rev. 9,
    # Table 3); KiCad 9's Transistor_BJT:BCX56 numbers it B-C-E (Q_NPN_BCE), which would swap
    # base and emitter: the generic E-C-B symbol carries the datasheet's numbering
    ("BCX56", "Transistor_BJT:Q_NPN_ECB", "Package_TO_SOT_SMD:SOT-89-3", "BCX56-16", "BCX56-16"),
    ("Z_13V", "Device:D_Zener", "Diode_SMD:D_SOD-123", "13V", "BZT52C13"),
    ("2N7002", "Transistor_FET:2N7002", "Package_TO_SOT_SMD:SOT-23", "2N7002", "2N7002"),
    ("LMV331", "Comparator:LMV331", "Package_TO_SOT_SMD:SOT-23-5", "LMV331", "LMV331IDBVR"),
    ("ACS725-30AB", "Sensor_Current:ACS725xLCTR-30AB", "Package_SO:SOIC-8_3.9x4.9mm_P1.27mm",
     "ACS725 30AB", "ACS725LLCTR-30AB-T"),
    ("TLV3011", "R2P:TLV3011", "Package_TO_SOT_SMD:SOT-23-6", "TLV3011", "TLV3011AIDBVR"),
    ("74LVC2G17", "R2P:74LVC2G17", "Package_TO_SOT_SMD:SOT-23-6", "74LVC2G17", "SN74LVC2G17DBVR"),
    ("SMCJ45A", "Device:D_TVS", "Diode_SMD:D_SMC", "SMCJ45A", "SMCJ45A-E3/57T"),
    # 30 A NANO2 456: KiCad has no 456 land pattern; R2P's is the datasheet's recommended one
    ("FUSE_30A", "Device:Fuse", "R2P:Fuse_Littelfuse-NANO2-456", "30A", "0456030.ER"),
    ("XT60_M", "Connector_Generic:Conn_01x02", "R2P:AMASS_XT60PW-M_1x02_P7.20mm_Horizontal",
     "XT60 IN", "XT60PW-M"),
    ("XT60_F", "Connector_Generic:Conn_01x02", "R2P:AMASS_XT60PW-F_1x02_P7.20mm_Horizontal",
     "XT60 MOTOR", "XT60PW-F"),
    # --- gateway (hardware/gateway/gateway.py; design numbers in calc/gateway.py)
    ("STM32F407VGT6", "MCU_ST_STM32F4:STM32F407VGTx", "Package_QFP:LQFP-100_14x14mm_P0.5mm",
     "STM32F407VGT6", "STM32F407VGT6"),
    # KiCad 9's Interface_Ethernet:LAN8742A with VDDCR (the 1.2 V regulator's output) drawn right of
    # VDD2A instead of between VDDIO and VDD1A, so the three 3.3 V pins join one rail on the sheet
    ("LAN8742A", "R2P:LAN8742A",
     "Package_DFN_QFN:VQFN-24-1EP_4x4mm_P0.5mm_EP2.5x2.5mm", "LAN8742A",
     "LAN8742A-CZ-TR"),
    # the Ethernet jack: magnetics, Bob Smith termination and two LEDs inside (HanRun HR911105A),
    # shielded metal, unlike the bus jacks' plastic 54602 (no magnetics): it cannot be mistaken
    ("RJ45_MAG", "Connector:RJ45_Hanrun_HR911105A_Horizontal",
     "R2P:RJ45_Hanrun_HR911105A_Horizontal", "ETHERNET", "HR911105A"),
    ("XTAL_25M", "Device:Crystal_GND24", "Crystal:Crystal_SMD_3225-4Pin_3.2x2.5mm",
     "25MHz", "X322525MOB4SI"),
    ("C_15p", C, C0603, "15pF C0G", "CL10C150JB8NNNC"),
    ("C_2u2", C, C0603, "2.2uF", "CL10A225KO8NNNC"),
    ("C_470p", C, C0603, "470pF", "0603B471K500NT"),
    ("R_49R9", R, R0603, "49.9", "0603WAF499JT5E"),
    ("R_1k5", R, R0603, "1.5k", "0603WAF1501T5E"),
    ("R_510", R, R0603, "510", "0603WAF5100T5E"),        # the PHY crystal's RS (calc/gateway.py)
    ("R_12k1", R, R0805, "12.1k", "0805W8F1212T5E"),     # 0805: the 1 % value public JLC BOMs confirm
    ("LED_B", "Device:LED", "LED_SMD:LED_0603_1608Metric", "blue", "KT-0603B"),
    # --- imu (hardware/imu/imu.py; design numbers in calc/imu.py)
    # KiCad 9 has no LSM6DSO symbol: the LSM6DSM's is the same LGA-14L pin table (1 SDO/SA0, 2 SDx,
    # 3 SCx, 4 INT1, 5 VDDIO, 6-7 GND, 8 VDD, 9 INT2, 10 OCS_Aux, 11 SDO_Aux, 12 CS, 13 SCL, 14 SDA;
    # LSM6DSO DS12140 Table 2) on the same 2.5 x 3 mm land pattern
    ("LSM6DSO", "Sensor_Motion:LSM6DSM", "Package_LGA:LGA-14_3x2.5mm_P0.5mm_LayoutBorder3x4y",
     "LSM6DSO", "LSM6DSOTR"),
    ("LIS3MDL", "Sensor_Magnetic:LIS3MDL", "Package_LGA:LGA-12_2x2mm_P0.5mm", "LIS3MDL", "LIS3MDLTR"),
    # the LPS22HH (LCSC stocks it; not the LPS22DF) drawn with KiCad's LPS22DF symbol: the same
    # HLGA-10L pin table (1 Vdd_IO, 2 SCL, 3 reserved to GND, 4 SDA, 5 SA0, 6 CS, 7 INT_DRDY, 8-9
    # GND, 10 VDD; the DF calls pin 8 GND_IO) and land pattern; KiCad's own LPS22HH symbol (an
    # LPS25HB alias) stacks pins 3, 8 and 9 on one hidden pin, which would leave the drawn board's
    # GND wire to pin 9 dangling. The firmware runs either part (r2p_drivers::lps22).
    ("LPS22HH", "Sensor_Pressure:LPS22DF", "Package_LGA:ST_HLGA-10_2x2mm_P0.5mm_LayoutBorder3x2y",
     "LPS22HH", "LPS22HHTR"),
    # the Pixhawk connector standard's (DS-009) basic GPS port: JST GH 6 pins, side entry
    ("JST_GH_6", "Connector_Generic_MountingPin:Conn_01x06_MountingPin",
     "Connector_JST:JST_GH_SM06B-GHS-TB_1x06-1MP_P1.25mm_Horizontal", "GPS (DS-009)",
     "SM06B-GHS-TB(LF)(SN)"),
    ("HDR_1x5", "Connector_Generic:Conn_01x05",
     "Connector_PinHeader_2.54mm:PinHeader_1x05_P2.54mm_Vertical", "GNSS", "PZ254V-11-05P"),
    # a 3-pad solder jumper, pads 1-2 bridged by a copper trace: a board feature, no BOM line
    ("SJ_3_BRIDGED12", "Jumper:SolderJumper_3_Bridged12",
     "Jumper:SolderJumper-3_P1.3mm_Bridged12_RoundedPad1.0x1.5mm", "GNSS VCC", ""),
]

_BY_KEY = {k: Item(k, s, f, v, m) for k, s, f, v, m in _ITEMS}


def item(key: str) -> Item:
    if key not in _BY_KEY:
        raise KeyError(f"no catalogue entry {key!r} in r2ptools/kicad/catalog.py")
    return _BY_KEY[key]


def items() -> list[Item]:
    return list(_BY_KEY.values())


@functools.cache
def database() -> dict[str, dict[str, str]]:
    """bom/parts.csv by MPN, with the KiCad symbol field names as keys.

    Read through `r2ptools.bom.load_parts`, the one reader of the database; an LCSC of `-`
    (LCSC does not stock the part) becomes an empty `LCSC` field on the symbol."""
    parts, errors = bom.load_parts(PARTS_CSV, ROOT)
    if errors:
        raise ValueError("\n".join(errors))
    return {mpn: {"MPN": mpn, "Manufacturer": f["manufacturer"],
                  "LCSC": "" if f["lcsc"] == bom.NOT_AT_LCSC else f["lcsc"],
                  "Package": f["package"], "Datasheet": f["datasheet"],
                  "Description": f["description"]}
            for mpn, f in ((mpn, row.fields) for mpn, row in parts.items())}
