//! ST LSM6DSO 6-axis IMU (3-axis accelerometer + 3-axis gyroscope) over I2C or SPI.
//!
//! Register map, sensitivities and bus protocols from the LSM6DSO datasheet (DS12140 rev 2,
//! STMicroelectronics): WHO_AM_I (0x0F) reads 0x6C; CTRL1_XL (0x10) and CTRL2_G (0x11) hold
//! the output data rate in bits 7:4 and the full scale in bits 3:2 (gyro ±125 dps in bit 1);
//! CTRL3_C (0x12) has BDU (bit 6, block data update: low and high bytes from one sample) and
//! IF_INC (bit 2, register address auto-increment on I2C and SPI, set at reset); STATUS_REG
//! (0x1E) bits 0..2 flag new accel, gyro and temperature data; OUT_TEMP (0x20), OUTX/Y/Z_G
//! (0x22..0x27) and OUTX/Y/Z_A (0x28..0x2D) are 16-bit little-endian two's complement, so
//! one 14-byte burst from 0x20 reads one consistent sample of everything.
//!
//! I2C: 7-bit address 0x6A (SA0 to GND) or 0x6B (SA0 to VDD); a register read is a write of
//! the register address then a repeated-start read. SPI (mode 3, up to 10 MHz): the first
//! byte is the register address with bit 7 set for a read, then the data.
//!
//! The driver is generic over [`RegisterBus`], implemented by [`I2cBus`] for any
//! [`embedded_hal::i2c::I2c`] and by [`SpiBus`] for any [`embedded_hal::spi::SpiDevice`]
//! (on a module: embassy-stm32's I2C, or its SPI with a chip-select pin through
//! embedded-hal-bus's `ExclusiveDevice`).

use embedded_hal::i2c::{I2c, SevenBitAddress};
use embedded_hal::spi::{Operation, SpiDevice};

/// WHO_AM_I register.
pub const WHO_AM_I: u8 = 0x0F;
/// WHO_AM_I's fixed value.
pub const WHO_AM_I_VALUE: u8 = 0x6C;
/// Accelerometer control: ODR_XL\[7:4\], FS_XL\[3:2\].
pub const CTRL1_XL: u8 = 0x10;
/// Gyroscope control: ODR_G\[7:4\], FS_G\[3:2\], FS_125 \[1\].
pub const CTRL2_G: u8 = 0x11;
/// Control 3: BOOT, BDU, H_LACTIVE, PP_OD, SIM, IF_INC, -, SW_RESET.
pub const CTRL3_C: u8 = 0x12;
/// CTRL4_C register.
pub const CTRL4_C: u8 = 0x13;
/// CTRL4_C: the I2C interface off (ST's LSM6DSO register header: `i2c_disable`, bit 2).
pub const CTRL4_I2C_DISABLE: u8 = 1 << 2;
/// Data-ready flags: TDA \[2\], GDA \[1\], XLDA \[0\].
pub const STATUS_REG: u8 = 0x1E;
/// First output register (temperature, low byte); gyro from 0x22, accel from 0x28.
pub const OUT_TEMP_L: u8 = 0x20;
/// CTRL3_C's block-data-update bit.
pub const CTRL3_BDU: u8 = 1 << 6;
/// CTRL3_C's auto-increment bit (reset value of CTRL3_C is this bit alone).
pub const CTRL3_IF_INC: u8 = 1 << 2;
/// CTRL3_C's software-reset bit.
pub const CTRL3_SW_RESET: u8 = 1 << 0;
/// Standard gravity, m/s² (the datasheet's g).
pub const G: f32 = 9.806_65;

/// Output data rate, shared by the accelerometer and the gyroscope (high-performance mode).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Odr {
    /// Power-down.
    Off = 0,
    /// 12.5 Hz.
    Hz12_5 = 1,
    /// 26 Hz.
    Hz26 = 2,
    /// 52 Hz.
    Hz52 = 3,
    /// 104 Hz.
    Hz104 = 4,
    /// 208 Hz.
    Hz208 = 5,
    /// 416 Hz.
    Hz416 = 6,
    /// 833 Hz.
    Hz833 = 7,
    /// 1.66 kHz.
    Hz1660 = 8,
    /// 3.33 kHz.
    Hz3330 = 9,
    /// 6.66 kHz.
    Hz6660 = 10,
}

