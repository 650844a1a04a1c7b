//! Register model of an ST LPS22DF barometer, fed with the pressure at the sensor.
//!
//! Registers as the driver (`r2p_drivers::lps22df`) documents them: reset values WHO_AM_I =
//! 0xB4, CTRL_REG3 = 0x01 (IF_ADD_INC), the others 0 (power-down). The configuration
//! registers (0x0B–0x1B) take writes; WHO_AM_I, the status and the outputs are read-only.
//! CTRL_REG2's SWRESET restores the reset values (the bit clears itself). IF_ADD_INC decides
//! whether a multi-byte access moves to the next register.
//!
//! Sampling: with ODR ≠ 0 a sample is taken every 1/ODR from the moment the rate was written;
//! with ODR = 0, writing ONESHOT takes one at the next [`Lps22dfModel::advance_with`] and
//! clears the bit. The pressure (Pa, from the caller) is stored as 24-bit counts of
//! 1/4096 hPa (round to nearest, saturated), the temperature as counts of 0.01 °C. STATUS's
//! P_DA and T_DA rise with each sample; a sample that finds P_DA still set raises P_OR and
//! T_OR. Reading the pressure outputs clears P_DA and P_OR, the temperature outputs T_DA and
//! T_OR.
//!
//! Simplifications: samples at the `advance_with` call that passes their time (the emulator
//! calls it every millisecond); the averaging and the low-pass filter change only the noise,
//! which the world's model gives; no FIFO, interrupts or reference-pressure mode.

use r2p_drivers::lps22df::{
    Odr, CTRL2_SWRESET, CTRL3_IF_ADD_INC, CTRL_REG1, CTRL_REG2, CTRL_REG3, LSB_PER_DEG_C,
    LSB_PER_HPA, PRESS_OUT_XL, STATUS, STATUS_P_DA, STATUS_P_OR, WHO_AM_I, WHO_AM_I_VALUE,
};

use super::RegisterDevice;

const NS_PER_S: f64 = 1e9;
const ONESHOT: u8 = 1 << 0;
const T_DA: u8 = 1 << 1;
const T_OR: u8 = 1 << 5;

/// What the sensor sees at a sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BaroInput {
    /// Static pressure at the port, Pa.
    pub pressure_pa: f64,
    /// Die temperature, °C.
    pub temperature_c: f64,
}

/// The device's registers and sampling state.
#[derive(Clone, Debug)]
pub struct Lps22dfModel {
    regs: [u8; 0x80],
    next_ns: Option<u64>,
    now_ns: u64,
    samples: u64,
}

impl Default for Lps22dfModel {
    fn default() -> Self {
        Self::new()
    }
}

impl Lps22dfModel {
    /// A device just powered up.
    pub fn new() -> Self {
        let mut regs = [0; 0x80];
        regs[usize::from(WHO_AM_I)] = WHO_AM_I_VALUE;
        regs[usize::from(CTRL_REG3)] = CTRL3_IF_ADD_INC;
        Self { regs, next_ns: None, now_ns: 0, samples: 0 }
    }

    /// Register `reg` without side effects (tests and inspection).
    pub fn peek(&self, reg: u8) -> u8 {
        self.regs[usize::from(reg & 0x7F)]
    }

