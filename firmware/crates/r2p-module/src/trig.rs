//! Sine, cosine and tangent in `f32` arithmetic only, for the angles a module works with.
//!
//! libm's `sinf`/`cosf`/`tanf` compute in `f64` (musl's kernels) and reduce any argument with
//! `rem_pio2f`: on the F103, which has no FPU, they bring in 2.3 KB of reduction and 2.5 KB of
//! double-precision soft float besides themselves (the imu image: ~6 KB of its flash). These
//! reduce the argument by multiples of π/2 with π/2 split in three (Cody and Waite, the
//! constants of Cephes' `sinf`, exact products for |x| ≤ 8192) and evaluate Cephes' minimax
//! polynomials on [−π/4, π/4]: an error within 3 × 10⁻⁷ of the true value there (tested against
//! the standard library), and fewer soft-float operations than libm's `f64` path. Beyond
//! |x| = 8192 (rad) the reduction loses accuracy; NaN and ±∞ give NaN.

/// π/2 = `PIO2_1 + PIO2_2 + PIO2_3`; the first two have short mantissas, so `k × PIO2_n` is
/// exact for the quadrant counts k of |x| ≤ 8192.
const PIO2_1: f32 = 1.570_312_5;
const PIO2_2: f32 = 4.837_513e-4;
const PIO2_3: f32 = 7.549_79e-8;

/// `x` as `r + k × π/2` with |r| ≤ π/4 (about): `(r, k mod 4)`.
fn reduce(x: f32) -> (f32, u32) {
    let q = x * core::f32::consts::FRAC_2_PI;
    // Rounded half away from zero; `as` saturates (and maps NaN to 0, which keeps r NaN).
    let k = (q + if q < 0.0 { -0.5 } else { 0.5 }) as i32;
    let kf = k as f32;
    let r = ((x - kf * PIO2_1) - kf * PIO2_2) - kf * PIO2_3;
    (r, k as u32 & 3)
}

/// sin r for |r| ≤ π/4.
fn sin_kernel(r: f32) -> f32 {
    let z = r * r;
    r + r * z * (-1.666_665_5e-1 + z * (8.332_161e-3 + z * -1.951_529_6e-4))
}

/// cos r for |r| ≤ π/4.
fn cos_kernel(r: f32) -> f32 {
    let z = r * r;
    1.0 - 0.5 * z + z * z * (4.166_664_6e-2 + z * (-1.388_731_6e-3 + z * 2.443_315_7e-5))
}

/// (sin x, cos x), sharing the reduction.
pub fn sin_cos(x: f32) -> (f32, f32) {
    let (r, q) = reduce(x);
    let (s, c) = (sin_kernel(r), cos_kernel(r));
    match q {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// sin x.
pub fn sinf(x: f32) -> f32 {
    sin_cos(x).0
}

/// cos x.
pub fn cosf(x: f32) -> f32 {
    sin_cos(x).1
}

/// tan x (as sin x / cos x: ±∞ or a large value near odd multiples of π/2).
pub fn tanf(x: f32) -> f32 {
    let (s, c) = sin_cos(x);
    s / c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every 1/1000 rad over ±4π, then every 0.37 rad up to ±8192.
    fn angles() -> impl Iterator<Item = f32> {
        let near = (-12_566..=12_566).map(|i| i as f32 / 1000.0);
        let far = (-22_140..=22_140).map(|i| i as f32 * 0.37);
        near.chain(far)
    }

    #[test]
    fn sine_and_cosine_are_within_3e_7_of_the_standard_library_up_to_8192_rad() {
        let mut worst = 0.0f64;
        for x in angles() {
            let (s, c) = sin_cos(x);
            let xd = f64::from(x);
            let err = (f64::from(s) - xd.sin()).abs().max((f64::from(c) - xd.cos()).abs());
            assert!(err < 3e-7, "x = {x}: sin {s} vs {}, cos {c} vs {}", xd.sin(), xd.cos());
            worst = worst.max(err);
        }
        assert!(worst > 0.0, "compared something");
        assert_eq!((sinf(0.5), cosf(0.5)), sin_cos(0.5));
    }

    #[test]
    fn tangent_is_within_1e_6_relative_away_from_its_poles() {
        for x in angles() {
            let t = f64::from(x).tan();
            if t.abs() < 100.0 {
                let err = (f64::from(tanf(x)) - t).abs() / t.abs().max(1.0);
                assert!(err < 1e-6, "x = {x}: tan {} vs {t}", tanf(x));
            }
        }
    }

    #[test]
    fn signs_and_exact_points() {
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        assert!(sinf(-0.0) == 0.0 && sinf(1.0) > 0.0 && sinf(-1.0) < 0.0);
        assert!((sinf(core::f32::consts::FRAC_PI_2) - 1.0).abs() < 1e-7);
        assert!((cosf(core::f32::consts::PI) + 1.0).abs() < 1e-7);
        assert!(
            sinf(f32::NAN).is_nan()
                && cosf(f32::INFINITY).is_nan()
                && tanf(f32::NEG_INFINITY).is_nan()
        );
    }
}
