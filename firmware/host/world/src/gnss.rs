//! Where a GNSS receiver on the base says it is (issue 21): the base's pose in the world's
//! east-north-up plane put on the WGS-84 ellipsoid around the robot file's origin, with a
//! receiver's fix acquisition and its slowly wandering position error.
//!
//! **Geodetic position.** For the few hundred metres a robot covers, the local tangent plane
//! at the origin (φ₀, λ₀, h₀) maps to latitude and longitude through the ellipsoid's radii of
//! curvature at φ₀ (WGS-84: a = 6 378 137 m, f = 1/298.257 223 563, e² = f(2 − f)):
//!
//! ```text
//! M = a(1 − e²) / (1 − e² sin²φ₀)^(3/2)      (meridian)
//! N = a / (1 − e² sin²φ₀)^(1/2)               (prime vertical)
//! φ = φ₀ + north / (M + h₀),   λ = λ₀ + east / ((N + h₀) cos φ₀),   h = h₀ + up
//! ```
//!
//! whose error grows with the square of the distance: under 1 mm at 1 km (the test checks the
//! round trip). Heights are above the ellipsoid.
//!
//! **The receiver** (u-blox M8/M10 class): no fix until its time to first fix has passed since
//! power-up (cold start), then a 3-D fix with its satellites; the position error is not white
//! but wanders (atmosphere, multipath, orbits), modelled per axis as a first-order
//! Gauss-Markov process with standard deviation σ and correlation time τ, so consecutive fixes
//! agree closely and the error averages out only over minutes. From u-blox's NEO-M8 data sheet
//! (UBX-13003366 R07, Table 1 "NEO-M8 performance in different GNSS modes", NEO-M8N with its
//! default GPS & GLONASS): cold-start time to first fix 26 s (all satellites at −130 dBm), and
//! a horizontal position accuracy of 2.5 m CEP autonomous (2.0 m with SBAS; CEP 50 %, 24 hours
//! static, −130 dBm, more than 6 satellites). For an error circular and Gaussian, CEP =
//! σ·√(2 ln 2) = 1.1774 σ, so σ per horizontal axis = 2.5 m / 1.1774 = 2.12 m. The data sheet
//! gives no vertical accuracy, correlation time or satellite count: σ 2.0 m vertical, τ 60 s
//! and 12 satellites are NOT VERIFIED (the vertical σ is likely optimistic: GNSS heights are
//! usually worse than positions).
//! Not modelled: satellite geometry and DOP changing, obstructions, RTK, velocity noise, loss
//! of fix.

use crate::noise::Noise;

/// WGS-84 semi-major axis, m.
const A: f64 = 6_378_137.0;
/// WGS-84 flattening.
const F: f64 = 1.0 / 298.257_223_563;

/// A point on the ellipsoid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geodetic {
    /// Latitude, degrees north.
    pub lat_deg: f64,
    /// Longitude, degrees east.
    pub lon_deg: f64,
    /// Height above the ellipsoid, m.
    pub height_m: f64,
}

impl Geodetic {
    /// The place `enu` metres east, north and up of `self`, on its tangent plane.
    pub fn offset(&self, enu: [f64; 3]) -> Geodetic {
        let (m, n) = radii(self.lat_deg);
        let lat = self.lat_deg.to_radians();
        Geodetic {
            lat_deg: self.lat_deg + (enu[1] / (m + self.height_m)).to_degrees(),
            lon_deg: self.lon_deg + (enu[0] / ((n + self.height_m) * lat.cos())).to_degrees(),
            height_m: self.height_m + enu[2],
        }
    }

    /// Metres east, north and up of `self` to `other` (the inverse of [`Self::offset`]).
    pub fn enu_to(&self, other: &Geodetic) -> [f64; 3] {
        let (m, n) = radii(self.lat_deg);
        let lat = self.lat_deg.to_radians();
        [
            (other.lon_deg - self.lon_deg).to_radians() * (n + self.height_m) * lat.cos(),
            (other.lat_deg - self.lat_deg).to_radians() * (m + self.height_m),
            other.height_m - self.height_m,
        ]
    }
}