    /// Samples latched so far.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    fn period_ns(&self) -> Option<u64> {
        let hz = Odr::from_code(self.peek(CTRL_REG1) >> 3)?.hz();
        (hz > 0.0).then(|| (NS_PER_S / f64::from(hz)).round() as u64)
    }

    /// Runs the samples due by `now_ns`, each from `input()`.
    pub fn advance_with(&mut self, now_ns: u64, mut input: impl FnMut() -> BaroInput) {
        self.now_ns = self.now_ns.max(now_ns);
        if self.peek(CTRL_REG2) & ONESHOT != 0 {
            self.latch(&input());
            self.regs[usize::from(CTRL_REG2)] &= !ONESHOT;
            return;
        }
        let (Some(next), Some(p)) = (self.next_ns, self.period_ns()) else { return };
        if next <= self.now_ns {
            self.latch(&input());
            // Skip the samples a long step missed, keep the phase.
            self.next_ns = Some(next + p * ((self.now_ns - next) / p + 1));
        }
    }

    /// Stores a sample as the outputs encode it and raises the data-ready (and overrun) flags.
    pub fn latch(&mut self, s: &BaroInput) {
        self.samples += 1;
        let p = (s.pressure_pa / 100.0 * f64::from(LSB_PER_HPA))
            .round()
            .clamp(-8_388_608.0, 8_388_607.0);
        let p = (p as i32).to_le_bytes();
        let t =
            (s.temperature_c * f64::from(LSB_PER_DEG_C)).round().clamp(-32768.0, 32767.0) as i16;
        let at = usize::from(PRESS_OUT_XL);
        self.regs[at..at + 3].copy_from_slice(&p[..3]);
        self.regs[at + 3..at + 5].copy_from_slice(&t.to_le_bytes());
        let status = &mut self.regs[usize::from(STATUS)];
        if *status & STATUS_P_DA != 0 {
            *status |= STATUS_P_OR | T_OR;
        }
        *status |= STATUS_P_DA | T_DA;
    }
}

impl RegisterDevice for Lps22dfModel {
    fn read_register(&mut self, reg: u8) -> u8 {
        let reg = reg & 0x7F;
        let value = self.regs[usize::from(reg)];
        let status = &mut self.regs[usize::from(STATUS)];
        match reg {
            0x28..=0x2A => *status &= !(STATUS_P_DA | STATUS_P_OR),
            0x2B..=0x2C => *status &= !(T_DA | T_OR),
            _ => {}
        }
        value
    }

    fn write_register(&mut self, reg: u8, value: u8) {
        let reg = reg & 0x7F;
        if !(0x0B..=0x1B).contains(&reg) || reg == WHO_AM_I {
            return; // read-only
        }
        if reg == CTRL_REG2 && value & CTRL2_SWRESET != 0 {
            let (now, samples) = (self.now_ns, self.samples);
            *self = Self::new();
            (self.now_ns, self.samples) = (now, samples);
            return;
        }
        let rate_before = self.peek(CTRL_REG1) >> 3;
        self.regs[usize::from(reg)] = value;
        if self.peek(CTRL_REG1) >> 3 != rate_before {
            self.next_ns = self.period_ns().map(|p| self.now_ns + p);
        }
    }

