//! ST LPS22HH and LPS22DF barometers over I2C or 4-wire SPI (issue 21: the IMU module's
//! altitude). The IMU board carries the LPS22HH (LCSC stocks it; the LPS22DF it was drawn for
//! has no LCSC number): both sit on the same HLGA-10L land pattern with the same pins, so the
//! driver reads WHO_AM_I and sets up whichever part it finds.
//!
//! What the two share (ST's register headers: STMems_Standard_C_drivers lps22hh_reg.h and
//! STMicroelectronics/lps22df-pid lps22df_reg.h; the datasheets DocID030890 (LPS22HH) and
//! DS13316 (LPS22DF), "Interpreting pressure readings"): WHO_AM_I at 0x0F, IF_CTRL 0x0E,
//! CTRL_REG1..3 0x10..0x12, STATUS (0x27) P_DA \[0\], T_DA \[1\], P_OR \[4\], T_OR \[5\];
//! PRESS_OUT (0x28..0x2A) 24-bit and TEMP_OUT (0x2B..0x2C) 16-bit, little-endian two's
//! complement, 4096 LSB/hPa and 100 LSB/°C, so one 6-byte burst from STATUS reads a whole
//! sample; CTRL_REG2's SWRESET \[2\] and ONE_SHOT \[0\]; I2C addresses 0x5C (SA0 to GND) and 0x5D
//! (SA0 to VDD); on SPI the first byte is the address with bit 7 set for a read.
//!
//! Where they differ ([`hh`] and [`df`] hold each one's bits):
//!
//! | | LPS22HH | LPS22DF |
//! |---|---|---|
//! | WHO_AM_I | 0xB3 | 0xB4 |
//! | IF_CTRL, I2C off | I2C_DISABLE \[0\], I3C_DISABLE \[1\] | I2C_I3C_DIS \[6\] |
//! | CTRL_REG1 | ODR \[6:4\] (off, 1, 10, 25, 50, 75, 100, 200 Hz), EN_LPFP \[3\], LPFP_CFG \[2\], BDU \[1\] | ODR \[6:3\] (off, 1, 4, 10, 25, 50, 75, 100, 200 Hz), AVG \[2:0\] |
//! | CTRL_REG2 | BOOT \[7\], INT_H_L \[6\], PP_OD \[5\], IF_ADD_INC \[4\], LOW_NOISE_EN \[1\] | BOOT \[7\], EN_LPFP \[5\], LFPF_CFG \[4\], BDU \[3\] |
//! | CTRL_REG3 | INT_F_FULL \[5\], INT_F_WTM \[4\], INT_F_OVR \[3\], DRDY \[2\], INT_S \[1:0\] | INT_H_L \[3\], PP_OD \[1\], IF_ADD_INC \[0\] |
//! | noise reduction | low-noise mode (ODR below 100 Hz only) | averaging, 4 to 512 samples |
//!
//! The HH's low-noise mode is its counterpart of the DF's averaging: [`Config`] asks for a rate
//! and an averaging; the HH takes the rate and its low-noise mode, the DF both.

use embedded_hal::i2c::{I2c, SevenBitAddress};
use embedded_hal::spi::{Operation, SpiDevice};

pub use crate::register_bus::{Error, RegisterBus};

/// IF_CTRL register (I2C/I3C off on SPI).
pub const IF_CTRL: u8 = 0x0E;
/// WHO_AM_I register.
pub const WHO_AM_I: u8 = 0x0F;
/// CTRL_REG1 (the rate).
pub const CTRL_REG1: u8 = 0x10;
/// CTRL_REG2.
pub const CTRL_REG2: u8 = 0x11;
/// CTRL_REG3.
pub const CTRL_REG3: u8 = 0x12;
/// T_OR \[5\], P_OR \[4\], T_DA \[1\], P_DA \[0\].
pub const STATUS: u8 = 0x27;
/// First output register (pressure, lowest byte); temperature from 0x2B.
pub const PRESS_OUT_XL: u8 = 0x28;
/// CTRL_REG2's software reset (both parts; it clears itself).
pub const CTRL2_SWRESET: u8 = 1 << 2;
/// CTRL_REG2's one-shot trigger in power-down (both parts; it clears itself).
pub const CTRL2_ONE_SHOT: u8 = 1 << 0;
/// STATUS: new pressure.
pub const STATUS_P_DA: u8 = 1 << 0;
/// STATUS: new temperature.
pub const STATUS_T_DA: u8 = 1 << 1;
/// STATUS: a pressure sample was overwritten before it was read.
pub const STATUS_P_OR: u8 = 1 << 4;
/// STATUS: a temperature sample was overwritten before it was read.
pub const STATUS_T_OR: u8 = 1 << 5;
/// Pressure output, LSB per hPa.
pub const LSB_PER_HPA: f32 = 4096.0;
/// Temperature output, LSB per °C.
pub const LSB_PER_DEG_C: f32 = 100.0;
/// SPI: bit 7 of the first byte, read.
pub const SPI_READ: u8 = 0x80;