/// Meridian and prime-vertical radii of curvature at latitude `lat_deg`, m.
fn radii(lat_deg: f64) -> (f64, f64) {
    let e2 = F * (2.0 - F);
    let s = lat_deg.to_radians().sin();
    let w = 1.0 - e2 * s * s;
    (A * (1.0 - e2) / w.powf(1.5), A / w.sqrt())
}

/// A receiver's figures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssParams {
    /// Time to first fix from power-up, s.
    pub ttff_s: f64,
    /// Horizontal error σ per axis, m.
    pub sigma_h_m: f64,
    /// Vertical error σ, m.
    pub sigma_v_m: f64,
    /// Correlation time of the error, s.
    pub tau_s: f64,
    /// Satellites used once fixed.
    pub satellites: u8,
}

impl GnssParams {
    /// A u-blox NEO-M8N, open sky: TTFF and σ_h from its data sheet, the rest NOT VERIFIED
    /// (see the module's doc).
    pub const UBLOX_M8: GnssParams =
        GnssParams { ttff_s: 26.0, sigma_h_m: 2.12, sigma_v_m: 2.0, tau_s: 60.0, satellites: 12 };
}

/// The fix type a receiver reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FixType {
    /// No fix yet.
    None,
    /// 3-D fix.
    Fix3d,
}

/// One navigation solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssFix {
    /// The fix type.
    pub fix: FixType,
    /// Position (meaningless without a fix).
    pub position: Geodetic,
    /// Horizontal accuracy estimate (1 σ), m.
    pub h_acc_m: f64,
    /// Vertical accuracy estimate, m.
    pub v_acc_m: f64,
    /// Satellites used.
    pub satellites: u8,
    /// The geoid's height above the ellipsoid the receiver takes for the height above mean sea
    /// level (its geoid model's, here the site's), m.
    pub geoid_separation_m: f64,
}

/// A receiver on the base.
#[derive(Clone, Debug)]
pub struct GnssReceiver {
    /// Its figures.
    pub params: GnssParams,
    /// The world's origin (the robot file's).
    pub origin: Geodetic,
    /// The geoid's separation there (the robot file's `[site]`), m: the receiver's geoid model
    /// agrees with the world's.
    pub geoid_separation_m: f64,
    /// Error state (east, north, up), m.
    error: [f64; 3],
    /// Time of the last solution, s since power-up.
    last_s: Option<f64>,
    noise: Noise,
}

impl GnssReceiver {
    /// A receiver powered up at time 0 around `origin`, where the geoid is
    /// `geoid_separation_m` above the ellipsoid, its error from stream `stream` of `seed`.
    pub fn new(
        params: GnssParams,
        origin: Geodetic,
        geoid_separation_m: f64,
        seed: u64,
        stream: u64,
    ) -> Self {
        Self {
            params,
            origin,
            geoid_separation_m,
            error: [0.0; 3],
            last_s: None,
            noise: Noise::new(seed, stream),
        }
    }