impl Odr {
    /// The rate for register code `code` (bits 7:4 of CTRL1_XL / CTRL2_G).
    pub fn from_code(code: u8) -> Option<Odr> {
        use Odr::*;
        [Off, Hz12_5, Hz26, Hz52, Hz104, Hz208, Hz416, Hz833, Hz1660, Hz3330, Hz6660]
            .get(usize::from(code))
            .copied()
    }

    /// Samples per second (0 when off).
    pub fn hz(self) -> f32 {
        match self {
            Odr::Off => 0.0,
            Odr::Hz12_5 => 12.5,
            Odr::Hz26 => 26.0,
            Odr::Hz52 => 52.0,
            Odr::Hz104 => 104.0,
            Odr::Hz208 => 208.0,
            Odr::Hz416 => 416.0,
            Odr::Hz833 => 833.0,
            Odr::Hz1660 => 1660.0,
            Odr::Hz3330 => 3330.0,
            Odr::Hz6660 => 6660.0,
        }
    }
}

/// Accelerometer full scale.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AccelScale {
    /// ±2 g, 0.061 mg/LSB.
    G2,
    /// ±4 g, 0.122 mg/LSB.
    G4,
    /// ±8 g, 0.244 mg/LSB.
    G8,
    /// ±16 g, 0.488 mg/LSB.
    G16,
}

impl AccelScale {
    /// FS_XL bits (CTRL1_XL\[3:2\]): note ±16 g is 01, not 11.
    pub fn bits(self) -> u8 {
        match self {
            AccelScale::G2 => 0b00,
            AccelScale::G16 => 0b01,
            AccelScale::G4 => 0b10,
            AccelScale::G8 => 0b11,
        }
    }

    /// The scale for FS_XL bits `bits`.
    pub fn from_bits(bits: u8) -> AccelScale {
        match bits & 0b11 {
            0b00 => AccelScale::G2,
            0b01 => AccelScale::G16,
            0b10 => AccelScale::G4,
            _ => AccelScale::G8,
        }
    }

    /// Sensitivity, mg per LSB (datasheet table 2, LA_So).
    pub fn mg_per_lsb(self) -> f32 {
        match self {
            AccelScale::G2 => 0.061,
            AccelScale::G4 => 0.122,
            AccelScale::G8 => 0.244,
            AccelScale::G16 => 0.488,
        }
    }

    /// Sensitivity, m/s² per LSB.
    pub fn m_s2_per_lsb(self) -> f32 {
        self.mg_per_lsb() * 1e-3 * G
    }
}

/// Gyroscope full scale.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GyroScale {
    /// ±125 dps, 4.375 mdps/LSB.
    Dps125,
    /// ±250 dps, 8.75 mdps/LSB.
    Dps250,
    /// ±500 dps, 17.50 mdps/LSB.
    Dps500,
    /// ±1000 dps, 35 mdps/LSB.
    Dps1000,
    /// ±2000 dps, 70 mdps/LSB.
    Dps2000,
}

impl GyroScale {
    /// FS_G and FS_125 bits (CTRL2_G\[3:1\]).
    pub fn bits(self) -> u8 {
        match self {
            GyroScale::Dps125 => 0b001,
            GyroScale::Dps250 => 0b000,
            GyroScale::Dps500 => 0b010,
            GyroScale::Dps1000 => 0b100,
            GyroScale::Dps2000 => 0b110,
        }
    }

    /// The scale for CTRL2_G\[3:1\] bits `bits` (FS_125 wins over FS_G).
    pub fn from_bits(bits: u8) -> GyroScale {
        if bits & 1 != 0 {
            return GyroScale::Dps125;
        }
        match (bits >> 1) & 0b11 {
            0b00 => GyroScale::Dps250,
            0b01 => GyroScale::Dps500,
            0b10 => GyroScale::Dps1000,
            _ => GyroScale::Dps2000,
        }
    }

    /// Sensitivity, mdps per LSB (datasheet table 2, G_So).
    pub fn mdps_per_lsb(self) -> f32 {
        match self {
            GyroScale::Dps125 => 4.375,
            GyroScale::Dps250 => 8.75,
            GyroScale::Dps500 => 17.5,
            GyroScale::Dps1000 => 35.0,
            GyroScale::Dps2000 => 70.0,
        }
    }

    /// Sensitivity, rad/s per LSB.
    pub fn rad_s_per_lsb(self) -> f32 {
        self.mdps_per_lsb() * 1e-3 * (core::f32::consts::PI / 180.0)
    }
}

