"""hardware/imu revision A: the IMU module, three ST sensors on SPI1 and SPI2 and an external
GNSS port, on the common core.

    SPI1 (PA5 SCK, PA6 MISO, PA7 MOSI; mode 3, 4-wire) shared by
      U101 LSM6DSO  accelerometer + gyroscope, CS PA4 (IMU_CS),  INT1 -> PB0 (IMU_INT1)
      U103 LPS22HH  barometer,                  CS PA2 (BARO_CS), INT_DRDY -> PA0 (BARO_INT)
    SPI2 (PB13 SCK, PB14 MISO, PB15 MOSI; mode 3, 4-wire) alone
      U102 LIS3MDL  magnetometer,               CS PA3 (MAG_CS),  DRDY -> PA1 (MAG_DRDY)
    (the LIS3MDL has no I2C-disable bit, DS9463 Rev 7 Table 25: deselected, it listens as an I2C
    target on SCL/SDA, so it gets a bus no other part's traffic runs on);
    each chip select pulled up (R101-R103, 10 k): the three stay deselected (their I2C mode, idle)
    while the MCU is in reset and its pins float.
    GNSS receiver (u-blox class, UBX/NMEA) on USART1: PA9 GNSS_TX to the receiver's RX, PA10
    GNSS_RX from its TX (R105 holds it idle-high with nothing plugged), its time pulse through
    R104 (1 k: PB1 is not 5 V tolerant) to PB1 GNSS_PPS (TIM3_CH4 input capture), R106 holding
    PPS low with nothing plugged; D101 (SRV05-4) clamps the three lines at the connectors.
    Two connectors, wired in parallel: J101 the Pixhawk connector standard's (DS-009) basic GPS
    port (JST GH 6: 1 VCC, 2 TX out, 3 RX in, 4 SCL, 5 SDA, 6 GND; SCL/SDA not wired: the board
    file gives the receiver no I2C) for the common drone GNSS modules (u-blox M8N/M9N/M10 with a
    compass), and J102 a 0.1" header (VCC, GND, TX, RX, PPS) for breakouts and for the PPS, which
    DS-009's port does not carry. JP101 selects the receiver's supply: pads 1-2 bridged (the
    default) +5V_MOD, cut and bridge 2-3 for +3V3 (calc/imu.py: the current and heat of each).

Pins: firmware/boards/imu.toml (scripts/check-pins imu). Design numbers: calc/imu.py.
Placement (calc/imu.py PLACES, README "Magnetometer"): the three sensors in the board's bottom
band, the magnetometer in the middle of the bottom edge, as far from the bus's +5V band (33 mm),
the M3 holes (26 mm) and the case's M5 screws (17.5 mm) as the 60 x 50 mm board allows; the GNSS
supply's copper on the left, away from it. The board has no inductor and no magnetics jack.
"""
from __future__ import annotations

from r2ptools.kicad.design import Module, Place, Sheet
from r2ptools.kicad.calc import imu as calc
from r2ptools.kicad.modules import core as core_mod
from r2ptools.kicad.modules import drawing_of
from r2ptools.kicad.modules.common import (BUS_TAP_PLACE, bus_tap, bus_tap_track, core_tracks,
                                           frame_texts, tvs_track)

NAME = "imu"
TITLE = "R2P IMU module"
REVISION = "A"

PINS = {"PA5": "IMU_SCK", "PA6": "IMU_MISO", "PA7": "IMU_MOSI", "PA4": "IMU_CS", "PB0": "IMU_INT1",
        "PB13": "MAG_SCK", "PB14": "MAG_MISO", "PB15": "MAG_MOSI", "PA3": "MAG_CS",
        "PA1": "MAG_DRDY", "PA2": "BARO_CS", "PA0": "BARO_INT",
        "PA9": "GNSS_TX", "PA10": "GNSS_RX", "PB1": "GNSS_PPS"}
"""MCU pins → firmware/boards/imu.toml's signals (scripts/check-pins)."""

P = Place
MAG = calc.PLACES["U102"]
PLACES = {
    # magnetometer in the middle of the bottom edge, its C1 and decoupling beside it
    "U102": P(*MAG, 0), "C105": P(MAG[0] - 2.2, MAG[1] + 0.2, 90),
    # its decoupling above it, so DRDY (its right side) has a way out to PA1
    "C103": P(MAG[0] + 0.6, MAG[1] - 2.6, 0), "C104": P(MAG[0] + 3.8, MAG[1] - 2.6, 0),
    # barometer beside it (PA0's long way round the MCU's left side is short to here), the
    # accelerometer + gyro to the right
    "U103": P(36.5, 46.8, 0), "C106": P(38.8, 46.8, 90), "C107": P(40.6, 46.8, 90),
    "U101": P(44.5, 43.0, 0), "C101": P(44.5, 45.7, 0), "C102": P(47.2, 43.0, 90),
    # chip-select pull-ups under the MCU's bottom row
    "R101": P(33.0, 39.0, 90), "R102": P(24.5, 37.5, 0), "R103": P(36.0, 39.0, 90),
    # GNSS: the header on the left, the GH connector beside it, both facing the bottom edge
    "J102": P(12.0, 38.0, 0), "J101": P(20.0, 46.3, 0),
    "JP101": P(16.3, 40.6, 0), "D101": P(21.0, 40.6, 0),
    "R104": P(25.0, 39.6, 0), "R105": P(27.8, 41.6, 90), "R106": P(25.0, 41.6, 0),
}


