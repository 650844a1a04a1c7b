//! Wheeled-base kinematics: three (or more) omni wheels, or a differential drive.
//!
//! Every wheel touches the floor at a point p (base frame) and drives along a unit vector u
//! (the direction its rim moves for positive wheel speed); without slip its angular speed for
//! a body twist (vx, vy, ωz) is
//!
//! ```text
//! ω_wheel = (u · v(p)) / r = (ux·vx + uy·vy + (p × u)·ωz) / r
//! ```
//!
//! - Omni (Triskar2): wheel k at angle αk on a circle of radius L, driving tangentially
//!   (u = (−sin αk, cos αk), positive = counter-clockwise about the centre), so
//!   ω = (−sin αk·vx + cos αk·vy + L·ωz)/r. Its rollers let it slide freely along p, so the
//!   base has 3 degrees of freedom (vx, vy, ωz).
//! - Differential: left wheel at (0, +W/2), right at (0, −W/2), both driving +x:
//!   ω = (vx ∓ ωz·W/2)/r. The wheels forbid sideways motion: 2 degrees of freedom (vx, ωz).
//!
//! Inverse kinematics is that formula; forward kinematics is its least-squares inverse,
//! exact for three omni wheels and for the differential drive (square, invertible), the best
//! fit for more omni wheels (odometry from redundant wheels).

use crate::geometry::{Twist, Vec2};
use crate::linalg::{self, Mat3};

/// Wheel arrangement of a base.
#[derive(Clone, Debug, PartialEq)]
pub enum Layout {
    /// Omni wheels on a circle, driving tangentially.
    Omni {
        /// Wheel radius r, m.
        wheel_radius: f64,
        /// Distance L from the base centre to each wheel's contact point, m.
        wheel_distance: f64,
        /// Angle αk of each wheel from the base's +x axis, rad (at least 3, not all on a line).
        angles: Vec<f64>,
    },
    /// Two wheels on a common axle.
    Differential {
        /// Wheel radius r, m.
        wheel_radius: f64,
        /// Distance W between the wheels' contact points, m.
        track: f64,
    },
}

/// Where a wheel touches the floor and which way it drives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelGeometry {
    /// Contact point in the base frame.
    pub position: Vec2,
    /// Unit drive direction in the base frame.
    pub drive: Vec2,
}

/// A base's kinematics.
#[derive(Clone, Debug, PartialEq)]
pub struct Kinematics {
    layout: Layout,
    wheels: Vec<WheelGeometry>,
    radius: f64,
    /// Degrees of freedom: 3 (vx, vy, ωz) or 2 (vx, ωz).
    dof: usize,
    /// Row k maps the generalised velocity q to wheel k's angular speed.
    rows: Vec<[f64; 3]>,
    /// (AᵀA)⁻¹: forward kinematics is (AᵀA)⁻¹Aᵀω.
    normal_inv: Mat3,
}

impl Kinematics {
    /// The kinematics of `layout`. Panics on a degenerate layout (fewer than 3 omni wheels,
    /// or all on one line; non-positive dimensions): the robot file is validated first.
    pub fn new(layout: Layout) -> Self {
        let (radius, wheels, dof) = match &layout {
            Layout::Omni { wheel_radius, wheel_distance, angles } => {
                assert!(angles.len() >= 3, "an omni base needs at least 3 wheels");
                let w = angles
                    .iter()
                    .map(|&a| WheelGeometry {
                        position: Vec2::from_angle(a) * *wheel_distance,
                        drive: Vec2::new(-a.sin(), a.cos()),
                    })
                    .collect();
                (*wheel_radius, w, 3)
            }
            Layout::Differential { wheel_radius, track } => {
                let w = [1.0, -1.0]
                    .map(|s| WheelGeometry {
                        position: Vec2::new(0.0, s * track / 2.0),
                        drive: Vec2::new(1.0, 0.0),
                    })
                    .to_vec();
                (*wheel_radius, w, 2)
            }
        };
        assert!(radius > 0.0, "wheel radius must be positive");
        let rows: Vec<[f64; 3]> = wheels
            .iter()
            .map(|w| {
                let full = [w.drive.x, w.drive.y, w.position.cross(w.drive)].map(|c| c / radius);
                if dof == 3 {
                    full
                } else {
                    [full[0], full[2], 0.0]
                }
            })
            .collect();
        let mut normal = [[0.0; 3]; 3];
        for r in &rows {
            for i in 0..dof {
                for j in 0..dof {
                    normal[i][j] += r[i] * r[j];
                }
            }
        }
        let normal_inv = linalg::inverse(&normal, dof);
        Self { layout, wheels, radius, dof, rows, normal_inv }
    }

    /// The layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Number of wheels.
    pub fn wheel_count(&self) -> usize {
        self.wheels.len()
    }

    /// The wheels' contact points and drive directions.
    pub fn wheels(&self) -> &[WheelGeometry] {
        &self.wheels
    }

    /// Wheel radius, m.
    pub fn wheel_radius(&self) -> f64 {
        self.radius
    }

    /// Degrees of freedom of the base (3 omni, 2 differential).
    pub fn dof(&self) -> usize {
        self.dof
    }

    /// Row `k` of the Jacobian: wheel k's angular speed per unit of each generalised velocity.
    pub fn row(&self, k: usize) -> [f64; 3] {
        self.rows[k]
    }

