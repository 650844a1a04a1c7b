"""Component heights above (or below) the board, for the case's clearances.

KiCad boards carry no body heights unless someone types them, and the 3D models (kicad-packages3d,
4.7 GB) are not installed, so a height comes from the first of:

1. the footprint's `Height` field (mm, e.g. `13.5` or `13.5mm`): set it on any part to be exact;
2. the footprint name, where KiCad's libraries encode it: `..._H8mm` (`L_12x12mm_H8mm`),
   `CP_Elec_8x10.5` (diameter x height), `CP_EIA-3528-21` (2.1 mm);
3. the table below, by library and name: each value is the tallest common part of its kind
   (a bound, not a typical value), so a case that fits these fits the real parts.

A footprint none of these cover is an error naming it: add a `Height` field or a table row
(with the datasheet maximum) rather than guess.
"""
from __future__ import annotations

import re

from ..kicad import fplib

# (pattern on "Library:Footprint", height in mm, what bounds it). First match wins.
TABLE: list[tuple[str, float, str]] = [
    # zero-height items: no body above the copper
    (r"^(MountingHole|Fiducial|TestPoint|NetTie|Symbol|Jumper):", 0.0, "no body"),
    (r"^[^:]*:(SolderJumper|TestPoint_Pad)", 0.0, "no body"),
    # connectors
    (r"^Connector_RJ:RJ45_.*Vertical", 16.5, "vertical 8P8C jacks"),
    (r"^Connector_RJ:RJ(45|12|14|25|9)_", 14.0, "horizontal 8P8C jacks, tab up/down: 13.3-13.9 mm"),
    (r"^Connector_PinHeader_2\.54mm:.*_Vertical", 8.5, "2.5 mm body + 6 mm pins"),
    (r"^Connector_PinHeader_2\.54mm:.*_Horizontal", 3.0, "2.5 mm body, pins bent sideways"),
    (r"^Connector_PinHeader_(1\.27|1\.00|2\.00)mm:.*_Vertical", 6.5, "body + pins"),
    (r"^Connector_PinHeader_(1\.27|1\.00|2\.00)mm:.*_Horizontal", 3.0, "body, pins sideways"),
    (r"^Connector_PinSocket_2\.54mm:", 8.5, "2.54 mm sockets"),
    (r"^Connector_PinSocket_", 6.5, "fine-pitch sockets"),
    (r"^Connector_IDC:", 9.2, "boxed IDC headers"),
    (r"^Connector_JST:JST_XH_", 9.8, "XH, top or side entry"),
    (r"^Connector_JST:JST_EH_", 8.0, "EH"),
    (r"^Connector_JST:JST_PH_", 6.1, "PH, top or side entry"),
    (r"^Connector_JST:JST_(GH|SH|ZH)_", 4.3, "GH/SH/ZH"),
    (r"^Connector_JST:JST_VH_", 17.0, "VH"),
    (r"^Connector_Molex:Molex_KK-254", 12.0, "KK 254 headers"),
    (r"^Connector_Molex:Molex_Micro-Fit", 11.0, "Micro-Fit 3.0"),
    (r"^Connector_Molex:Molex_(PicoBlade|Pico-Lock|CLIK-Mate)", 6.5, "wire-to-board, fine pitch"),
    (r"^Connector_AMASS:AMASS_XT30PW", 7.0, "XT30 right angle"),
    (r"^Connector_AMASS:AMASS_XT60PW", 9.0, "XT60 right angle"),
    (r"^Connector_AMASS:AMASS_XT30", 12.0, "XT30 vertical"),
    (r"^Connector_AMASS:AMASS_XT60", 16.5, "XT60 vertical"),
    (r"^Connector_BarrelJack:", 11.5, "DC barrel jacks"),
    (r"^Connector_USB:USB_Micro", 3.2, "micro-B receptacles"),
    (r"^Connector_USB:USB_C_", 3.6, "USB-C receptacles"),
    (r"^Connector_Phoenix_MSTB:", 13.0, "MSTB headers"),
    (r"^Connector_Phoenix_MC:", 9.5, "MC headers"),
    (r"^TerminalBlock", 12.5, "PCB screw terminals (5.0/5.08 mm)"),
    # switches and buttons
    (r"^Button_Switch_SMD:SW_DIP_", 3.0, "SMD DIP and slide switches"),
    (r"^Button_Switch_SMD:SW_(Push|SPST|Tactile)", 5.5, "SMD tact switches"),
    (r"^Button_Switch_SMD:", 5.5, "SMD switches"),
    (r"^Button_Switch_THT:SW_DIP_", 5.0, "DIP switches"),
    (r"^Button_Switch_THT:", 9.5, "THT tact switches"),
    # passives
    (r"^Resistor_SMD:", 0.8, "chip resistors, 0402-2512"),
    (r"^Capacitor_SMD:C_(0201|0402|0603)", 1.0, "MLCC"),
    (r"^Capacitor_SMD:C_(0805|1206)", 1.8, "MLCC, high-capacitance"),
    (r"^Capacitor_SMD:C_(1210|1812|2220)", 2.8, "MLCC, high-capacitance"),
    (r"^Capacitor_Tantalum_SMD:", 3.0, "tantalum, case E"),
    (r"^Capacitor_THT:CP_Radial_D16\.0mm", 27.0,
     "16 mm radial electrolytics up to 16 x 25 mm (+2 mm: Rubycon ZLH's length tolerance above "
     "20 mm); a taller can needs a Height field"),
    (r"^Inductor_SMD:L_(0402|0603|0805|1008|1206|1210)", 2.0, "chip inductors and beads"),
    (r"^Inductor_SMD:", 10.0, "shielded power inductors up to 12.5 mm square"),
    (r"^Fuse:Fuse_(0402|0603|0805|1206|1210|1812|2010|2512)", 1.5, "chip fuses and PTCs"),
    (r"^R2P:Fuse_Littelfuse-NANO2-456", 3.35, "NANO2 456: 3.05 mm square body (456 datasheet), +0.3"),
    (r"^Fuse:", 10.0, "fuse holders"),
    (r"^Crystal:Crystal_SMD_(2016|2520|3225|5032|2012)", 1.2, "ceramic SMD crystals"),
    (r"^Crystal:Crystal_SMD_HC49", 4.5, "HC49-SD"),
    (r"^Crystal:Crystal_HC49-U_", 13.5, "HC49/U"),
    (r"^Crystal:Crystal_HC49-4H_", 4.0, "HC49/4H"),
    (r"^Oscillator:Oscillator_SMD_", 1.6, "SMD oscillators"),
    # semiconductors
    (r"^LED_SMD:", 1.4, "chip LEDs, 0402-1206 and PLCC"),
    (r"^LED_THT:LED_D3\.0mm", 5.6, "3 mm LEDs"),
    (r"^LED_THT:LED_D5\.0mm", 9.0, "5 mm LEDs"),
    (r"^Diode_SMD:D_(SOD|MiniMELF|MicroMELF|SOT|0603|0805|1206)", 1.4, "small SMD diodes"),
    (r"^Diode_SMD:D_(SMA|SMB|SMC|PowerDI|SMF|TO-|DPAK|D2PAK)", 2.7, "power SMD diodes"),
    (r"^Diode_SMD:", 2.7, "SMD diodes"),
    (r"^Diode_THT:", 5.5, "axial diodes, up to DO-201 lying"),
    (r"^Package_QFP:", 1.7, "LQFP/TQFP"),
    (r"^Package_(DFN_QFN|SON|LGA|CSP|BGA):", 1.6, "leadless and area-array packages"),
    (r"^Package_SO:(TSSOP|MSOP|SSOP|VSSOP|HTSSOP|TSOP)", 1.3, "thin small-outline"),
    (r"^Package_SO:", 1.8, "SOIC"),
    (r"^Package_TO_SOT_SMD:(SOT-23|SOT-323|SOT-353|SOT-363|SOT-523|SOT-563|SC-70|TSOT)", 1.45, "SOT-23 family"),
    (r"^Package_TO_SOT_SMD:(SOT-89|SOT-223)", 1.8, "SOT-89, SOT-223"),
    (r"^Package_TO_SOT_SMD:(TO-252|DPAK)", 2.5, "DPAK"),
    (r"^Package_TO_SOT_SMD:(TO-263|D2PAK|TO-268)", 4.8, "D2PAK"),
    (r"^Package_TO_SOT_SMD:", 2.5, "other SMD power packages"),
    (r"^Package_TO_SOT_THT:TO-220.*Horizontal", 5.0, "TO-220 lying"),
    (r"^Package_TO_SOT_THT:TO-92", 5.5, "TO-92"),
    (r"^Package_DIP:", 5.1, "DIP"),
]

