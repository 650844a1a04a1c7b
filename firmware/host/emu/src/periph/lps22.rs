//! Register model of an ST LPS22HH or LPS22DF barometer, fed with the pressure at the sensor.
//!
//! Registers as the driver (`r2p_drivers::lps22`) documents them, from ST's register headers
//! (lps22hh_reg.h, lps22df_reg.h) and ST's `lps22hh-rs` register descriptions:
//!
//! - **LPS22HH**: at power-up WHO_AM_I = 0xB3, CTRL_REG2 = 0x10 (IF_ADD_INC: "1: Enabled
//!   (default)", lps22hh-rs `CtrlReg2`), the others 0 (power-down). Writable: INTERRUPT_CFG
//!   0x0B, THS_P 0x0C–0x0D, IF_CTRL 0x0E, CTRL_REG1..3 0x10–0x12, FIFO_CTRL 0x13, FIFO_WTM
//!   0x14, REF_P 0x15–0x16, RPDS 0x18–0x19 (0x17 is not in the map); the bits the header marks
//!   `not_used` are not stored (they read 0): THS_P_H \[7\], IF_CTRL \[6:5\], CTRL_REG1 \[7\],
//!   CTRL_REG2 \[3\], CTRL_REG3 \[7:6\], FIFO_CTRL \[7:4\], FIFO_WTM \[7\]. The rate is CTRL_REG1's
//!   ODR \[6:4\]; auto-increment CTRL_REG2's IF_ADD_INC \[4\]; BOOT \[7\] (reload the trimming)
//!   clears itself and is not kept.
//! - **LPS22DF**: WHO_AM_I = 0xB4, CTRL_REG3 = 0x01 (IF_ADD_INC), the others 0. Writable
//!   0x0B–0x1B but WHO_AM_I, every bit stored. The rate is CTRL_REG1's ODR \[6:3\] (codes 9–15
//!   are no rate: no sampling); auto-increment CTRL_REG3's IF_ADD_INC \[0\].
//!
//! Both: WHO_AM_I, the status and the outputs are read-only; CTRL_REG2's SWRESET \[2\] restores
//! the power-up values (the bit clears itself).
//!
//! Sampling: with a rate set a sample is taken every 1/ODR from the moment the rate was
//! written; in power-down, writing ONE_SHOT takes one at the next [`Lps22Model::advance_with`]
//! and clears the bit. The pressure (Pa, from the caller) is stored as 24-bit counts of 1/4096
//! hPa (round to nearest, saturated), the temperature as counts of 0.01 °C. STATUS's P_DA and
//! T_DA rise with each sample; a sample that finds P_DA still set raises P_OR and T_OR.
//! Reading the pressure outputs clears P_DA and P_OR, the temperature outputs T_DA and T_OR.
//!
//! Simplifications: samples at the `advance_with` call that passes their time (the emulator
//! calls it every millisecond); the DF's averaging, the HH's low-noise mode and the low-pass
//! filters change only the noise, which the world's model gives; no FIFO, interrupts,
//! reference-pressure or offset (RPDS) mode; block data update not modelled (a burst reads one
//! sample's bytes anyway).

use r2p_drivers::lps22::{
    hh, Chip, CTRL2_ONE_SHOT, CTRL2_SWRESET, CTRL_REG1, CTRL_REG2, CTRL_REG3, LSB_PER_DEG_C,
    LSB_PER_HPA, PRESS_OUT_XL, STATUS, STATUS_P_DA, STATUS_P_OR, STATUS_T_DA, STATUS_T_OR,
    WHO_AM_I,
};

use super::RegisterDevice;

const NS_PER_S: f64 = 1e9;
/// The LPS22HH's CTRL_REG2 BOOT bit (self-clearing).
const HH_CTRL2_BOOT: u8 = 1 << 7;

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
pub struct Lps22Model {
    chip: Chip,
    regs: [u8; 0x80],
    next_ns: Option<u64>,
    now_ns: u64,
    samples: u64,
}

impl Lps22Model {
    /// A `chip` just powered up.
    pub fn new(chip: Chip) -> Self {
        let mut regs = [0; 0x80];
        regs[usize::from(WHO_AM_I)] = chip.who_am_i();
        match chip {
            Chip::Hh => regs[usize::from(CTRL_REG2)] = hh::CTRL2_IF_ADD_INC,
            Chip::Df => regs[usize::from(CTRL_REG3)] = r2p_drivers::lps22::df::CTRL3_IF_ADD_INC,
        }
        Self { chip, regs, next_ns: None, now_ns: 0, samples: 0 }
    }

    /// Which part this is.
    pub fn chip(&self) -> Chip {
        self.chip
    }

