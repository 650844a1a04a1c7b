//! Latched faults (the bits of `WheelState.faults` and `MotorFault`) and the timers that
//! decide when a condition has lasted long enough to latch one.

/// A set of fault bits. A fault stays latched until a clear command (`FaultClear`) clears it;
/// one whose cause is still there latches again at once.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Faults(pub u8);

impl Faults {
    /// No fault.
    pub const NONE: Self = Self(0);
    /// Measured |current| above `trip_current` for `trip_ms`: bridge disabled.
    pub const OVER_CURRENT: Self = Self(1 << 0);
    /// Driving (duty and back-EMF) with no encoder edge for `encoder_timeout_ms`: bridge
    /// disabled.
    pub const ENCODER_LOSS: Self = Self(1 << 1);
    /// No fresh setpoint for `watchdog_ms`: the motor is brought to a stop and braked.
    pub const WATCHDOG: Self = Self(1 << 2);
    /// The gate driver pulled DRV_FAULT (TIM1 break: the PWM outputs were cut in hardware):
    /// bridge disabled.
    pub const DRIVER: Self = Self(1 << 3);
    /// The current sensor's zero, calibrated at start-up, is off mid-scale by more than
    /// `frontend::HALL_ZERO_TOLERANCE`: sensor missing or broken, bridge disabled.
    pub const CURRENT_SENSOR: Self = Self(1 << 4);
    /// Not a fault but a condition, in `WheelState.faults` beside them: VMOT was above
    /// `regen_start_v` since the last state, so the braking current was derated
    /// (`control::regen_share`). Never latched, no `MotorFault` event: it clears by itself once
    /// VMOT falls (a charger or a supply that does not sink, a pulled battery lead).
    pub const REGEN_LIMITED: Self = Self(1 << 5);
    /// The condition bits: bit, name, what the motor does.
    pub const CONDITIONS: [(Self, &'static str, &'static str); 1] = [(
        Self::REGEN_LIMITED,
        "regeneration limited: VMOT above `regen_start_v` (not latched)",
        "braking current derated, none from `regen_stop_v`; clears when VMOT falls",
    )];
    /// Every fault bit, for documentation and "clear all".
    pub const ALL: [(Self, &'static str, &'static str); 5] = [
        (Self::OVER_CURRENT, "over-current", "bridge disabled"),
        (Self::ENCODER_LOSS, "encoder loss", "bridge disabled"),
        (Self::WATCHDOG, "setpoint watchdog", "stopped under control, then braked"),
        (Self::DRIVER, "driver fault (DRV_FAULT, TIM1 break)", "bridge disabled"),
        (Self::CURRENT_SENSOR, "current sensor zero out of range", "bridge disabled"),
    ];
    /// The faults after which the bridge is switched off (coasting): all but the watchdog.
    pub const DISABLING: Self =
        Self(Self::OVER_CURRENT.0 | Self::ENCODER_LOSS.0 | Self::DRIVER.0 | Self::CURRENT_SENSOR.0);

    /// Whether any bit of `other` is set.
    pub const fn any(self, other: Self) -> bool {
        self.0 & other.0 != 0
    }

    /// Whether no bit is set.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }
}

impl core::ops::BitOr for Faults {
    type Output = Self;
    fn bitor(self, rhs: Self) -> Self {
        Self(self.0 | rhs.0)
    }
}

/// Says when a condition has held without a break for a given time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Persistence {
    since: Option<u64>,
}

impl Persistence {
    /// A timer that has seen nothing.
    pub const fn new() -> Self {
        Self { since: None }
    }

    /// Feeds the condition at `now_us`; true once it has held since at least `hold_us` ago.
    pub fn check(&mut self, condition: bool, now_us: u64, hold_us: u64) -> bool {
        if !condition {
            self.since = None;
            return false;
        }
        let since = *self.since.get_or_insert(now_us);
        now_us.saturating_sub(since) >= hold_us
    }

    /// Forgets the condition.
    pub fn reset(&mut self) {
        self.since = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn persistence_needs_an_unbroken_run() {
        let mut p = Persistence::new();
        assert!(!p.check(true, 1_000, 5_000));
        assert!(!p.check(true, 5_999, 5_000));
        assert!(!p.check(false, 6_000, 5_000), "a break restarts the timer");
        assert!(!p.check(true, 7_000, 5_000));
        assert!(!p.check(true, 11_999, 5_000));
        assert!(p.check(true, 12_000, 5_000));
    }

    #[test]
    fn only_the_watchdog_leaves_the_bridge_on() {
        for (bit, _, _) in Faults::ALL {
            assert_eq!(Faults::DISABLING.any(bit), bit != Faults::WATCHDOG);
        }
        assert_eq!(Faults::REGEN_LIMITED.0, 0b10_0000, "bit 5, as WheelState.msg says");
        for (bit, _, _) in Faults::CONDITIONS {
            assert!(!Faults::DISABLING.any(bit), "a condition never stops the motor");
            assert!(Faults::ALL.iter().all(|(f, _, _)| !f.any(bit)), "its own bit");
        }
    }
}
