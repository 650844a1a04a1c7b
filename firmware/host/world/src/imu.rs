//! An inertial measurement unit on the base: what its gyroscope and accelerometer measure of
//! the base's motion, with the errors of an ST LSM6DSO.
//!
//! **Kinematics.** The base moves in the plane with body twist (vx, vy, ω) and its rate
//! (v̇x, v̇y, ω̇) ([`World::twist`], [`World::twist_rate`]). The sensor sits flat (its z up)
//! at `r = (rx, ry)` in the base frame, turned by ψ about z. In the rotating body frame the
//! acceleration of the base centre is a_c = (v̇x − ω·vy, v̇y + ω·vx), and of the sensor point
//!
//! ```text
//! a = a_c + ω̇ ẑ × r − ω² r = (a_cx − ω̇·ry − ω²·rx,  a_cy + ω̇·rx − ω²·ry,  0)
//! ```
//!
//! An accelerometer measures specific force f = a − g with g = (0, 0, −9.806 65 m/s²), so at
//! rest it reads +1 g on z. Both vectors are turned into the sensor frame by −ψ. The gyro
//! reads (0, 0, ω).
//!
//! **Errors** (LSM6DSO datasheet DS12140, table 2, typical values): rate noise density
//! 3.8 mdps/√Hz and acceleration noise density 70 µg/√Hz (high-performance mode); zero-rate
//! level ±1 dps and zero-g level ±20 mg; sensitivity tolerance ±1 % for both. Each device
//! draws its offsets and sensitivity errors once, uniformly within those bounds, per axis
//! (the datasheet gives typical spreads, not distributions); every sample adds white Gaussian
//! noise of σ = density·√(ODR/2), the noise bandwidth of the output at its data rate with the
//! default digital filtering (assumed: the LPF1/LPF2 options are not modelled). Measured =
//! (1 + e)·true + offset + noise. Range, resolution and saturation belong to the register
//! level (the emulator's LSM6DSO model), not here.
//!
//! Not modelled: temperature drift, cross-axis sensitivity, tilt of the floor or the mount,
//! vibration, the filters' group delay.

use crate::geometry::{Pose, Twist, Vec2};
use crate::noise::Noise;
use crate::world::World;

/// Standard gravity, m/s².
pub const G: f64 = crate::base::G;

/// Error figures of an IMU (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuParams {
    /// Gyro white-noise density, rad/s/√Hz.
    pub gyro_noise_density: f64,
    /// Accelerometer white-noise density, m/s²/√Hz.
    pub accel_noise_density: f64,
    /// Bound of the per-axis zero-rate offset, rad/s.
    pub gyro_offset: f64,
    /// Bound of the per-axis zero-g offset, m/s².
    pub accel_offset: f64,
    /// Bound of the per-axis sensitivity error (fraction).
    pub gyro_scale_error: f64,
    /// Bound of the per-axis sensitivity error (fraction).
    pub accel_scale_error: f64,
    /// Die temperature, °C.
    pub temperature_c: f64,
}

const DEG: f64 = std::f64::consts::PI / 180.0;

impl ImuParams {
    /// ST LSM6DSO, typical values of DS12140 table 2.
    pub const LSM6DSO: ImuParams = ImuParams {
        gyro_noise_density: 3.8e-3 * DEG,
        accel_noise_density: 70e-6 * G,
        gyro_offset: 1.0 * DEG,
        accel_offset: 20e-3 * G,
        gyro_scale_error: 0.01,
        accel_scale_error: 0.01,
        temperature_c: 30.0,
    };

    /// An ideal sensor (no noise, offset or scale error): for tests of the kinematics.
    pub const IDEAL: ImuParams = ImuParams {
        gyro_noise_density: 0.0,
        accel_noise_density: 0.0,
        gyro_offset: 0.0,
        accel_offset: 0.0,
        gyro_scale_error: 0.0,
        accel_scale_error: 0.0,
        temperature_c: 25.0,
    };

    /// Noise σ per sample of the gyro at `odr_hz`, rad/s.
    pub fn gyro_sigma(&self, odr_hz: f64) -> f64 {
        self.gyro_noise_density * (odr_hz / 2.0).sqrt()
    }

    /// Noise σ per sample of the accelerometer at `odr_hz`, m/s².
    pub fn accel_sigma(&self, odr_hz: f64) -> f64 {
        self.accel_noise_density * (odr_hz / 2.0).sqrt()
    }
}

/// One measurement, in the sensor's axes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImuReading {
    /// Angular rate, rad/s.
    pub gyro: [f64; 3],
    /// Specific force, m/s².
    pub accel: [f64; 3],
    /// Die temperature, °C.
    pub temperature_c: f64,
}