    /// Register `reg` without side effects (tests and inspection).
    pub fn peek(&self, reg: u8) -> u8 {
        self.regs[usize::from(reg & 0x7F)]
    }

    /// Samples latched so far.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// CTRL_REG1's ODR code.
    fn odr_code(&self) -> u8 {
        self.peek(CTRL_REG1) >> self.chip.odr_shift()
    }

    fn period_ns(&self) -> Option<u64> {
        let hz = self.chip.odr_hz(self.odr_code())?;
        (hz > 0.0).then(|| (NS_PER_S / f64::from(hz)).round() as u64)
    }

    /// The bits of register `reg` that take writes (`None`: read-only or not in the map).
    fn writable(&self, reg: u8) -> Option<u8> {
        match self.chip {
            Chip::Hh => match reg {
                0x0B | 0x0C | 0x15 | 0x16 | 0x18 | 0x19 => Some(0xFF),
                0x0D | 0x14 => Some(0x7F),
                0x0E => Some(hh::IF_CTRL_MASK),
                0x10 => Some(hh::CTRL1_MASK),
                0x11 => Some(hh::CTRL2_MASK & !HH_CTRL2_BOOT),
                0x12 => Some(hh::CTRL3_MASK),
                0x13 => Some(0x0F),
                _ => None,
            },
            Chip::Df => ((0x0B..=0x1B).contains(&reg) && reg != WHO_AM_I).then_some(0xFF),
        }
    }

    /// Runs the samples due by `now_ns`, each from `input()`.
    pub fn advance_with(&mut self, now_ns: u64, mut input: impl FnMut() -> BaroInput) {
        self.now_ns = self.now_ns.max(now_ns);
        if self.peek(CTRL_REG2) & CTRL2_ONE_SHOT != 0 {
            self.latch(&input());
            self.regs[usize::from(CTRL_REG2)] &= !CTRL2_ONE_SHOT;
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
            *status |= STATUS_P_OR | STATUS_T_OR;
        }
        *status |= STATUS_P_DA | STATUS_T_DA;
    }
}

impl RegisterDevice for Lps22Model {
    fn read_register(&mut self, reg: u8) -> u8 {
        let reg = reg & 0x7F;
        let value = self.regs[usize::from(reg)];
        let status = &mut self.regs[usize::from(STATUS)];
        match reg {
            0x28..=0x2A => *status &= !(STATUS_P_DA | STATUS_P_OR),
            0x2B..=0x2C => *status &= !(STATUS_T_DA | STATUS_T_OR),
            _ => {}
        }
        value
    }

    fn write_register(&mut self, reg: u8, value: u8) {
        let reg = reg & 0x7F;
        let Some(mask) = self.writable(reg) else { return };
        if reg == CTRL_REG2 && value & CTRL2_SWRESET != 0 {
            let (now, samples) = (self.now_ns, self.samples);
            *self = Self::new(self.chip);
            (self.now_ns, self.samples) = (now, samples);
            return;
        }
        let rate_before = self.odr_code();
        self.regs[usize::from(reg)] = value & mask;
        if self.odr_code() != rate_before {
            self.next_ns = self.period_ns().map(|p| self.now_ns + p);
        }
    }

