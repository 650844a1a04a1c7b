//! ST LPS22DF barometer over I2C or 4-wire SPI (issue 21: the IMU module's altitude).
//!
//! Register map as ST's LPS22DF driver header (STMicroelectronics/lps22df-pid, lps22df_reg.h)
//! and ArduPilot's AP_Baro_LPS22DF give it, from the LPS22DF datasheet (DS13316): WHO_AM_I
//! (0x0F) reads 0xB4; CTRL_REG1 (0x10) holds the data rate ODR \[6:3\] (0 one-shot/power-down,
//! 1, 4, 10, 25, 50, 75, 100, 200 Hz) and the averaging AVG \[2:0\]; CTRL_REG2 (0x11) BOOT \[7\],
//! EN_LPFP \[5\], LFPF_CFG \[4\], BDU \[3\], SWRESET \[2\], ONESHOT \[0\]; CTRL_REG3 (0x12)
//! IF_ADD_INC \[0\] (register address auto-increment, set at reset); STATUS (0x27) P_DA \[0\],
//! T_DA \[1\], P_OR \[4\], T_OR \[5\]; PRESS_OUT (0x28..0x2A) 24-bit and TEMP_OUT (0x2B..0x2C)
//! 16-bit, little-endian two's complement: 4096 LSB/hPa and 100 LSB/°C. So one 6-byte burst
//! from STATUS reads a whole sample. SPI: the first byte is the address with bit 7 set for a
//! read (as the LSM6DSO). I2C addresses 0x5C (SA0 to GND) and 0x5D (SA0 to VDD).

use embedded_hal::i2c::{I2c, SevenBitAddress};
use embedded_hal::spi::{Operation, SpiDevice};

pub use crate::register_bus::{Error, RegisterBus};

/// WHO_AM_I register.
pub const WHO_AM_I: u8 = 0x0F;
/// WHO_AM_I's fixed value.
pub const WHO_AM_I_VALUE: u8 = 0xB4;
/// IF_CTRL register.
pub const IF_CTRL: u8 = 0x0E;
/// IF_CTRL: I2C and I3C off (bit 6, I2C_I3C_DIS; ST's LPS22DF register header).
pub const IF_CTRL_I2C_I3C_DIS: u8 = 1 << 6;
/// ODR \[6:3\], AVG \[2:0\].
pub const CTRL_REG1: u8 = 0x10;
/// BOOT \[7\], EN_LPFP \[5\], LFPF_CFG \[4\], BDU \[3\], SWRESET \[2\], ONESHOT \[0\].
pub const CTRL_REG2: u8 = 0x11;
/// INT_H_L \[3\], PP_OD \[1\], IF_ADD_INC \[0\].
pub const CTRL_REG3: u8 = 0x12;
/// T_OR \[5\], P_OR \[4\], T_DA \[1\], P_DA \[0\].
pub const STATUS: u8 = 0x27;
/// First output register (pressure, lowest byte); temperature from 0x2B.
pub const PRESS_OUT_XL: u8 = 0x28;
/// CTRL_REG2's block data update.
pub const CTRL2_BDU: u8 = 1 << 3;
/// CTRL_REG2's software reset.
pub const CTRL2_SWRESET: u8 = 1 << 2;
/// CTRL_REG2's low-pass filter on the pressure output (ODR/4, or ODR/9 with LFPF_CFG).
pub const CTRL2_EN_LPFP: u8 = 1 << 5;
/// CTRL_REG3's auto-increment (its reset value).
pub const CTRL3_IF_ADD_INC: u8 = 1 << 0;
/// STATUS: new pressure.
pub const STATUS_P_DA: u8 = 1 << 0;
/// STATUS: a pressure sample was overwritten before it was read.
pub const STATUS_P_OR: u8 = 1 << 4;
/// Pressure output, LSB per hPa.
pub const LSB_PER_HPA: f32 = 4096.0;
/// Temperature output, LSB per °C.
pub const LSB_PER_DEG_C: f32 = 100.0;
/// SPI: bit 7 of the first byte, read.
pub const SPI_READ: u8 = 0x80;

