//! Register model of an ST LIS3MDL magnetometer, fed with the field at the sensor.
//!
//! Registers as in the datasheet (DocID024204; addresses and scales shared with the driver,
//! `r2p_drivers::lis3mdl`): reset values WHO_AM_I = 0x3D, CTRL_REG1 = 0x10 (10 Hz),
//! CTRL_REG3 = 0x03 (power-down), the others 0. The control registers (0x20–0x24) and the
//! interrupt configuration (0x30, 0x32–0x33) take writes; everything else is read-only.
//! CTRL_REG2's SOFT_RST restores the control registers' reset values (the bit clears itself).
//! Bits DS9463 (Rev 7, Tables 22–27) says must be 0 are not stored: CTRL_REG2 keeps 0x6C,
//! CTRL_REG3 0x27 (LP, SIM, MD; no I2C switch: ST's own register header has none either),
//! CTRL_REG4 0x0E, CTRL_REG5 0xC0. On the part a 1 there is undefined; here a driver that
//! writes one fails its read-back check.
//! A multi-byte access moves to the next register only when the command asked for it: SPI's
//! MS bit (6 of the command byte), I2C's sub-address MSB ([`RegisterDevice::spi_address`],
//! [`RegisterDevice::i2c_pointer`]); without it, it reads the same register again.
//!
//! Sampling: in continuous mode (MD = 00) a sample is taken every 1/ODR from the moment the
//! mode or the rate was written; single mode (MD = 01) takes one, one period later, then
//! returns to power-down (MD = 11), as the datasheet describes. [`Lis3mdlModel::advance_with`]
//! runs the samples due: the field (µT, sensor axes) from the caller, converted with the
//! configured full scale (round to nearest, saturate at the 16-bit limits), little-endian;
//! the temperature at 8 LSB/°C from 25 °C while TEMP_EN is set. STATUS_REG's ZYXDA (and
//! X/Y/ZDA) rise with each sample; a sample that finds them still set raises ZYXOR (and
//! X/Y/ZOR): the previous one was never read. Reading an output register clears the status.
//!
//! Simplifications: a sample is taken at the `advance_with` call that passes its time (the
//! emulator calls it every millisecond); block data update is implicit (a bus transaction is
//! atomic in virtual time); no FAST_ODR rates, self-test, interrupts or big-endian outputs
//! (BLE).

use r2p_drivers::lis3mdl::{
    Odr, Scale, CTRL1_TEMP_EN, CTRL2_SOFT_RST, CTRL_REG1, CTRL_REG2, CTRL_REG3, CTRL_REG5,
    I2C_INCREMENT, OUT_X_L, SPI_INCREMENT, STATUS_REG, STATUS_ZYXDA, STATUS_ZYXOR, WHO_AM_I,
    WHO_AM_I_VALUE,
};

use super::RegisterDevice;

const NS_PER_S: f64 = 1e9;
const TEMP_OUT_L: u8 = 0x2E;
/// STATUS_REG's data-available bits (ZYXDA, ZDA, YDA, XDA).
const ALL_DA: u8 = 0x0F;

/// What the sensor sees at a sample: the flux density at its die in its own axes, µT, and
/// the die temperature, °C.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MagInput {
    /// Flux density, µT (x, y, z of the sensor).
    pub field_ut: [f64; 3],
    /// Die temperature, °C.
    pub temperature_c: f64,
}

/// The device's registers and sampling state.
#[derive(Clone, Debug)]
pub struct Lis3mdlModel {
    regs: [u8; 0x40],
    /// Next sample, ns (None: not converting).
    next_ns: Option<u64>,
    now_ns: u64,
    samples: u64,
    /// Whether the current access increments the address (set by its command).
    increment: bool,
}

impl Default for Lis3mdlModel {
    fn default() -> Self {
        Self::new()
    }
}

/// Round to nearest and saturate to a 16-bit two's-complement output.
fn counts(value: f64, per_lsb: f64) -> i16 {
    (value / per_lsb).round().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16
}

