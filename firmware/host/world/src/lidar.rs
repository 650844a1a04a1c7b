//! A single-point time-of-flight LiDAR on the base (Benewake TFmini-S): what distance,
//! signal strength and temperature each of its frames reports.
//!
//! From the TFmini-S product manual (SJ-PM-TFmini-S, Benewake): range 0.1–12 m on a 90 %
//! reflective target and 0.1–4 m on a 10 % one (indoor), field of view 2°, resolution 1 cm,
//! accuracy ±6 cm from 0.1 to 6 m and ±1 % from 6 to 12 m, 100 frames/s by default. Dist is
//! −1 when the signal strength is 100 or less; strength falls with distance and reflectivity.
//!
//! **Model.** The distance is the nearest obstacle along a 2° beam (±1°, the rangers'
//! [`Obstacles::cast_beam`]) from the sensor's mount pose. Strength S = S₀·ρ/d², the
//! far-field return of a diffuse target; S₀ = 16 000 puts both datasheet range limits at the
//! reliability threshold of 100 (16 000·0.9/12² = 100 and 16 000·0.1/4² = 100), clamped to
//! 65 534 (the sensor's gain control keeps near diffuse targets out of saturation; the −2
//! saturation and −4 ambient-light codes are not produced). A weak return (S ≤ 100), nothing
//! in the beam, or a target inside the 10 cm blind zone reads Dist −1. Noise: Gaussian with
//! σ = 2 cm up to 6 m and σ = d/300 beyond (the accuracy figures as 3σ), then rounded to the
//! 1 cm resolution. Temperature: a constant die temperature, sent as 8·(T + 256).
//!
//! Every surface reflects like the given reflectivity ρ (the robot file's obstacles carry
//! none); angle of incidence, multipath and sunlight are not modelled.

use crate::geometry::Pose;
use crate::noise::Noise;
use crate::obstacles::{Beam, Obstacles};

/// Error and range figures of a TFmini-S-like LiDAR.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LidarParams {
    /// Blind zone: nearer than this reads −1, m.
    pub min_range_m: f64,
    /// Strength of a ρ = 1 target at 1 m (S₀).
    pub strength_at_1m: f64,
    /// Strength at or below which Dist is −1.
    pub strength_threshold: f64,
    /// Reflectivity of every surface (0..1).
    pub reflectivity: f64,
    /// Half the field of view, rad.
    pub half_angle: f64,
    /// Noise σ up to `near_limit_m`, m.
    pub sigma_near_m: f64,
    /// Where the noise becomes relative, m.
    pub near_limit_m: f64,
    /// Relative noise σ beyond `near_limit_m`.
    pub sigma_rel_far: f64,
    /// Die temperature, °C.
    pub temperature_c: f64,
}

impl LidarParams {
    /// Benewake TFmini-S, looking at white (90 %) surfaces.
    pub const TFMINI_S: LidarParams = LidarParams {
        min_range_m: 0.10,
        strength_at_1m: 16_000.0,
        strength_threshold: 100.0,
        reflectivity: 0.9,
        half_angle: 1.0 * std::f64::consts::PI / 180.0,
        sigma_near_m: 0.02,
        near_limit_m: 6.0,
        sigma_rel_far: 1.0 / 300.0,
        temperature_c: 40.0,
    };

    /// Farthest reliable range on the configured reflectivity, m: √(S₀·ρ/threshold).
    pub fn max_range_m(&self) -> f64 {
        (self.strength_at_1m * self.reflectivity / self.strength_threshold).sqrt()
    }

    /// Noise-free strength at `d` m.
    pub fn strength_at(&self, d: f64) -> f64 {
        (self.strength_at_1m * self.reflectivity / (d * d)).min(65_534.0)
    }

    /// Distance noise σ at `d` m.
    pub fn sigma_at(&self, d: f64) -> f64 {
        if d <= self.near_limit_m {
            self.sigma_near_m
        } else {
            d * self.sigma_rel_far
        }
    }
}

/// One frame's content, as the sensor would send it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LidarReading {
    /// Dist: cm, or −1.
    pub dist_cm: i16,
    /// Signal strength.
    pub strength: u16,
    /// Temp: 8·(°C + 256).
    pub temp: u16,
}

/// A LiDAR mounted on the base.
#[derive(Clone, Debug)]
pub struct Lidar {
    /// Its figures.
    pub params: LidarParams,
    /// Its pose in the base frame (beam along its +x).
    pub mount: Pose,
    noise: Noise,
}

impl Lidar {
    /// A sensor at `mount` with noise from stream `stream` of `seed`.
    pub fn new(params: LidarParams, mount: Pose, seed: u64, stream: u64) -> Self {
        Self { params, mount, noise: Noise::new(seed, stream) }
    }