    fn next_register(&self, reg: u8) -> u8 {
        let inc = match self.chip {
            Chip::Hh => self.peek(CTRL_REG2) & hh::CTRL2_IF_ADD_INC != 0,
            Chip::Df => self.peek(CTRL_REG3) & r2p_drivers::lps22::df::CTRL3_IF_ADD_INC != 0,
        };
        if inc {
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
    use embedded_hal::spi::{Operation, SpiDevice};
    use r2p_drivers::lps22::{
        Address, Averaging, Config, Error, Lps22, Odr, SpiBus, EITHER, IF_CTRL,
    };

    const MS: u64 = 1_000_000;
    const CHIPS: [Chip; 2] = [Chip::Hh, Chip::Df];

    fn input() -> BaroInput {
        BaroInput { pressure_pa: 100_512.37, temperature_c: 27.31 }
    }

    fn spi_rig(chip: Chip) -> (Shared<Lps22Model>, Lps22<SpiBus<SimSpi>>) {
        let dev = shared(Lps22Model::new(chip));
        (dev.clone(), Lps22::new_spi(SimSpi::new(dev)))
    }

    #[test]
    fn the_driver_finds_the_lps22hh_and_configures_it_over_spi() {
        let (dev, mut baro) = spi_rig(Chip::Hh);
        assert_eq!(baro.init(Config::default()), Ok(Chip::Hh));
        assert_eq!(baro.chip(), Some(Chip::Hh));
        let d = dev.borrow();
        assert_eq!(d.peek(IF_CTRL), 0x03, "I2C_DISABLE | I3C_DISABLE");
        assert_eq!(d.peek(CTRL_REG1), 3 << 4 | 1 << 1, "25 Hz, BDU");
        assert_eq!(d.peek(CTRL_REG2), 1 << 4 | 1 << 1, "IF_ADD_INC, LOW_NOISE_EN");
        assert_eq!(d.peek(CTRL_REG3), 0);
    }

    #[test]
    fn the_driver_finds_the_lps22df_and_configures_it_over_spi() {
        let (dev, mut baro) = spi_rig(Chip::Df);
        assert_eq!(baro.init(Config::default()), Ok(Chip::Df));
        let d = dev.borrow();
        assert_eq!(d.peek(IF_CTRL), 0x40, "I2C_I3C_DIS");
        assert_eq!(d.peek(CTRL_REG1), 4 << 3 | 3, "25 Hz, 32 samples averaged");
        assert_eq!(d.peek(CTRL_REG2), 1 << 3, "BDU");
        assert_eq!(d.peek(CTRL_REG3), 1, "IF_ADD_INC");
    }

    #[test]
    fn either_part_reads_pascals_at_its_rate() {
        for chip in CHIPS {
            let (dev, mut baro) = spi_rig(chip);
            baro.init(Config::default()).unwrap();
            assert_eq!(baro.read().unwrap(), None, "{chip:?}: nothing before the first period");
            dev.borrow_mut().advance_with(39 * MS, input);
            assert_eq!(baro.read().unwrap(), None, "{chip:?}: 25 Hz is 40 ms");
            dev.borrow_mut().advance_with(41 * MS, input);
            let s = baro.read().unwrap().expect("a sample after 40 ms");
            // 1/4096 hPa = 0.024 Pa per count.
            assert!((f64::from(s.pressure_pa) - 100_512.37).abs() < 0.02, "{chip:?} {s:?}");
            assert!((s.temp_c - 27.31).abs() < 1e-4);
            assert!(!s.overrun);
            assert_eq!(baro.read().unwrap(), None, "read once");
        }
    }

    #[test]
    fn an_unread_sample_is_an_overrun_and_negative_counts_sign_extend() {
        for chip in CHIPS {
            let (dev, mut baro) = spi_rig(chip);
            baro.init(Config { odr: Odr::Hz200, averaging: Averaging::X4 }).unwrap();
            dev.borrow_mut().advance_with(5 * MS, input);
            dev.borrow_mut()
                .advance_with(10 * MS, || BaroInput { pressure_pa: -50.0, temperature_c: -5.5 });
            let s = baro.read().unwrap().unwrap();
            assert!(s.overrun);
            assert!((s.pressure_pa + 50.0).abs() < 0.02 && (s.temp_c + 5.5).abs() < 1e-4);
            assert_eq!(dev.borrow().samples(), 2);
        }
    }

    #[test]
    fn the_rate_field_is_each_parts_own() {
        // ODR code 2 is 10 Hz on the HH (bits 6:4), 4 Hz on the DF (bits 6:3).
        for (chip, reg1, period_ms) in [(Chip::Hh, 2 << 4, 100), (Chip::Df, 2 << 3, 250)] {
            let dev = shared(Lps22Model::new(chip));
            let mut bus = SimSpi::new(dev.clone());
            bus.write(&[CTRL_REG1, reg1]).unwrap();
            dev.borrow_mut().advance_with((period_ms - 1) * MS, input);
            assert_eq!(dev.borrow().samples(), 0, "{chip:?}");
            dev.borrow_mut().advance_with(period_ms * MS, input);
            assert_eq!(dev.borrow().samples(), 1, "{chip:?}");
        }
        // The DF's codes 9-15 are no rate.
        let dev = shared(Lps22Model::new(Chip::Df));
        SimSpi::new(dev.clone()).write(&[CTRL_REG1, 9 << 3]).unwrap();
        dev.borrow_mut().advance_with(2_000 * MS, input);
        assert_eq!(dev.borrow().samples(), 0);
    }

    #[test]
    fn one_shot_takes_one_sample_and_software_reset_restores_the_defaults() {
        for chip in CHIPS {
            let (dev, mut baro) = spi_rig(chip);
            baro.probe().unwrap();
            let reset2 = dev.borrow().peek(CTRL_REG2);
            let mut bus = SimSpi::new(dev.clone());
            bus.write(&[CTRL_REG2, reset2 | CTRL2_ONE_SHOT]).unwrap();
            for t in [1, 2, 3] {
                dev.borrow_mut().advance_with(t * MS, input);
            }
            assert_eq!(dev.borrow().samples(), 1);
            assert_eq!(dev.borrow().peek(CTRL_REG2), reset2, "ONE_SHOT clears itself");
            bus.write(&[CTRL_REG1, 0x7F]).unwrap();
            bus.write(&[CTRL_REG2, CTRL2_SWRESET]).unwrap();
            let d = dev.borrow();
            let want = match chip {
                Chip::Hh => (0, 0x10, 0),
                Chip::Df => (0, 0, 1),
            };
            assert_eq!((d.peek(CTRL_REG1), d.peek(CTRL_REG2), d.peek(CTRL_REG3)), want);
        }
    }

    #[test]
    fn the_lps22hh_keeps_only_its_writable_bits() {
        let dev = shared(Lps22Model::new(Chip::Hh));
        let mut bus = SimSpi::new(dev.clone());
        for reg in 0x0B..=0x1B {
            // All ones but CTRL_REG2's SWRESET, which would put everything back.
            let value = if reg == CTRL_REG2 { !CTRL2_SWRESET } else { 0xFF };
            bus.write(&[reg, value]).unwrap();
        }
        let d = dev.borrow();
        let got: Vec<u8> = (0x0B..=0x1B).map(|r| d.peek(r)).collect();
        #[rustfmt::skip]
        let want = [
            0xFF, 0xFF, 0x7F, // INTERRUPT_CFG, THS_P_L, THS_P_H
            0x9F, 0xB3,       // IF_CTRL, WHO_AM_I (read-only)
            0x7F, 0x73, 0x3F, // CTRL_REG1, CTRL_REG2 (no BOOT, bit 3, SWRESET), CTRL_REG3
            0x0F, 0x7F,       // FIFO_CTRL, FIFO_WTM
            0xFF, 0xFF, 0x00, // REF_P_L, REF_P_H, 0x17 (not in the map)
            0xFF, 0xFF,       // RPDS_L, RPDS_H
            0x00, 0x00,       // 0x1A, 0x1B (not in the map)
        ];
        assert_eq!(got, want);
    }

    #[test]
    fn the_driver_works_over_i2c_and_names_a_wrong_chip() {
        for chip in CHIPS {
            let dev = shared(Lps22Model::new(chip));
            let mut i2c = SimI2c::default();
            i2c.attach(0x5D, dev.clone());
            let mut baro = Lps22::new_i2c(i2c, Address::Sa0High);
            assert_eq!(baro.init(Config::default()), Ok(chip));
            assert_eq!(dev.borrow().peek(IF_CTRL), 0, "{chip:?}: I2C stays on over I2C");
            dev.borrow_mut().advance_with(41 * MS, input);
            assert!(baro.read().unwrap().is_some());
        }
        let mut baro = Lps22::new_spi(SimSpi::unconnected());
        let e = baro.init(Config::default()).unwrap_err();
        assert_eq!(e, Error::WrongDevice { part: EITHER, found: 0xFF, expected: 0xB3 });
        assert!(e.to_string().contains("not an LPS22HH or LPS22DF: WHO_AM_I read 0xff"), "{e}");
        assert_eq!(baro.chip(), None);
        assert_eq!(baro.read().unwrap_err(), Error::NotAnswering { part: EITHER });
    }

    /// The model with one register that keeps its reset value.
    struct Stuck(Lps22Model, u8);

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
        for (chip, part, reg, wrote, read) in [
            (Chip::Hh, "LPS22HH", CTRL_REG1, 0x32, 0x00),
            (Chip::Hh, "LPS22HH", CTRL_REG2, 0x12, 0x10),
            (Chip::Hh, "LPS22HH", IF_CTRL, 0x03, 0x00),
            (Chip::Df, "LPS22DF", CTRL_REG2, 0x08, 0x00),
            (Chip::Df, "LPS22DF", IF_CTRL, 0x40, 0x00),
        ] {
            let dev = shared(Stuck(Lps22Model::new(chip), reg));
            let e = Lps22::new_spi(SimSpi::new(dev)).init(Config::default()).unwrap_err();
            assert_eq!(e, Error::ConfigNotApplied { part, register: reg, wrote, read });
        }
    }

    #[test]
    fn without_auto_increment_a_burst_reads_one_register_again() {
        for (chip, reg, off) in [(Chip::Hh, CTRL_REG2, 0), (Chip::Df, CTRL_REG3, 0)] {
            let dev = shared(Lps22Model::new(chip));
            let mut bus = SimSpi::new(dev.clone());
            bus.write(&[reg, off]).unwrap();
            let mut b = [0; 3];
            bus.transaction(&mut [Operation::Write(&[0x80 | WHO_AM_I]), Operation::Read(&mut b)])
                .unwrap();
            assert_eq!(b, [chip.who_am_i(); 3]);
        }
    }
}
