//! Synthetic magnetometer samples for tests (here and in `r2p imu calibrate`'s): a known
//! hard- and soft-iron distortion of the Earth's field as a robot turns, with Gaussian noise
//! from a small deterministic generator, so that a fit can be checked against the truth and
//! every run draws the same samples.

/// A small deterministic generator (xorshift64*, Marsaglia 2003 with Vigna's multiplier):
/// enough for test noise, and the same samples on every run and machine.
pub struct Rng(u64);

impl Rng {
    /// A generator from `seed` (0 is taken as 1: xorshift's state must not be zero).
    pub fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u = self.uniform().max(1e-300);
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * self.uniform()).cos()
    }
}

fn mat_vec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|j| m[i][j] * v[j]).sum())
}

/// A distortion: the sensor measures `W·b + h` for a true field b, with W = S⁻¹ up to scale.
pub struct Distortion {
    /// Hard iron, µT.
    pub h: [f64; 3],
    /// W, symmetric positive definite.
    pub w: [[f64; 3]; 3],
}

/// The distortion the tests use: tens of µT of hard iron, up to 12 % of soft iron with
/// cross terms (its W is symmetric positive definite, as soft iron's is).
pub fn distortion() -> Distortion {
    Distortion {
        h: [31.5, -12.25, 48.0],
        w: [[1.12, 0.06, -0.03], [0.06, 0.91, 0.04], [-0.03, 0.04, 1.02]],
    }
}

impl Distortion {
    /// What the sensor reads for the true field `b`, with `noise` µT (standard deviation) on
    /// each axis.
    pub fn measure(&self, b: [f64; 3], noise: f64, rng: &mut Rng) -> [f64; 3] {
        let m = mat_vec(&self.w, b);
        std::array::from_fn(|i| m[i] + self.h[i] + noise * rng.normal())
    }
}

/// The true field (48 µT, inclined 60° down) in the sensor's axes after yaw ψ, pitch θ.
pub fn field(yaw: f64, pitch: f64) -> [f64; 3] {
    let (bh, bv) = (48.0 * 60f64.to_radians().cos(), -48.0 * 60f64.to_radians().sin());
    // Rotate the world's (bh, 0, bv) into the body: yaw about z, then pitch about y.
    let (x, y) = (bh * yaw.cos(), -bh * yaw.sin());
    let (c, s) = (pitch.cos(), pitch.sin());
    [c * x - s * bv, y, s * x + c * bv]
}
