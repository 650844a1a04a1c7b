//! Register model of an ST LSM6DSO IMU, fed by the world's [`Imu`] model.
//!
//! Registers as in the datasheet (DS12140; addresses and scale tables shared with the
//! driver, `r2p_drivers::lsm6dso`): reset values WHO_AM_I = 0x6C, CTRL3_C = 0x04 (IF_INC),
//! everything else 0 (both sensors powered down). Writes reach the control and configuration
//! registers; WHO_AM_I, STATUS_REG and the outputs (0x0F, 0x1A–0x4F) are read-only. CTRL3_C's
//! SW_RESET restores the reset values (the bit clears itself). IF_INC decides whether a
//! multi-byte access moves to the next register ([`RegisterDevice::next_register`]).
//!
//! Sampling: each sensor whose ODR is not power-down takes a sample every 1/ODR from the
//! moment it was switched on. [`Lsm6dsoModel::advance_to`] runs the samples due: it asks the
//! world's [`Imu`] for a reading, converts it with the configured full scale (round to
//! nearest, saturate at the 16-bit limits: ±2 g reads at most 1.999 g), stores the
//! little-endian outputs and sets XLDA/GDA/TDA in STATUS_REG. Reading any byte of an output
//! clears its flag. The temperature output follows the die temperature, 256 LSB/°C from 25 °C.
//!
//! Simplifications: a sample is taken at the `advance_to` call that passes its time (the
//! emulator calls it every millisecond, so sample instants are late by < 1 ms; samples
//! missed by a longer step are skipped); block data update is implicit (a bus transaction
//! is atomic in virtual time); no FIFO, interrupts, filters' delay or embedded functions.

use r2p_drivers::lsm6dso::{
    AccelScale, GyroScale, Odr, CTRL1_XL, CTRL2_G, CTRL3_C, CTRL3_IF_INC, CTRL3_SW_RESET,
    OUT_TEMP_L, STATUS_REG, WHO_AM_I, WHO_AM_I_VALUE,
};
use r2p_world::imu::{Imu, ImuReading};
use r2p_world::World;

use super::RegisterDevice;

const NS_PER_S: f64 = 1e9;
const OUT_GYRO: u8 = 0x22;
const OUT_ACCEL: u8 = 0x28;

/// Per-sensor sampling schedule.
#[derive(Clone, Copy, Debug, Default)]
struct Schedule {
    /// ODR code it runs at (0: off).
    code: u8,
    /// Next sample, ns.
    next_ns: u64,
}

/// The device's registers and sampling state.
#[derive(Clone, Debug)]
pub struct Lsm6dsoModel {
    regs: [u8; 0x80],
    accel: Schedule,
    gyro: Schedule,
    now_ns: u64,
    samples: u64,
}

impl Default for Lsm6dsoModel {
    fn default() -> Self {
        Self::new()
    }
}

fn period_ns(code: u8) -> Option<u64> {
    let hz = Odr::from_code(code)?.hz();
    (hz > 0.0).then(|| (NS_PER_S / f64::from(hz)).round() as u64)
}

/// Round to nearest and saturate to a 16-bit two's-complement output.
fn counts(value: f64, per_lsb: f64) -> i16 {
    (value / per_lsb).round().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16
}

impl Lsm6dsoModel {
    /// A device just powered up.
    pub fn new() -> Self {
        let mut regs = [0; 0x80];
        regs[usize::from(WHO_AM_I)] = WHO_AM_I_VALUE;
        regs[usize::from(CTRL3_C)] = CTRL3_IF_INC;
        Self { regs, accel: Schedule::default(), gyro: Schedule::default(), now_ns: 0, samples: 0 }
    }

    /// Register `reg` without side effects (tests and inspection).
    pub fn peek(&self, reg: u8) -> u8 {
        self.regs[usize::from(reg & 0x7F)]
    }

    /// Samples latched so far (either sensor).
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Accelerometer ODR code (CTRL1_XL\[7:4\]).
    fn accel_code(&self) -> u8 {
        self.peek(CTRL1_XL) >> 4
    }

    /// Gyroscope ODR code (CTRL2_G\[7:4\]).
    fn gyro_code(&self) -> u8 {
        self.peek(CTRL2_G) >> 4
    }

    /// Restarts a schedule whose ODR changed: the first sample one period after the write.
    fn reschedule(sched: &mut Schedule, code: u8, now_ns: u64) {
        if sched.code != code {
            sched.code = code;
            sched.next_ns = now_ns + period_ns(code).unwrap_or(0);
        }
    }

