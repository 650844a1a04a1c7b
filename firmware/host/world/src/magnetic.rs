//! The magnetic field a magnetometer on the base measures (issue 21): the Earth's field at the
//! robot's site, turned into the base frame by its heading, distorted by the robot's own iron,
//! plus the sensor's noise.
//!
//! **Frames.** The world is east-north-up (x east, y north, z up: ROS REP 103); the base's
//! heading θ is its x axis's angle from east, counter-clockwise ([`crate::geometry::Pose`]).
//! The sensor sits flat at the base's mount, turned by ψ about z, as the IMU does
//! ([`crate::imu`]); the field is uniform over the base, so its position does not matter.
//!
//! **The Earth's field** from its three elements, as geomagnetic models give them (e.g. NOAA's
//! World Magnetic Model): total intensity F, inclination I (positive down, the northern
//! hemisphere) and declination D (magnetic north east of true north, positive):
//!
//! ```text
//! B_enu = F · (cos I · sin D,  cos I · cos D,  −sin I)
//! ```
//!
//! **The robot's iron** (what a calibration removes): soft iron S (a 3 × 3 matrix: the robot's
//! ferrous parts bend and scale the field, fixed to the base) and hard iron h (a field of its
//! own: magnets, magnetised steel, DC currents), both in the base frame:
//! B_base = S · Rz(−θ) · B_enu + h. Then B_sensor = Rz(−ψ) · B_base + noise.
//!
//! **Sensor errors**: the die's zero-gauss offset o (per axis, in the sensor's axes, drawn once
//! per device within its bound: the datasheet gives a typical spread, not a distribution) and
//! white Gaussian noise of σ per axis at the sensor's output:
//! B_sensor = Rz(−ψ) · B_base + o + noise. The offset adds to the robot's hard iron: a
//! calibration finds their sum. ST's LIS3MDL datasheet (DS9463 Rev 7, DocID024204 in its older
//! revisions, Table 2 "Magnetic characteristics") gives the zero-gauss level at ±4 gauss full
//! scale as ±1 gauss (±100 µT) typical, and the RMS noise in ultrahigh-performance mode at
//! ±12 gauss as 3.2 mgauss on X and Y and 4.1 mgauss on Z (σ 0.32, 0.32 and 0.41 µT): typical
//! figures, "not guaranteed" (its note 1), and none given at the ±4 gauss the firmware uses.
//! Not modelled: sensitivity and cross-axis errors of the die, temperature drift, the floor's
//! steel, motors' fields that change with their current, tilt.

use crate::geometry::Pose;
use crate::noise::Noise;

const DEG: f64 = std::f64::consts::PI / 180.0;

/// The Earth's field at a site.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EarthField {
    /// Total intensity F, µT.
    pub intensity_ut: f64,
    /// Inclination I (dip), degrees, positive down.
    pub inclination_deg: f64,
    /// Declination D, degrees, positive when magnetic north is east of true north.
    pub declination_deg: f64,
}

impl EarthField {
    /// Milan (Politecnico di Milano, where R2P and Triskar2 were built), approximately, for
    /// 2026: F ≈ 47.4 µT, I ≈ 60°, D ≈ +3.3° (NOT VERIFIED: NOAA's World Magnetic Model
    /// calculator was not reachable here; a robot file will give its own site).
    pub const MILAN: EarthField =
        EarthField { intensity_ut: 47.4, inclination_deg: 60.0, declination_deg: 3.3 };

    /// The field in the world's east-north-up frame, µT.
    pub fn enu(&self) -> [f64; 3] {
        let (i, d) = (self.inclination_deg * DEG, self.declination_deg * DEG);
        let h = self.intensity_ut * i.cos();
        [h * d.sin(), h * d.cos(), -self.intensity_ut * i.sin()]
    }
}

/// The robot's own distortion of the field, in the base frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Iron {
    /// Hard iron h, µT.
    pub hard_ut: [f64; 3],
    /// Soft iron S (row-major).
    pub soft: [[f64; 3]; 3],
}

impl Iron {
    /// No distortion.
    pub const NONE: Iron =
        Iron { hard_ut: [0.0; 3], soft: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] };

    /// `S · b + h`.
    pub fn apply(&self, b: [f64; 3]) -> [f64; 3] {
        let s = &self.soft;
        [0, 1, 2].map(|r| s[r][0] * b[0] + s[r][1] * b[1] + s[r][2] * b[2] + self.hard_ut[r])
    }
}

/// A magnetometer's error figures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagParams {
    /// White noise σ of each axis (x, y, z) at the output, µT.
    pub noise_ut: [f64; 3],
    /// Bound of the per-axis zero-gauss offset, µT.
    pub offset_ut: f64,
    /// Die temperature, °C.
    pub temperature_c: f64,
}

