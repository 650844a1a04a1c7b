//! Barometric altitude and vertical speed.
//!
//! **Altitude** from the International Standard Atmosphere's troposphere (ISO 2533; ICAO Doc
//! 7488): `h = T₀/L · (1 − (p/p₀)^(R·L/(g·M)))` with T₀ = 288.15 K, L = 0.0065 K/m and the
//! exponent 0.190 263, i.e. `h = 44 330.8 m · (1 − (p/p₀)^0.190263)`, p₀ the sea-level
//! pressure the `qnh_pa` parameter gives (the local QNH for true altitude; 101 325 Pa for the
//! standard pressure altitude). The power is computed as exp(0.190263 · ln x) with two short
//! series (x = p/p₀ in 0.5 … 1.1: 0 to 5.5 km and below sea level) instead of libm's `powf`,
//! whose f32 version brings ≈ 1.5 KB of tables and range reduction into an image with little
//! flash to spare; the series' error is under 2 mm over that range (tests).
//!
//! **Vertical speed**: an α-β filter (a steady-state Kalman filter of a constant-velocity
//! model) on the altitude: predict with the speed, correct by fractions α (altitude) and β/dt
//! (speed) of the residual. Its poles are the roots of z² + (α + β − 2)z + (1 − α) = 0, a double
//! one at 1 − α/2 for β = 2 − α − 2√(1 − α) ≈ α²/4: α = 2dt/τ and β = α²/4 give one time
//! constant τ, a single parameter to reason about. The filter follows a constant vertical speed
//! without lag (what the speed state is for); its zero makes it reach an altitude step in about
//! τ and overshoot it by 13 % before it settles (tested). The LPS22HH's noise (0.65 Pa RMS,
//! ≈ 5.4 cm; its conditions NOT VERIFIED, see the world's `pressure` model) differentiated at
//! 25 Hz would be metres per second of noise: the filter is what makes the speed usable.

/// ISA: the altitude, m, at pressure `p_pa` under sea-level pressure `p0_pa`.
pub fn isa_altitude(p_pa: f32, p0_pa: f32) -> f32 {
    let x = p_pa / p0_pa;
    // ln x = 2·atanh(u), u = (x − 1)/(x + 1) ∈ [−1/3, 0.05]: odd series to u⁹.
    let u = (x - 1.0) / (x + 1.0);
    let u2 = u * u;
    let ln = 2.0 * u * (1.0 + u2 * (1.0 / 3.0 + u2 * (0.2 + u2 * (1.0 / 7.0 + u2 / 9.0))));
    // e^y − 1 for y = 0.190263·ln x ∈ [−0.14, 0.02]: series to y⁵ (error < y⁶/720 ≈ 1e-8).
    let y = 0.190_263 * ln;
    let expm1 = y * (1.0 + y * (0.5 + y * (1.0 / 6.0 + y * (1.0 / 24.0 + y / 120.0))));
    -44_330.8 * expm1
}

/// Altitude and vertical speed estimate.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vertical {
    /// Altitude, m (None until the first reading).
    pub altitude: Option<f32>,
    /// Vertical speed, m/s, up positive.
    pub speed: f32,
}

impl Vertical {
    /// Takes a measured altitude `h` after `dt` s, with the filter's time constant `tau` s.
    pub fn update(&mut self, h: f32, dt: f32, tau: f32) {
        let Some(est) = self.altitude else {
            self.altitude = Some(h);
            return;
        };
        let alpha = (2.0 * dt / tau).min(1.0);
        let beta = alpha * alpha * 0.25;
        let predicted = est + self.speed * dt;
        let r = h - predicted;
        self.altitude = Some(predicted + alpha * r);
        self.speed += beta * r / dt;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ISA's pressure at `h`, in f64, for reference.
    fn isa_pressure(h: f64, p0: f64) -> f64 {
        p0 * (1.0 - h / 44_330.8).powf(1.0 / 0.190_263)
    }

    #[test]
    fn the_series_match_the_isa_within_two_millimetres_from_below_sea_level_to_5_km() {
        // The ISA table (ICAO Doc 7488): 89 875 Pa at 1 000 m, 54 020 Pa at 5 000 m.
        assert!((isa_altitude(89_874.6, 101_325.0) - 1000.0).abs() < 0.5);
        assert!((isa_altitude(54_019.9, 101_325.0) - 5000.0).abs() < 1.0);
        for h in (-400..=5500).step_by(100) {
            let p = isa_pressure(f64::from(h), 101_325.0) as f32;
            let got = isa_altitude(p, 101_325.0);
            // f32's pressure resolution (≈ 8 mPa at 1 bar, 7 cm) dominates the series' error.
            assert!((got - h as f32).abs() < 0.1, "{h} m: {got}");
        }
        assert_eq!(isa_altitude(101_325.0, 101_325.0), 0.0);
        // QNH shifts it: 1 hPa ≈ 8.3 m near sea level.
        let h = isa_altitude(101_325.0, 101_425.0);
        assert!((h - 8.32).abs() < 0.05, "{h}");
    }

    #[test]
    fn the_filter_follows_a_climb_and_settles_on_its_speed() {
        let mut v = Vertical::default();
        let dt = 0.04;
        for i in 0..1000 {
            v.update(0.5 * i as f32 * dt, dt, 1.0); // climbing at 0.5 m/s
        }
        assert!((v.speed - 0.5).abs() < 1e-3, "{}", v.speed);
        let h = v.altitude.unwrap();
        assert!((h - 0.5 * 999.0 * dt).abs() < 0.01, "{h}");
    }

    #[test]
    fn a_step_is_reached_in_the_time_constant_with_the_filters_overshoot() {
        // At rest at 0 m, then 1 m: the double pole is at 1 − α/2 (τ), and the filter's zero
        // (what lets it follow a constant climb without lag) makes the estimate reach the step
        // in about τ and overshoot it by 13 %, then settle.
        let (dt, tau) = (0.01, 1.0);
        let mut v = Vertical::default();
        v.update(0.0, dt, tau);
        let mut path = std::vec::Vec::new();
        for _ in 0..1000 {
            v.update(1.0, dt, tau);
            path.push(v.altitude.unwrap());
        }
        assert!(path[49] > 0.6 && path[49] < 0.8, "{}", path[49]);
        assert!((path[99] - 1.0).abs() < 0.01, "{}", path[99]);
        let peak = path.iter().cloned().fold(0.0, f32::max);
        assert!((peak - 1.133).abs() < 0.005, "overshoot {peak}");
        assert!((path[999] - 1.0).abs() < 1e-3);
    }

    #[test]
    fn the_first_reading_sets_the_altitude_at_rest() {
        let mut v = Vertical::default();
        v.update(122.0, 0.04, 1.0);
        assert_eq!((v.altitude, v.speed), (Some(122.0), 0.0));
        v.update(122.0, 0.04, 1.0);
        assert_eq!((v.altitude, v.speed), (Some(122.0), 0.0));
    }
}