/// The LPS22HH's own bits (lps22hh_reg.h: lps22hh_if_ctrl_t, lps22hh_ctrl_reg1_t,
/// lps22hh_ctrl_reg2_t, lps22hh_ctrl_reg3_t, lps22hh_odr_t).
pub mod hh {
    /// WHO_AM_I's value (LPS22HH_ID).
    pub const WHO_AM_I_VALUE: u8 = 0xB3;
    /// IF_CTRL: I2C off.
    pub const IF_CTRL_I2C_DISABLE: u8 = 1 << 0;
    /// IF_CTRL: I3C off.
    pub const IF_CTRL_I3C_DISABLE: u8 = 1 << 1;
    /// IF_CTRL's writable bits (bits 6:5 are not used: they read 0).
    pub const IF_CTRL_MASK: u8 = 0x9F;
    /// CTRL_REG1: the ODR field's shift (ODR \[6:4\]).
    pub const CTRL1_ODR_SHIFT: u8 = 4;
    /// CTRL_REG1: low-pass filter on the pressure output.
    pub const CTRL1_EN_LPFP: u8 = 1 << 3;
    /// CTRL_REG1: block data update.
    pub const CTRL1_BDU: u8 = 1 << 1;
    /// CTRL_REG1's writable bits (bit 7 is not used).
    pub const CTRL1_MASK: u8 = 0x7F;
    /// CTRL_REG2: register address auto-increment (set at reset).
    pub const CTRL2_IF_ADD_INC: u8 = 1 << 4;
    /// CTRL_REG2: low-noise mode (0: low-current), for rates below 100 Hz.
    pub const CTRL2_LOW_NOISE_EN: u8 = 1 << 1;
    /// CTRL_REG2's writable bits (bit 3 is not used).
    pub const CTRL2_MASK: u8 = 0xF7;
    /// CTRL_REG3's writable bits (bits 7:6 are not used).
    pub const CTRL3_MASK: u8 = 0x3F;
    /// Output data rate per ODR code, Hz (0: power-down).
    pub const ODR_HZ: [f32; 8] = [0.0, 1.0, 10.0, 25.0, 50.0, 75.0, 100.0, 200.0];
}

/// The LPS22DF's own bits (lps22df_reg.h).
pub mod df {
    /// WHO_AM_I's value.
    pub const WHO_AM_I_VALUE: u8 = 0xB4;
    /// IF_CTRL: I2C and I3C off.
    pub const IF_CTRL_I2C_I3C_DIS: u8 = 1 << 6;
    /// CTRL_REG1: the ODR field's shift (ODR \[6:3\]; AVG \[2:0\]).
    pub const CTRL1_ODR_SHIFT: u8 = 3;
    /// CTRL_REG2: block data update.
    pub const CTRL2_BDU: u8 = 1 << 3;
    /// CTRL_REG2: low-pass filter on the pressure output (ODR/4, or ODR/9 with LFPF_CFG).
    pub const CTRL2_EN_LPFP: u8 = 1 << 5;
    /// CTRL_REG3: register address auto-increment (set at reset).
    pub const CTRL3_IF_ADD_INC: u8 = 1 << 0;
    /// Output data rate per ODR code, Hz (0: power-down).
    pub const ODR_HZ: [f32; 9] = [0.0, 1.0, 4.0, 10.0, 25.0, 50.0, 75.0, 100.0, 200.0];
}

