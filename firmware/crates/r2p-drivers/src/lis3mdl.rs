//! ST LIS3MDL 3-axis magnetometer over I2C or 4-wire SPI (issue 21: the IMU module's compass).
//!
//! From the LIS3MDL datasheet (DocID024204 Rev 4, STMicroelectronics): WHO_AM_I (0x0F) reads
//! 0x3D; CTRL_REG1 (0x20) holds TEMP_EN \[7\], the X/Y operating mode OM \[6:5\] and the data
//! rate DO \[4:2\]; CTRL_REG2 (0x21) the full scale FS \[6:5\], REBOOT \[3\] and SOFT_RST \[2\];
//! CTRL_REG3 (0x22) the mode MD \[1:0\] (00 continuous, 11 power-down at reset); CTRL_REG4
//! (0x23) the Z operating mode OMZ \[3:2\]; CTRL_REG5 (0x24) BDU \[6\]; STATUS_REG (0x27) ZYXDA
//! \[3\] and ZYXOR \[7\]; OUT_X/Y/Z (0x28..0x2D) and TEMP_OUT (0x2E..0x2F) are 16-bit
//! little-endian two's complement, so one 9-byte burst from STATUS_REG reads a whole sample.
//! Sensitivity 6842 / 3421 / 2281 / 1711 LSB/gauss at ±4 / 8 / 12 / 16 gauss (DS9463 Rev 7,
//! Table 2); 1 gauss = 100 µT. Temperature 8 LSB/°C (Table 3); 0 at 25 °C NOT VERIFIED (unstated).
//!
//! Multi-byte access (unlike the LSM6DSO's IF_INC): on SPI the command byte is RW \[7\], MS
//! \[6\] (1: the address increments) and the address \[5:0\]; on I2C the sub-address's MSB
//! asks for the increment. I2C addresses 0x1C (SA1 to GND) and 0x1E (SA1 to VDD). The same
//! register map is the LSM9DS1's magnetic sensor, whose SPI protocol text (DocID025715 §5.3)
//! was read to check the MS bit.

use embedded_hal::i2c::{I2c, SevenBitAddress};
use embedded_hal::spi::{Operation, SpiDevice};

pub use crate::register_bus::{Error, RegisterBus};

/// WHO_AM_I register.
pub const WHO_AM_I: u8 = 0x0F;
/// WHO_AM_I's fixed value.
pub const WHO_AM_I_VALUE: u8 = 0x3D;
/// TEMP_EN \[7\], OM \[6:5\], DO \[4:2\], FAST_ODR \[1\], ST \[0\]; reset 0x10 (10 Hz).
pub const CTRL_REG1: u8 = 0x20;
/// FS \[6:5\], REBOOT \[3\], SOFT_RST \[2\].
pub const CTRL_REG2: u8 = 0x21;
/// LP \[5\], SIM \[2\], MD \[1:0\], the others 0 (DS9463 Rev 7, Table 25: unlike the LSM6DSO
/// and the LPS22HH/DF, the LIS3MDL has no bit that turns its I2C interface off); reset 0x03
/// (power-down).
pub const CTRL_REG3: u8 = 0x22;
/// OMZ \[3:2\], BLE \[1\].
pub const CTRL_REG4: u8 = 0x23;
/// FAST_READ \[7\], BDU \[6\].
pub const CTRL_REG5: u8 = 0x24;
/// ZYXOR \[7\] … ZYXDA \[3\], ZDA, YDA, XDA.
pub const STATUS_REG: u8 = 0x27;
/// First output register (X, low byte); temperature from 0x2E.
pub const OUT_X_L: u8 = 0x28;
/// CTRL_REG1's temperature-sensor enable.
pub const CTRL1_TEMP_EN: u8 = 1 << 7;
/// CTRL_REG2's software reset (clears the configuration and user registers).
pub const CTRL2_SOFT_RST: u8 = 1 << 2;
/// CTRL_REG5's block data update.
pub const CTRL5_BDU: u8 = 1 << 6;
/// STATUS_REG: a new X, Y and Z sample.
pub const STATUS_ZYXDA: u8 = 1 << 3;
/// STATUS_REG: a sample was overwritten before it was read.
pub const STATUS_ZYXOR: u8 = 1 << 7;
/// Ultra-high-performance mode (OM and OMZ = 11): the lowest noise.
pub const MODE_ULTRA_HIGH_PERFORMANCE: u8 = 0b11;
/// SPI command: read.
pub const SPI_READ: u8 = 0x80;
/// SPI command: the address increments (MS).
pub const SPI_INCREMENT: u8 = 0x40;
/// I2C sub-address: the address increments.
pub const I2C_INCREMENT: u8 = 0x80;

