//! Coulomb counting and the remaining-time estimate.

/// `remaining_s` when it cannot be estimated (Battery.msg: 0xFFFFFFFF = unknown).
pub const UNKNOWN_REMAINING: u32 = u32::MAX;
/// Below this current the battery is taken as idle: remaining time unknown, not "years".
pub const MIN_CURRENT_A: f32 = 0.05;
/// Longest gap between two steps that is integrated (a stalled or restarted clock counts no
/// more than this).
pub const MAX_STEP_US: u64 = 1_000_000;

/// Picocoulombs (µA·µs) in one ampere-hour.
const PC_PER_AH: f32 = 3.6e15;

/// Charge drawn from the battery since boot (a battery is swapped with the PSU off, so boot is
/// "declared full"). Integrated in integer µA·µs so that hours of 1 ms steps lose nothing to
/// float rounding: an `i64` holds 2 500 Ah.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ChargeCounter {
    pico_coulombs: i64,
}

impl ChargeCounter {
    /// Adds `amps` flowing for `dt_us` (clamped to [`MAX_STEP_US`]); negative amps (charging,
    /// or a calibration offset below zero) subtract.
    pub fn add(&mut self, amps: f32, dt_us: u64) {
        // The magnitude as a `u32` (saturating at 4 294 A: the front end reads ±6.6 A; NaN → 0)
        // and the sign apart: float-to-`i64` and float-to-`i32` conversions are 112 and 74 B
        // of compiler-builtins the PSU's slot lacks, float-to-`u32` is linked already.
        let micro_amps = (amps.abs() * 1e6) as u32;
        let charge = i64::from(micro_amps) * dt_us.min(MAX_STEP_US) as i64;
        self.pico_coulombs = if amps < 0.0 {
            self.pico_coulombs.saturating_sub(charge)
        } else {
            self.pico_coulombs.saturating_add(charge)
        };
    }

    /// Charge used, Ah (the count stays exact in the integer; only this reading is rounded,
    /// to f32's 24 bits: no f64 code on an FPU-less Cortex-M3).
    ///
    /// The count is converted in two 32-bit halves: `i64 as f32` links compiler-builtins'
    /// `__aeabi_l2f` (120 B), and the halves' sum is within an f32 rounding of it.
    pub fn amp_hours(&self) -> f32 {
        let magnitude = self.pico_coulombs.unsigned_abs();
        let high = (magnitude >> 32) as u32 as f32 * 4_294_967_296.0;
        let ah = (high + magnitude as u32 as f32) / PC_PER_AH;
        if self.pico_coulombs < 0 {
            -ah
        } else {
            ah
        }
    }
}

/// Seconds left at `amps` with `used_ah` of `capacity_ah` drawn: [`UNKNOWN_REMAINING`] when the
/// capacity is not set (≤ 0) or the battery is idle (below [`MIN_CURRENT_A`]); 0 once the
/// capacity is used up.
pub fn remaining_s(capacity_ah: f32, used_ah: f32, amps: f32) -> u32 {
    if capacity_ah.is_nan() || capacity_ah <= 0.0 || amps.is_nan() || amps < MIN_CURRENT_A {
        return UNKNOWN_REMAINING;
    }
    let left_ah = (capacity_ah - used_ah).max(0.0);
    let s = left_ah / amps * 3600.0;
    if s >= (UNKNOWN_REMAINING - 1) as f32 {
        UNKNOWN_REMAINING - 1
    } else {
        s as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_amps_for_thirty_minutes_is_one_amp_hour() {
        let mut c = ChargeCounter::default();
        for _ in 0..1_800_000 {
            c.add(2.0, 1000);
        }
        assert!((c.amp_hours() - 1.0).abs() < 1e-6, "{}", c.amp_hours());
    }

    #[test]
    fn gaps_are_integrated_up_to_a_second() {
        let mut c = ChargeCounter::default();
        c.add(3.6, 500_000);
        assert!((c.amp_hours() - 0.0005).abs() < 1e-9);
        c.add(3.6, 10_000_000);
        assert!((c.amp_hours() - 0.0015).abs() < 1e-9, "10 s counts as 1 s");
        c.add(-3.6, 1_000_000);
        assert!((c.amp_hours() - 0.0005).abs() < 1e-9, "charging subtracts");
    }

    #[test]
    fn the_reading_taken_in_halves_is_the_count_within_an_f32_rounding() {
        let counts = [
            0i64,
            1,
            -1,
            1 << 32,
            -(1 << 32) - 5,
            1_800_000_000_000,
            (1 << 40) + 12_345,
            3_600_000_000_000_000,
            -3_600_000_000_000_000,
            9_000_000_000_000_000_000,
            i64::MIN,
        ];
        for pc in counts {
            let exact = pc as f64 / 3.6e15;
            let read = f64::from(ChargeCounter { pico_coulombs: pc }.amp_hours());
            assert!((read - exact).abs() <= exact.abs() * 2.5e-7, "{pc}: {read} vs {exact}");
        }
    }

    #[test]
    fn remaining_time_is_what_is_left_over_the_current() {
        assert_eq!(remaining_s(2.0, 0.5, 1.5), 3600);
        assert_eq!(remaining_s(10.0, 0.0, 2.0), 18_000);
        assert_eq!(remaining_s(1.0, 1.2, 1.0), 0, "used up");
        assert_eq!(remaining_s(0.0, 0.0, 1.0), UNKNOWN_REMAINING, "capacity not set");
        assert_eq!(remaining_s(2.0, 0.0, 0.01), UNKNOWN_REMAINING, "idle");
        assert_eq!(remaining_s(2.0, 0.0, f32::NAN), UNKNOWN_REMAINING);
        assert_eq!(remaining_s(1000.0, 0.0, MIN_CURRENT_A), 72_000_000);
    }
}