/// Which part answered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Chip {
    /// ST LPS22HH (the IMU board's).
    Hh,
    /// ST LPS22DF.
    Df,
}

impl Chip {
    /// The part's name, as errors give it.
    pub fn name(self) -> &'static str {
        match self {
            Chip::Hh => "LPS22HH",
            Chip::Df => "LPS22DF",
        }
    }

    /// WHO_AM_I's value.
    pub fn who_am_i(self) -> u8 {
        match self {
            Chip::Hh => hh::WHO_AM_I_VALUE,
            Chip::Df => df::WHO_AM_I_VALUE,
        }
    }

    /// The part whose WHO_AM_I is `value`, if either.
    pub fn from_who_am_i(value: u8) -> Option<Chip> {
        [Chip::Hh, Chip::Df].into_iter().find(|c| c.who_am_i() == value)
    }

    /// The rate of ODR code `code` (the field of CTRL_REG1), Hz, if it is one.
    pub fn odr_hz(self, code: u8) -> Option<f32> {
        let table: &[f32] = match self {
            Chip::Hh => &hh::ODR_HZ,
            Chip::Df => &df::ODR_HZ,
        };
        table.get(usize::from(code)).copied()
    }

    /// CTRL_REG1's ODR field: its code for a rate.
    pub fn odr_code(self, odr: Odr) -> u8 {
        let code = odr as u8;
        // The DF has a 4 Hz rate (code 2) that the HH lacks; above it the DF's codes are one up.
        if self == Chip::Df && code >= 2 {
            code + 1
        } else {
            code
        }
    }

    /// CTRL_REG1's shift of the ODR field.
    pub fn odr_shift(self) -> u8 {
        match self {
            Chip::Hh => hh::CTRL1_ODR_SHIFT,
            Chip::Df => df::CTRL1_ODR_SHIFT,
        }
    }

    /// The IF_CTRL value that turns I2C (and I3C) off, for a part on SPI.
    pub fn if_ctrl_spi(self) -> u8 {
        match self {
            Chip::Hh => hh::IF_CTRL_I2C_DISABLE | hh::IF_CTRL_I3C_DISABLE,
            Chip::Df => df::IF_CTRL_I2C_I3C_DIS,
        }
    }

    /// CTRL_REG1, CTRL_REG2 and CTRL_REG3 for `config`: the rate, block data update and
    /// register auto-increment, and the noise reduction (the DF's averaging; the HH's
    /// low-noise mode, which its datasheet allows below 100 Hz only).
    pub fn control(self, config: Config) -> [u8; 3] {
        let odr = self.odr_code(config.odr) << self.odr_shift();
        match self {
            Chip::Hh => {
                let low_noise = if config.odr.hz() < 100.0 { hh::CTRL2_LOW_NOISE_EN } else { 0 };
                [odr | hh::CTRL1_BDU, hh::CTRL2_IF_ADD_INC | low_noise, 0]
            }
            Chip::Df => [odr | config.averaging as u8, df::CTRL2_BDU, df::CTRL3_IF_ADD_INC],
        }
    }
}

/// Output data rate, one both parts have (the DF's 4 Hz is not offered).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Odr {
    /// Power-down (one-shot on request).
    Off = 0,
    /// 1 Hz.
    Hz1 = 1,
    /// 10 Hz.
    Hz10 = 2,
    /// 25 Hz.
    Hz25 = 3,
    /// 50 Hz.
    Hz50 = 4,
    /// 75 Hz.
    Hz75 = 5,
    /// 100 Hz.
    Hz100 = 6,
    /// 200 Hz.
    Hz200 = 7,
}

impl Odr {
    /// Samples per second (0 when off).
    pub fn hz(self) -> f32 {
        hh::ODR_HZ[self as usize]
    }
}

/// Samples the LPS22DF averages into each output (CTRL_REG1's AVG): more is less noise, more
/// current. The LPS22HH has no averaging (its low-noise mode instead).
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

/// What [`Lps22::init`] sets up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Output data rate.
    pub odr: Odr,
    /// Averaging (the LPS22DF's; the LPS22HH runs in low-noise mode below 100 Hz instead).
    pub averaging: Averaging,
}

