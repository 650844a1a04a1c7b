//! Roll, pitch and heading from the bias-corrected gyro and the accelerometer: the module's
//! filter until issue 21, replaced by [`crate::ahrs`] (quaternion, magnetometer, bias tracked).
//! Kept for its helpers ([`wrap`], [`tilt`]) and as `make bench`'s baseline for the new filter's
//! cost (firmware/targets/qemu/src/bin/fusion.rs); the images do not link [`Attitude`].
//!
//! **Propagation**: the Euler angles (roll φ, pitch θ, yaw ψ; z-y-x, as ROS's `rpy`) follow
//! the body rates (p, q, r) by the Euler kinematic equations
//!
//! ```text
//! φ̇ = p + tan θ · (q sin φ + r cos φ)     θ̇ = q cos φ − r sin φ     ψ̇ = (q sin φ + r cos φ) / cos θ
//! ```
//!
//! so that on a flat floor the heading rate is exactly the z rate, counter-clockwise positive
//! (rad), and a tilted mount still integrates the heading about the vertical.
//!
//! **Correction (complementary filter)**: at rest the accelerometer measures the specific
//! force +g along the vertical, so φₐ = atan2(a_y, a_z) and θₐ = atan2(−a_x, √(a_y² + a_z²)).
//! Each sample moves roll and pitch a fraction dt/(τ + dt) towards those: the gyro is trusted
//! on time scales below τ, the accelerometer above it. Only while |a| is within `accel_gate`
//! of g: a base braking hard tilts the measured vertical, and the gyro carries the angles
//! through it. Turning off-centre or driving a curve also tilts it (centripetal acceleration,
//! which no gate sees at moderate speeds): the filter's τ smooths it, it cannot remove it.
//! The heading has no absolute reference (no magnetometer on the module): it drifts with the
//! residual bias.

use core::f32::consts::PI;

use libm::{atan2f, sqrtf};
// r2p-module's f32-only sine, cosine and tangent: libm's compute in f64, which brings 2.3 KB of
// range reduction and 2.5 KB of double soft float into the image (7.6 KB in all, measured).
use r2p_module::trig::{cosf, sinf, tanf};

/// Standard gravity, m/s² (as the driver's).
pub const G: f32 = r2p_drivers::lsm6dso::G;

/// The attitude estimate, rad.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Attitude {
    /// About x.
    pub roll: f32,
    /// About y.
    pub pitch: f32,
    /// About z, wrapped to (−π, π].
    pub yaw: f32,
}

/// `a` wrapped to (−π, π].
pub fn wrap(a: f32) -> f32 {
    let mut a = a % (2.0 * PI);
    if a > PI {
        a -= 2.0 * PI;
    } else if a <= -PI {
        a += 2.0 * PI;
    }
    a
}

/// Roll and pitch of the measured vertical (specific force `accel`, m/s²).
pub fn tilt(accel: [f32; 3]) -> (f32, f32) {
    let [ax, ay, az] = accel;
    (atan2f(ay, az), atan2f(-ax, sqrtf(ay * ay + az * az)))
}

impl Attitude {
    /// Level with the measured vertical, heading 0.
    pub fn levelled(accel: [f32; 3]) -> Self {
        let (roll, pitch) = tilt(accel);
        Attitude { roll, pitch, yaw: 0.0 }
    }

