//! The magnetometer's hard- and soft-iron fit for `r2p imu calibrate`: raw field samples `m`
//! (µT) lie on an ellipsoid `(m − h)ᵀ E (m − h) = 1`; the module corrects them with
//! `S·(m − h)` (its `mag_offset_*` = h and `mag_soft_*` = S parameters), which puts them on a
//! sphere.
//!
//! **Method** — an algebraic least-squares fit of a general quadric (conic in 2-D) with a unit
//! norm constraint on the coefficient vector, as in Gander, Golub and Strebel, "Least-squares
//! fitting of circles and ellipses", BIT 34 (1994), §2 (here in three dimensions): each sample
//! gives a row `[x², y², z², 2xy, 2xz, 2yz, 2x, 2y, 2z, 1]` of a design matrix `D`, and the
//! coefficients are the eigenvector of `DᵀD` with the smallest eigenvalue. The samples are
//! first centred on their mean and scaled to unit RMS radius so that `DᵀD` is well
//! conditioned whatever the offset and field strength. Unlike the common 9-parameter fit
//! (constant term fixed at −1), this one does not break down when the ellipsoid passes near
//! the origin (an offset as large as the field), and unlike Li and Griffiths' ellipsoid-specific
//! fit (2004) it needs only a symmetric eigensolver; it does not force an ellipsoid, so a
//! quadric that is not one is reported ([`FitError::NotAnEllipsoid`]) rather than bent into
//! one.
//!
//! **From quadric to calibration** — with `A`, `b`, `d` the quadric's matrix, linear part and
//! constant, the centre is `h = −A⁻¹b` and `E = A / (hᵀAh − d)`, which must be positive
//! definite. `S = r·E^½` (the symmetric square root, so S is symmetric as the module's six
//! parameters are), with `r` the geometric mean of the ellipsoid's semi-axes: `det S = 1`, so
//! the correction reshapes the field without inventing a gain, and `|S(m − h)|` stays the
//! field strength the sensor measured, in µT (the true local field strength is not known).
//!
//! **Planar** — a wheeled robot that only spins on the floor sees the field's horizontal
//! component turn in the sensor's x/y plane and its vertical component stay still: only the
//! 2-D conic in x/y is determined (hₓ, h_y and the 2×2 block of S, `det = 1` likewise); the z
//! terms cannot be and are left to the caller.
//!
//! **Quality** — the residual RMS of `|S(m − h)|` about its mean (µT and % of the mean), the
//! fit's determinacy (second-smallest over smallest eigenvalue of `DᵀD`: near 1 means another
//! quadric fits as well, the samples do not pin the ellipsoid down) and the axis ratio of the
//! ellipsoid (longest over shortest semi-axis: how much soft iron there is).

use std::fmt;

use nalgebra::{DMatrix, DVector, SymmetricEigen};

/// Which fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// The 3-D ellipsoid: the robot turned through every orientation.
    Full,
    /// The 2-D ellipse in x/y: the robot spun on the floor; z terms undetermined.
    Planar,
}

impl Kind {
    /// Its name on the command line and in the output.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Full => "full",
            Kind::Planar => "planar",
        }
    }

    /// Dimensions fitted.
    fn dims(self) -> usize {
        match self {
            Kind::Full => 3,
            Kind::Planar => 2,
        }
    }
}

/// Fewest samples either fit accepts: several per coefficient (10 for the ellipsoid), so that
/// noise averages out.
pub const MIN_SAMPLES: usize = 50;

/// Smallest accepted determinacy (second-smallest over smallest eigenvalue of `DᵀD`). A cloud
/// on a plane or a small cap fits a family of quadrics: the two smallest eigenvalues are then
/// both near zero and their ratio near 1; a well-covered ellipsoid gives hundreds or more.
pub const MIN_DETERMINACY: f64 = 10.0;

/// Largest accepted axis ratio. Soft iron near a sensor stretches the field by some tens of
/// percent; a fit much flatter than this came from samples that cover a band or a cap of the
/// ellipsoid only (a robot turned on the floor, fitted in 3-D), where a flat ellipsoid through
/// the band fits as well as the true one.
pub const MAX_AXIS_RATIO: f64 = 3.0;

