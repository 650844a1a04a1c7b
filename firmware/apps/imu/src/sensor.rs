//! The sensors' poll both board-support layers run every step (the MCU over embassy-stm32's
//! SPI, the emulated board over the simulated SPI bus and register models), so that what the
//! application sees of the sensors is the same code on both.
//!
//! [`Sensors`] owns the three drivers and sets each part up: at its first poll, and again
//! [`RETRY_US`] after it stops answering or stops giving samples — a part unplugged and
//! plugged back (or browned out) powers up unconfigured, with no data-ready flag ever set, and
//! only the firmware can notice and configure it again.

use r2p_drivers::lis3mdl::{self, Lis3mdl};
use r2p_drivers::lps22::{self, Lps22};
use r2p_drivers::lsm6dso::{Lsm6dso, RawSample, RegisterBus};
use r2p_module::leds;

use crate::app::{Reading, Sample};

/// Reads the data-ready flags and, when the gyro has a new sample, the 14-byte burst of
/// temperature, gyro and accel. `initialised` is whether [`Lsm6dso::init`] succeeded at boot
/// (with [`crate::App::sensor_config`]); a bus error on the way marks the step's sample
/// `sensor_ok = false`. (A board with the LSM6DSO alone; the IMU board's three parts:
/// [`Sensors`].)
pub fn poll<B: RegisterBus>(
    imu: &mut Lsm6dso<B>,
    initialised: bool,
    status: leds::Status,
) -> Sample {
    let r = if initialised { read_lsm6dso(imu) } else { Reading::Failed };
    sample_of(r, status)
}

/// The LSM6DSO's data-ready flags, then its burst when the gyro has a new sample.
fn read_lsm6dso<B: RegisterBus>(imu: &mut Lsm6dso<B>) -> Reading<RawSample> {
    match imu.data_ready() {
        Ok(d) if d.gyro => imu.read_raw().map_or(Reading::Failed, Reading::Fresh),
        Ok(_) => Reading::Idle,
        Err(_) => Reading::Failed,
    }
}

/// The step's sample with the LSM6DSO's read `r` (the other parts not read yet).
fn sample_of(r: Reading<RawSample>, status: leds::Status) -> Sample {
    let mut s = Sample { status, ..Sample::default() };
    s.sensor_ok = !matches!(r, Reading::Failed);
    if let Reading::Fresh(raw) = r {
        (s.fresh, s.raw) = (true, raw);
    }
    s
}

/// A driver's `Ok(Some)` / `Ok(None)` / `Err` as a [`Reading`].
fn reading<T, E>(read: Result<Option<T>, E>) -> Reading<T> {
    match read {
        Ok(Some(s)) => Reading::Fresh(s),
        Ok(None) => Reading::Idle,
        Err(_) => Reading::Failed,
    }
}

/// How long a part that does not answer (or gives no sample) waits before its set-up is
/// tried again, µs.
pub const RETRY_US: u64 = 1_000_000;

/// One part's set-up state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Setup {
    configured: bool,
    /// When the set-up may be tried (again).
    next_try_us: u64,
    /// The last fresh sample, or the set-up.
    last_fresh_us: u64,
}

impl Setup {
    /// Sets the part up if due (`init`), then reads it (`read`); a part configured but silent
    /// for `stale_us` counts as lost and is set up again [`RETRY_US`] later.
    fn poll<D, T>(
        &mut self,
        dev: &mut D,
        now_us: u64,
        stale_us: u64,
        init: impl FnOnce(&mut D) -> bool,
        read: impl FnOnce(&mut D) -> Reading<T>,
    ) -> Reading<T> {
        if !self.configured {
            if now_us < self.next_try_us {
                return Reading::Failed;
            }
            self.configured = init(dev);
            self.next_try_us = now_us + RETRY_US;
            self.last_fresh_us = now_us;
            if !self.configured {
                return Reading::Failed;
            }
        }
        let r = read(dev);
        match r {
            Reading::Fresh(_) => self.last_fresh_us = now_us,
            Reading::Failed => self.lost(now_us),
            Reading::Idle if now_us - self.last_fresh_us > stale_us => self.lost(now_us),
            Reading::Idle => {}
        }
        r
    }

    fn lost(&mut self, now_us: u64) {
        self.configured = false;
        self.next_try_us = self.next_try_us.max(now_us + RETRY_US);
    }
}

/// The board's three sensors and their set-up states.
pub struct Sensors<I, M, B> {
    /// The LSM6DSO.
    pub imu: Lsm6dso<I>,
    /// The LIS3MDL.
    pub mag: Lis3mdl<M>,
    /// The barometer (the board's LPS22HH, or an LPS22DF: the driver tells them apart).
    pub baro: Lps22<B>,
    setup: [Setup; 3],
}

impl<I: RegisterBus, M: RegisterBus, B: RegisterBus> Sensors<I, M, B> {
    /// The drivers, none set up yet (the first [`Self::poll`] does it: call it once the
    /// parts have booted, 10 ms after power-up).
    pub fn new(imu: Lsm6dso<I>, mag: Lis3mdl<M>, baro: Lps22<B>) -> Self {
        Self { imu, mag, baro, setup: [Setup::default(); 3] }
    }

    /// Whether each part is set up now: LSM6DSO, LIS3MDL, barometer.
    pub fn configured(&self) -> [bool; 3] {
        self.setup.map(|s| s.configured)
    }

