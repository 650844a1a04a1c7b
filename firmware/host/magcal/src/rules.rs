//! The rules of a calibration around the fit: which fit (planar or full), which parameters
//! it writes and with what values, when the result must not be written (coverage, residual,
//! the module's ranges) and, for a planar fit, keeping the module's z terms consistent. The
//! command (`r2p imu calibrate`) does the bus work; these decide.

use crate::coverage::{Coverage, MIN_BANDS, MIN_SECTORS, SECTORS};
use crate::ellipsoid::{Fit, Kind};

/// The hard-iron parameters, x, y, z.
pub const OFFSET: [&str; 3] = ["mag_offset_x", "mag_offset_y", "mag_offset_z"];
/// The soft-iron parameters with the matrix entry each holds.
pub const SOFT: [(&str, usize, usize); 6] = [
    ("mag_soft_xx", 0, 0),
    ("mag_soft_xy", 0, 1),
    ("mag_soft_xz", 0, 2),
    ("mag_soft_yy", 1, 1),
    ("mag_soft_yz", 1, 2),
    ("mag_soft_zz", 2, 2),
];

/// The planar choice: a robot turning on the floor sees the field's vertical component still,
/// so z varies by the noise (and a slope's tilt) while x and y swing by the horizontal field.
/// Below this ratio of z's standard deviation to x's and y's (RMS of the two), the fit is planar.
pub const PLANAR_RATIO: f64 = 0.25;

/// Above this residual (percent of the radius) a fit is refused: the samples do not lie on one
/// ellipsoid, so the field changed during the run. A magnetometer's noise and a calibrated
/// soft-iron model leave about 1 %.
pub const MAX_RMS_PERCENT: f64 = 10.0;

/// The values to write for `fit`: every parameter (full), or x/y's (planar).
pub fn values(fit: &Fit) -> Vec<(&'static str, f32)> {
    let planar = fit.kind == Kind::Planar;
    let mut v: Vec<(&str, f32)> = OFFSET
        .iter()
        .enumerate()
        .filter(|(i, _)| !planar || *i < 2)
        .map(|(i, n)| (*n, fit.offset[i] as f32))
        .collect();
    v.extend(
        SOFT.iter()
            // SOFT is the upper triangle (i ≤ j): j < 2 is the x/y block.
            .filter(|(_, _, j)| !planar || *j < 2)
            .map(|&(n, i, j)| (n, fit.soft[i][j] as f32)),
    );
    v
}

/// For a planar fit, the module's z terms stay, and the module computes
/// `x/y = S₂·(m_xy − h_xy) + (s_xz, s_yz)·(m_z − h_z)`: with cross terms already set (by an
/// earlier full calibration), the second part is a constant shift of the horizontal field
/// while the robot is level (m_z is constant then), and it would move the heading circle off
/// the origin. Moving h_xy by `S₂⁻¹·(s_xz, s_yz)·(m̄_z − h_z)` (m̄_z the samples' mean raw z)
/// cancels it. Returns the shift (zero with the default identity's zero cross terms).
pub fn keep_z(fit: &mut Fit, mean_z: f64, h_z: f64, s_xz: f64, s_yz: f64) -> [f64; 2] {
    let [[a, b, _], [_, c, _], _] = fit.soft;
    let det = a * c - b * b;
    let (vx, vy) = (s_xz * (mean_z - h_z), s_yz * (mean_z - h_z));
    let shift = [(c * vx - b * vy) / det, (a * vy - b * vx) / det];
    fit.offset[0] += shift[0];
    fit.offset[1] += shift[1];
    shift
}

/// A parameter of the module's table: its index and range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slot {
    /// Its name.
    pub name: &'static str,
    /// Its index on the bus.
    pub index: u16,
    /// Its range.
    pub min: f32,
    /// Its range.
    pub max: f32,
}

/// Which fit: as asked (`planar`, `full`: at most one), or planar when z hardly moved (see
/// [`PLANAR_RATIO`]). Returns the kind and the spreads (z's standard deviation, x's and y's
/// RMS), µT.
pub fn choose(samples: &[[f64; 3]], planar: bool, full: bool) -> (Kind, f64, f64) {
    let n = samples.len().max(1) as f64;
    let sd = |i: usize| {
        let mean = samples.iter().map(|m| m[i]).sum::<f64>() / n;
        (samples.iter().map(|m| (m[i] - mean).powi(2)).sum::<f64>() / n).sqrt()
    };
    let (z, h) = (sd(2), ((sd(0).powi(2) + sd(1).powi(2)) / 2.0).sqrt());
    let kind = if planar || (!full && z < PLANAR_RATIO * h) { Kind::Planar } else { Kind::Full };
    (kind, z, h)
}

/// The coverage of samples about a centre: the fit's, or while collecting the midrange of
/// what came so far (an estimate of the hard iron that needs no fit).
pub fn coverage(samples: &[[f64; 3]], correct: impl Fn([f64; 3]) -> [f64; 3]) -> Coverage {
    let mut c = Coverage::new();
    samples.iter().for_each(|&m| c.add(correct(m)));
    c
}