/// A fitted calibration and its quality.
#[derive(Clone, Debug, PartialEq)]
pub struct Fit {
    /// Which fit.
    pub kind: Kind,
    /// Hard iron h, µT (planar: z is 0, not fitted).
    pub offset: [f64; 3],
    /// Soft iron S, symmetric (planar: the z row and column are identity's, not fitted).
    pub soft: [[f64; 3]; 3],
    /// Mean of `|S(m − h)|` over the samples, µT.
    pub radius: f64,
    /// RMS of `|S(m − h)|` about [`Fit::radius`], µT.
    pub rms: f64,
    /// Second-smallest over smallest eigenvalue of the normalised `DᵀD`.
    pub determinacy: f64,
    /// Longest over shortest semi-axis of the fitted ellipsoid (ellipse).
    pub axis_ratio: f64,
    /// Samples fitted.
    pub samples: usize,
}

impl Fit {
    /// [`Fit::rms`] as a percentage of [`Fit::radius`].
    pub fn rms_percent(&self) -> f64 {
        100.0 * self.rms / self.radius
    }

    /// `S·(m − h)`: a raw sample corrected as the module will (planar: x and y only, z as is).
    pub fn apply(&self, m: [f64; 3]) -> [f64; 3] {
        let d = [m[0] - self.offset[0], m[1] - self.offset[1], m[2] - self.offset[2]];
        std::array::from_fn(|i| (0..3).map(|j| self.soft[i][j] * d[j]).sum())
    }
}

/// Why no calibration came out of the samples; each message says what, why and what to do.
#[derive(Clone, Debug, PartialEq)]
pub enum FitError {
    /// Fewer than [`MIN_SAMPLES`].
    TooFewSamples {
        /// Samples given.
        got: usize,
    },
    /// A sample is NaN or infinite.
    NotFinite {
        /// Its position.
        index: usize,
    },
    /// Another quadric fits nearly as well: the samples do not determine the ellipsoid.
    Undetermined {
        /// The determinacy found.
        determinacy: f64,
    },
    /// The ellipsoid is flatter than [`MAX_AXIS_RATIO`].
    TooFlat {
        /// Its longest over its shortest semi-axis.
        axis_ratio: f64,
    },
    /// The best quadric is not an ellipsoid (ellipse): a hyperboloid, paraboloid or a pair of
    /// planes.
    NotAnEllipsoid,
}

impl fmt::Display for FitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FitError::TooFewSamples { got } => write!(
                f,
                "{got} samples, the fit needs at least {MIN_SAMPLES}: the module published too \
                 few during the run; check `r2p echo` on its mag topic and run longer (--seconds)"
            ),
            FitError::NotFinite { index } => write!(
                f,
                "sample {index} is not a finite number: the magnetometer sends bad data; \
                 check it with `r2p echo` on its mag topic"
            ),
            FitError::Undetermined { determinacy } => write!(
                f,
                "the samples do not determine the ellipsoid (determinacy {determinacy:.1}, \
                 needs {MIN_DETERMINACY}): they lie on a plane or a small patch of it; turn the \
                 robot through more orientations (a full fit needs it rolled and pitched as well \
                 as turned; a robot that only turns on the floor needs --planar)"
            ),
            FitError::TooFlat { axis_ratio } => write!(
                f,
                "the fitted ellipsoid is {axis_ratio:.1} times longer than it is wide (at most \
                 {MAX_AXIS_RATIO} from soft iron): the samples cover a band or a patch of it \
                 only; turn the robot through more orientations (a full fit needs it rolled and \
                 pitched as well as turned; a robot that only turns on the floor needs --planar)"
            ),
            FitError::NotAnEllipsoid => f.write_str(
                "the samples fit no ellipsoid (the best quadric is a hyperboloid or an open \
                 surface): the field changed during the run (steel, magnets or running motors \
                 nearby) or the samples cover too little of it; move away from them and turn the \
                 robot through a whole turn (or every orientation) slowly",
            ),
        }
    }
}

impl std::error::Error for FitError {}

/// The design matrix's row for a centred, scaled sample `u` (first `dims` coordinates):
/// quadratic terms (squares, then doubled cross terms), doubled linear terms, 1.
fn row(u: &[f64]) -> Vec<f64> {
    let n = u.len();
    let mut r: Vec<f64> = u.iter().map(|x| x * x).collect();
    for i in 0..n {
        for j in i + 1..n {
            r.push(2.0 * u[i] * u[j]);
        }
    }
    r.extend(u.iter().map(|x| 2.0 * x));
    r.push(1.0);
    r
}

