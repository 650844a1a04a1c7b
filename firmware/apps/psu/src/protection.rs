//! Over-current and under-voltage detection and the bus output's switch state.

use crate::event::CAUSE_COMMAND;

/// Trips once when the current has stayed above a threshold for a time; re-arms when it falls
/// back below.
#[derive(Clone, Copy, Debug, Default)]
pub struct OverCurrent {
    above_since: Option<u64>,
    tripped: bool,
}

impl OverCurrent {
    /// Feeds one sample at `now_us`; true on the step the over-current has lasted `time_us`.
    pub fn update(&mut self, now_us: u64, amps: f32, threshold_a: f32, time_us: u64) -> bool {
        if amps > threshold_a {
            let since = *self.above_since.get_or_insert(now_us);
            if !self.tripped && now_us.saturating_sub(since) >= time_us {
                self.tripped = true;
                return true;
            }
        } else {
            *self = Self::default();
        }
        false
    }
}

/// Under-voltage with hysteresis: low below the threshold, cleared above threshold + hysteresis.
#[derive(Clone, Copy, Debug, Default)]
pub struct UnderVoltage {
    low: bool,
}

impl UnderVoltage {
    /// Feeds the filtered voltage; `Some(true)` when it goes low, `Some(false)` when it clears.
    pub fn update(&mut self, volts: f32, threshold_v: f32, hysteresis_v: f32) -> Option<bool> {
        if !self.low && volts < threshold_v {
            self.low = true;
            Some(true)
        } else if self.low && volts > threshold_v + hysteresis_v {
            self.low = false;
            Some(false)
        } else {
            None
        }
    }

    /// Whether the battery is low now.
    pub fn is_low(&self) -> bool {
        self.low
    }
}

/// The bus output switch (`BUS_EN`). On at boot, as the board file's `init` says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Output {
    on: bool,
    /// The fault (`CAUSE_*`) holding the output off until an on command; 0 when not latched.
    latched: u8,
}

impl Default for Output {
    fn default() -> Self {
        Self { on: true, latched: 0 }
    }
}

impl Output {
    /// Whether the output is on.
    pub fn is_on(&self) -> bool {
        self.on
    }

    /// The latched fault (`CAUSE_OVER_CURRENT`, `CAUSE_EFUSE`) or 0.
    pub fn latched(&self) -> u8 {
        self.latched
    }

    /// A command: `Some(on)` if the output changed. "On" also clears a latched fault.
    pub fn command(&mut self, on: bool) -> Option<bool> {
        if on {
            self.latched = 0;
        }
        (self.on != on).then(|| {
            self.on = on;
            on
        })
    }

    /// A protection switches the output off and latches (`cause` is a `CAUSE_*`, not
    /// `CAUSE_COMMAND`); true if it was on.
    pub fn trip(&mut self, cause: u8) -> bool {
        debug_assert_ne!(cause, CAUSE_COMMAND);
        let was_on = self.on;
        self.on = false;
        if was_on || self.latched == 0 {
            self.latched = cause;
        }
        was_on
    }
}

/// The eFuse fault flag, debounced: asserted for this long while the output is on trips it.
pub const EFUSE_DEBOUNCE_US: u64 = 2_000;

/// Debounces `BUS_FAULT` (only meaningful while the output is on).
#[derive(Clone, Copy, Debug, Default)]
pub struct EfuseFault {
    since: Option<u64>,
}

impl EfuseFault {
    /// True once the flag has been asserted for [`EFUSE_DEBOUNCE_US`] while `armed`.
    pub fn update(&mut self, now_us: u64, asserted: bool, armed: bool) -> bool {
        if asserted && armed {
            let since = *self.since.get_or_insert(now_us);
            now_us.saturating_sub(since) >= EFUSE_DEBOUNCE_US
        } else {
            self.since = None;
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::event::{CAUSE_EFUSE, CAUSE_OVER_CURRENT};

    #[test]
    fn over_current_trips_after_its_time_once() {
        let mut oc = OverCurrent::default();
        let trips: std::vec::Vec<u64> =
            (0..200u64).filter(|t| oc.update(t * 1000, 6.0, 5.0, 50_000)).collect();
        assert_eq!(trips, [50_000 / 1000]);
        assert!(!oc.update(300_000, 4.0, 5.0, 50_000));
        assert!(!oc.update(301_000, 6.0, 5.0, 50_000), "re-armed, timing again");
        assert!(oc.update(351_000, 6.0, 5.0, 50_000));
    }

    #[test]
    fn a_dip_below_the_threshold_restarts_the_timer() {
        let mut oc = OverCurrent::default();
        assert!(!oc.update(0, 6.0, 5.0, 10_000));
        assert!(!oc.update(9_000, 6.0, 5.0, 10_000));
        assert!(!oc.update(9_500, 4.9, 5.0, 10_000));
        assert!(!oc.update(10_000, 6.0, 5.0, 10_000));
        assert!(oc.update(20_000, 6.0, 5.0, 10_000));
    }

    #[test]
    fn under_voltage_has_hysteresis() {
        let mut uv = UnderVoltage::default();
        let seq = [(7.0, None), (5.9, Some(true)), (5.5, None), (6.3, None), (6.51, Some(false))];
        for (v, want) in seq {
            assert_eq!(uv.update(v, 6.0, 0.5), want, "{v} V");
        }
        assert!(!uv.is_low());
    }

    #[test]
    fn a_trip_latches_until_an_on_command() {
        let mut out = Output::default();
        assert!(out.is_on());
        assert!(out.trip(CAUSE_OVER_CURRENT));
        assert_eq!((out.is_on(), out.latched()), (false, CAUSE_OVER_CURRENT));
        assert!(!out.trip(CAUSE_EFUSE), "already off");
        assert_eq!(out.latched(), CAUSE_OVER_CURRENT, "the first cause stays");
        assert_eq!(out.command(false), None);
        assert_eq!(out.command(true), Some(true));
        assert_eq!(out.latched(), 0);
        assert_eq!(out.command(false), Some(false));
    }

    #[test]
    fn the_efuse_flag_is_debounced_and_ignored_while_off() {
        let mut f = EfuseFault::default();
        assert!(!f.update(0, true, true));
        assert!(!f.update(1_000, true, true));
        assert!(f.update(2_000, true, true));
        assert!(!f.update(3_000, true, false), "output off: ignored");
        assert!(!f.update(4_000, true, true), "timing restarts");
    }
}