/// What [`Lsm6dso::init`] sets up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Accelerometer output data rate.
    pub accel_odr: Odr,
    /// Accelerometer full scale.
    pub accel_scale: AccelScale,
    /// Gyroscope output data rate.
    pub gyro_odr: Odr,
    /// Gyroscope full scale.
    pub gyro_scale: GyroScale,
}

impl Default for Config {
    /// 104 Hz, ±4 g, ±500 dps: a mobile base's accelerations and turn rates with margin, at
    /// a rate above the 100 Hz control loops.
    fn default() -> Self {
        Config {
            accel_odr: Odr::Hz104,
            accel_scale: AccelScale::G4,
            gyro_odr: Odr::Hz104,
            gyro_scale: GyroScale::Dps500,
        }
    }
}

/// Register access over some bus (here `read_registers` needs IF_INC, set at reset).
pub use crate::register_bus::{Error, RegisterBus};

/// I2C address, set by the SA0 pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Address {
    /// SA0 to GND: 0x6A.
    Sa0Low,
    /// SA0 to VDD: 0x6B.
    Sa0High,
}

impl Address {
    /// The 7-bit address.
    pub fn bits(self) -> SevenBitAddress {
        match self {
            Address::Sa0Low => 0x6A,
            Address::Sa0High => 0x6B,
        }
    }
}

/// The LSM6DSO on an I2C bus.
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

/// The LSM6DSO on an SPI device (chip select handled by the [`SpiDevice`]).
#[derive(Debug)]
pub struct SpiBus<S> {
    spi: S,
}

/// Bit 7 of the first SPI byte: read.
pub const SPI_READ: u8 = 0x80;

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

/// One sample in raw counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RawSample {
    /// Temperature, 256 LSB/°C, 0 at 25 °C.
    pub temp: i16,
    /// Gyro x, y, z.
    pub gyro: [i16; 3],
    /// Accel x, y, z.
    pub accel: [i16; 3],
}

impl RawSample {
    /// Decodes the 14 bytes from OUT_TEMP_L.
    pub fn from_bytes(b: &[u8; 14]) -> RawSample {
        let w = |i: usize| i16::from_le_bytes([b[2 * i], b[2 * i + 1]]);
        RawSample { temp: w(0), gyro: [w(1), w(2), w(3)], accel: [w(4), w(5), w(6)] }
    }
}

/// One sample in SI units (sensor axes).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Angular rate, rad/s.
    pub gyro: [f32; 3],
    /// Specific force (acceleration minus gravity: +g up when at rest), m/s².
    pub accel: [f32; 3],
    /// Die temperature, °C.
    pub temp_c: f32,
}

/// Which outputs hold data not read yet (STATUS_REG).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DataReady {
    /// XLDA.
    pub accel: bool,
    /// GDA.
    pub gyro: bool,
    /// TDA.
    pub temp: bool,
}

/// An LSM6DSO driver.
#[derive(Debug)]
pub struct Lsm6dso<B> {
    bus: B,
    config: Config,
}

impl<I: I2c> Lsm6dso<I2cBus<I>> {
    /// The IMU at `address` on `i2c`.
    pub fn new_i2c(i2c: I, address: Address) -> Self {
        Self::new(I2cBus { i2c, address: address.bits() })
    }
}

impl<S: SpiDevice> Lsm6dso<SpiBus<S>> {
    /// The IMU on `spi` (4-wire, mode 3).
    pub fn new_spi(spi: S) -> Self {
        Self::new(SpiBus { spi })
    }
}

impl<B: RegisterBus> Lsm6dso<B> {
    /// The IMU on `bus`, assumed in its reset state (both sensors off) until [`Self::init`].
    pub fn new(bus: B) -> Self {
        let off = Config {
            accel_odr: Odr::Off,
            accel_scale: AccelScale::G2,
            gyro_odr: Odr::Off,
            gyro_scale: GyroScale::Dps250,
        };
        Self { bus, config: off }
    }

    /// Checks WHO_AM_I.
    pub fn probe(&mut self) -> Result<(), Error<B::Error>> {
        crate::register_bus::probe(&mut self.bus, "LSM6DSO", WHO_AM_I, WHO_AM_I_VALUE)
    }