    /// Runs the samples due by `now_ns`, reading the world through `imu`.
    pub fn advance_to(&mut self, now_ns: u64, imu: &mut Imu, world: &World) {
        self.advance_with(now_ns, |odr_hz| imu.sample(world, odr_hz));
    }

    /// Runs the samples due by `now_ns`, taking each from `sample(odr_hz)` (an emulated board
    /// passes the world's IMU on its mount: [`World::sample_imu`]).
    pub fn advance_with(&mut self, now_ns: u64, mut sample: impl FnMut(f64) -> ImuReading) {
        self.now_ns = self.now_ns.max(now_ns);
        let now = self.now_ns;
        let due = |s: &Schedule| period_ns(s.code).is_some() && s.next_ns <= now;
        let (accel_due, gyro_due) = (due(&self.accel), due(&self.gyro));
        if !accel_due && !gyro_due {
            return;
        }
        // Both sensors run on one clock: a single reading serves whichever is due.
        let odr = if gyro_due { self.gyro_code() } else { self.accel_code() };
        let hz = Odr::from_code(odr).map_or(0.0, Odr::hz);
        let r = sample(f64::from(hz));
        self.latch(&r, accel_due, gyro_due);
        for (s, is_due) in [(&mut self.accel, accel_due), (&mut self.gyro, gyro_due)] {
            if let (true, Some(p)) = (is_due, period_ns(s.code)) {
                // Skip samples a long step missed, keep the phase.
                s.next_ns += p * ((now - s.next_ns) / p + 1);
            }
        }
    }

    /// Stores a reading in the outputs of the sensors named, as the configured full scales
    /// encode it, and raises their data-ready flags.
    pub fn latch(&mut self, r: &ImuReading, accel: bool, gyro: bool) {
        self.samples += 1;
        let g = f64::from(GyroScale::from_bits(self.peek(CTRL2_G) >> 1).rad_s_per_lsb());
        let a = f64::from(AccelScale::from_bits(self.peek(CTRL1_XL) >> 2).m_s2_per_lsb());
        let regs = &mut self.regs;
        let mut put = |reg: u8, v: i16| {
            let [lo, hi] = v.to_le_bytes();
            regs[usize::from(reg)] = lo;
            regs[usize::from(reg) + 1] = hi;
        };
        put(OUT_TEMP_L, counts(r.temperature_c - 25.0, 1.0 / 256.0));
        let mut status = 0b100;
        if gyro {
            for (i, v) in r.gyro.iter().enumerate() {
                put(OUT_GYRO + 2 * i as u8, counts(*v, g));
            }
            status |= 0b010;
        }
        if accel {
            for (i, v) in r.accel.iter().enumerate() {
                put(OUT_ACCEL + 2 * i as u8, counts(*v, a));
            }
            status |= 0b001;
        }
        self.regs[usize::from(STATUS_REG)] |= status;
    }
}

impl RegisterDevice for Lsm6dsoModel {
    fn read_register(&mut self, reg: u8) -> u8 {
        let reg = reg & 0x7F;
        let clear = match reg {
            0x20..=0x21 => 0b100,
            0x22..=0x27 => 0b010,
            0x28..=0x2D => 0b001,
            _ => 0,
        };
        self.regs[usize::from(STATUS_REG)] &= !clear;
        self.regs[usize::from(reg)]
    }

    fn write_register(&mut self, reg: u8, value: u8) {
        let reg = reg & 0x7F;
        if (0x0F..=0x4F).contains(&reg) && !(0x10..=0x19).contains(&reg) {
            return; // read-only
        }
        if reg == CTRL3_C && value & CTRL3_SW_RESET != 0 {
            let (now, samples) = (self.now_ns, self.samples);
            *self = Self::new();
            (self.now_ns, self.samples) = (now, samples);
            return;
        }
        self.regs[usize::from(reg)] = value;
        let (a, g) = (self.accel_code(), self.gyro_code());
        Self::reschedule(&mut self.accel, a, self.now_ns);
        Self::reschedule(&mut self.gyro, g, self.now_ns);
    }

    fn next_register(&self, reg: u8) -> u8 {
        if self.peek(CTRL3_C) & CTRL3_IF_INC != 0 {
            (reg + 1) & 0x7F
        } else {
            reg
        }
    }
}
