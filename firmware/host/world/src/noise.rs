//! Seeded noise: independent, reproducible streams of Gaussian draws.
//!
//! Every noisy signal owns its stream, keyed by the world seed and a stable stream number, so
//! that reading one channel more often, or adding a sensor, leaves every other channel's noise
//! unchanged, and the same seed always gives the same draws. The generator is xoshiro256++
//! (rand's `Xoshiro256PlusPlus`, a fixed, documented algorithm) and the normal distribution
//! rand_distr's ziggurat, pinned by Cargo.lock.

use rand::rngs::Xoshiro256PlusPlus;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};

/// One stream of noise.
#[derive(Clone, Debug)]
pub struct Noise {
    rng: Xoshiro256PlusPlus,
}

impl Noise {
    /// Stream number `stream` of the world seeded with `seed`.
    pub fn new(seed: u64, stream: u64) -> Self {
        // seed_from_u64 expands its argument through PCG32, so neighbouring (seed, stream)
        // pairs give unrelated states.
        let key = seed.wrapping_add(stream.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        Self { rng: Xoshiro256PlusPlus::seed_from_u64(key) }
    }

    /// A draw from N(0, `sigma`²); exactly 0 (and no draw) when `sigma` is 0.
    pub fn gaussian(&mut self, sigma: f64) -> f64 {
        if sigma == 0.0 {
            return 0.0;
        }
        let z: f64 = StandardNormal.sample(&mut self.rng);
        sigma * z
    }

    /// A draw from U[0, 1).
    pub fn uniform(&mut self) -> f64 {
        // 53 random bits → [0, 1) with every value a multiple of 2^-53.
        (self.rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_draws_other_stream_other_draws() {
        let mut a = Noise::new(7, 3);
        let mut b = Noise::new(7, 3);
        let mut c = Noise::new(7, 4);
        let xa: Vec<f64> = (0..100).map(|_| a.gaussian(1.0)).collect();
        let xb: Vec<f64> = (0..100).map(|_| b.gaussian(1.0)).collect();
        let xc: Vec<f64> = (0..100).map(|_| c.gaussian(1.0)).collect();
        assert_eq!(xa, xb);
        assert_ne!(xa, xc);
    }

    #[test]
    fn gaussian_moments() {
        // n = 40 000 draws of N(0, 0.5²): the sample mean's standard error is 0.5/200 =
        // 0.0025 and the sample standard deviation's is 0.5/√(2n) ≈ 0.0018; 5σ bounds.
        let mut n = Noise::new(1, 0);
        let xs: Vec<f64> = (0..40_000).map(|_| n.gaussian(0.5)).collect();
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / xs.len() as f64).sqrt();
        assert!(mean.abs() < 5.0 * 0.0025, "{mean}");
        assert!((sd - 0.5).abs() < 5.0 * 0.0018, "{sd}");
    }

    #[test]
    fn uniform_range_and_mean() {
        let mut n = Noise::new(2, 9);
        let xs: Vec<f64> = (0..40_000).map(|_| n.uniform()).collect();
        assert!(xs.iter().all(|&x| (0.0..1.0).contains(&x)));
        // Mean 1/2, standard error √(1/12)/200 ≈ 0.00144; 5σ.
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        assert!((mean - 0.5).abs() < 5.0 * 0.00144, "{mean}");
    }
}