    /// True distance to the nearest obstacle in the beam from base pose `base`, if within
    /// twice the reliable range (beyond it the return is too weak anyway).
    pub fn true_distance(&self, base: &Pose, obstacles: &Obstacles) -> Option<f64> {
        let p = base.compose(&self.mount);
        let beam =
            Beam { half_angle: self.params.half_angle, max_range: 2.0 * self.params.max_range_m() };
        obstacles.cast_beam(p.position(), p.theta, &beam)
    }

    /// One frame for the base at `base`.
    pub fn measure(&mut self, base: &Pose, obstacles: &Obstacles) -> LidarReading {
        let p = &self.params;
        let temp = (8.0 * (p.temperature_c + 256.0)).round() as u16;
        let Some(d) = self.true_distance(base, obstacles) else {
            return LidarReading { dist_cm: -1, strength: 0, temp };
        };
        let strength = p.strength_at(d);
        if strength <= p.strength_threshold || d < p.min_range_m {
            return LidarReading { dist_cm: -1, strength: strength.round() as u16, temp };
        }
        let noisy = d + self.noise.gaussian(p.sigma_at(d));
        let dist_cm = (noisy * 100.0).round().clamp(0.0, f64::from(i16::MAX)) as i16;
        LidarReading { dist_cm, strength: strength.round() as u16, temp }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Vec2;
    use crate::obstacles::Obstacle;

    fn box_at(x: f64) -> Obstacles {
        Obstacles::new(vec![Obstacle::Box {
            min: Vec2::new(x, -0.3),
            max: Vec2::new(x + 0.4, 0.3),
        }])
    }

    #[test]
    fn datasheet_range_limits_fall_on_the_threshold() {
        let p = LidarParams::TFMINI_S;
        assert!((p.max_range_m() - 12.0).abs() < 1e-12);
        let dark = LidarParams { reflectivity: 0.1, ..p };
        assert!((dark.max_range_m() - 4.0).abs() < 1e-12);
        assert_eq!(p.strength_at(12.0).round(), 100.0);
        assert_eq!(p.strength_at(0.2), 65_534.0);
    }

    #[test]
    fn reads_a_box_within_accuracy_and_unbiased() {
        // Box face 2.0 m ahead of a sensor mounted 0.1 m ahead of the base centre.
        let mut l = Lidar::new(LidarParams::TFMINI_S, Pose::new(0.1, 0.0, 0.0), 1, 0);
        let w = box_at(2.1);
        assert!((l.true_distance(&Pose::default(), &w).unwrap() - 2.0).abs() < 1e-12);
        let n = 2000;
        let mut sum = 0.0;
        for _ in 0..n {
            let r = l.measure(&Pose::default(), &w);
            assert!((i32::from(r.dist_cm) - 200).abs() <= 8, "{r:?}"); // 4σ
            assert_eq!(r.strength, 3600); // 16 000·0.9/4
            assert_eq!(r.temp, 2368); // 8·(40 + 256)
            sum += f64::from(r.dist_cm);
        }
        // Mean within 0.1 cm (σ/√n = 0.045 cm, plus rounding's ≤ 0.5 cm bias: none at 200).
        assert!((sum / n as f64 - 200.0).abs() < 0.2, "{}", sum / n as f64);
    }

    #[test]
    fn far_noise_is_relative() {
        let p = LidarParams::TFMINI_S;
        assert_eq!(p.sigma_at(3.0), 0.02);
        assert!((p.sigma_at(9.0) - 0.03).abs() < 1e-12);
    }

    #[test]
    fn out_of_range_blind_zone_and_nothing_read_minus_one() {
        let mut l = Lidar::new(LidarParams::TFMINI_S, Pose::default(), 1, 0);
        // 13 m: strength 85 ≤ 100.
        let r = l.measure(&Pose::default(), &box_at(13.0));
        assert_eq!((r.dist_cm, r.strength), (-1, 85));
        // 11.9 m: still reliable.
        assert!(l.measure(&Pose::default(), &box_at(11.9)).dist_cm > 1100);
        // Inside the 10 cm blind zone.
        assert_eq!(l.measure(&Pose::default(), &box_at(0.05)).dist_cm, -1);
        // Nothing at all.
        assert_eq!(l.measure(&Pose::default(), &Obstacles::default()).dist_cm, -1);
        // Looking away from the box.
        let back = Pose::new(0.0, 0.0, std::f64::consts::PI);
        assert_eq!(l.measure(&back, &box_at(2.0)).dist_cm, -1);
    }

    #[test]
    fn narrow_beam_misses_what_is_two_degrees_off_axis() {
        // A 2 cm post 1 m ahead, 5 cm to the side (2.9° off axis): outside ±1°.
        let post =
            Obstacles::new(vec![Obstacle::Circle { center: Vec2::new(1.0, 0.05), radius: 0.01 }]);
        let l = Lidar::new(LidarParams::TFMINI_S, Pose::default(), 1, 0);
        assert_eq!(l.true_distance(&Pose::default(), &post), None);
        let turned = Pose::new(0.0, 0.0, 0.05f64.atan2(1.0));
        assert!(l.true_distance(&turned, &post).is_some());
    }
}