/// Output data rate (CTRL_REG1's ODR).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Odr {
    /// Power-down (one-shot on request).
    Off = 0,
    /// 1 Hz.
    Hz1 = 1,
    /// 4 Hz.
    Hz4 = 2,
    /// 10 Hz.
    Hz10 = 3,
    /// 25 Hz.
    Hz25 = 4,
    /// 50 Hz.
    Hz50 = 5,
    /// 75 Hz.
    Hz75 = 6,
    /// 100 Hz.
    Hz100 = 7,
    /// 200 Hz.
    Hz200 = 8,
}

impl Odr {
    /// The rate for ODR code `code`, if it is one.
    pub fn from_code(code: u8) -> Option<Odr> {
        use Odr::*;
        [Off, Hz1, Hz4, Hz10, Hz25, Hz50, Hz75, Hz100, Hz200].get(usize::from(code)).copied()
    }

    /// Samples per second (0 when off).
    pub fn hz(self) -> f32 {
        [0.0, 1.0, 4.0, 10.0, 25.0, 50.0, 75.0, 100.0, 200.0][self as usize]
    }
}

/// Samples averaged into each output (CTRL_REG1's AVG): more is less noise, more current.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Averaging {
    /// 4 samples.
    X4 = 0,
    /// 8.
    X8 = 1,
    /// 16.
    X16 = 2,
    /// 32.
    X32 = 3,
    /// 64.
    X64 = 4,
    /// 128.
    X128 = 5,
    /// 512.
    X512 = 7,
}

/// What [`Lps22df::init`] sets up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Output data rate.
    pub odr: Odr,
    /// Averaging.
    pub averaging: Averaging,
}

impl Default for Config {
    /// 25 Hz with 32 samples averaged: altitude and vertical speed for a ground robot, low
    /// noise at a rate the 32-sample average allows.
    fn default() -> Self {
        Config { odr: Odr::Hz25, averaging: Averaging::X32 }
    }
}

/// I2C address, set by the SA0 pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Address {
    /// SA0 to GND: 0x5C.
    Sa0Low,
    /// SA0 to VDD: 0x5D.
    Sa0High,
}

impl Address {
    /// The 7-bit address.
    pub fn bits(self) -> SevenBitAddress {
        match self {
            Address::Sa0Low => 0x5C,
            Address::Sa0High => 0x5D,
        }
    }
}

/// The LPS22DF on an I2C bus.
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
        self.i2c.write_read(self.address, &[reg], buf)
    }
}

/// The LPS22DF on a 4-wire SPI device (chip select handled by the [`SpiDevice`]).
#[derive(Debug)]
pub struct SpiBus<S> {
    spi: S,
}

impl<S: SpiDevice> RegisterBus for SpiBus<S> {
    type Error = S::Error;
    const SPI: bool = true;
    fn write_register(&mut self, reg: u8, value: u8) -> Result<(), S::Error> {
        self.spi.write(&[reg & !SPI_READ, value])
    }
    fn read_registers(&mut self, reg: u8, buf: &mut [u8]) -> Result<(), S::Error> {
        self.spi.transaction(&mut [Operation::Write(&[reg | SPI_READ]), Operation::Read(buf)])
    }
}

/// One sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Pressure, Pa.
    pub pressure_pa: f32,
    /// Temperature, °C.
    pub temp_c: f32,
    /// A sample was overwritten before this one was read (P_OR).
    pub overrun: bool,
}

/// An LPS22DF driver.
#[derive(Debug)]
pub struct Lps22df<B> {
    bus: B,
}

impl<I: I2c> Lps22df<I2cBus<I>> {
    /// The barometer at `address` on `i2c`.
    pub fn new_i2c(i2c: I, address: Address) -> Self {
        Self::new(I2cBus { i2c, address: address.bits() })
    }
}

impl<S: SpiDevice> Lps22df<SpiBus<S>> {
    /// The barometer on `spi` (4-wire, mode 3).
    pub fn new_spi(spi: S) -> Self {
        Self::new(SpiBus { spi })
    }
}