/// Subtracts the midrange of `samples` (per axis).
pub fn midrange(samples: &[[f64; 3]]) -> impl Fn([f64; 3]) -> [f64; 3] {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for m in samples {
        for i in 0..3 {
            lo[i] = lo[i].min(m[i]);
            hi[i] = hi[i].max(m[i]);
        }
    }
    move |m: [f64; 3]| std::array::from_fn(|i| m[i] - (lo[i] + hi[i]) / 2.0)
}

/// Checks a fit against the coverage and quality rules; the reason if it must not be written.
pub fn check(fit: &Fit, cov: &Coverage) -> Result<(), String> {
    check_sectors(cov)?;
    if fit.kind == Kind::Full && cov.bands_covered() < MIN_BANDS {
        return Err(format!(
            "the samples cover {} of 6 30° elevation bands, a full fit needs at least \
             {MIN_BANDS}; roll and pitch the robot through every orientation, or use --planar \
             for a robot that only turns on the floor",
            cov.bands_covered()
        ));
    }
    if fit.rms_percent() > MAX_RMS_PERCENT {
        return Err(format!(
            "the residual is {:.1} µT RMS, {:.1} % of the field (at most {MAX_RMS_PERCENT} %): \
             the field changed during the run; calibrate away from steel, magnets and running \
             motors, and keep the robot's own motors off",
            fit.rms,
            fit.rms_percent()
        ));
    }
    Ok(())
}

/// Checks the heading coverage alone.
pub fn check_sectors(cov: &Coverage) -> Result<(), String> {
    if cov.sectors_covered() < MIN_SECTORS {
        return Err(format!(
            "the samples cover {} of {SECTORS} 10° heading sectors, at least {MIN_SECTORS} are \
             needed (missing: {}); turn the robot slowly through a whole turn while it collects",
            cov.sectors_covered(),
            cov.missing()
        ));
    }
    Ok(())
}