_NAME_H = re.compile(r"_H(\d+(?:\.\d+)?)mm")
_ELEC = re.compile(r":CP_Elec_\d+(?:\.\d+)?x(\d+(?:\.\d+)?)")
_EIA = re.compile(r":(?:CP|C)_EIA-\d{4}-(\d{2})")
_FIELD = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*(mm)?\s*$")


class HeightError(ValueError):
    """A footprint's height is unknown or malformed."""


def height_of(fpid: str, ref: str, field: str | None, where: str) -> tuple[float, str]:
    """(height in mm, where it came from) for footprint `fpid` ("Lib:Name")."""
    if field is not None and field.strip():
        m = _FIELD.match(field)
        if not m:
            raise HeightError(f"{where}: {ref} ({fpid}): Height field {field!r} is not a number of mm; "
                              "write it like 13.5 or 13.5mm")
        return float(m.group(1)), "Height field"
    for rx, src in ((_NAME_H, "name _H…mm"), (_ELEC, "name CP_Elec_DxH"), (_EIA, "name EIA code")):
        m = rx.search(fpid)
        if m:
            h = float(m.group(1))
            return (h / 10 if rx is _EIA else h), src
    fpid = fplib.source(fpid)        # a project variant (R2P:) is its KiCad source's body
    for pattern, h, what in TABLE:
        if re.search(pattern, fpid):
            return h, f"table: {what}"
    raise HeightError(
        f"{where}: {ref} ({fpid}): no height known for this footprint. Add a 'Height' field "
        "(mm, datasheet maximum) to the footprint in KiCad, or a row to "
        "scripts/r2ptools/enclosure/heights.py TABLE")
