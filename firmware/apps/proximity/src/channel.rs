//! One sensor channel: median of 5 samples (rejects spikes such as the Sharp's LED-pulse
//! glitches), first-order low-pass, detection of an empty connector, and the transfer curve.

use r2p_module::filters::{LowPass, Median};

use crate::curves::{curve, Reading, NO_SENSOR_BELOW_V};
use crate::frontend::volts;

/// Samples in the median window.
pub const MEDIAN: usize = 5;
/// Consecutive samples (1 ms each) below [`NO_SENSOR_BELOW_V`] after which a channel reads "no
/// sensor", and above it after which a sensor is back.
pub const NO_SENSOR_SAMPLES: u16 = 10;
/// Period the filters are sampled at (`App::step`), s.
pub const STEP_S: f32 = 0.001;

/// `Proximity.status`: a distance.
pub const STATUS_OK: u8 = 0;
/// `Proximity.status`: nearer than the sensor measures.
pub const STATUS_TOO_NEAR: u8 = 1;
/// `Proximity.status`: farther than the sensor measures, or nothing in view.
pub const STATUS_TOO_FAR: u8 = 2;
/// `Proximity.status`: no sensor configured or connected, sensors off, or powering up.
pub const STATUS_NO_SENSOR: u8 = 3;

/// Time from power-on (or a change of sensor type) to a sensor's first valid output, µs.
/// Sharp GP2Y0A21/GP2Y0A02 datasheets: first output after one measurement, 38.3 ± 9.6 ms,
/// plus 5 ms; LV-MaxSonar-EZ datasheet: 250 ms after power-up, then a first reading of
/// 49 ms plus ~100 ms of calibration.
pub fn settle_us(kind: u32) -> u64 {
    match kind {
        3 => 400_000,
        _ => 60_000,
    }
}

/// What a channel reads now.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Status {
    /// A target at this distance, m.
    Ok(f32),
    /// Nearer than the sensor's range.
    TooNear,
    /// Farther than its range, or nothing in view.
    TooFar,
    /// No sensor configured or connected, sensors off, or still powering up.
    NoSensor,
}

impl Status {
    /// `Proximity.distance` (NaN unless a distance).
    pub fn distance(self) -> f32 {
        match self {
            Status::Ok(d) => d,
            _ => f32::NAN,
        }
    }

    /// `Proximity.status`.
    pub fn code(self) -> u8 {
        match self {
            Status::Ok(_) => STATUS_OK,
            Status::TooNear => STATUS_TOO_NEAR,
            Status::TooFar => STATUS_TOO_FAR,
            Status::NoSensor => STATUS_NO_SENSOR,
        }
    }
}

/// A low-pass filter whose time constant is a parameter: rebuilt from its present value when
/// the parameter changes; 0 passes samples through.
#[derive(Clone, Copy, Debug, Default)]
struct Smoothed {
    filter: Option<LowPass>,
    tau_us: u32,
}

impl Smoothed {
    fn push(&mut self, x: f32, tau_us: u32) -> f32 {
        if tau_us == 0 {
            self.filter = None;
            return x;
        }
        if self.filter.is_none() || self.tau_us != tau_us {
            let cutoff_hz = 1e6 / (2.0 * core::f32::consts::PI * tau_us as f32);
            let mut f = LowPass::new(cutoff_hz, STEP_S);
            if let Some(y) = self.filter.and_then(|f| f.value()) {
                f.push(y);
            }
            self.filter = Some(f);
            self.tau_us = tau_us;
        }
        self.filter.as_mut().map_or(x, |f| f.push(x))
    }

    fn reset(&mut self) {
        self.filter = None;
    }
}

/// One channel's filters and state.
#[derive(Clone, Copy, Debug)]
pub struct Channel {
    kind: u32,
    powered: bool,
    ready_at_us: u64,
    median: Median<u16, MEDIAN>,
    low_pass: Smoothed,
    below: u16,
    above: u16,
    present: bool,
    status: Status,
}

impl Default for Channel {
    fn default() -> Self {
        Self {
            kind: 0,
            powered: false,
            ready_at_us: 0,
            median: Median::new(),
            low_pass: Smoothed::default(),
            below: 0,
            above: 0,
            present: false,
            status: Status::NoSensor,
        }
    }
}