/// What an ideal IMU at `mount` reads for body twist `t` and its rate `dt`: (gyro, accel).
pub fn ideal_reading(mount: &Pose, t: &Twist, dt: &Twist) -> ([f64; 3], [f64; 3]) {
    let (w, wd, r) = (t.wz, dt.wz, mount.position());
    let ac = Vec2::new(dt.vx - w * t.vy, dt.vy + w * t.vx);
    let a = Vec2::new(ac.x - wd * r.y - w * w * r.x, ac.y + wd * r.x - w * w * r.y);
    let s = a.rotated(-mount.theta);
    ([0.0, 0.0, w], [s.x, s.y, G])
}

/// One IMU mounted on the base, with its own offsets, sensitivity errors and noise stream.
#[derive(Clone, Debug)]
pub struct Imu {
    /// Its error figures.
    pub params: ImuParams,
    /// Its pose in the base frame (z up).
    pub mount: Pose,
    gyro_offset: [f64; 3],
    accel_offset: [f64; 3],
    gyro_gain: [f64; 3],
    accel_gain: [f64; 3],
    noise: Noise,
}

impl Imu {
    /// A device at `mount`: its offsets and gains are drawn from stream `stream` of `seed`
    /// (and its noise from the next stream), so the same seed gives the same device.
    pub fn new(params: ImuParams, mount: Pose, seed: u64, stream: u64) -> Self {
        let mut d = Noise::new(seed, stream);
        let mut within = |bound: f64| (2.0 * d.uniform() - 1.0) * bound;
        let gyro_offset = [(); 3].map(|_| within(params.gyro_offset));
        let accel_offset = [(); 3].map(|_| within(params.accel_offset));
        let gyro_gain = [(); 3].map(|_| 1.0 + within(params.gyro_scale_error));
        let accel_gain = [(); 3].map(|_| 1.0 + within(params.accel_scale_error));
        Self {
            params,
            mount,
            gyro_offset,
            accel_offset,
            gyro_gain,
            accel_gain,
            noise: Noise::new(seed, stream + 1),
        }
    }

    /// This device's zero-rate offsets, rad/s.
    pub fn gyro_offset(&self) -> [f64; 3] {
        self.gyro_offset
    }

    /// This device's zero-g offsets, m/s².
    pub fn accel_offset(&self) -> [f64; 3] {
        self.accel_offset
    }

    /// This device's gains (1 + sensitivity error): gyro, accel.
    pub fn gains(&self) -> ([f64; 3], [f64; 3]) {
        (self.gyro_gain, self.accel_gain)
    }

    /// What the device reads, without noise, for twist `t` and twist rate `dt`.
    pub fn expected(&self, t: &Twist, dt: &Twist) -> ImuReading {
        let (g, a) = ideal_reading(&self.mount, t, dt);
        ImuReading {
            gyro: [0, 1, 2].map(|i| self.gyro_gain[i] * g[i] + self.gyro_offset[i]),
            accel: [0, 1, 2].map(|i| self.accel_gain[i] * a[i] + self.accel_offset[i]),
            temperature_c: self.params.temperature_c,
        }
    }

    /// One sample at output data rate `odr_hz` for twist `t` and rate `dt`.
    pub fn measure(&mut self, t: &Twist, dt: &Twist, odr_hz: f64) -> ImuReading {
        let mut r = self.expected(t, dt);
        let (sg, sa) = (self.params.gyro_sigma(odr_hz), self.params.accel_sigma(odr_hz));
        for i in 0..3 {
            r.gyro[i] += self.noise.gaussian(sg);
            r.accel[i] += self.noise.gaussian(sa);
        }
        r
    }