impl MagParams {
    /// ST LIS3MDL in ultrahigh-performance mode (DS9463 Rev 7 Table 2: see the module's doc).
    pub const LIS3MDL: MagParams =
        MagParams { noise_ut: [0.32, 0.32, 0.41], offset_ut: 100.0, temperature_c: 30.0 };
    /// An ideal sensor: for tests of the geometry.
    pub const IDEAL: MagParams =
        MagParams { noise_ut: [0.0; 3], offset_ut: 0.0, temperature_c: 25.0 };
}

/// One sample as the sensor's outputs carry it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MagSample {
    /// Flux density at the die, µT, in the sensor's axes.
    pub field_ut: [f64; 3],
    /// Die temperature, °C.
    pub temperature_c: f64,
}

/// The field around the base and one magnetometer on it, with its own noise stream.
#[derive(Clone, Debug)]
pub struct Magnetometer {
    /// Its error figures.
    pub params: MagParams,
    /// Its pose in the base frame (z up).
    pub mount: Pose,
    /// The Earth's field at the site.
    pub earth: EarthField,
    /// The robot's iron.
    pub iron: Iron,
    offset_ut: [f64; 3],
    noise: Noise,
}

impl Magnetometer {
    /// A magnetometer at `mount` on a base at a site with field `earth` and iron `iron`; its
    /// zero-gauss offset is drawn from stream `stream` of `seed` and its noise from the next
    /// stream, so the same seed gives the same device.
    pub fn new(
        params: MagParams,
        mount: Pose,
        earth: EarthField,
        iron: Iron,
        seed: u64,
        stream: u64,
    ) -> Self {
        let mut d = Noise::new(seed, stream);
        let offset_ut = [(); 3].map(|_| (2.0 * d.uniform() - 1.0) * params.offset_ut);
        Self { params, mount, earth, iron, offset_ut, noise: Noise::new(seed, stream + 1) }
    }

    /// This device's zero-gauss offset, µT in its axes.
    pub fn offset_ut(&self) -> [f64; 3] {
        self.offset_ut
    }

    /// What it reads without noise with the base at heading `heading_rad` (from east,
    /// counter-clockwise), µT in the sensor's axes.
    pub fn expected(&self, heading_rad: f64) -> [f64; 3] {
        let base = self.iron.apply(rotate_z(self.earth.enu(), -heading_rad));
        let b = rotate_z(base, -self.mount.theta);
        [0, 1, 2].map(|i| b[i] + self.offset_ut[i])
    }

    /// One sample with the base at heading `heading_rad`.
    pub fn measure(&mut self, heading_rad: f64) -> [f64; 3] {
        let (e, sigma) = (self.expected(heading_rad), self.params.noise_ut);
        [0, 1, 2].map(|i| e[i] + self.noise.gaussian(sigma[i]))
    }

    /// One sample with the base at heading `heading_rad`, with the die's temperature.
    pub fn sample(&mut self, heading_rad: f64) -> MagSample {
        MagSample { field_ut: self.measure(heading_rad), temperature_c: self.params.temperature_c }
    }
}

/// `v` turned by `angle` about z.
fn rotate_z(v: [f64; 3], angle: f64) -> [f64; 3] {
    let (s, c) = angle.sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]]
}