impl<B: RegisterBus> Lps22df<B> {
    /// The barometer on `bus`, assumed in its reset state (power-down) until [`Self::init`].
    pub fn new(bus: B) -> Self {
        Self { bus }
    }

    /// Checks WHO_AM_I.
    pub fn probe(&mut self) -> Result<(), Error<B::Error>> {
        crate::register_bus::probe(&mut self.bus, "LPS22DF", WHO_AM_I, WHO_AM_I_VALUE)
    }

    /// Probes, then sets auto-increment, block data update and `config`'s rate and
    /// averaging, checking the control registers read back what was written.
    pub fn init(&mut self, config: Config) -> Result<(), Error<B::Error>> {
        self.probe()?;
        if B::SPI {
            self.bus.write_register(IF_CTRL, IF_CTRL_I2C_I3C_DIS)?;
            let mut back = [0];
            self.bus.read_registers(IF_CTRL, &mut back)?;
            if back[0] != IF_CTRL_I2C_I3C_DIS {
                return Err(Error::ConfigNotApplied {
                    part: "LPS22DF",
                    register: IF_CTRL,
                    wrote: IF_CTRL_I2C_I3C_DIS,
                    read: back[0],
                });
            }
        }
        let ctrl = [(config.odr as u8) << 3 | config.averaging as u8, CTRL2_BDU, CTRL3_IF_ADD_INC];
        self.bus.write_register(CTRL_REG3, ctrl[2])?;
        self.bus.write_register(CTRL_REG2, ctrl[1])?;
        self.bus.write_register(CTRL_REG1, ctrl[0])?;
        let mut back = [0; 3];
        self.bus.read_registers(CTRL_REG1, &mut back)?;
        for (i, (&wrote, &read)) in ctrl.iter().zip(&back).enumerate() {
            if read != wrote {
                return Err(Error::ConfigNotApplied {
                    part: "LPS22DF",
                    register: CTRL_REG1 + i as u8,
                    wrote,
                    read,
                });
            }
        }
        Ok(())
    }

    /// The newest sample if one arrived since the last read (`None`: none yet), from one
    /// burst of STATUS, the pressure and the temperature.
    pub fn read(&mut self) -> Result<Option<Sample>, Error<B::Error>> {
        let mut b = [0; 6];
        self.bus.read_registers(STATUS, &mut b)?;
        // STATUS's bits 7:6 and 3:2 are reserved (0): all ones is a part not answering.
        crate::register_bus::answered("LPS22DF", &b)?;
        if b[0] & STATUS_P_DA == 0 {
            return Ok(None);
        }
        // 24-bit two's complement: sign-extend through the top byte of an i32.
        let counts = i32::from_le_bytes([0, b[1], b[2], b[3]]) >> 8;
        let temp = i16::from_le_bytes([b[4], b[5]]);
        Ok(Some(Sample {
            pressure_pa: counts as f32 * (100.0 / LSB_PER_HPA),
            temp_c: f32::from(temp) / LSB_PER_DEG_C,
            overrun: b[0] & STATUS_P_OR != 0,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_and_control_bits_are_the_datasheets() {
        let hz: [f32; 9] = [0.0, 1.0, 4.0, 10.0, 25.0, 50.0, 75.0, 100.0, 200.0];
        for (code, want) in hz.iter().enumerate() {
            assert_eq!(Odr::from_code(code as u8).unwrap().hz(), *want);
        }
        assert_eq!(Odr::from_code(9), None);
        assert_eq!(
            [CTRL2_BDU, CTRL2_SWRESET, CTRL2_EN_LPFP, CTRL3_IF_ADD_INC],
            [0x08, 0x04, 0x20, 0x01]
        );
        assert_eq!([STATUS_P_DA, STATUS_P_OR], [0x01, 0x10]);
        assert_eq!((LSB_PER_HPA, LSB_PER_DEG_C), (4096.0, 100.0));
    }
}
