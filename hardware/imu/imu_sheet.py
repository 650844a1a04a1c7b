"""How the IMU module's root sheet is drawn (hardware/imu/imu.kicad_sch): one block per function.

Top left the fused bus tap (as the template's), the core sheet's box beside it; right of the box
the three sensors (SPI1's two, SPI2's LIS3MDL), each in its block with its decoupling and chip-select pull-up; bottom
left the GNSS port (supply jumper, the two connectors, the ESD clamp, the PPS protection); below
them the placement notes (the magnetometer's distances, from calc/imu.py). The MCU's signals
meet the blocks by label. Grid units of 2.54 mm (drawing.py).
"""
from __future__ import annotations

from r2ptools.kicad.calc import imu as calc
from r2ptools.kicad.design import At, Block

A = At
_b = calc.budget()
_d = {k: calc._dist_mm("U102", k) for k in ("bus +5V band", "H3", "M5 left", "JP101")}

DRAWING = {
    # bus tap
    "F101": A(20, 14, 90),
    "flag:+5V": A(8, 22), "flag:GND": A(18, 22), "flag:+5V_MOD": A(28, 22),
    "sheet:core": A(60, 8),
    # LSM6DSO turned a quarter: its SPI and strap pins along the bottom, INT1/INT2 on top
    "U101": A(104, 20, 90), "C101": A(118, 12), "C102": A(123, 12), "R103": A(90, 12),
    # LPS22HH
    "U103": A(140, 22), "C106": A(150, 10), "C107": A(155, 10), "R102": A(157, 27),
    # LIS3MDL
    "U102": A(104, 62), "C103": A(116, 50), "C104": A(121, 50), "C105": A(120, 68),
    "R101": A(90, 56, 90),
    # GNSS port, one small block each, so the connectors meet by label, not by long wires
    "JP101": A(18, 50, 270), "R105": A(32, 50),
    "D101": A(58, 58), "R104": A(72, 66, 90), "R106": A(68, 72),
    "J101": A(14, 74, 180), "J102": A(50, 85, 180),
}

BLOCKS = [
    Block("Bus tap: the module's own fused 5 V", 4, 4, 50, 34, notes=[
        (6, 28, "F101 0.5 A hold polyfuse: a module that shorts inside trips its own fuse\n"
                "instead of pulling the whole bus into the PSU's current limit.")]),
    Block("Accelerometer + gyroscope LSM6DSO (SPI1, CS PA4)", 84, 4, 128, 40, notes=[
        (85, 35, "Mode 1 (DS12140 Table 2): SPI 4-wire, SDx/SCx to GND,\nOCS_Aux and SDO_Aux open."
                 " 100 nF at VDD and VDDIO.\nR103 keeps CS high (deselected) while the MCU resets.")]),
    Block("Barometer LPS22HH (SPI1, CS PA2)", 130, 4, 163, 40, notes=[
        (131, 33, "CS low = SPI; CS high = I2C/I3C:\nR102 holds it high (idle) in reset.\n"
                  "SA0 is SDO in 4-wire SPI.")]),
    Block("Magnetometer LIS3MDL (SPI2, CS PA3)", 84, 42, 140, 82, notes=[
        (85, 76, "C1 100 nF (DocID024204 Table 2). Vdd 100 nF + 1 uF,\nVdd_IO 100 nF."
                 " SDO/SA1 is SDO in 4-wire SPI.\nAlone on SPI2 (PB13-15): no I2C-disable bit"
                 " (DS9463\nTable 25), deselected it listens as I2C on SCL/SDA.")]),
    Block("GNSS supply", 4, 42, 40, 58, notes=[
        (6, 55.5, "JP101 1-2 bridged: +5V_MOD (default);\ncut, bridge 2-3: +3V3.")]),
    Block("GNSS lines: ESD clamp, PPS into PB1", 42, 42, 82, 76, notes=[
        (43, 74, f"R104 1 k: a 5 V PPS injects {calc.pps_injection_ma():.1f} mA (PB1: <= 5 mA).")]),
    Block("Pixhawk DS-009 basic GPS port (JST GH)", 4, 60, 40, 92, notes=[
        (6, 86, "1 VCC, 2 TX out, 3 RX in,\n4 SCL, 5 SDA (open), 6 GND.")]),
    Block("GNSS header 0.1 in (with PPS)", 42, 78, 82, 92),
    Block("Placement of the magnetometer (board, README)", 4, 94, 100, 114, notes=[
        (6, 103, f"U102 sits mid bottom edge: {_d['bus +5V band']:.0f} mm from the bus +5V band,"
                f" {_d['H3']:.0f} mm from the M3 holes,\n{_d['M5 left']:.1f} mm from the case's"
                f" M5 floor screws, {_d['JP101']:.0f} mm from the GNSS supply (JP101).\n"
                f"3 A of bus current: <= {calc.field_ut(3.0, _d['bus +5V band']):.0f} uT as one"
                f" wire, ~{calc.field_ut(3.0, _d['bus +5V band'], calc.RETURN_GAP_MM):.1f} uT with"
                " its return (estimate, measure).\nNo inductor, no magnetics jack on the board.\n"
                f"Budget: core {calc.CORE_WORST_MA:g} + sensors {_b['sensors_ma']:.1f} + receiver"
                f" peak 67 mA = {_b['total_ma']:.0f} mA <= 200 mA (receiver up to"
                f" {_b['receiver_allowed_ma']:.0f} mA).")]),
]