/// Output data rate (DO, FAST_ODR off).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Odr {
    /// 0.625 Hz.
    Hz0_625 = 0,
    /// 1.25 Hz.
    Hz1_25 = 1,
    /// 2.5 Hz.
    Hz2_5 = 2,
    /// 5 Hz.
    Hz5 = 3,
    /// 10 Hz (reset).
    Hz10 = 4,
    /// 20 Hz.
    Hz20 = 5,
    /// 40 Hz.
    Hz40 = 6,
    /// 80 Hz.
    Hz80 = 7,
}

impl Odr {
    /// The rate for DO code `code` (CTRL_REG1 \[4:2\]).
    pub fn from_code(code: u8) -> Odr {
        use Odr::*;
        [Hz0_625, Hz1_25, Hz2_5, Hz5, Hz10, Hz20, Hz40, Hz80][usize::from(code & 0b111)]
    }

    /// Samples per second.
    pub fn hz(self) -> f32 {
        0.625 * f32::from(1u8 << (self as u8))
    }
}

/// Full scale.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Scale {
    /// ±4 gauss (±400 µT), 6842 LSB/gauss.
    Gauss4 = 0,
    /// ±8 gauss, 3421 LSB/gauss.
    Gauss8 = 1,
    /// ±12 gauss, 2281 LSB/gauss.
    Gauss12 = 2,
    /// ±16 gauss, 1711 LSB/gauss.
    Gauss16 = 3,
}

impl Scale {
    /// The scale for FS bits `bits` (CTRL_REG2 \[6:5\]).
    pub fn from_bits(bits: u8) -> Scale {
        [Scale::Gauss4, Scale::Gauss8, Scale::Gauss12, Scale::Gauss16][usize::from(bits & 0b11)]
    }

    /// Sensitivity, LSB per gauss (datasheet table 3, GN).
    pub fn lsb_per_gauss(self) -> f32 {
        match self {
            Scale::Gauss4 => 6842.0,
            Scale::Gauss8 => 3421.0,
            Scale::Gauss12 => 2281.0,
            Scale::Gauss16 => 1711.0,
        }
    }

    /// µT per LSB.
    pub fn ut_per_lsb(self) -> f32 {
        100.0 / self.lsb_per_gauss()
    }
}

/// What [`Lis3mdl::init`] sets up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Output data rate.
    pub odr: Odr,
    /// Full scale.
    pub scale: Scale,
}

impl Default for Config {
    /// 80 Hz, ±4 gauss: the Earth's 25–65 µT with room for a robot's hard iron, the finest
    /// resolution (0.015 µT), a rate above the heading filter's.
    fn default() -> Self {
        Config { odr: Odr::Hz80, scale: Scale::Gauss4 }
    }
}

/// I2C address, set by the SA1 pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Address {
    /// SA1 to GND: 0x1C.
    Sa1Low,
    /// SA1 to VDD: 0x1E.
    Sa1High,
}

impl Address {
    /// The 7-bit address.
    pub fn bits(self) -> SevenBitAddress {
        match self {
            Address::Sa1Low => 0x1C,
            Address::Sa1High => 0x1E,
        }
    }
}

/// The LIS3MDL on an I2C bus.
#[derive(Debug)]
pub struct I2cBus<I> {
    i2c: I,
    address: SevenBitAddress,
}

impl<I: I2c> RegisterBus for I2cBus<I> {
    type Error = I::Error;
    fn write_register(&mut self, reg: u8, value: u8) -> Result<(), I::Error> {
        self.i2c.write(self.address, &[reg, value])
    }
    fn read_registers(&mut self, reg: u8, buf: &mut [u8]) -> Result<(), I::Error> {
        self.i2c.write_read(self.address, &[reg | I2C_INCREMENT], buf)
    }
}

/// The LIS3MDL on a 4-wire SPI device (chip select handled by the [`SpiDevice`]).
#[derive(Debug)]
pub struct SpiBus<S> {
    spi: S,
}

impl<S: SpiDevice> RegisterBus for SpiBus<S> {
    type Error = S::Error;
    const SPI: bool = true;
    fn write_register(&mut self, reg: u8, value: u8) -> Result<(), S::Error> {
        self.spi.write(&[reg & 0x3F, value])
    }
    fn read_registers(&mut self, reg: u8, buf: &mut [u8]) -> Result<(), S::Error> {
        let command = SPI_READ | SPI_INCREMENT | (reg & 0x3F);
        self.spi.transaction(&mut [Operation::Write(&[command]), Operation::Read(buf)])
    }
}

/// One sample in sensor axes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Magnetic flux density, µT.
    pub field_ut: [f32; 3],
    /// Die temperature, °C.
    pub temp_c: f32,
    /// A sample was overwritten before this one was read (STATUS_REG's ZYXOR): reads are
    /// slower than the data rate.
    pub overrun: bool,
}

/// An LIS3MDL driver.
#[derive(Debug)]
pub struct Lis3mdl<B> {
    bus: B,
    scale: Scale,
}