    /// Probes, then sets BDU and auto-increment and `config`'s rates and scales, checking
    /// each control register reads back what was written.
    pub fn init(&mut self, config: Config) -> Result<(), Error<B::Error>> {
        self.probe()?;
        let ctrl3 = CTRL3_BDU | CTRL3_IF_INC;
        let ctrl1 = (config.accel_odr as u8) << 4 | config.accel_scale.bits() << 2;
        let ctrl2 = (config.gyro_odr as u8) << 4 | config.gyro_scale.bits() << 1;
        let ctrl4 = if B::SPI { CTRL4_I2C_DISABLE } else { 0 };
        for (reg, value) in
            [(CTRL3_C, ctrl3), (CTRL4_C, ctrl4), (CTRL1_XL, ctrl1), (CTRL2_G, ctrl2)]
        {
            self.bus.write_register(reg, value)?;
        }
        let mut back = [0; 4];
        self.bus.read_registers(CTRL1_XL, &mut back)?;
        for (reg, wrote, read) in [
            (CTRL1_XL, ctrl1, back[0]),
            (CTRL2_G, ctrl2, back[1]),
            (CTRL3_C, ctrl3, back[2]),
            (CTRL4_C, ctrl4, back[3]),
        ] {
            if read != wrote {
                return Err(Error::ConfigNotApplied {
                    part: "LSM6DSO",
                    register: reg,
                    wrote,
                    read,
                });
            }
        }
        self.config = config;
        Ok(())
    }

    /// The configuration in force.
    pub fn config(&self) -> Config {
        self.config
    }

    /// Which outputs hold new data.
    pub fn data_ready(&mut self) -> Result<DataReady, Error<B::Error>> {
        let mut s = [0];
        self.bus.read_registers(STATUS_REG, &mut s)?;
        // STATUS_REG's bits 7:3 are reserved (0): all ones is a part not answering.
        crate::register_bus::answered("LSM6DSO", &s)?;
        Ok(DataReady { accel: s[0] & 1 != 0, gyro: s[0] & 2 != 0, temp: s[0] & 4 != 0 })
    }

    /// Reads temperature, gyro and accel in one 14-byte burst.
    pub fn read_raw(&mut self) -> Result<RawSample, Error<B::Error>> {
        let mut b = [0; 14];
        self.bus.read_registers(OUT_TEMP_L, &mut b)?;
        Ok(RawSample::from_bytes(&b))
    }

    /// Reads a sample and converts it with the configured full scales.
    pub fn read(&mut self) -> Result<Sample, Error<B::Error>> {
        let raw = self.read_raw()?;
        Ok(self.convert(&raw))
    }

    /// Converts raw counts with the configured full scales.
    pub fn convert(&self, raw: &RawSample) -> Sample {
        let g = self.config.gyro_scale.rad_s_per_lsb();
        let a = self.config.accel_scale.m_s2_per_lsb();
        Sample {
            gyro: raw.gyro.map(|c| f32::from(c) * g),
            accel: raw.accel.map(|c| f32::from(c) * a),
            temp_c: 25.0 + f32::from(raw.temp) / 256.0,
        }
    }