impl Lis3mdlModel {
    /// A device just powered up.
    pub fn new() -> Self {
        let mut m =
            Self { regs: [0; 0x40], next_ns: None, now_ns: 0, samples: 0, increment: false };
        m.reset_control();
        m.regs[usize::from(WHO_AM_I)] = WHO_AM_I_VALUE;
        m
    }

    fn reset_control(&mut self) {
        for (reg, value) in
            [(CTRL_REG1, 0x10), (CTRL_REG2, 0), (CTRL_REG3, 0x03), (0x23, 0), (CTRL_REG5, 0)]
        {
            self.regs[usize::from(reg)] = value;
        }
        self.next_ns = None;
    }

    /// Register `reg` without side effects (tests and inspection).
    pub fn peek(&self, reg: u8) -> u8 {
        self.regs[usize::from(reg & 0x3F)]
    }

    /// Samples latched so far.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    fn period_ns(&self) -> u64 {
        let hz = Odr::from_code(self.peek(CTRL_REG1) >> 2).hz();
        (NS_PER_S / f64::from(hz)).round() as u64
    }

    /// MD: 0 continuous, 1 single, 2–3 power-down.
    fn mode(&self) -> u8 {
        self.peek(CTRL_REG3) & 0b11
    }

    /// Runs the samples due by `now_ns`, each from `input()`.
    pub fn advance_with(&mut self, now_ns: u64, mut input: impl FnMut() -> MagInput) {
        self.now_ns = self.now_ns.max(now_ns);
        let Some(next) = self.next_ns.filter(|&n| n <= self.now_ns) else { return };
        self.latch(&input());
        if self.mode() == 1 {
            self.regs[usize::from(CTRL_REG3)] |= 0b11; // single conversion done: power-down
            self.next_ns = None;
        } else {
            // Skip the samples a long step missed, keep the phase.
            let p = self.period_ns();
            self.next_ns = Some(next + p * ((self.now_ns - next) / p + 1));
        }
    }

    /// Stores a sample in the outputs as the configured full scale encodes it and raises the
    /// data-available flags (and the overrun flags if the last sample was not read).
    pub fn latch(&mut self, s: &MagInput) {
        self.samples += 1;
        let k = f64::from(Scale::from_bits(self.peek(CTRL_REG2) >> 5).ut_per_lsb());
        let temp_on = self.peek(CTRL_REG1) & CTRL1_TEMP_EN != 0;
        let mut put = |reg: u8, v: i16| {
            let [lo, hi] = v.to_le_bytes();
            self.regs[usize::from(reg)] = lo;
            self.regs[usize::from(reg) + 1] = hi;
        };
        for (i, b) in s.field_ut.iter().enumerate() {
            put(OUT_X_L + 2 * i as u8, counts(*b, k));
        }
        if temp_on {
            put(TEMP_OUT_L, counts(s.temperature_c - 25.0, 1.0 / 8.0));
        }
        let status = &mut self.regs[usize::from(STATUS_REG)];
        if *status & STATUS_ZYXDA != 0 {
            *status |= STATUS_ZYXOR | 0x70;
        }
        *status |= ALL_DA;
    }

    /// (Re)starts conversion after a write to the rate or the mode.
    fn reschedule(&mut self) {
        self.next_ns = (self.mode() <= 1).then(|| self.now_ns + self.period_ns());
    }
}

impl RegisterDevice for Lis3mdlModel {
    fn read_register(&mut self, reg: u8) -> u8 {
        let reg = reg & 0x3F;
        let value = self.regs[usize::from(reg)];
        if (OUT_X_L..OUT_X_L + 6).contains(&reg) {
            self.regs[usize::from(STATUS_REG)] = 0;
        }
        value
    }