    /// Wheel `k`'s angular speed (rad/s) at generalised velocity `q` (or its angular
    /// acceleration at generalised acceleration `q`).
    pub fn wheel_rate(&self, k: usize, q: &[f64; 3]) -> f64 {
        let a = &self.rows[k];
        a[0] * q[0] + a[1] * q[1] + a[2] * q[2]
    }

    /// The body twist of generalised velocity `q`.
    pub fn twist(&self, q: &[f64; 3]) -> Twist {
        if self.dof == 3 {
            Twist::new(q[0], q[1], q[2])
        } else {
            Twist::new(q[0], 0.0, q[1])
        }
    }

    /// The generalised velocity of twist `t` (a differential drive drops vy).
    pub fn generalised(&self, t: &Twist) -> [f64; 3] {
        if self.dof == 3 {
            [t.vx, t.vy, t.wz]
        } else {
            [t.vx, t.wz, 0.0]
        }
    }

    /// Inverse kinematics: wheel angular speeds (rad/s) for body twist `t`. A differential
    /// drive cannot move sideways: its `vy` is ignored.
    pub fn inverse(&self, t: &Twist) -> Vec<f64> {
        let q = self.generalised(t);
        self.rows.iter().map(|r| r[0] * q[0] + r[1] * q[1] + r[2] * q[2]).collect()
    }

    /// Forward kinematics: the body twist (least squares) from wheel angular speeds (rad/s).
    pub fn forward(&self, wheel_speeds: &[f64]) -> Twist {
        assert_eq!(wheel_speeds.len(), self.rows.len(), "one speed per wheel");
        let mut atw = [0.0; 3];
        for (r, w) in self.rows.iter().zip(wheel_speeds) {
            for i in 0..self.dof {
                atw[i] += r[i] * w;
            }
        }
        let mut q = [0.0; 3];
        for (qi, inv) in q.iter_mut().zip(&self.normal_inv).take(self.dof) {
            *qi = inv.iter().zip(&atw).take(self.dof).map(|(m, a)| m * a).sum();
        }
        self.twist(&q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn triskar() -> Kinematics {
        Kinematics::new(Layout::Omni {
            wheel_radius: 0.05,
            wheel_distance: 0.25,
            angles: [60.0f64, 180.0, 300.0].map(f64::to_radians).to_vec(),
        })
    }

    fn diff() -> Kinematics {
        Kinematics::new(Layout::Differential { wheel_radius: 0.05, track: 0.4 })
    }

    #[test]
    fn omni_wheel_speeds_by_hand() {
        let k = triskar();
        // Spinning at 1 rad/s: every rim moves at L·ω = 0.25 m/s → 5 rad/s.
        for w in k.inverse(&Twist::new(0.0, 0.0, 1.0)) {
            assert!((w - 5.0).abs() < 1e-12);
        }
        // Forward at 1 m/s: wheel at 60° turns −sin 60°/r, at 180° not at all.
        let w = k.inverse(&Twist::new(1.0, 0.0, 0.0));
        assert!((w[0] + 3f64.sqrt() / 2.0 / 0.05).abs() < 1e-12);
        assert!(w[1].abs() < 1e-12);
        assert!((w[2] - 3f64.sqrt() / 2.0 / 0.05).abs() < 1e-12);
    }

    #[test]
    fn differential_by_hand() {
        let k = diff();
        let w = k.inverse(&Twist::new(1.0, 0.0, 2.0));
        // Left rim 1 − 2·0.2 = 0.6 m/s, right 1.4 m/s.
        assert!((w[0] - 12.0).abs() < 1e-12 && (w[1] - 28.0).abs() < 1e-12, "{w:?}");
        let t = k.forward(&w);
        assert!((t.vx - 1.0).abs() < 1e-12 && (t.wz - 2.0).abs() < 1e-12 && t.vy == 0.0);
    }

    #[test]
    fn four_omni_wheels_least_squares() {
        let k = Kinematics::new(Layout::Omni {
            wheel_radius: 0.04,
            wheel_distance: 0.2,
            angles: [45.0f64, 135.0, 225.0, 315.0].map(f64::to_radians).to_vec(),
        });
        let t = Twist::new(0.3, -0.2, 0.5);
        let back = k.forward(&k.inverse(&t));
        assert!((back.vx - t.vx).abs() < 1e-12 && (back.vy - t.vy).abs() < 1e-12);
        assert!((back.wz - t.wz).abs() < 1e-12);
    }

    proptest! {
        /// FK∘IK = identity on twists; IK∘FK = identity on wheel speeds (square layouts).
        #[test]
        fn round_trips(vx in -2.0f64..2.0, vy in -2.0f64..2.0, wz in -6.0f64..6.0,
                       w in proptest::array::uniform3(-50.0f64..50.0)) {
            let k = triskar();
            let t = Twist::new(vx, vy, wz);
            let back = k.forward(&k.inverse(&t));
            prop_assert!((back.vx - vx).abs() < 1e-12 && (back.vy - vy).abs() < 1e-12);
            prop_assert!((back.wz - wz).abs() < 1e-12);
            let ws = k.inverse(&k.forward(&w));
            for i in 0..3 {
                prop_assert!((ws[i] - w[i]).abs() < 1e-11, "{ws:?} vs {w:?}");
            }
            let d = diff();
            let ws = d.inverse(&d.forward(&w[..2]));
            prop_assert!((ws[0] - w[0]).abs() < 1e-11 && (ws[1] - w[1]).abs() < 1e-11);
        }
    }
}