    /// Gives the bus back.
    pub fn release(self) -> B {
        self.bus
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    /// A register file behind [`RegisterBus`] that logs accesses (the bus protocols are tested
    /// against the emulator's I2C and SPI models in r2p-emu).
    struct Regs {
        r: [u8; 128],
        log: Vec<(char, u8, usize)>,
        fail: bool,
    }

    impl RegisterBus for Regs {
        type Error = &'static str;
        fn write_register(&mut self, reg: u8, value: u8) -> Result<(), &'static str> {
            if self.fail {
                return Err("nack");
            }
            self.log.push(('w', reg, 1));
            self.r[usize::from(reg)] = value;
            Ok(())
        }
        fn read_registers(&mut self, reg: u8, buf: &mut [u8]) -> Result<(), &'static str> {
            if self.fail {
                return Err("nack");
            }
            self.log.push(('r', reg, buf.len()));
            let start = usize::from(reg);
            buf.copy_from_slice(&self.r[start..start + buf.len()]);
            Ok(())
        }
    }

    fn regs() -> Regs {
        let mut r = [0; 128];
        r[usize::from(WHO_AM_I)] = WHO_AM_I_VALUE;
        r[usize::from(CTRL3_C)] = CTRL3_IF_INC;
        Regs { r, log: Vec::new(), fail: false }
    }

    #[test]
    fn init_writes_datasheet_bit_patterns() {
        let mut imu = Lsm6dso::new(regs());
        imu.init(Config::default()).unwrap();
        let r = imu.release();
        // 104 Hz = 0100, ±4 g = 10 → 0x48; ±500 dps: FS_G = 01 → 0x44; BDU | IF_INC = 0x44.
        assert_eq!(r.r[0x10], 0x48);
        assert_eq!(r.r[0x11], 0x44);
        assert_eq!(r.r[0x12], 0x44);
        let mut imu = Lsm6dso::new(regs());
        let c = Config {
            accel_odr: Odr::Hz6660,
            accel_scale: AccelScale::G16,
            gyro_odr: Odr::Hz12_5,
            gyro_scale: GyroScale::Dps125,
        };
        imu.init(c).unwrap();
        let r = imu.release();
        assert_eq!(r.r[0x10], 0xA4);
        assert_eq!(r.r[0x11], 0x12);
    }

    #[test]
    fn scale_bits_round_trip() {
        for s in [AccelScale::G2, AccelScale::G4, AccelScale::G8, AccelScale::G16] {
            assert_eq!(AccelScale::from_bits(s.bits()), s);
        }
        for s in [
            GyroScale::Dps125,
            GyroScale::Dps250,
            GyroScale::Dps500,
            GyroScale::Dps1000,
            GyroScale::Dps2000,
        ] {
            assert_eq!(GyroScale::from_bits(s.bits()), s);
        }
        for c in 0..=10 {
            assert_eq!(Odr::from_code(c).unwrap() as u8, c);
        }
        assert_eq!(Odr::from_code(11), None);
    }

    #[test]
    fn wrong_who_am_i_names_both_values() {
        let mut r = regs();
        r.r[usize::from(WHO_AM_I)] = 0x6A; // an LSM6DS3
        let e = Lsm6dso::new(r).init(Config::default()).unwrap_err();
        assert_eq!(e, Error::WrongDevice { part: "LSM6DSO", found: 0x6A, expected: 0x6C });
        let text = std::format!("{e}");
        assert!(text.contains("read 0x6a") && text.contains("expected 0x6c"), "{text}");
    }

    #[test]
    fn bus_errors_propagate() {
        let mut r = regs();
        r.fail = true;
        assert_eq!(Lsm6dso::new(r).init(Config::default()), Err(Error::Bus("nack")));
    }

    #[test]
    fn burst_read_converts_with_datasheet_sensitivities() {
        let mut r = regs();
        let bytes: [i16; 7] = [512, 1000, -1000, 0, 8197, 0, -16393];
        for (i, w) in bytes.iter().enumerate() {
            let [lo, hi] = w.to_le_bytes();
            r.r[0x20 + 2 * i] = lo;
            r.r[0x21 + 2 * i] = hi;
        }
        let mut imu = Lsm6dso::new(r);
        imu.init(Config::default()).unwrap();
        let s = imu.read().unwrap();
        // One burst of 14 bytes from 0x20.
        assert_eq!(imu.release().log.last(), Some(&('r', 0x20, 14)));
        assert_eq!(s.temp_c, 27.0);
        // 1000 × 17.5 mdps = 17.5 dps = 0.30543 rad/s.
        assert!((s.gyro[0] - 0.305_432_6).abs() < 1e-5, "{:?}", s.gyro);
        assert!((s.gyro[1] + 0.305_432_6).abs() < 1e-5);
        // 8197 × 0.122 mg = 1.000 g; −16393 × 0.122 mg = −2.000 g.
        assert!((s.accel[0] - 9.806_65).abs() < 2e-3, "{:?}", s.accel);
        assert_eq!(s.accel[1], 0.0);
        assert!((s.accel[2] + 2.0 * 9.806_65).abs() < 3e-3);
    }

    #[test]
    fn config_not_applied_is_reported() {
        struct Stuck(Regs);
        impl RegisterBus for Stuck {
            type Error = &'static str;
            fn write_register(&mut self, reg: u8, v: u8) -> Result<(), &'static str> {
                // CTRL2_G's writes are lost.
                if reg != CTRL2_G {
                    self.0.write_register(reg, v)?;
                }
                Ok(())
            }
            fn read_registers(&mut self, reg: u8, buf: &mut [u8]) -> Result<(), &'static str> {
                self.0.read_registers(reg, buf)
            }
        }
        let e = Lsm6dso::new(Stuck(regs())).init(Config::default()).unwrap_err();
        assert_eq!(
            e,
            Error::ConfigNotApplied { part: "LSM6DSO", register: CTRL2_G, wrote: 0x44, read: 0 }
        );
    }
}