/// Checks each value against its parameter's range.
pub fn in_range(values: &[(&'static str, f32)], slots: &[Slot]) -> Result<(), String> {
    for (name, v) in values {
        let s = slots
            .iter()
            .find(|s| s.name == *name)
            .ok_or_else(|| format!("{name}: no such parameter"))?;
        if !(s.min..=s.max).contains(v) {
            return Err(format!(
                "{name} = {v} is outside the module's range {}…{}: the sensor sits too close to \
                 a magnet or a piece of steel; move it or the steel and calibrate again",
                s.min, s.max
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_out_of_the_modules_range_are_refused() {
        let slot = |name, index, lim: f32| Slot { name, index, min: -lim, max: lim };
        let slots = [
            slot("mag_offset_x", 1, 400.0),
            slot("mag_offset_y", 2, 400.0),
            slot("mag_soft_zz", 9, 4.0),
        ];
        assert!(in_range(&[("mag_soft_zz", 4.0), ("mag_offset_x", -400.0)], &slots).is_ok());
        let e = in_range(&[("mag_offset_x", 1.0), ("mag_soft_zz", 4.5)], &slots).unwrap_err();
        assert!(e.starts_with("mag_soft_zz = 4.5 is outside the module's range -4…4"), "{e}");
        assert!(in_range(&[("mag_offset_y", -400.5)], &slots).is_err());
        assert!(in_range(&[("mag_offset_y", f32::NAN)], &slots).is_err());
        let e = in_range(&[("mag_soft_xy", 0.0)], &slots).unwrap_err();
        assert_eq!(e, "mag_soft_xy: no such parameter");
    }

    #[test]
    fn planar_is_chosen_when_z_hardly_moves() {
        let circle = |z: f64| -> Vec<[f64; 3]> {
            (0..360)
                .map(|d| {
                    let t = (d as f64).to_radians();
                    // z swings ±z over the turn: its standard deviation is z/√2.
                    [40.0 * t.cos(), 40.0 * t.sin(), z * (2.0 * t).sin()]
                })
                .collect()
        };
        // x and y: standard deviation 40/√2 each, so planar below z = 0.25 × 40 = 10.
        assert_eq!(choose(&circle(9.9), false, false).0, Kind::Planar);
        assert_eq!(choose(&circle(10.1), false, false).0, Kind::Full);
        let (_, z, h) = choose(&circle(10.0), false, false);
        assert!((z - 10.0 / 2f64.sqrt()).abs() < 1e-9 && (h - 40.0 / 2f64.sqrt()).abs() < 1e-9);
        // The spreads are about the samples' means: a hard-iron offset changes nothing.
        let offset: Vec<[f64; 3]> =
            circle(10.0).iter().map(|m| [m[0] + 30.0, m[1] - 20.0, m[2] + 50.0]).collect();
        let (kind, z2, h2) = choose(&offset, false, false);
        assert!((z2 - z).abs() < 1e-9 && (h2 - h).abs() < 1e-9, "{z2} {h2}");
        assert_eq!(kind, choose(&circle(10.0), false, false).0);
        assert_eq!(choose(&circle(0.0), false, true).0, Kind::Full);
        assert_eq!(choose(&circle(30.0), true, false).0, Kind::Planar);
    }

    #[test]
    fn planar_writes_only_the_x_y_terms() {
        let fit = Fit {
            kind: Kind::Planar,
            offset: [1.0, 2.0, 0.0],
            soft: [[1.1, 0.1, 0.0], [0.1, 0.9, 0.0], [0.0, 0.0, 1.0]],
            radius: 40.0,
            rms: 0.4,
            determinacy: 1e4,
            axis_ratio: 1.2,
            samples: 100,
        };
        let names: Vec<&str> = values(&fit).iter().map(|v| v.0).collect();
        assert_eq!(
            names,
            ["mag_offset_x", "mag_offset_y", "mag_soft_xx", "mag_soft_xy", "mag_soft_yy"]
        );
        assert_eq!(values(&fit)[3].1, 0.1);
        let full = Fit { kind: Kind::Full, ..fit.clone() };
        assert_eq!(values(&full).len(), 9);
        assert_eq!(values(&full)[2], ("mag_offset_z", 0.0));
        // Quality rules: coverage first, then the residual.
        let mut cov = Coverage::new();
        (0..360).for_each(|d| {
            cov.add([(d as f64).to_radians().cos(), (d as f64).to_radians().sin(), 0.0])
        });
        assert!(check(&fit, &cov).is_ok());
        let e = check(&full, &cov).unwrap_err();
        assert!(e.contains("1 of 6 30° elevation bands") && e.contains("--planar"), "{e}");
        let noisy = Fit { rms: 4.1, ..fit };
        let e = check(&noisy, &cov).unwrap_err();
        assert!(e.contains("10.2 % of the field (at most 10 %)"), "{e}");
    }

    fn planar_fit(soft: [[f64; 2]; 2]) -> Fit {
        Fit {
            kind: Kind::Planar,
            offset: [10.0, -20.0, 0.0],
            soft: [[soft[0][0], soft[0][1], 0.0], [soft[1][0], soft[1][1], 0.0], [0.0, 0.0, 1.0]],
            radius: 24.0,
            rms: 0.3,
            determinacy: 1e3,
            axis_ratio: 1.2,
            samples: 100,
        }
    }

    #[test]
    fn keep_z_cancels_the_modules_cross_terms_at_the_samples_z() {
        // S₂ (det 1.25 − 0.0625 ≠ 1: the rule must not assume det S₂ = 1) and cross terms.
        let soft = [[1.25, 0.25], [0.25, 0.95]];
        let mut fit = planar_fit(soft);
        let (mean_z, h_z, s_xz, s_yz) = (-30.0, 6.0, 0.08, -0.12);
        let shift = keep_z(&mut fit, mean_z, h_z, s_xz, s_yz);
        assert_eq!(fit.offset[0], 10.0 + shift[0]);
        assert_eq!(fit.offset[1], -20.0 + shift[1]);
        assert_eq!(fit.offset[2], 0.0);
        // The module's x/y at the samples' z with the moved h equals S₂·(m − fitted centre).
        for m in [[13.0, -4.0], [-50.0, 70.0], [0.0, 0.0]] {
            let module: [f64; 2] = std::array::from_fn(|i| {
                soft[i][0] * (m[0] - fit.offset[0])
                    + soft[i][1] * (m[1] - fit.offset[1])
                    + [s_xz, s_yz][i] * (mean_z - h_z)
            });
            let want: [f64; 2] =
                std::array::from_fn(|i| soft[i][0] * (m[0] - 10.0) + soft[i][1] * (m[1] + 20.0));
            for i in 0..2 {
                assert!((module[i] - want[i]).abs() < 1e-9, "{module:?} {want:?}");
            }
        }
        // No cross terms, or the samples at h_z: no shift.
        let mut plain = planar_fit(soft);
        assert_eq!(keep_z(&mut plain, mean_z, h_z, 0.0, 0.0), [0.0, 0.0]);
        assert_eq!(keep_z(&mut plain, 6.0, 6.0, s_xz, s_yz), [0.0, 0.0]);
        assert_eq!(plain.offset, [10.0, -20.0, 0.0]);
    }

    #[test]
    fn the_midrange_centres_each_axis_on_its_extremes() {
        let samples = [[1.0, -10.0, 5.0], [3.0, 30.0, 5.0], [2.0, 0.0, 7.0]];
        let centre = midrange(&samples);
        assert_eq!(centre([2.0, 10.0, 6.0]), [0.0, 0.0, 0.0]);
        assert_eq!(centre([0.0, 0.0, 0.0]), [-2.0, -10.0, -6.0]);
        let c = coverage(&samples, &centre);
        assert_eq!(c.sectors.iter().sum::<u32>(), 3);
        assert_eq!(c.sectors_covered(), 3, "{:?}", c.rose());
    }
}