    /// Advances by `dt` s with body rates `rate` (rad/s) and specific force `accel` (m/s²),
    /// correcting roll and pitch with time constant `tau` s while |a| is within `gate`·g.
    pub fn update(&mut self, rate: [f32; 3], accel: [f32; 3], dt: f32, tau: f32, gate: f32) {
        let [p, q, r] = rate;
        let (sr, cr) = (sinf(self.roll), cosf(self.roll));
        let cp = cosf(self.pitch).max(1e-3); // gimbal lock at ±90° pitch: not a mobile base's
        let yaw_rate = q * sr + r * cr;
        self.roll = wrap(self.roll + (p + tanf(self.pitch) * yaw_rate) * dt);
        self.pitch += (q * cr - r * sr) * dt;
        self.yaw = wrap(self.yaw + yaw_rate / cp * dt);
        let [ax, ay, az] = accel;
        let norm = sqrtf(ax * ax + ay * ay + az * az);
        if (norm - G).abs() <= gate * G {
            let k = dt / (tau + dt);
            let (ra, pa) = tilt(accel);
            self.roll = wrap(self.roll + k * wrap(ra - self.roll));
            self.pitch += k * (pa - self.pitch);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const UP: [f32; 3] = [0.0, 0.0, G];

    #[test]
    fn a_z_rate_turns_the_heading_counter_clockwise_in_radians() {
        let mut a = Attitude::levelled(UP);
        // 0.5 rad/s for 1 s in 100 steps: +0.5 rad.
        for _ in 0..100 {
            a.update([0.0, 0.0, 0.5], UP, 0.01, 2.0, 0.1);
        }
        assert!((a.yaw - 0.5).abs() < 1e-5, "{}", a.yaw);
        assert!(a.roll.abs() < 1e-6 && a.pitch.abs() < 1e-6);
        // Clockwise, 4 s at −1 rad/s: 0.5 − 4 = −3.5 rad, wrapped to 2.783 rad.
        for _ in 0..400 {
            a.update([0.0, 0.0, -1.0], UP, 0.01, 2.0, 0.1);
        }
        assert!((a.yaw - (-3.5 + 2.0 * PI)).abs() < 1e-4, "{}", a.yaw);
    }

    #[test]
    fn wrap_keeps_the_half_open_interval() {
        assert_eq!(wrap(PI), PI);
        assert!((wrap(-PI) - PI).abs() < 1e-6);
        assert!((wrap(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-6);
        assert!((wrap(-7.0) - (-7.0 + 2.0 * PI)).abs() < 1e-6);
        assert_eq!(wrap(0.25), 0.25);
    }

    #[test]
    fn the_accelerometer_gives_roll_and_pitch_with_their_signs() {
        // Rolled right-side down by 10°: gravity's reaction leans towards +y.
        let r = 10f32.to_radians();
        let (roll, pitch) = tilt([0.0, G * sinf(r), G * cosf(r)]);
        assert!((roll - r).abs() < 1e-6 && pitch.abs() < 1e-6, "{roll} {pitch}");
        // Pitched +10° (about y, which points left: nose down): the reaction leans to −x.
        let (roll, pitch) = tilt([-G * sinf(r), 0.0, G * cosf(r)]);
        assert!(roll.abs() < 1e-6 && (pitch - r).abs() < 1e-6, "{roll} {pitch}");
    }

    #[test]
    fn the_filter_converges_to_the_accelerometer_with_its_time_constant() {
        // Start level, the sensor actually at 10° roll, no rotation: after τ the estimate has
        // covered 1 − 1/e of the way (discrete: (1 − k)^n with k = dt/(τ + dt)).
        let r = 10f32.to_radians();
        let acc = [0.0, G * sinf(r), G * cosf(r)];
        let mut a = Attitude::default();
        for _ in 0..200 {
            a.update([0.0; 3], acc, 0.01, 2.0, 0.1);
        }
        let want = r * (1.0 - (1.0 - 0.01 / 2.01f32).powi(200));
        assert!((a.roll - want).abs() < 1e-5, "{} vs {want}", a.roll);
        assert!((a.roll - r * (1.0 - (-1f32).exp())).abs() < 0.01 * r);
    }

    #[test]
    fn the_gate_keeps_a_braking_base_level() {
        // Braking at 3 m/s² (|a| = 1.05 g): a 0.1 g gate still corrects, 0.02 g does not.
        let acc = [-3.0, 0.0, G];
        let mut a = Attitude::default();
        a.update([0.0; 3], acc, 0.01, 0.1, 0.1);
        assert!(a.pitch > 0.002, "{}", a.pitch);
        let mut b = Attitude::default();
        b.update([0.0; 3], acc, 0.01, 0.1, 0.02);
        assert_eq!(b.pitch, 0.0);
    }

    #[test]
    fn a_rolled_mount_still_integrates_the_heading_about_the_vertical() {
        // Rolled by 30°, the base turning at 1 rad/s about the vertical: the sensor's y and z
        // see the rate split (q = sin 30°, r = cos 30°); the heading still turns 1 rad/s.
        let r = 30f32.to_radians();
        let mut a = Attitude { roll: r, pitch: 0.0, yaw: 0.0 };
        let acc = [0.0, G * sinf(r), G * cosf(r)];
        for _ in 0..100 {
            a.update([0.0, sinf(r), cosf(r)], acc, 0.01, 2.0, 0.1);
        }
        assert!((a.yaw - 1.0).abs() < 1e-4, "{}", a.yaw);
        assert!((a.roll - r).abs() < 1e-4, "{}", a.roll);
    }
}