impl<I: I2c> Lis3mdl<I2cBus<I>> {
    /// The magnetometer at `address` on `i2c`.
    pub fn new_i2c(i2c: I, address: Address) -> Self {
        Self::new(I2cBus { i2c, address: address.bits() })
    }
}

impl<S: SpiDevice> Lis3mdl<SpiBus<S>> {
    /// The magnetometer on `spi` (4-wire, mode 3).
    pub fn new_spi(spi: S) -> Self {
        Self::new(SpiBus { spi })
    }
}

impl<B: RegisterBus> Lis3mdl<B> {
    /// The magnetometer on `bus`, assumed in its reset state (power-down) until [`Self::init`].
    pub fn new(bus: B) -> Self {
        Self { bus, scale: Scale::Gauss4 }
    }

    /// Checks WHO_AM_I.
    pub fn probe(&mut self) -> Result<(), Error<B::Error>> {
        crate::register_bus::probe(&mut self.bus, "LIS3MDL", WHO_AM_I, WHO_AM_I_VALUE)
    }

    /// Probes, then sets ultra-high-performance mode on all axes, `config`'s rate and scale,
    /// the temperature sensor, block data update and continuous conversion, checking that the
    /// control registers read back what was written.
    pub fn init(&mut self, config: Config) -> Result<(), Error<B::Error>> {
        self.probe()?;
        let ctrl = [
            CTRL1_TEMP_EN | MODE_ULTRA_HIGH_PERFORMANCE << 5 | (config.odr as u8) << 2,
            (config.scale as u8) << 5,
            // MD = 00: continuous conversion, 4-wire SPI (SIM = 0), low power off.
            0,
            MODE_ULTRA_HIGH_PERFORMANCE << 2,
            CTRL5_BDU,
        ];
        for (i, value) in ctrl.iter().enumerate() {
            self.bus.write_register(CTRL_REG1 + i as u8, *value)?;
        }
        let mut back = [0; 5];
        self.bus.read_registers(CTRL_REG1, &mut back)?;
        for (i, (&wrote, &read)) in ctrl.iter().zip(&back).enumerate() {
            if read != wrote {
                return Err(Error::ConfigNotApplied {
                    part: "LIS3MDL",
                    register: CTRL_REG1 + i as u8,
                    wrote,
                    read,
                });
            }
        }
        self.scale = config.scale;
        Ok(())
    }

    /// The newest sample if one arrived since the last read (`None`: none yet), from one
    /// burst of STATUS_REG, the outputs and the temperature.
    pub fn read(&mut self) -> Result<Option<Sample>, Error<B::Error>> {
        let mut b = [0; 9];
        self.bus.read_registers(STATUS_REG, &mut b)?;
        // Every status bit may be set (overrun on all axes), but not with −1 LSB on each axis
        // and the temperature too: nine bytes of ones are a part not answering.
        crate::register_bus::answered("LIS3MDL", &b)?;
        if b[0] & STATUS_ZYXDA == 0 {
            return Ok(None);
        }
        let w = |i: usize| f32::from(i16::from_le_bytes([b[1 + 2 * i], b[2 + 2 * i]]));
        let k = self.scale.ut_per_lsb();
        Ok(Some(Sample {
            field_ut: [w(0) * k, w(1) * k, w(2) * k],
            temp_c: 25.0 + w(3) / 8.0,
            overrun: b[0] & STATUS_ZYXOR != 0,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_and_scales_are_the_datasheets() {
        // DO codes 0..7: 0.625 Hz doubling to 80 Hz.
        let hz: [f32; 8] = [0.625, 1.25, 2.5, 5.0, 10.0, 20.0, 40.0, 80.0];
        for (code, want) in hz.iter().enumerate() {
            assert_eq!(Odr::from_code(code as u8).hz(), *want);
        }
        assert_eq!(Scale::from_bits(0b10), Scale::Gauss12);
        assert!((Scale::Gauss4.ut_per_lsb() - 0.014_616).abs() < 1e-6);
        assert!((Scale::Gauss16.ut_per_lsb() - 0.058_445).abs() < 1e-6);
    }

    #[test]
    fn control_bits_are_where_the_datasheet_puts_them() {
        // CTRL_REG1 TEMP_EN bit 7; CTRL_REG2 SOFT_RST bit 2; CTRL_REG5 BDU bit 6; STATUS_REG
        // ZYXDA bit 3, ZYXOR bit 7.
        assert_eq!([CTRL1_TEMP_EN, CTRL2_SOFT_RST, CTRL5_BDU], [0x80, 0x04, 0x40]);
        assert_eq!([STATUS_ZYXDA, STATUS_ZYXOR], [0x08, 0x80]);
        assert_eq!([SPI_READ, SPI_INCREMENT, I2C_INCREMENT], [0x80, 0x40, 0x80]);
    }
}