/// The quadric's matrix, linear part and constant from its coefficients (as [`row`] orders them).
fn unpack(v: &DVector<f64>, n: usize) -> (DMatrix<f64>, DVector<f64>, f64) {
    let mut a = DMatrix::zeros(n, n);
    for i in 0..n {
        a[(i, i)] = v[i];
    }
    let mut k = n;
    for i in 0..n {
        for j in i + 1..n {
            a[(i, j)] = v[k];
            a[(j, i)] = v[k];
            k += 1;
        }
    }
    let b = DVector::from_fn(n, |i, _| v[k + i]);
    (a, b, v[k + n])
}

/// Fits `kind` to raw samples (µT, sensor axes).
pub fn fit(samples: &[[f64; 3]], kind: Kind) -> Result<Fit, FitError> {
    if let Some(index) = samples.iter().position(|m| m.iter().any(|x| !x.is_finite())) {
        return Err(FitError::NotFinite { index });
    }
    if samples.len() < MIN_SAMPLES {
        return Err(FitError::TooFewSamples { got: samples.len() });
    }
    let n = kind.dims();
    let count = samples.len() as f64;
    // Centre and scale: u = (m − μ)/σ, σ the RMS distance from the mean.
    let mu: Vec<f64> = (0..n).map(|i| samples.iter().map(|m| m[i]).sum::<f64>() / count).collect();
    let sigma =
        (samples.iter().map(|m| (0..n).map(|i| (m[i] - mu[i]).powi(2)).sum::<f64>()).sum::<f64>()
            / count)
            .sqrt();
    if sigma == 0.0 {
        return Err(FitError::Undetermined { determinacy: 1.0 });
    }
    let cols = row(&vec![0.0; n]).len();
    let mut m = DMatrix::<f64>::zeros(cols, cols);
    for s in samples {
        let u: Vec<f64> = (0..n).map(|i| (s[i] - mu[i]) / sigma).collect();
        let r = DVector::from_vec(row(&u));
        m += &r * r.transpose();
    }
    m /= count;
    // Eigenvalues below this are zero within rounding (the normalised matrix's trace is O(1)).
    let floor = 1e-12 * m.trace();
    let eig = SymmetricEigen::new(m);
    let mut order: Vec<usize> = (0..cols).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let (l1, l2) = (eig.eigenvalues[order[0]].max(floor), eig.eigenvalues[order[1]].max(floor));
    let determinacy = l2 / l1;
    if determinacy.is_nan() || determinacy < MIN_DETERMINACY {
        return Err(FitError::Undetermined { determinacy });
    }
    let v = eig.eigenvectors.column(order[0]).into_owned();
    let (mut a, mut b, mut d) = unpack(&v, n);
    if a.trace() < 0.0 {
        a = -a;
        b = -b;
        d = -d;
    }
    let centre = a.clone().lu().solve(&(-&b)).ok_or(FitError::NotAnEllipsoid)?;
    // (u − c)ᵀ A (u − c) = k: an ellipsoid when A is positive definite and k > 0. E = A/(kσ²)
    // in µT, but only E's shape matters below (S is scaled to det 1), so A stands for it.
    let k = (centre.transpose() * &a * &centre)[(0, 0)] - d;
    let se = SymmetricEigen::new(a);
    let (lo, hi) =
        se.eigenvalues.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &l| (lo.min(l), hi.max(l)));
    if !(k > 0.0 && lo > 0.0 && lo.is_finite()) {
        return Err(FitError::NotAnEllipsoid);
    }
    let axis_ratio = (hi / lo).sqrt();
    if axis_ratio > MAX_AXIS_RATIO {
        return Err(FitError::TooFlat { axis_ratio });
    }
    // S = r·A^½ with r making det S = 1 (the geometric mean semi-axis, in A's units).
    let r = se.eigenvalues.iter().map(|l| l.ln()).sum::<f64>() / (-2.0 * n as f64);
    let root = DMatrix::from_diagonal(&se.eigenvalues.map(|l| l.sqrt() * r.exp()));
    let s_n = &se.eigenvectors * root * se.eigenvectors.transpose();
    let mut offset = [0.0; 3];
    let mut soft = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for i in 0..n {
        offset[i] = mu[i] + sigma * centre[i];
        for j in 0..n {
            // Symmetrised: the eigen-decomposition leaves differences of an ulp or so.
            soft[i][j] = 0.5 * (s_n[(i, j)] + s_n[(j, i)]);
        }
    }
    let mut fit = Fit {
        kind,
        offset,
        soft,
        radius: 0.0,
        rms: 0.0,
        determinacy,
        axis_ratio,
        samples: samples.len(),
    };
    let radii: Vec<f64> = samples
        .iter()
        .map(|&m| {
            let c = fit.apply(m);
            c[..n].iter().map(|x| x * x).sum::<f64>().sqrt()
        })
        .collect();
    fit.radius = radii.iter().sum::<f64>() / count;
    fit.rms = (radii.iter().map(|x| (x - fit.radius).powi(2)).sum::<f64>() / count).sqrt();
    Ok(fit)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::{distortion, field, Rng};

    fn full_samples(n: usize, noise: f64, seed: u64) -> Vec<[f64; 3]> {
        let d = distortion();
        let mut rng = Rng::new(seed);
        (0..n)
            .map(|_| {
                // A uniformly random direction on the sphere, field strength 48 µT.
                let z = 2.0 * rng.uniform() - 1.0;
                let t = std::f64::consts::TAU * rng.uniform();
                let r = (1.0 - z * z).sqrt();
                d.measure([48.0 * r * t.cos(), 48.0 * r * t.sin(), 48.0 * z], noise, &mut rng)
            })
            .collect()
    }

    fn planar_samples(n: usize, noise: f64, turn_deg: f64, seed: u64) -> Vec<[f64; 3]> {
        let d = distortion();
        let mut rng = Rng::new(seed);
        (0..n)
            .map(|i| {
                let yaw = (turn_deg * i as f64 / n as f64).to_radians();
                d.measure(field(yaw, 0.0), noise, &mut rng)
            })
            .collect()
    }

    /// S·W is a rotation times a scale when S undoes W; with S symmetric and det S = 1 it is
    /// the identity times det(W)^(1/3).
    fn assert_undoes(fit: &Fit, n: usize, tol: f64) {
        let d = distortion();
        let sw: Vec<Vec<f64>> = (0..n)
            .map(|i| (0..n).map(|j| (0..n).map(|k| fit.soft[i][k] * d.w[k][j]).sum()).collect())
            .collect();
        let scale = sw[0][0];
        for (i, row) in sw.iter().enumerate() {
            for (j, x) in row.iter().enumerate() {
                let want = if i == j { scale } else { 0.0 };
                assert!((x - want).abs() < tol, "S·W[{i}][{j}] = {x} (scale {scale})");
            }
        }
    }

    #[test]
    fn the_full_fit_recovers_hard_and_soft_iron_from_noisy_samples() {
        let samples = full_samples(2000, 0.3, 7);
        let fit = fit(&samples, Kind::Full).unwrap();
        let d = distortion();
        for i in 0..3 {
            assert!((fit.offset[i] - d.h[i]).abs() < 0.1, "h = {:?}", fit.offset);
        }
        assert_undoes(&fit, 3, 0.005);
        let det = nalgebra::Matrix3::from_fn(|i, j| fit.soft[i][j]).determinant();
        assert!((det - 1.0).abs() < 1e-9, "det S = {det}");
        for i in 0..3 {
            for j in 0..3 {
                assert_eq!(fit.soft[i][j], fit.soft[j][i]);
            }
        }
        // The radius is the field times det(W)^(1/3); the RMS is the noise's share, ~0.3 µT.
        let w_det = nalgebra::Matrix3::from_fn(|i, j| d.w[i][j]).determinant();
        assert!((fit.radius - 48.0 * w_det.cbrt()).abs() < 0.1, "radius {}", fit.radius);
        assert!(fit.rms > 0.2 && fit.rms < 0.45, "rms {}", fit.rms);
        assert!((fit.rms_percent() - 100.0 * fit.rms / fit.radius).abs() < 1e-12);
        assert!(fit.determinacy > 100.0, "determinacy {}", fit.determinacy);
        let w = SymmetricEigen::new(nalgebra::Matrix3::from_fn(|i, j| d.w[i][j])).eigenvalues;
        let want = w.max() / w.min();
        assert!((fit.axis_ratio - want).abs() < 0.01, "axis ratio {} want {want}", fit.axis_ratio);
        assert_eq!((fit.kind, fit.samples), (Kind::Full, 2000));
    }

    #[test]
    fn noise_free_samples_fit_exactly() {
        let fit = fit(&full_samples(200, 0.0, 3), Kind::Full).unwrap();
        assert!(fit.rms < 1e-9, "rms {}", fit.rms);
        assert!(fit.determinacy > 1e6, "{}", fit.determinacy);
        for (got, want) in fit.offset.iter().zip(distortion().h) {
            assert!((got - want).abs() < 1e-9);
        }
        assert_undoes(&fit, 3, 1e-9);
    }

    #[test]
    fn the_planar_fit_recovers_the_horizontal_terms_and_leaves_z_alone() {
        let samples = planar_samples(720, 0.3, 360.0, 11);
        let fit = fit(&samples, Kind::Planar).unwrap();
        let d = distortion();
        // Spinning flat, the vertical field through W's xz/yz terms shifts x/y as well:
        // the ellipse's centre is h plus W's z column times the vertical field.
        let bv = field(0.0, 0.0)[2];
        for i in 0..2 {
            let want = d.h[i] + d.w[i][2] * bv;
            assert!((fit.offset[i] - want).abs() < 0.1, "h = {:?} want {want}", fit.offset);
        }
        assert_eq!(fit.offset[2], 0.0);
        assert_eq!(fit.soft[2], [0.0, 0.0, 1.0]);
        assert_eq!((fit.soft[0][2], fit.soft[1][2]), (0.0, 0.0));
        assert_undoes(&fit, 2, 0.005);
        let det = fit.soft[0][0] * fit.soft[1][1] - fit.soft[0][1] * fit.soft[1][0];
        assert!((det - 1.0).abs() < 1e-9, "det {det}");
        assert!(fit.rms > 0.15 && fit.rms < 0.45, "rms {}", fit.rms);
        // Corrected, the horizontal field is a circle: every sample's |S(m − h)| near the mean.
        for m in &samples {
            let c = fit.apply(*m);
            assert!(((c[0] * c[0] + c[1] * c[1]).sqrt() - fit.radius).abs() < 2.0);
        }
    }

    #[test]
    fn a_full_fit_of_a_robot_that_only_turned_on_the_floor_is_refused() {
        // With noise off the plane a flat ellipsoid through the circle fits; without, a family.
        let e = fit(&planar_samples(720, 0.3, 360.0, 5), Kind::Full).unwrap_err();
        assert!(matches!(e, FitError::TooFlat { axis_ratio } if axis_ratio > 10.0), "{e:?}");
        let text = e.to_string();
        assert!(text.contains("longer than it is wide") && text.contains("--planar"), "{text}");
        let e = fit(&planar_samples(720, 0.0, 360.0, 5), Kind::Full).unwrap_err();
        assert!(matches!(e, FitError::Undetermined { .. }), "{e:?}");
        let text = e.to_string();
        assert!(
            text.contains("do not determine the ellipsoid") && text.contains("--planar"),
            "{text}"
        );
    }

    #[test]
    fn degenerate_inputs_are_refused_with_what_to_do() {
        let few = full_samples(MIN_SAMPLES - 1, 0.3, 1);
        let e = fit(&few, Kind::Full).unwrap_err();
        assert_eq!(e, FitError::TooFewSamples { got: MIN_SAMPLES - 1 });
        assert!(e.to_string().contains("at least 50") && e.to_string().contains("--seconds"));
        assert!(fit(&full_samples(MIN_SAMPLES, 0.3, 1), Kind::Full).is_ok());
        let mut bad = full_samples(100, 0.3, 1);
        bad[42][1] = f64::NAN;
        assert_eq!(fit(&bad, Kind::Full).unwrap_err(), FitError::NotFinite { index: 42 });
        bad[42][1] = f64::INFINITY;
        assert_eq!(fit(&bad, Kind::Planar).unwrap_err(), FitError::NotFinite { index: 42 });
        // One point over and over: nothing to fit.
        let still = vec![[10.0, 20.0, 30.0]; 100];
        assert!(matches!(fit(&still, Kind::Full), Err(FitError::Undetermined { .. })));
        assert!(matches!(fit(&still, Kind::Planar), Err(FitError::Undetermined { .. })));
        // On a line: a family of conics through it.
        let line: Vec<[f64; 3]> = (0..100).map(|i| [i as f64, 2.0 * i as f64, 0.0]).collect();
        assert!(matches!(fit(&line, Kind::Planar), Err(FitError::Undetermined { .. })));
        assert!(fit(&line, Kind::Planar).unwrap_err().to_string().contains("turn the robot"));
    }

    #[test]
    fn a_hyperbola_is_not_an_ellipse() {
        // x² − y² = 400 sampled on both branches, noisy.
        let mut rng = Rng::new(9);
        let samples: Vec<[f64; 3]> = (0..400)
            .map(|i| {
                let t = (i % 200) as f64 / 100.0 - 1.0;
                let s = if i < 200 { 1.0 } else { -1.0 };
                [s * 20.0 * t.cosh() + 0.01 * rng.normal(), 20.0 * t.sinh(), 0.0]
            })
            .collect();
        let e = fit(&samples, Kind::Planar).unwrap_err();
        assert_eq!(e, FitError::NotAnEllipsoid);
        assert!(e.to_string().contains("steel, magnets or running motors"), "{e}");
        // A hyperboloid of one sheet, x² + y² − z² = 400.
        let samples: Vec<[f64; 3]> = (0..600)
            .map(|i| {
                let (t, h) = (i as f64 * 0.37, (i % 30) as f64 / 15.0 - 1.0);
                let r = 20.0 * h.cosh();
                [r * t.cos(), r * t.sin(), 20.0 * h.sinh() + 0.01 * rng.normal()]
            })
            .collect();
        assert_eq!(fit(&samples, Kind::Full).unwrap_err(), FitError::NotAnEllipsoid);
    }

    #[test]
    fn an_offset_as_large_as_the_field_fits_as_well() {
        // The ellipsoid passes through the origin: the 9-parameter fit (d = −1) breaks here.
        let samples: Vec<[f64; 3]> = full_samples(500, 0.0, 4)
            .iter()
            .map(|m| {
                let d = distortion();
                [m[0] - d.h[0] + 48.0, m[1] - d.h[1], m[2] - d.h[2]]
            })
            .collect();
        let fit = fit(&samples, Kind::Full).unwrap();
        assert!(
            (fit.offset[0] - 48.0).abs() < 1e-6 && fit.offset[1].abs() < 1e-6,
            "{:?}",
            fit.offset
        );
    }

    #[test]
    fn the_fit_moves_with_the_samples_and_does_not_depend_on_their_units() {
        // The samples are centred and scaled before the fit: shifted, the same S and a shifted
        // h come out; in nT instead of µT, the same S and h × 1000 (with noise: a fit that
        // weighted its terms by where the samples sit or their units would differ).
        let samples = full_samples(300, 0.5, 21);
        let a = fit(&samples, Kind::Full).unwrap();
        let shift = [250.0, -180.0, 90.0];
        let moved: Vec<[f64; 3]> =
            samples.iter().map(|m| std::array::from_fn(|i| m[i] + shift[i])).collect();
        let b = fit(&moved, Kind::Full).unwrap();
        let nano: Vec<[f64; 3]> = samples.iter().map(|m| m.map(|x| x * 1000.0)).collect();
        let c = fit(&nano, Kind::Full).unwrap();
        for (i, d) in shift.iter().enumerate() {
            assert!((b.offset[i] - a.offset[i] - d).abs() < 1e-7, "{:?} {:?}", a.offset, b.offset);
            assert!(
                (c.offset[i] - 1000.0 * a.offset[i]).abs() < 1e-5,
                "{:?} {:?}",
                a.offset,
                c.offset
            );
            for j in 0..3 {
                assert!((b.soft[i][j] - a.soft[i][j]).abs() < 1e-9);
                assert!((c.soft[i][j] - a.soft[i][j]).abs() < 1e-9);
            }
        }
        assert!((b.rms - a.rms).abs() < 1e-9 && (c.rms - 1000.0 * a.rms).abs() < 1e-6);
        assert!((b.determinacy / a.determinacy - 1.0).abs() < 1e-6);
    }

    #[test]
    fn kinds_are_named() {
        assert_eq!((Kind::Full.name(), Kind::Planar.name()), ("full", "planar"));
        assert_eq!((Kind::Full.dims(), Kind::Planar.dims()), (3, 2));
    }
}
