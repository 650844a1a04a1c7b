//! Kinematics of a three-wheel omnidirectional base (Triskar2).
//!
//! Wheel `i` sits at angle `αᵢ = α₀ + i·120°` from the base's x axis (forward), at distance `R`
//! from the centre, and drives tangentially (counter-clockwise positive). Its rim speed for a
//! base velocity (vx, vy, ωz) in the base frame is `vᵢ = −sin αᵢ·vx + cos αᵢ·vy + R·ωz`, and its
//! angular speed `vᵢ / r`. With the wheels 120° apart the 3×3 map has the closed-form inverse
//! `vx = −⅔ Σ sin αᵢ vᵢ`, `vy = ⅔ Σ cos αᵢ vᵢ`, `ωz = Σ vᵢ / 3R` (Σ sin² = Σ cos² = 3/2,
//! Σ sin·cos = Σ sin = Σ cos = 0).

use r2p_module::trig::{cosf, sinf};

/// Geometry of a three-wheel omni base.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Omni3 {
    /// Wheel radius r, m.
    pub wheel_radius: f32,
    /// Distance R from the centre to each wheel's contact point, m.
    pub base_radius: f32,
    /// Angle α₀ of wheel 0 from the x axis, rad.
    pub first_wheel: f32,
}

impl Omni3 {
    fn angle(&self, i: usize) -> f32 {
        self.first_wheel + i as f32 * (2.0 * core::f32::consts::PI / 3.0)
    }

    /// Wheel angular speeds (rad/s) for a base velocity (m/s, m/s, rad/s).
    pub fn inverse(&self, vx: f32, vy: f32, wz: f32) -> [f32; 3] {
        core::array::from_fn(|i| {
            let a = self.angle(i);
            (-sinf(a) * vx + cosf(a) * vy + self.base_radius * wz) / self.wheel_radius
        })
    }

    /// Base velocity (vx, vy, ωz) for wheel angular speeds (rad/s).
    pub fn forward(&self, wheels: [f32; 3]) -> (f32, f32, f32) {
        let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
        for (i, w) in wheels.iter().enumerate() {
            let v = w * self.wheel_radius;
            let a = self.angle(i);
            sx += sinf(a) * v;
            sy += cosf(a) * v;
            sw += v;
        }
        (-2.0 / 3.0 * sx, 2.0 / 3.0 * sy, sw / (3.0 * self.base_radius))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRISKAR: Omni3 =
        Omni3 { wheel_radius: 0.06, base_radius: 0.25, first_wheel: core::f32::consts::FRAC_PI_6 };

    #[test]
    fn forward_undoes_inverse() {
        for (vx, vy, wz) in [(1.0, 0.0, 0.0), (0.0, -0.7, 0.0), (0.3, 0.4, 1.5), (-2.0, 1.0, -3.0)]
        {
            let (x, y, w) = TRISKAR.forward(TRISKAR.inverse(vx, vy, wz));
            assert!((x - vx).abs() < 1e-5 && (y - vy).abs() < 1e-5 && (w - wz).abs() < 1e-5);
        }
    }

    #[test]
    fn pure_rotation_turns_every_wheel_alike() {
        let w = TRISKAR.inverse(0.0, 0.0, 1.0);
        for s in w {
            assert!((s - 0.25 / 0.06).abs() < 1e-5, "{w:?}");
        }
    }

    #[test]
    fn straight_ahead_leaves_the_wheel_on_the_axis_still() {
        // A wheel at α = 0 drives along y: forward motion does not turn it.
        let g = Omni3 { first_wheel: 0.0, ..TRISKAR };
        let w = g.inverse(1.0, 0.0, 0.0);
        assert!(w[0].abs() < 1e-6);
        assert!((w[1] + w[2]).abs() < 1e-5, "the other two turn opposite: {w:?}");
    }
}