    /// One sample of the world's base now.
    pub fn sample(&mut self, world: &World, odr_hz: f64) -> ImuReading {
        self.measure(&world.twist(), &world.twist_rate(), odr_hz)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn at_rest_reads_one_g_up_and_no_rate() {
        let (g, a) = ideal_reading(&Pose::default(), &Twist::default(), &Twist::default());
        assert_eq!(g, [0.0; 3]);
        assert_eq!(a, [0.0, 0.0, G]);
    }

    #[test]
    fn spinning_off_centre_feels_centripetal_acceleration() {
        // 0.2 m ahead of the centre, spinning at 2 rad/s: −ω²r = −0.8 m/s² along x (towards
        // the centre); spinning up at 3 rad/s²: ω̇·r = 0.6 m/s² along y.
        let mount = Pose::new(0.2, 0.0, 0.0);
        let (g, a) = ideal_reading(&mount, &Twist::new(0.0, 0.0, 2.0), &Twist::new(0.0, 0.0, 3.0));
        assert_eq!(g[2], 2.0);
        assert!(close(a[0], -0.8, 1e-12) && close(a[1], 0.6, 1e-12), "{a:?}");
        // The same sensor turned 90° (its x to the left): the vector seen turned by −90°.
        let (_, b) = ideal_reading(
            &Pose::new(0.2, 0.0, std::f64::consts::FRAC_PI_2),
            &Twist::new(0.0, 0.0, 2.0),
            &Twist::new(0.0, 0.0, 3.0),
        );
        assert!(close(b[0], 0.6, 1e-12) && close(b[1], 0.8, 1e-12), "{b:?}");
    }

    #[test]
    fn driving_a_circle_feels_omega_times_v() {
        // At the centre, 0.5 m/s forward while turning 1 rad/s, steady: a_y = ω·vx = 0.5.
        let (_, a) = ideal_reading(&Pose::default(), &Twist::new(0.5, 0.0, 1.0), &Twist::default());
        assert!(close(a[0], 0.0, 1e-12) && close(a[1], 0.5, 1e-12), "{a:?}");
        // Braking straight at 2 m/s²: −2 on x.
        let (_, a) = ideal_reading(
            &Pose::default(),
            &Twist::new(1.0, 0.0, 0.0),
            &Twist::new(-2.0, 0.0, 0.0),
        );
        assert_eq!(a[0], -2.0);
    }

    #[test]
    fn device_errors_stay_within_the_datasheet_bounds_and_are_seeded() {
        let p = ImuParams::LSM6DSO;
        let a = Imu::new(p, Pose::default(), 7, 100);
        let b = Imu::new(p, Pose::default(), 7, 100);
        let c = Imu::new(p, Pose::default(), 8, 100);
        assert_eq!(a.gyro_offset(), b.gyro_offset());
        assert_ne!(a.gyro_offset(), c.gyro_offset());
        for k in 0..50 {
            let d = Imu::new(p, Pose::default(), k, 100);
            let (gg, ag) = d.gains();
            for i in 0..3 {
                assert!(d.gyro_offset()[i].abs() <= 1.0 * DEG);
                assert!(d.accel_offset()[i].abs() <= 0.020 * G);
                assert!((gg[i] - 1.0).abs() <= 0.01 && (ag[i] - 1.0).abs() <= 0.01);
            }
        }
    }

    #[test]
    fn noise_has_the_density_times_root_half_odr() {
        // 104 Hz: σ_gyro = 3.8 mdps·√52 = 27.4 mdps = 4.78e-4 rad/s; σ_accel = 70 µg·√52 =
        // 0.505 mg = 4.95e-3 m/s². n = 20 000 samples: the sample σ is within 1 % (5 SE).
        let p = ImuParams::LSM6DSO;
        assert!(close(p.gyro_sigma(104.0), 4.783e-4, 1e-6), "{}", p.gyro_sigma(104.0));
        assert!(close(p.accel_sigma(104.0), 4.950e-3, 1e-5), "{}", p.accel_sigma(104.0));
        let mut imu = Imu::new(p, Pose::default(), 1, 10);
        let t = Twist::new(0.0, 0.0, 1.0);
        let e = imu.expected(&t, &Twist::default());
        let n = 20_000;
        let (mut sg, mut sa) = (0.0, 0.0);
        for _ in 0..n {
            let r = imu.measure(&t, &Twist::default(), 104.0);
            sg += (r.gyro[2] - e.gyro[2]).powi(2);
            sa += (r.accel[0] - e.accel[0]).powi(2);
        }
        let (sg, sa) = ((sg / n as f64).sqrt(), (sa / n as f64).sqrt());
        assert!(close(sg / p.gyro_sigma(104.0), 1.0, 0.025), "{sg}");
        assert!(close(sa / p.accel_sigma(104.0), 1.0, 0.025), "{sa}");
    }

    #[test]
    fn expected_applies_gain_then_offset() {
        let imu = Imu::new(ImuParams::LSM6DSO, Pose::default(), 3, 0);
        let e = imu.expected(&Twist::new(0.0, 0.0, 2.0), &Twist::default());
        let (gg, ag) = imu.gains();
        assert_eq!(e.gyro[2], gg[2] * 2.0 + imu.gyro_offset()[2]);
        assert_eq!(e.accel[2], ag[2] * G + imu.accel_offset()[2]);
        assert_eq!(e.gyro[0], imu.gyro_offset()[0]);
    }
}
