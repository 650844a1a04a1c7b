//! The gyroscope's zero-rate offset, estimated while the robot stands still after boot.
//!
//! The LSM6DSO's zero-rate level is up to ±1 °/s per axis (datasheet DS12140, table 2): left
//! in, it turns a still robot's heading by a degree every second. It changes little over a run
//! (temperature drift, ±0.01 °/s/°C, is not tracked), so the module measures it once.
//!
//! **Method: the mean over a still window** of `bias_ms` from boot. For a constant offset in
//! white noise the sample mean is the minimum-variance unbiased estimate; at 104 Hz over 1 s
//! (σ ≈ 27 m°/s per sample) its error is ≈ 2.7 m°/s, a heading drift of ≈ 10°/h. A running
//! low-pass or a Kalman filter on the rate would go on estimating while the robot moves, and
//! then would absorb slow real turns into the "bias"; the window is only taken at rest.
//!
//! **Stillness check**: a sample farther than `still_dps` from the window's mean on any axis
//! is motion (someone picked the robot up, the base started early): the window restarts from
//! that sample, so the estimate is made of still samples only. A turn slower than the
//! threshold from the very first sample cannot be told from an offset: that is the method's
//! limit, the reason the threshold is a parameter and the README says "boot it at rest".

/// The estimator's state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BiasEstimator {
    sum: [f32; 3],
    n: u32,
    started_us: u64,
    /// The estimate, once the window is complete.
    done: Option<[f32; 3]>,
}

impl BiasEstimator {
    /// The estimate (rad/s per axis), or `None` while the window is still open.
    pub fn bias(&self) -> Option<[f32; 3]> {
        self.done
    }

    /// Samples in the current window.
    pub fn samples(&self) -> u32 {
        self.n
    }

    /// Takes one gyro sample `rate` (rad/s) at `now_us`. The window closes once it spans
    /// `window_us` of still samples (with `window_us` = 0, at once with a zero bias).
    pub fn update(&mut self, now_us: u64, rate: [f32; 3], window_us: u64, still_rad_s: f32) {
        if self.done.is_some() {
            return;
        }
        if window_us == 0 {
            self.done = Some([0.0; 3]);
            return;
        }
        if self.n > 0 {
            let n = self.n as f32;
            let moved = (0..3).any(|i| (rate[i] - self.sum[i] / n).abs() > still_rad_s);
            if moved {
                self.n = 0;
            }
        }
        if self.n == 0 {
            (self.sum, self.started_us) = ([0.0; 3], now_us);
        }
        for (s, r) in self.sum.iter_mut().zip(rate) {
            *s += r;
        }
        self.n += 1;
        if now_us - self.started_us >= window_us {
            let n = self.n as f32;
            self.done = Some(self.sum.map(|s| s / n));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic noise-like sequence in [-1, 1].
    fn wiggle(k: u32) -> f32 {
        ((k.wrapping_mul(2_654_435_761) >> 8) as f32 / (1u32 << 24) as f32) * 2.0 - 1.0
    }

    #[test]
    fn the_mean_of_a_still_window_is_the_offset() {
        let offset = [0.012, -0.017, 0.0093]; // rad/s: ~0.7, −1, 0.5 °/s
        let mut b = BiasEstimator::default();
        let mut t = 0;
        let mut k = 0;
        while b.bias().is_none() {
            let r = [0, 1, 2].map(|i| offset[i] + 5e-4 * wiggle(3 * k + i as u32));
            b.update(t, r, 1_000_000, 1f32.to_radians());
            t += 9_615; // 104 Hz
            k += 1;
        }
        // The window spans 1 s: samples 0…105, at 0…1.0096 s.
        assert_eq!(b.samples(), 106);
        for (e, o) in b.bias().unwrap().iter().zip(offset) {
            assert!((e - o).abs() < 1e-4, "{e} vs {o}");
        }
        // Closed: later samples change nothing.
        let before = b.bias();
        b.update(t, [1.0; 3], 1_000_000, 0.01);
        assert_eq!(b.bias(), before);
    }

    #[test]
    fn motion_restarts_the_window() {
        let mut b = BiasEstimator::default();
        let still = 1f32.to_radians();
        for k in 0..50u64 {
            b.update(k * 10_000, [0.01, 0.0, 0.0], 1_000_000, still);
        }
        assert_eq!(b.samples(), 50);
        // A bump of 2 °/s on z at 0.5 s: the window starts again there.
        b.update(500_000, [0.01, 0.0, 2f32.to_radians()], 1_000_000, still);
        assert_eq!(b.samples(), 1);
        // Just under the threshold does not restart.
        b.update(510_000, [0.01, 0.0, 1.1f32.to_radians()], 1_000_000, still);
        assert_eq!(b.samples(), 2);
        for k in 52..150u64 {
            b.update(k * 10_000, [0.01, 0.0, 2f32.to_radians()], 1_000_000, still);
        }
        assert!(b.bias().is_none(), "1 s from the restart at 0.5 s is 1.5 s");
        b.update(1_500_000, [0.01, 0.0, 2f32.to_radians()], 1_000_000, still);
        let e = b.bias().unwrap();
        assert!((e[2] - 2f32.to_radians()).abs() < 1e-3 && (e[0] - 0.01).abs() < 1e-6, "{e:?}");
    }

    #[test]
    fn a_zero_window_means_no_estimate() {
        let mut b = BiasEstimator::default();
        b.update(0, [0.3; 3], 0, 0.01);
        assert_eq!(b.bias(), Some([0.0; 3]));
    }
}