impl Default for Config {
    /// 25 Hz with the part's noise reduction (the DF's 32-sample average, the HH's low-noise
    /// mode): altitude and vertical speed for a ground robot.
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

/// The barometer on an I2C bus.
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

/// The barometer on a 4-wire SPI device (chip select handled by the [`SpiDevice`]).
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

/// The name errors give before a part has answered: either may be fitted.
pub const EITHER: &str = "LPS22HH or LPS22DF";

/// An LPS22HH / LPS22DF driver.
#[derive(Debug)]
pub struct Lps22<B> {
    bus: B,
    chip: Option<Chip>,
}

impl<I: I2c> Lps22<I2cBus<I>> {
    /// The barometer at `address` on `i2c`.
    pub fn new_i2c(i2c: I, address: Address) -> Self {
        Self::new(I2cBus { i2c, address: address.bits() })
    }
}

impl<S: SpiDevice> Lps22<SpiBus<S>> {
    /// The barometer on `spi` (4-wire, mode 3).
    pub fn new_spi(spi: S) -> Self {
        Self::new(SpiBus { spi })
    }
}

impl<B: RegisterBus> Lps22<B> {
    /// The barometer on `bus`, assumed in its reset state (power-down) until [`Self::init`].
    pub fn new(bus: B) -> Self {
        Self { bus, chip: None }
    }

    /// The part found by the last [`Self::probe`] (`None` before one, or after one failed).
    pub fn chip(&self) -> Option<Chip> {
        self.chip
    }

    fn name(&self) -> &'static str {
        self.chip.map_or(EITHER, Chip::name)
    }

    /// Reads WHO_AM_I and tells the part. Neither part's value is
    /// [`Error::WrongDevice`] with the board's part's value (the LPS22HH's) as the expected one.
    pub fn probe(&mut self) -> Result<Chip, Error<B::Error>> {
        self.chip = None;
        let mut id = [0];
        self.bus.read_registers(WHO_AM_I, &mut id)?;
        let chip = Chip::from_who_am_i(id[0]).ok_or(Error::WrongDevice {
            part: EITHER,
            found: id[0],
            expected: hh::WHO_AM_I_VALUE,
        })?;
        self.chip = Some(chip);
        Ok(chip)
    }

    /// Writes `wrote` to `register` and checks it reads back.
    fn write_checked(&mut self, register: u8, wrote: u8) -> Result<(), Error<B::Error>> {
        self.bus.write_register(register, wrote)?;
        let mut back = [0];
        self.bus.read_registers(register, &mut back)?;
        if back[0] != wrote {
            return Err(Error::ConfigNotApplied {
                part: self.name(),
                register,
                wrote,
                read: back[0],
            });
        }
        Ok(())
    }

    /// Probes, then (on SPI) turns the part's I2C off and sets `config` — rate, block data
    /// update, auto-increment, noise reduction ([`Chip::control`]) — checking the control
    /// registers read back what was written. The rate goes last, so the part starts sampling
    /// only once it is set up (and the HH's low-noise bit changes in power-down).
    pub fn init(&mut self, config: Config) -> Result<Chip, Error<B::Error>> {
        let chip = self.probe()?;
        if B::SPI {
            self.write_checked(IF_CTRL, chip.if_ctrl_spi())?;
        }
        let ctrl = chip.control(config);
        self.bus.write_register(CTRL_REG3, ctrl[2])?;
        self.bus.write_register(CTRL_REG2, ctrl[1])?;
        self.bus.write_register(CTRL_REG1, ctrl[0])?;
        let mut back = [0; 3];
        self.bus.read_registers(CTRL_REG1, &mut back)?;
        for (i, (&wrote, &read)) in ctrl.iter().zip(&back).enumerate() {
            if read != wrote {
                return Err(Error::ConfigNotApplied {
                    part: chip.name(),
                    register: CTRL_REG1 + i as u8,
                    wrote,
                    read,
                });
            }
        }
        Ok(chip)
    }

