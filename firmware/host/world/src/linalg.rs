//! Dense linear algebra for the base's at most 3 degrees of freedom: Gaussian elimination
//! with partial pivoting on fixed 3 × 3 arrays (only the leading `n` × `n` block is used).

/// A 3 × 3 matrix, row-major.
pub(crate) type Mat3 = [[f64; 3]; 3];

/// Solves `m x = b` on the leading `n` × `n` block. Panics on a singular matrix: the callers'
/// matrices (mass matrices, normal equations of a validated wheel layout) are positive
/// definite.
pub(crate) fn solve(m: &Mat3, b: &[f64; 3], n: usize) -> [f64; 3] {
    let mut a = *m;
    let mut x = *b;
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs())).unwrap_or(c);
        assert!(a[p][c].abs() > 1e-300, "singular {n}×{n} system");
        a.swap(c, p);
        x.swap(c, p);
        for r in c + 1..n {
            let f = a[r][c] / a[c][c];
            let pivot = a[c];
            for (v, p) in a[r].iter_mut().zip(pivot).skip(c).take(n - c) {
                *v -= f * p;
            }
            x[r] -= f * x[c];
        }
    }
    for c in (0..n).rev() {
        let s: f64 = (c + 1..n).map(|k| a[c][k] * x[k]).sum();
        x[c] = (x[c] - s) / a[c][c];
    }
    for v in x.iter_mut().skip(n) {
        *v = 0.0;
    }
    x
}

/// The determinant of `m` (the rule of Sarrus).
pub(crate) fn det(m: &Mat3) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// The inverse of the leading `n` × `n` block (zeros elsewhere).
pub(crate) fn inverse(m: &Mat3, n: usize) -> Mat3 {
    let mut inv = [[0.0; 3]; 3];
    for c in 0..n {
        let mut e = [0.0; 3];
        e[c] = 1.0;
        let col = solve(m, &e, n);
        for r in 0..n {
            inv[r][c] = col[r];
        }
    }
    inv
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops read like the formulas
mod tests {
    use super::*;

    #[test]
    fn solves_with_pivoting() {
        // A zero on the diagonal needs a row swap.
        let m = [[0.0, 2.0, 1.0], [1.0, 1.0, 0.0], [3.0, 0.0, 1.0]];
        let x = [1.0, -2.0, 0.5];
        let b = [0.0 + 2.0 * -2.0 + 0.5, 1.0 - 2.0, 3.0 + 0.5];
        let got = solve(&m, &b, 3);
        for i in 0..3 {
            assert!((got[i] - x[i]).abs() < 1e-14, "{got:?}");
        }
        let inv = inverse(&m, 3);
        for i in 0..3 {
            for j in 0..3 {
                let p: f64 = (0..3).map(|k| m[i][k] * inv[k][j]).sum();
                assert!((p - f64::from(u8::from(i == j))).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn determinant_of_a_full_matrix() {
        // By cofactors of the first row: 2·(4·6 − 1·2) − 3·(5·6 − 1·7) + 1·(5·2 − 4·7)
        // = 44 − 69 − 18 = −43; swapping two rows flips its sign.
        let m = [[2.0, 3.0, 1.0], [5.0, 4.0, 1.0], [7.0, 2.0, 6.0]];
        assert_eq!(det(&m), -43.0);
        assert_eq!(det(&[m[1], m[0], m[2]]), 43.0);
        assert_eq!(det(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), 1.0);
    }

    #[test]
    fn leading_block_only() {
        let m = [[2.0, 1.0, 99.0], [1.0, 3.0, 99.0], [99.0, 99.0, 99.0]];
        let x = solve(&m, &[3.0, 5.0, 7.0], 2);
        assert!((x[0] - 0.8).abs() < 1e-14 && (x[1] - 1.4).abs() < 1e-14 && x[2] == 0.0);
    }
}