    fn write_register(&mut self, reg: u8, value: u8) {
        let reg = reg & 0x3F;
        if !matches!(reg, 0x20..=0x24 | 0x30 | 0x32 | 0x33) {
            return; // read-only
        }
        if reg == CTRL_REG2 && value & CTRL2_SOFT_RST != 0 {
            self.reset_control();
            return;
        }
        let writable = match reg {
            CTRL_REG2 => 0x6C,
            CTRL_REG3 => 0x27,
            0x23 => 0x0E,
            CTRL_REG5 => 0xC0,
            _ => 0xFF,
        };
        let before = (self.peek(CTRL_REG1) & 0x1C, self.mode());
        self.regs[usize::from(reg)] = value & writable;
        if (self.peek(CTRL_REG1) & 0x1C, self.mode()) != before {
            self.reschedule();
        }
    }

    fn next_register(&self, reg: u8) -> u8 {
        if self.increment {
            (reg + 1) & 0x3F
        } else {
            reg
        }
    }

    fn spi_address(&mut self, command: u8) -> u8 {
        self.increment = command & SPI_INCREMENT != 0;
        command & 0x3F
    }

    fn i2c_pointer(&mut self, sub_address: u8) -> u8 {
        self.increment = sub_address & I2C_INCREMENT != 0;
        sub_address & 0x3F
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::periph::i2c::SimI2c;
    use crate::periph::spi::SimSpi;
    use crate::periph::{shared, Shared};
    use r2p_drivers::lis3mdl::{Address, Config, Error, Lis3mdl};

    const MS: u64 = 1_000_000;
    /// A typical field in Milan (µT, sensor axes level and facing north-east).
    const FIELD: [f64; 3] = [16.8, 16.8, -41.0];

    fn input() -> MagInput {
        MagInput { field_ut: FIELD, temperature_c: 31.0 }
    }

    fn spi_rig() -> (Shared<Lis3mdlModel>, Lis3mdl<r2p_drivers::lis3mdl::SpiBus<SimSpi>>) {
        let dev = shared(Lis3mdlModel::new());
        (dev.clone(), Lis3mdl::new_spi(SimSpi::new(dev)))
    }

    #[test]
    fn the_driver_configures_the_model_over_spi_and_reads_the_field_in_microtesla() {
        let (dev, mut mag) = spi_rig();
        mag.init(Config::default()).unwrap();
        // 80 Hz, UHP on x/y/z, temperature on, continuous, BDU.
        assert_eq!(dev.borrow().peek(CTRL_REG1), 0x80 | 0x60 | 7 << 2);
        assert_eq!(dev.borrow().peek(CTRL_REG3), 0, "continuous, 4-wire SPI");
        assert_eq!(dev.borrow().peek(0x23), 0b1100);
        assert_eq!(mag.read().unwrap(), None, "no sample before the first period");
        dev.borrow_mut().advance_with(13 * MS, input);
        let s = mag.read().unwrap().expect("a sample after 12.5 ms");
        for (got, want) in s.field_ut.iter().zip(FIELD) {
            // ±4 gauss: 0.0146 µT per LSB.
            assert!((f64::from(*got) - want).abs() < 0.01, "{:?}", s.field_ut);
        }
        assert_eq!(s.temp_c, 31.0);
        assert!(!s.overrun);
        assert_eq!(mag.read().unwrap(), None, "read once");
    }

    #[test]
    fn a_sample_left_unread_is_reported_as_an_overrun() {
        let (dev, mut mag) = spi_rig();
        mag.init(Config::default()).unwrap();
        dev.borrow_mut().advance_with(13 * MS, input);
        dev.borrow_mut().advance_with(26 * MS, input);
        assert!(mag.read().unwrap().unwrap().overrun);
        dev.borrow_mut().advance_with(39 * MS, input);
        assert!(!mag.read().unwrap().unwrap().overrun);
        assert_eq!(dev.borrow().samples(), 3);
    }

    #[test]
    fn without_the_increment_bit_a_burst_reads_one_register_again() {
        use embedded_hal::spi::{Operation, SpiDevice};
        let dev = shared(Lis3mdlModel::new());
        let mut spi = SimSpi::new(dev.clone());
        let mut b = [0; 3];
        spi.transaction(&mut [Operation::Write(&[0x80 | WHO_AM_I]), Operation::Read(&mut b)])
            .unwrap();
        assert_eq!(b, [0x3D; 3]);
        spi.transaction(&mut [Operation::Write(&[0xC0 | CTRL_REG1]), Operation::Read(&mut b)])
            .unwrap();
        assert_eq!(b, [0x10, 0x00, 0x03], "reset values of CTRL_REG1..3");
    }

    #[test]
    fn the_driver_works_over_i2c_at_the_sa1_high_address() {
        let dev = shared(Lis3mdlModel::new());
        let mut i2c = SimI2c::default();
        i2c.attach(0x1E, dev.clone());
        let mut mag = Lis3mdl::new_i2c(i2c, Address::Sa1High);
        mag.init(Config { odr: r2p_drivers::lis3mdl::Odr::Hz10, scale: Scale::Gauss16 }).unwrap();
        dev.borrow_mut().advance_with(101 * MS, input);
        let s = mag.read().unwrap().unwrap();
        // ±16 gauss: 0.058 µT per LSB.
        assert!((f64::from(s.field_ut[2]) - FIELD[2]).abs() < 0.03, "{:?}", s.field_ut);
    }

    #[test]
    fn an_absent_or_wrong_chip_is_named_by_what_it_read() {
        let mut mag = Lis3mdl::new_spi(SimSpi::unconnected());
        let e = mag.init(Config::default()).unwrap_err();
        assert_eq!(e, Error::WrongDevice { part: "LIS3MDL", found: 0xFF, expected: 0x3D });
        assert!(e.to_string().contains("read 0xff, expected 0x3d"), "{e}");
    }

    #[test]
    fn single_mode_takes_one_sample_then_powers_down_and_soft_reset_restores_the_defaults() {
        let (dev, mut mag) = spi_rig();
        mag.init(Config::default()).unwrap();
        let mut bus = SimSpi::new(dev.clone());
        use embedded_hal::spi::SpiDevice;
        bus.write(&[CTRL_REG3, 0x01]).unwrap();
        for t in [13, 26, 39] {
            dev.borrow_mut().advance_with(t * MS, input);
        }
        assert_eq!(dev.borrow().samples(), 1);
        assert_eq!(dev.borrow().peek(CTRL_REG3), 0x03);
        bus.write(&[CTRL_REG2, CTRL2_SOFT_RST]).unwrap();
        assert_eq!((dev.borrow().peek(CTRL_REG1), dev.borrow().peek(CTRL_REG5)), (0x10, 0));
    }

    /// The model with one register that keeps its reset value (a stuck bit, a bus fault).
    struct Stuck(Lis3mdlModel, u8);

    impl RegisterDevice for Stuck {
        fn read_register(&mut self, reg: u8) -> u8 {
            self.0.read_register(reg)
        }
        fn write_register(&mut self, reg: u8, value: u8) {
            if reg & 0x3F != self.1 {
                self.0.write_register(reg, value);
            }
        }
        fn next_register(&self, reg: u8) -> u8 {
            self.0.next_register(reg)
        }
        fn spi_address(&mut self, command: u8) -> u8 {
            self.0.spi_address(command)
        }
    }

    #[test]
    fn a_control_register_that_does_not_take_its_value_is_named() {
        let mut mag = Lis3mdl::new_spi(SimSpi::new(shared(Stuck(Lis3mdlModel::new(), 0x23))));
        let e = mag.init(Config::default()).unwrap_err();
        assert_eq!(
            e,
            Error::ConfigNotApplied { part: "LIS3MDL", register: 0x23, wrote: 0x0C, read: 0x00 }
        );
        assert!(e.to_string().contains("register 0x23 reads back 0x00 after writing 0x0c"), "{e}");
    }

    #[test]
    fn fields_beyond_the_full_scale_saturate() {
        let mut m = Lis3mdlModel::new();
        m.latch(&MagInput { field_ut: [500.0, -500.0, 0.0], temperature_c: 25.0 });
        assert_eq!(i16::from_le_bytes([m.peek(0x28), m.peek(0x29)]), i16::MAX);
        assert_eq!(i16::from_le_bytes([m.peek(0x2A), m.peek(0x2B)]), i16::MIN);
    }
}
