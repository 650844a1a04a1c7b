//! A discrete PI controller with output limits and anti-windup by conditional integration.
//!
//! The integrator only moves when the output is inside its limits, or when the error pulls a
//! saturated output back inside, so it never holds more than the output needs. After a long
//! saturation (a step the current limit slows down, a stalled motor) the output leaves the
//! limit as soon as the error changes sign, without first unwinding a huge integral.

/// Proportional and integral gains.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Gains {
    /// Output per unit of error.
    pub kp: f32,
    /// Output per unit of error and second.
    pub ki: f32,
}

/// The controller's state: its integral.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pi {
    integral: f32,
}

impl Pi {
    /// A controller with an empty integrator.
    pub const fn new() -> Self {
        Self { integral: 0.0 }
    }

    /// One step of `dt_s` seconds: the output for `error`, plus the feed-forward `ff`, within
    /// `lo..=hi`.
    pub fn step(&mut self, gains: Gains, error: f32, dt_s: f32, ff: f32, lo: f32, hi: f32) -> f32 {
        self.step_weighted(gains, error, error, dt_s, ff, lo, hi)
    }

    /// As [`step`](Self::step) with the proportional term acting on `p_error` (a two-degree-
    /// of-freedom PI: `p_error` = b × setpoint − measurement, b < 1, removes the overshoot the
    /// controller's zero gives a setpoint step, while disturbances meet the full gains).
    #[allow(clippy::too_many_arguments)]
    pub fn step_weighted(
        &mut self,
        gains: Gains,
        error: f32,
        p_error: f32,
        dt_s: f32,
        ff: f32,
        lo: f32,
        hi: f32,
    ) -> f32 {
        let integral = self.integral + gains.ki * dt_s * error;
        let wanted = ff + gains.kp * p_error + integral;
        let out = wanted.clamp(lo, hi);
        let unwinding = (wanted > hi && error < 0.0) || (wanted < lo && error > 0.0);
        if wanted == out || unwinding {
            self.integral = integral;
        }
        out
    }

    /// The integral term.
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// Sets the integral (bumpless hand-over: the output the loop should start from).
    pub fn preset(&mut self, integral: f32) {
        self.integral = integral;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const G: Gains = Gains { kp: 2.0, ki: 10.0 };

    #[test]
    fn proportional_plus_integral_inside_the_limits() {
        let mut pi = Pi::new();
        // 2·1 + 10·0.1·1 = 3, then 2·1 + 2 = 4.
        assert_eq!(pi.step(G, 1.0, 0.1, 0.0, -10.0, 10.0), 3.0);
        assert_eq!(pi.step(G, 1.0, 0.1, 0.0, -10.0, 10.0), 4.0);
        assert_eq!(pi.step(G, 0.0, 0.1, 0.5, -10.0, 10.0), 2.5, "feed-forward adds");
    }

    #[test]
    fn a_saturated_output_does_not_wind_up_and_leaves_the_limit_at_once() {
        let mut pi = Pi::new();
        for _ in 0..1000 {
            assert_eq!(pi.step(G, 5.0, 0.1, 0.0, -4.0, 4.0), 4.0);
        }
        assert_eq!(pi.integral(), 0.0, "the integral did not move while saturated");
        // The error reverses: the output drops below the limit on the same step.
        assert!(pi.step(G, -1.0, 0.1, 0.0, -4.0, 4.0) < 4.0);
        // Without anti-windup the integral would be 5·1000 and the output would stay at 4.
    }
}