impl Channel {
    /// Feeds the ADC code read at `now_us` for a sensor of type `kind` (0 none) that is
    /// `powered`; returns what the channel reads.
    pub fn update(
        &mut self,
        now_us: u64,
        code: u16,
        kind: u32,
        powered: bool,
        tau_us: u32,
    ) -> Status {
        let Some(curve) = curve(kind).filter(|_| powered) else {
            *self = Self { kind, ..Self::default() };
            return self.status;
        };
        if kind != self.kind || !self.powered {
            *self =
                Self { kind, powered, ready_at_us: now_us + settle_us(kind), ..Self::default() };
        }
        let v = volts(self.median.push(code));
        if v < NO_SENSOR_BELOW_V {
            // Hold the last reading while deciding, so an unplugged sensor never reads as a
            // target running away.
            self.above = 0;
            self.below = self.below.saturating_add(1);
            if self.below >= NO_SENSOR_SAMPLES {
                self.present = false;
                self.low_pass.reset();
                self.status = Status::NoSensor;
            }
            return self.status;
        }
        self.below = 0;
        self.above = self.above.saturating_add(1);
        if !self.present && self.above >= NO_SENSOR_SAMPLES {
            self.present = true;
        }
        if !self.present || now_us < self.ready_at_us {
            self.low_pass.reset();
            self.status = Status::NoSensor;
            return self.status;
        }
        self.status = match curve.classify(self.low_pass.push(v, tau_us)) {
            Reading::Distance(d) => Status::Ok(d),
            Reading::TooNear => Status::TooNear,
            Reading::TooFar => Status::TooFar,
        };
        self.status
    }

    /// What the channel read last.
    pub fn status(&self) -> Status {
        self.status
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::curves::GP2Y0A21YK;
    use crate::frontend::counts;

    fn run(ch: &mut Channel, t: &mut u64, ms: u64, code: u16, kind: u32) -> Status {
        let mut s = Status::NoSensor;
        for _ in 0..ms {
            s = ch.update(*t, code, kind, true, 20_000);
            *t += 1000;
        }
        s
    }

    #[test]
    fn a_sensor_reads_after_it_settles() {
        let (mut ch, mut t) = (Channel::default(), 0);
        let code = counts(GP2Y0A21YK.volts_at(0.30));
        assert_eq!(run(&mut ch, &mut t, 59, code, 1), Status::NoSensor, "powering up");
        let Status::Ok(d) = run(&mut ch, &mut t, 2, code, 1) else { panic!("{:?}", ch.status()) };
        assert!((d - 0.30).abs() < 0.003, "{d}");
    }

    #[test]
    fn unplugging_holds_the_reading_then_says_no_sensor() {
        let (mut ch, mut t) = (Channel::default(), 0);
        let code = counts(GP2Y0A21YK.volts_at(0.40));
        run(&mut ch, &mut t, 200, code, 1);
        let before = ch.status();
        assert!(matches!(before, Status::Ok(_)));
        // The median lets 0 V through at the third sample, the tenth below decides: 11 held.
        assert_eq!(run(&mut ch, &mut t, 2 + NO_SENSOR_SAMPLES as u64 - 1, 0, 1), before);
        assert_eq!(run(&mut ch, &mut t, 1, 0, 1), Status::NoSensor);
        assert_eq!(run(&mut ch, &mut t, 1000, 0, 1), Status::NoSensor);
        // Plugged back in: a fresh reading, not a ramp from the last one.
        run(&mut ch, &mut t, 3 + NO_SENSOR_SAMPLES as u64, code, 1);
        let Status::Ok(d) = ch.status() else { panic!("{:?}", ch.status()) };
        assert!((d - 0.40).abs() < 0.005, "{d}");
    }

    #[test]
    fn type_none_and_power_off_read_no_sensor() {
        let mut ch = Channel::default();
        let code = counts(1.0);
        assert_eq!(ch.update(0, code, 0, true, 0), Status::NoSensor);
        assert_eq!(ch.update(1000, code, 1, false, 0), Status::NoSensor);
        assert_eq!(Status::NoSensor.code(), 3);
        assert!(Status::TooFar.distance().is_nan());
    }
}