    /// The newest sample if one arrived since the last read (`None`: none yet), from one
    /// burst of STATUS, the pressure and the temperature (the same registers on both parts).
    pub fn read(&mut self) -> Result<Option<Sample>, Error<B::Error>> {
        let mut b = [0; 6];
        self.bus.read_registers(STATUS, &mut b)?;
        // STATUS's bits 7:6 and 3:2 are reserved (0): all ones is a part not answering.
        crate::register_bus::answered(self.name(), &b)?;
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
    fn rates_and_control_bits_are_the_register_headers() {
        let hh: [f32; 8] = [0.0, 1.0, 10.0, 25.0, 50.0, 75.0, 100.0, 200.0];
        let df: [f32; 9] = [0.0, 1.0, 4.0, 10.0, 25.0, 50.0, 75.0, 100.0, 200.0];
        for (code, want) in hh.iter().enumerate() {
            assert_eq!(Chip::Hh.odr_hz(code as u8), Some(*want));
        }
        for (code, want) in df.iter().enumerate() {
            assert_eq!(Chip::Df.odr_hz(code as u8), Some(*want));
        }
        assert_eq!((Chip::Hh.odr_hz(8), Chip::Df.odr_hz(9)), (None, None));
        use Odr::*;
        for odr in [Off, Hz1, Hz10, Hz25, Hz50, Hz75, Hz100, Hz200] {
            for chip in [Chip::Hh, Chip::Df] {
                assert_eq!(chip.odr_hz(chip.odr_code(odr)), Some(odr.hz()), "{chip:?} {odr:?}");
            }
        }
        assert_eq!(
            [hh::IF_CTRL_I2C_DISABLE, hh::IF_CTRL_I3C_DISABLE, df::IF_CTRL_I2C_I3C_DIS],
            [0x01, 0x02, 0x40]
        );
        assert_eq!([hh::CTRL1_EN_LPFP, hh::CTRL1_BDU], [0x08, 0x02]);
        assert_eq!([hh::CTRL2_IF_ADD_INC, hh::CTRL2_LOW_NOISE_EN], [0x10, 0x02]);
        assert_eq!([df::CTRL2_BDU, df::CTRL2_EN_LPFP, df::CTRL3_IF_ADD_INC], [0x08, 0x20, 0x01]);
        assert_eq!([CTRL2_SWRESET, CTRL2_ONE_SHOT], [0x04, 0x01]);
        assert_eq!([STATUS_P_DA, STATUS_T_DA, STATUS_P_OR, STATUS_T_OR], [0x01, 0x02, 0x10, 0x20]);
        assert_eq!((LSB_PER_HPA, LSB_PER_DEG_C), (4096.0, 100.0));
        assert_eq!((Chip::Hh.name(), Chip::Df.name()), ("LPS22HH", "LPS22DF"));
        assert_eq!(Chip::from_who_am_i(0xB3), Some(Chip::Hh));
        assert_eq!(Chip::from_who_am_i(0xB4), Some(Chip::Df));
        assert_eq!(Chip::from_who_am_i(0xB1), None, "the LPS22HB is another map");
    }

    #[test]
    fn each_part_gets_its_own_control_bytes() {
        let c = Config::default();
        // HH: 25 Hz = code 3 in [6:4], BDU; IF_ADD_INC and low-noise; CTRL_REG3 0.
        assert_eq!(Chip::Hh.control(c), [0x32, 0x12, 0x00]);
        // DF: 25 Hz = code 4 in [6:3], AVG 32 = 3; BDU; IF_ADD_INC.
        assert_eq!(Chip::Df.control(c), [0x23, 0x08, 0x01]);
        // The HH's low-noise mode stops at 100 Hz.
        let fast = Config { odr: Odr::Hz100, ..c };
        assert_eq!(Chip::Hh.control(fast), [0x62, 0x10, 0x00]);
        let slow = Config { odr: Odr::Hz75, averaging: Averaging::X512 };
        assert_eq!(Chip::Hh.control(slow), [0x52, 0x12, 0x00]);
        assert_eq!(Chip::Df.control(slow), [0x37, 0x08, 0x01]);
        assert_eq!((Chip::Hh.if_ctrl_spi(), Chip::Df.if_ctrl_spi()), (0x03, 0x40));
    }
}