def build(core: Sheet) -> Module:
    s = Sheet(NAME, f"{TITLE}: LSM6DSO, LPS22HH on SPI1, LIS3MDL on SPI2, GNSS port")
    bus_tap(s, "+5V_MOD", at=BUS_TAP_PLACE)
    pins = {p: "" for p in core_mod.FREE_GPIO}
    pins.update(PINS)
    pins["V5_IN"] = "+5V_MOD"
    s.use(core, pins)

    # LSM6DSO in mode 1 (SPI 4-wire to the MCU, no auxiliary SPI): SDx and SCx to GND,
    # OCS_Aux and SDO_Aux unconnected, INT2 unused (DS12140 Table 2)
    s.part("U101", "LSM6DSO", {"SDO/SA0": "IMU_MISO", "SDA": "IMU_MOSI", "SCL": "IMU_SCK",
                               "CS": "IMU_CS", "INT1": "IMU_INT1", "SDX": "GND", "SCX": "GND",
                               "VDD": "+3V3", "VDDIO": "+3V3", "GND": "GND"},
           nc=("INT2", "OCS_Aux", "SDO_Aux"))
    s.part("C101", "C_100n", {"1": "+3V3", "2": "GND"})      # VDD
    s.part("C102", "C_100n", {"1": "+3V3", "2": "GND"})      # VDDIO
    s.part("R103", "R_10k", {"1": "+3V3", "2": "IMU_CS"})

    # LIS3MDL alone on SPI2 (no I2C-disable bit), 4-wire SPI: SDA/SDI in, SDO/SA1 out; C1 its
    # 100 nF; reserved pins to GND
    s.part("U102", "LIS3MDL", {"~{CS}": "MAG_CS", "SCL/SPC": "MAG_SCK", "SDA/SDI/SDO": "MAG_MOSI",
                               "SDO/SA1": "MAG_MISO", "DRDY": "MAG_DRDY", "C1": "MAG_C1",
                               "Vdd": "+3V3", "Vdd_IO": "+3V3", "GND": "GND"}, nc=("INT",))
    s.part("C105", "C_100n", {"1": "MAG_C1", "2": "GND"})
    s.part("C103", "C_100n", {"1": "+3V3", "2": "GND"})
    s.part("C104", "C_1u", {"1": "+3V3", "2": "GND"})
    s.part("R101", "R_10k", {"1": "+3V3", "2": "MAG_CS"})

    # LPS22HH, 4-wire SPI: SDA = SDI, SA0 = SDO; CS low = SPI (high: I2C/I3C, idle here); drawn
    # with the LPS22DF's symbol (catalog.py), whose pin 8 is named GND_IO
    s.part("U103", "LPS22HH", {"~{CS}": "BARO_CS", "SCL": "IMU_SCK", "SDA": "IMU_MOSI",
                               "SA0": "IMU_MISO", "INT_DRDY": "BARO_INT", "VDD": "+3V3",
                               "Vdd_IO": "+3V3", "GND": "GND", "GND_IO": "GND"})
    s.part("C106", "C_100n", {"1": "+3V3", "2": "GND"})      # VDD
    s.part("C107", "C_100n", {"1": "+3V3", "2": "GND"})      # Vdd_IO
    s.part("R102", "R_10k", {"1": "+3V3", "2": "BARO_CS"})

    # GNSS port: supply jumper, the two connectors in parallel, ESD clamp, PPS protection
    s.part("JP101", "SJ_3_BRIDGED12", {"A": "+5V_MOD", "C": "GNSS_VCC", "B": "+3V3"})
    s.part("J101", "JST_GH_6", {"1": "GNSS_VCC", "2": "GNSS_TX", "3": "GNSS_RX", "6": "GND",
                                "MP": "GND"}, nc=("4", "5"), value="GPS (DS-009)")
    s.part("J102", "HDR_1x5", {"1": "GNSS_VCC", "2": "GND", "3": "GNSS_TX", "4": "GNSS_RX",
                               "5": "GNSS_PPS_IN"}, value="GNSS")
    s.part("D101", "SRV05-4", {"IO1": "GNSS_TX", "IO2": "GNSS_RX", "IO3": "GNSS_PPS_IN",
                               "VP": "+5V_MOD", "VN": "GND"}, nc=("IO4",))
    s.part("R104", "R_1k", {"1": "GNSS_PPS_IN", "2": "GNSS_PPS"})
    s.part("R106", "R_100k", {"1": "GNSS_PPS_IN", "2": "GND"})
    s.part("R105", "R_10k", {"1": "+3V3", "2": "GNSS_RX"})


    for p in s.parts:
        if p.ref in PLACES:
            p.place = PLACES[p.ref]
    sheet = drawing_of(__file__)
    s.drawing, s.blocks = sheet.DRAWING, sheet.BLOCKS
    m = Module(NAME, TITLE, REVISION, s,
               tracks=[*core_mod.bus_tracks(), bus_tap_track(), tvs_track(), *core_tracks()],
               seed=21)
    m.fiducials = list(core_mod.FIDUCIALS)
    m.texts = frame_texts(NAME, REVISION)
    return m