    /// One step's reads at `now_us` (µs since boot): each part set up with `config` (the
    /// LSM6DSO's, [`crate::App::sensor_config`]) or the drivers' defaults when due.
    pub fn poll(
        &mut self,
        now_us: u64,
        config: r2p_drivers::lsm6dso::Config,
        status: leds::Status,
    ) -> Sample {
        let [si, sm, sb] = &mut self.setup;
        let period = |hz: f32| (1e6 / hz) as u64;
        let lost = crate::app::LOST_AFTER_PERIODS;
        let r = si.poll(
            &mut self.imu,
            now_us,
            lost * period(config.gyro_odr.hz()),
            |imu| imu.init(config).is_ok(),
            read_lsm6dso,
        );
        let mut s = sample_of(r, status);
        let mag = lis3mdl::Config::default();
        s.mag = sm.poll(
            &mut self.mag,
            now_us,
            lost * period(mag.odr.hz()),
            |m| m.init(mag).is_ok(),
            |m| reading(m.read()),
        );
        let baro = lps22::Config::default();
        s.baro = sb.poll(
            &mut self.baro,
            now_us,
            lost * period(baro.odr.hz()),
            |b| b.init(baro).is_ok(),
            |b| reading(b.read()),
        );
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A part as `Setup` sees it: whether its set-up succeeds, what its reads give, and how
    /// often each was tried.
    #[derive(Default)]
    struct Part {
        answers: bool,
        inits: u32,
        reads: u32,
        next: Option<Reading<u8>>,
    }

    fn step(s: &mut Setup, p: &mut Part, now_us: u64) -> Reading<u8> {
        s.poll(
            p,
            now_us,
            50_000,
            |p| {
                p.inits += 1;
                p.answers
            },
            |p| {
                p.reads += 1;
                p.next.take().unwrap_or(Reading::Idle)
            },
        )
    }

    #[test]
    fn a_part_that_does_not_answer_is_tried_again_once_a_retry_period_later() {
        let (mut s, mut p) = (Setup::default(), Part::default());
        assert_eq!(step(&mut s, &mut p, 0), Reading::Failed);
        assert_eq!((p.inits, p.reads), (1, 0), "set up at the first poll, not read");
        for t in (1_000..RETRY_US).step_by(1_000) {
            assert_eq!(step(&mut s, &mut p, t), Reading::Failed);
        }
        assert_eq!(p.inits, 1, "not before RETRY_US");
        p.answers = true;
        p.next = Some(Reading::Fresh(7));
        assert_eq!(step(&mut s, &mut p, RETRY_US), Reading::Fresh(7));
        assert_eq!((p.inits, p.reads), (2, 1));
    }

    #[test]
    fn a_configured_part_silent_past_its_stale_time_is_set_up_again() {
        let (mut s, mut p) = (Setup::default(), Part { answers: true, ..Part::default() });
        p.next = Some(Reading::Fresh(1));
        assert_eq!(step(&mut s, &mut p, 0), Reading::Fresh(1));
        // Idle up to the stale time (50 ms) is a part between samples.
        for t in (1_000..=50_000).step_by(1_000) {
            assert_eq!(step(&mut s, &mut p, t), Reading::Idle);
        }
        assert_eq!(p.inits, 1);
        // One more millisecond without a sample: lost (this read still reported as it was).
        assert_eq!(step(&mut s, &mut p, 51_000), Reading::Idle);
        assert_eq!(step(&mut s, &mut p, 52_000), Reading::Failed, "lost: not read");
        let reads = p.reads;
        assert_eq!(step(&mut s, &mut p, 51_000 + RETRY_US - 1), Reading::Failed);
        assert_eq!((p.inits, p.reads), (1, reads));
        p.next = Some(Reading::Fresh(2));
        assert_eq!(step(&mut s, &mut p, 51_000 + RETRY_US), Reading::Fresh(2));
        assert_eq!(p.inits, 2, "set up again a retry period after it was lost");
    }

    #[test]
    fn a_failed_read_loses_the_part_until_the_retry() {
        let (mut s, mut p) = (Setup::default(), Part { answers: true, ..Part::default() });
        p.next = Some(Reading::Fresh(1));
        assert_eq!(step(&mut s, &mut p, 0), Reading::Fresh(1));
        // The set-up's retry time (RETRY_US after it) has passed: the retry is a full period
        // after the failure, not at the earlier time.
        p.next = Some(Reading::Failed);
        assert_eq!(step(&mut s, &mut p, 2 * RETRY_US), Reading::Failed);
        assert_eq!(step(&mut s, &mut p, 3 * RETRY_US - 1), Reading::Failed);
        assert_eq!(p.inits, 1);
        assert_eq!(step(&mut s, &mut p, 3 * RETRY_US), Reading::Idle);
        assert_eq!(p.inits, 2);
    }

    #[test]
    fn the_steps_sample_carries_the_lsm6dsos_read_and_the_node_status() {
        let status = leds::Status { running: true, synced: true, ..leds::Status::default() };
        let raw = RawSample { temp: 1, gyro: [2, 3, 4], accel: [5, 6, 7] };
        let s = sample_of(Reading::Fresh(raw), status);
        assert_eq!((s.fresh, s.raw, s.sensor_ok, s.status), (true, raw, true, status));
        let s = sample_of(Reading::Idle, status);
        assert_eq!((s.fresh, s.sensor_ok), (false, true));
        let s = sample_of(Reading::Failed, leds::Status::default());
        assert_eq!((s.fresh, s.sensor_ok, s.status), (false, false, leds::Status::default()));
    }

    #[test]
    fn a_reading_is_fresh_idle_or_failed_as_the_driver_says() {
        assert_eq!(reading::<u8, ()>(Ok(Some(3))), Reading::Fresh(3));
        assert_eq!(reading::<u8, ()>(Ok(None)), Reading::Idle);
        assert_eq!(reading::<u8, ()>(Err(())), Reading::Failed);
    }
}