    fn next_register(&self, reg: u8) -> u8 {
        if self.peek(CTRL_REG3) & CTRL3_IF_ADD_INC != 0 {
            (reg + 1) & 0x7F
        } else {
            reg
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::periph::i2c::SimI2c;
    use crate::periph::spi::SimSpi;
    use crate::periph::{shared, Shared};
    use embedded_hal::spi::SpiDevice;
    use r2p_drivers::lps22df::{Address, Averaging, Config, Error, Lps22df, SpiBus};

    const MS: u64 = 1_000_000;

    fn input() -> BaroInput {
        BaroInput { pressure_pa: 100_512.37, temperature_c: 27.31 }
    }

    fn spi_rig() -> (Shared<Lps22dfModel>, Lps22df<SpiBus<SimSpi>>) {
        let dev = shared(Lps22dfModel::new());
        (dev.clone(), Lps22df::new_spi(SimSpi::new(dev)))
    }

    #[test]
    fn the_driver_configures_the_model_over_spi_and_reads_pascals() {
        let (dev, mut baro) = spi_rig();
        baro.init(Config::default()).unwrap();
        assert_eq!(dev.borrow().peek(CTRL_REG1), 4 << 3 | 3, "25 Hz, 32 samples averaged");
        assert_eq!(dev.borrow().peek(CTRL_REG2), 1 << 3, "BDU");
        assert_eq!(baro.read().unwrap(), None, "nothing before the first period");
        dev.borrow_mut().advance_with(41 * MS, input);
        let s = baro.read().unwrap().expect("a sample after 40 ms");
        // 1/4096 hPa = 0.024 Pa per count.
        assert!((f64::from(s.pressure_pa) - 100_512.37).abs() < 0.02, "{s:?}");
        assert!((s.temp_c - 27.31).abs() < 1e-4);
        assert!(!s.overrun);
        assert_eq!(baro.read().unwrap(), None, "read once");
    }

    #[test]
    fn an_unread_sample_is_an_overrun_and_negative_counts_sign_extend() {
        let (dev, mut baro) = spi_rig();
        baro.init(Config { odr: Odr::Hz200, averaging: Averaging::X4 }).unwrap();
        dev.borrow_mut().advance_with(5 * MS, input);
        dev.borrow_mut()
            .advance_with(10 * MS, || BaroInput { pressure_pa: -50.0, temperature_c: -5.5 });
        let s = baro.read().unwrap().unwrap();
        assert!(s.overrun);
        assert!((s.pressure_pa + 50.0).abs() < 0.02 && (s.temp_c + 5.5).abs() < 1e-4, "{s:?}");
        assert_eq!(dev.borrow().samples(), 2);
    }

    #[test]
    fn one_shot_takes_one_sample_and_software_reset_restores_the_defaults() {
        let (dev, mut baro) = spi_rig();
        baro.probe().unwrap();
        let mut bus = SimSpi::new(dev.clone());
        bus.write(&[CTRL_REG2, ONESHOT]).unwrap();
        for t in [1, 2, 3] {
            dev.borrow_mut().advance_with(t * MS, input);
        }
        assert_eq!(dev.borrow().samples(), 1);
        assert_eq!(dev.borrow().peek(CTRL_REG2), 0, "ONESHOT clears itself");
        bus.write(&[CTRL_REG1, 0x7F]).unwrap();
        bus.write(&[CTRL_REG2, CTRL2_SWRESET]).unwrap();
        assert_eq!((dev.borrow().peek(CTRL_REG1), dev.borrow().peek(CTRL_REG3)), (0, 1));
    }

    #[test]
    fn the_driver_works_over_i2c_and_names_a_wrong_chip() {
        let dev = shared(Lps22dfModel::new());
        let mut i2c = SimI2c::default();
        i2c.attach(0x5C, dev.clone());
        let mut baro = Lps22df::new_i2c(i2c, Address::Sa0Low);
        baro.init(Config::default()).unwrap();
        dev.borrow_mut().advance_with(41 * MS, input);
        assert!(baro.read().unwrap().is_some());
        let e = Lps22df::new_spi(SimSpi::unconnected()).init(Config::default()).unwrap_err();
        assert_eq!(e, Error::WrongDevice { part: "LPS22DF", found: 0xFF, expected: 0xB4 });
        assert!(e.to_string().contains("read 0xff, expected 0xb4"), "{e}");
    }

    /// The model with one register that keeps its reset value.
    struct Stuck(Lps22dfModel, u8);

    impl RegisterDevice for Stuck {
        fn read_register(&mut self, reg: u8) -> u8 {
            self.0.read_register(reg)
        }
        fn write_register(&mut self, reg: u8, value: u8) {
            if reg & 0x7F != self.1 {
                self.0.write_register(reg, value);
            }
        }
        fn next_register(&self, reg: u8) -> u8 {
            self.0.next_register(reg)
        }
    }

    #[test]
    fn a_control_register_that_does_not_take_its_value_is_named() {
        let mut baro = Lps22df::new_spi(SimSpi::new(shared(Stuck(Lps22dfModel::new(), CTRL_REG2))));
        let e = baro.init(Config::default()).unwrap_err();
        assert_eq!(
            e,
            Error::ConfigNotApplied { part: "LPS22DF", register: 0x11, wrote: 0x08, read: 0x00 }
        );
    }

    #[test]
    fn without_auto_increment_a_burst_reads_one_register_again() {
        let dev = shared(Lps22dfModel::new());
        let mut bus = SimSpi::new(dev.clone());
        bus.write(&[CTRL_REG3, 0]).unwrap();
        let mut b = [0; 3];
        use embedded_hal::spi::Operation;
        bus.transaction(&mut [Operation::Write(&[0x80 | WHO_AM_I]), Operation::Read(&mut b)])
            .unwrap();
        assert_eq!(b, [0xB4; 3]);
    }
}