    /// The solution at `t_s` seconds since power-up for the antenna `enu` metres from the
    /// origin. Calls must come in time order (one per navigation epoch).
    pub fn solve(&mut self, t_s: f64, enu: [f64; 3]) -> GnssFix {
        let p = self.params;
        let sigma = [p.sigma_h_m, p.sigma_h_m, p.sigma_v_m];
        match self.last_s {
            // The first solution: the error starts in its stationary distribution.
            None => self.error = sigma.map(|s| self.noise.gaussian(s)),
            Some(last) => {
                // Exact discretisation of dx = −x/τ dt + σ√(2/τ) dW over the step.
                let phi = (-(t_s - last).max(0.0) / p.tau_s).exp();
                for (e, s) in self.error.iter_mut().zip(sigma) {
                    *e = phi * *e + self.noise.gaussian(s * (1.0 - phi * phi).sqrt());
                }
            }
        }
        self.last_s = Some(t_s);
        let fixed = t_s >= p.ttff_s;
        let at = [0, 1, 2].map(|i| enu[i] + self.error[i]);
        GnssFix {
            fix: if fixed { FixType::Fix3d } else { FixType::None },
            position: self.origin.offset(at),
            h_acc_m: if fixed { p.sigma_h_m } else { f64::INFINITY },
            v_acc_m: if fixed { p.sigma_v_m } else { f64::INFINITY },
            satellites: if fixed { p.satellites } else { 0 },
            geoid_separation_m: self.geoid_separation_m,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Politecnico di Milano, Leonardo campus (approximately).
    const MILAN: Geodetic = Geodetic { lat_deg: 45.478, lon_deg: 9.227, height_m: 170.0 };

    #[test]
    fn a_degree_of_latitude_and_longitude_has_the_ellipsoids_length() {
        // WGS-84 at 45°: 111 131.78 m per degree of latitude, 78 846.84 m per degree of
        // longitude (the published tables round them to 111 132 and 78 847 m); with e² taken
        // as f(2 + f) instead of f(2 − f) the first would be 0.64 m shorter.
        let o = Geodetic { lat_deg: 45.0, lon_deg: 0.0, height_m: 0.0 };
        let north = o.offset([0.0, 1000.0, 0.0]);
        let east = o.offset([1000.0, 0.0, 0.0]);
        assert!((1000.0 / (north.lat_deg - 45.0) - 111_131.78).abs() < 0.05);
        assert!((1000.0 / east.lon_deg - 78_846.84).abs() < 0.05);
    }

    #[test]
    fn offsets_round_trip_to_the_millimetre() {
        for enu in [[0.0, 0.0, 0.0], [350.0, -120.0, 3.0], [-1000.0, 1000.0, -10.0]] {
            let back = MILAN.enu_to(&MILAN.offset(enu));
            for i in 0..3 {
                assert!((back[i] - enu[i]).abs() < 1e-3, "{enu:?} → {back:?}");
            }
        }
    }

    #[test]
    fn no_fix_before_the_ttff_then_a_fix_within_its_accuracy() {
        let mut r = GnssReceiver::new(GnssParams::UBLOX_M8, MILAN, 47.0, 7, 0);
        let early = r.solve(10.0, [5.0, 5.0, 0.0]);
        assert_eq!((early.fix, early.satellites), (FixType::None, 0));
        let mut errs = Vec::new();
        for k in 0..3600 {
            let t = 26.0 + f64::from(k);
            let f = r.solve(t, [5.0, 5.0, 0.0]);
            assert_eq!((f.fix, f.satellites), (FixType::Fix3d, 12));
            errs.push(MILAN.enu_to(&f.position)[0] - 5.0);
        }
        let sd = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
        let sigma = GnssParams::UBLOX_M8.sigma_h_m;
        assert!((0.5 * sigma..1.6 * sigma).contains(&sd), "east error σ over an hour {sd}");
        // Correlated: a second apart, fixes differ by σ·√(1 − e^(−2/τ)) = 0.18 σ RMS (0.38 m),
        // where white errors of the same σ would differ by σ√2 (3.0 m).
        let steps = errs.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>();
        let rms = (steps / (errs.len() - 1) as f64).sqrt();
        assert!((0.14 * sigma..0.23 * sigma).contains(&rms), "RMS of 1 s steps {rms}");
    }

    #[test]
    fn at_ten_hertz_the_error_moves_by_the_shorter_steps_share() {
        // 0.1 s steps: σ·√(1 − e^(−0.2/τ)) = 0.058 σ RMS (1 s steps: 0.18 σ).
        let mut r = GnssReceiver::new(GnssParams::UBLOX_M8, MILAN, 47.0, 11, 0);
        let east: Vec<f64> = (0..20_000)
            .map(|k| MILAN.enu_to(&r.solve(30.0 + 0.1 * f64::from(k), [0.0; 3]).position)[0])
            .collect();
        let rms = (east.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>()
            / (east.len() - 1) as f64)
            .sqrt();
        let sigma = GnssParams::UBLOX_M8.sigma_h_m;
        assert!((0.05 * sigma..0.066 * sigma).contains(&rms), "RMS of 0.1 s steps {rms}");
    }

    #[test]
    fn the_same_seed_gives_the_same_fixes() {
        let run = |seed| {
            let mut r = GnssReceiver::new(GnssParams::UBLOX_M8, MILAN, 47.0, seed, 0);
            (0..40)
                .map(|k| r.solve(f64::from(k), [1.0, 2.0, 0.0]).position.lat_deg)
                .collect::<Vec<_>>()
        };
        assert_eq!(run(3), run(3));
        assert_ne!(run(3), run(4));
    }
}