/// The compass heading a level sensor's field gives (radians, clockwise from magnetic north,
/// of the sensor's x axis, in (−π, π]): what a tilt-free e-compass computes.
pub fn magnetic_heading(b: [f64; 3]) -> f64 {
    b[1].atan2(b[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ideal(earth: EarthField, iron: Iron, mount: Pose) -> Magnetometer {
        Magnetometer::new(MagParams::IDEAL, mount, earth, iron, 1, 0)
    }

    fn wrap(a: f64) -> f64 {
        (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
    }

    #[test]
    fn the_field_points_north_and_down_with_its_intensity() {
        let b =
            EarthField { intensity_ut: 50.0, inclination_deg: 60.0, declination_deg: 0.0 }.enu();
        assert!(b[0].abs() < 1e-12 && (b[1] - 25.0).abs() < 1e-9 && (b[2] + 43.301).abs() < 1e-3);
        let e = EarthField::MILAN.enu();
        assert!(((e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt() - 47.4).abs() < 1e-9);
        assert!(e[0] > 0.0, "declination east: magnetic north leans east");
    }

    #[test]
    fn a_level_compass_reads_the_heading_from_magnetic_north_clockwise() {
        let m = ideal(EarthField::MILAN, Iron::NONE, Pose::default());
        let d = EarthField::MILAN.declination_deg * DEG;
        for deg in [0.0f64, 30.0, 90.0, 135.0, 180.0, 270.0, 359.0] {
            // The base faces `deg` clockwise from magnetic north: θ from east, CCW.
            let theta = std::f64::consts::FRAC_PI_2 - d - deg * DEG;
            let h = magnetic_heading(m.expected(theta));
            assert!(wrap(h - deg * DEG).abs() < 1e-9, "{deg}°: read {}°", h / DEG);
        }
    }

    #[test]
    fn the_mount_turns_the_reading_and_hard_iron_shifts_it() {
        let quarter = Pose { theta: std::f64::consts::FRAC_PI_2, ..Pose::default() };
        let flat = ideal(EarthField::MILAN, Iron::NONE, Pose::default()).expected(0.3);
        let turned = ideal(EarthField::MILAN, Iron::NONE, quarter).expected(0.3);
        // The sensor's x is the base's y: it reads the base's y component.
        assert!((turned[0] - flat[1]).abs() < 1e-9 && (turned[1] + flat[0]).abs() < 1e-9);
        let iron = Iron { hard_ut: [10.0, -5.0, 2.0], ..Iron::NONE };
        let shifted = ideal(EarthField::MILAN, iron, Pose::default()).expected(0.3);
        for i in 0..3 {
            assert!((shifted[i] - flat[i] - iron.hard_ut[i]).abs() < 1e-9);
        }
    }

    #[test]
    fn iron_is_the_soft_matrix_times_the_field_plus_the_hard_field() {
        let iron = Iron {
            hard_ut: [1.0, 2.0, 3.0],
            soft: [[1.1, 0.2, -0.1], [0.3, 0.9, 0.05], [-0.2, 0.1, 1.2]],
        };
        let b = iron.apply([10.0, 20.0, -40.0]);
        // Row by row: 11 + 4 + 4 + 1, 3 + 18 − 2 + 2, −2 + 2 − 48 + 3.
        let want = [20.0, 21.0, -45.0];
        for i in 0..3 {
            assert!((b[i] - want[i]).abs() < 1e-12, "{b:?}");
        }
    }

    #[test]
    fn soft_iron_bends_the_heading_a_compass_reads() {
        // 20 % more sensitive along the base's x: headings between the axes are pulled to x.
        let iron = Iron { soft: [[1.2, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], ..Iron::NONE };
        let earth = EarthField { declination_deg: 0.0, ..EarthField::MILAN };
        let m = ideal(earth, iron, Pose::default());
        let theta = std::f64::consts::FRAC_PI_2 - 45.0 * DEG; // facing 45° east of north
        let h = magnetic_heading(m.expected(theta)) / DEG;
        assert!((h - (1.0f64 / 1.2).atan().to_degrees()).abs() < 1e-9, "{h}°");
    }

    #[test]
    fn noise_has_its_sigma_and_the_same_seed_gives_the_same_samples() {
        let mk = |seed| {
            Magnetometer::new(
                MagParams::LIS3MDL,
                Pose::default(),
                EarthField::MILAN,
                Iron::NONE,
                seed,
                9,
            )
        };
        let (mut a, mut b, mut c) = (mk(1), mk(1), mk(2));
        let xa: Vec<[f64; 3]> = (0..4000).map(|_| a.measure(0.0)).collect();
        let xb: Vec<[f64; 3]> = (0..4000).map(|_| b.measure(0.0)).collect();
        assert_eq!(xa, xb);
        assert_ne!(xa[0], c.measure(0.0));
        let mean = a.expected(0.0);
        for (i, want) in [0.32, 0.32, 0.41].into_iter().enumerate() {
            let var = xa.iter().map(|s| (s[i] - mean[i]).powi(2)).sum::<f64>() / xa.len() as f64;
            assert!((var.sqrt() - want).abs() < 0.02, "axis {i}: σ {}", var.sqrt());
        }
    }

    #[test]
    fn each_device_has_its_own_offset_within_the_bound_added_in_its_axes() {
        let mk = |seed| {
            let turned = Pose { theta: 0.7, ..Pose::default() };
            Magnetometer::new(MagParams::LIS3MDL, turned, EarthField::MILAN, Iron::NONE, seed, 4)
        };
        let (a, b) = (mk(5), mk(6));
        assert_eq!(a.offset_ut(), mk(5).offset_ut());
        assert_ne!(a.offset_ut(), b.offset_ut());
        let geometry = ideal(EarthField::MILAN, Iron::NONE, a.mount).expected(1.1);
        let (e, o) = (a.expected(1.1), a.offset_ut());
        assert_eq!(e, [0, 1, 2].map(|i| geometry[i] + o[i]));
        let spread = (0..200).flat_map(|s| mk(s).offset_ut()).fold(0.0f64, |m, o| m.max(o.abs()));
        assert!(spread <= 100.0 && spread > 90.0, "offsets spread to ±{spread} µT");
        assert_eq!(ideal(EarthField::MILAN, Iron::NONE, Pose::default()).offset_ut(), [0.0; 3]);
    }
}
