//! Rigid-base dynamics: how the wheels' torques move the base, and the load the base puts
//! back on each wheel.
//!
//! Model (a lumped rigid body, no slip): the base is one rigid body of mass m and yaw inertia
//! I about its centre, centre of mass at the centre, riding on the wheels. Newton–Euler in
//! the body frame with the wheels' traction forces as constraint forces gives, in the
//! generalised velocity q (see [`Kinematics`]):
//!
//! ```text
//! (M + Σk Jk·ak·akᵀ) q̇ = Σk ak·τk + c(q) + Q_roll(q)
//! ```
//!
//! where M = diag(m, m, I) (omni) or diag(m, I) (differential), ak is wheel k's Jacobian row
//! (wheel speed = ak·q), Jk the inertia turning with wheel k referred to the wheel (wheel +
//! gearbox-reflected rotor, N²·Jrotor), τk the torque the drive train applies to wheel k, and
//! c(q) = (m·ωz·vy, −m·ωz·vx, 0) the body-frame Coriolis term of the base's own mass (the
//! wheels' spin adds none in the plane). Rolling resistance acts at each contact point
//! against its velocity, Crr·m·g/n per wheel (equal load sharing), smoothed over a few mm/s
//! so it does not chatter at rest. The load torque a wheel sees is what is left of its drive
//! torque after accelerating its own inertia: the share of base inertia, Coriolis and
//! rolling resistance it carries.
//!
//! Not modelled: wheel slip, weight transfer under acceleration, roller friction of omni
//! wheels beyond rolling resistance, casters of a differential base (they carry no load
//! here), collisions.

use crate::geometry::Twist;
use crate::kinematics::Kinematics;
use crate::linalg::{self, Mat3};

/// Standard gravity, m/s².
pub const G: f64 = 9.806_65;

/// Mass properties and floor contact of a base.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaseParams {
    /// Mass m, kg.
    pub mass_kg: f64,
    /// Yaw inertia I about the centre, kg·m².
    pub inertia_kg_m2: f64,
    /// Rolling-resistance coefficient Crr.
    pub rolling_resistance: f64,
    /// Contact speed over which rolling resistance builds up, m/s.
    pub rolling_smoothing: f64,
}

/// A base's dynamics on a given wheel layout.
#[derive(Clone, Debug, PartialEq)]
pub struct Base {
    /// Its parameters.
    pub params: BaseParams,
    /// Body mass matrix in generalised coordinates.
    mass: Mat3,
}

/// One sub-step's solution.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Acceleration {
    /// Generalised acceleration q̇ (each wheel's angular acceleration is
    /// [`Kinematics::wheel_rate`] of it).
    pub q_dot: [f64; 3],
    /// Power lost to rolling resistance, W (≥ 0).
    pub rolling_loss: f64,
}

impl Base {
    /// The dynamics of `params` on `kin`'s layout.
    pub fn new(params: BaseParams, kin: &Kinematics) -> Self {
        let mut mass = [[0.0; 3]; 3];
        if kin.dof() == 3 {
            mass[0][0] = params.mass_kg;
            mass[1][1] = params.mass_kg;
            mass[2][2] = params.inertia_kg_m2;
        } else {
            mass[0][0] = params.mass_kg;
            mass[1][1] = params.inertia_kg_m2;
        }
        Self { params, mass }
    }

    /// Kinetic energy of the base body (not its wheels) at generalised velocity `q`, J.
    pub fn kinetic_energy(&self, q: &[f64; 3]) -> f64 {
        (0..3).map(|i| (0..3).map(|j| 0.5 * q[i] * self.mass[i][j] * q[j]).sum::<f64>()).sum()
    }

    /// Body wrench (fx, fy, τz) as a generalised force.
    fn generalised(kin: &Kinematics, fx: f64, fy: f64, tz: f64) -> [f64; 3] {
        if kin.dof() == 3 {
            [fx, fy, tz]
        } else {
            [fx, tz, 0.0]
        }
    }

    /// Rolling resistance as a generalised force, and the power it dissipates.
    fn rolling(&self, kin: &Kinematics, t: &Twist) -> ([f64; 3], f64) {
        let p = &self.params;
        let n = kin.wheel_count() as f64;
        let per_wheel = p.rolling_resistance * p.mass_kg * G / n;
        let (mut f, mut loss) = ([0.0; 3], 0.0);
        for w in kin.wheels() {
            let v = t.point_velocity(w.position);
            let speed2 = v.dot(v);
            // F = −μN·v/√(|v|² + vs²): the sign of v, smoothed over vs.
            let k = per_wheel / (speed2 + p.rolling_smoothing * p.rolling_smoothing).sqrt();
            let force = v * -k;
            let g = Self::generalised(kin, force.x, force.y, w.position.cross(force));
            for (fi, gi) in f.iter_mut().zip(g) {
                *fi += gi;
            }
            loss += k * speed2;
        }
        (f, loss)
    }

    /// Solves the dynamics at generalised velocity `q` with torques `wheel_torques` (N·m,
    /// at each wheel) and inertias `wheel_inertias` (kg·m², turning with each wheel).
    pub fn accelerate(
        &self,
        kin: &Kinematics,
        q: &[f64; 3],
        wheel_torques: &[f64],
        wheel_inertias: &[f64],
    ) -> Acceleration {
        let (rhs, rolling_loss) = self.forces(kin, q, wheel_torques);
        let lhs = self.mass_matrix(kin, wheel_inertias);
        Acceleration { q_dot: linalg::solve(&lhs, &rhs, kin.dof()), rolling_loss }
    }

    /// The total mass matrix M + Σ Jk·ak·akᵀ for inertias `wheel_inertias` turning with the
    /// wheels (it changes only with them: the world keeps its inverses).
    pub(crate) fn mass_matrix(&self, kin: &Kinematics, wheel_inertias: &[f64]) -> Mat3 {
        let n = kin.dof();
        let mut lhs = self.mass;
        for (k, &j) in wheel_inertias.iter().enumerate() {
            let a = kin.row(k);
            for r in 0..n {
                for c in 0..n {
                    lhs[r][c] += j * a[r] * a[c];
                }
            }
        }
        lhs
    }

    /// The generalised force at `q` with `wheel_torques`: wheels, Coriolis, rolling
    /// resistance; and the rolling loss, W.
    pub(crate) fn forces(
        &self,
        kin: &Kinematics,
        q: &[f64; 3],
        wheel_torques: &[f64],
    ) -> ([f64; 3], f64) {
        let n = kin.dof();
        let t = kin.twist(q);
        let m = self.params.mass_kg;
        let mut rhs = Self::generalised(kin, m * t.wz * t.vy, -m * t.wz * t.vx, 0.0);
        let (roll, rolling_loss) = self.rolling(kin, &t);
        for i in 0..n {
            rhs[i] += roll[i];
        }
        for (k, &tau) in wheel_torques.iter().enumerate() {
            let a = kin.row(k);
            for r in 0..n {
                rhs[r] += a[r] * tau;
            }
        }
        (rhs, rolling_loss)
    }

    /// The inertia the base presents at the wheels, kg·m²: the matrix Mw with
    /// Σ τ = Mw·ω̇wheels for a base at rest (square layouts: three omni wheels or a
    /// differential drive). Its diagonal is what one wheel feels when the others hold still.
    pub fn wheel_space_inertia(&self, kin: &Kinematics) -> Vec<Vec<f64>> {
        let n = kin.dof();
        assert_eq!(kin.wheel_count(), n, "wheel-space inertia needs a square layout");
        // A (n×n) with rows ak; Mw = A⁻ᵀ M A⁻¹.
        let mut a = [[0.0; 3]; 3];
        for (k, row) in a.iter_mut().enumerate().take(n) {
            *row = kin.row(k);
        }
        let ai = linalg::inverse(&a, n);
        let mut out = vec![vec![0.0; n]; n];
        for (i, row) in out.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..n)
                    .flat_map(|p| (0..n).map(move |q| (p, q)))
                    .map(|(p, q)| ai[p][i] * self.mass[p][q] * ai[q][j])
                    .sum();
            }
        }
        out
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops read like the formulas
mod tests {
    use super::*;
    use crate::kinematics::Layout;

    const R: f64 = 0.05;
    const L: f64 = 0.25;

    fn triskar() -> Kinematics {
        Kinematics::new(Layout::Omni {
            wheel_radius: R,
            wheel_distance: L,
            angles: [60.0f64, 180.0, 300.0].map(f64::to_radians).to_vec(),
        })
    }

    fn frictionless(m: f64, i: f64) -> BaseParams {
        BaseParams {
            mass_kg: m,
            inertia_kg_m2: i,
            rolling_resistance: 0.0,
            rolling_smoothing: 0.005,
        }
    }

    #[test]
    fn equal_torques_spin_the_base() {
        // τ at each wheel: torque about the centre 3·L·τ/r, inertia I + 3·J·(L/r)².
        let k = triskar();
        let b = Base::new(frictionless(20.0, 0.9), &k);
        let j = 2e-3;
        let acc = b.accelerate(&k, &[0.0; 3], &[0.1; 3], &[j; 3]);
        let expect = 3.0 * L * 0.1 / R / (0.9 + 3.0 * j * (L / R).powi(2));
        assert!(acc.q_dot[0].abs() < 1e-12 && acc.q_dot[1].abs() < 1e-12);
        assert!((acc.q_dot[2] - expect).abs() < 1e-12, "{:?} vs {expect}", acc.q_dot);
        for w in 0..3 {
            assert!((k.wheel_rate(w, &acc.q_dot) - expect * L / R).abs() < 1e-9);
        }
    }

    #[test]
    fn force_along_x_accelerates_effective_mass() {
        // Wheel torques giving a pure generalised force (F, 0, 0) = Aᵀτ: τ = A⁻ᵀ(F, 0, 0).
        // Effective mass m + J·Σ(sin²αk)/r² = m + 1.5·J/r².
        let k = triskar();
        let b = Base::new(frictionless(20.0, 0.9), &k);
        let f = 10.0;
        let mut a = [[0.0; 3]; 3];
        for (i, row) in a.iter_mut().enumerate() {
            *row = k.row(i);
        }
        // Solve Aᵀτ = (F, 0, 0).
        let mut at = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                at[i][j] = a[j][i];
            }
        }
        let tau = linalg::solve(&at, &[f, 0.0, 0.0], 3);
        let j = 2e-3;
        let acc = b.accelerate(&k, &[0.0; 3], &tau, &[j; 3]);
        let expect = f / (20.0 + 1.5 * j / (R * R));
        assert!((acc.q_dot[0] - expect).abs() < 1e-12, "{:?}", acc.q_dot);
        assert!(acc.q_dot[1].abs() < 1e-12 && acc.q_dot[2].abs() < 1e-12);
    }

    #[test]
    fn rolling_resistance_opposes_motion_with_mu_m_g() {
        // Moving at 1 m/s (≫ smoothing): total drag Crr·m·g, along −x; no torque by symmetry.
        let k = triskar();
        let p = BaseParams { rolling_resistance: 0.02, ..frictionless(20.0, 0.9) };
        let b = Base::new(p, &k);
        let acc = b.accelerate(&k, &[1.0, 0.0, 0.0], &[0.0; 3], &[0.0; 3]);
        let drag = 0.02 * 20.0 * G / (1.0f64 + 0.005 * 0.005).sqrt();
        assert!((acc.q_dot[0] + drag / 20.0).abs() < 1e-12, "{:?}", acc.q_dot);
        assert!((acc.rolling_loss - drag * 1.0).abs() < 1e-9);
        assert!(acc.q_dot[2].abs() < 1e-12);
    }

    #[test]
    fn coriolis_rotates_body_velocity_and_keeps_energy() {
        // Coasting: a base translating while spinning keeps its world velocity (no wheel
        // inertia): in the body frame v̇ = −ωz × v. Integrate with small steps and compare.
        let k = triskar();
        let b = Base::new(frictionless(20.0, 0.9), &k);
        let (mut q, h, wz): ([f64; 3], f64, f64) = ([1.0, 0.0, 2.0], 1e-5, 2.0);
        let e0 = b.kinetic_energy(&q);
        let n = 100_000; // 1 s
        for _ in 0..n {
            let a = b.accelerate(&k, &q, &[0.0; 3], &[0.0; 3]);
            for i in 0..3 {
                q[i] += h * a.q_dot[i];
            }
        }
        // Body velocity after 1 s: (cos 2, −sin 2) (the world velocity, seen from a body that
        // turned 2 rad). Explicit rotation grows |v| by (1 + (hω)²)^(n/2) − 1 ≈ n(hω)²/2
        // = 2e-5, and its phase error is O(n(hω)³); 4e-5 bounds both.
        let t: f64 = 1.0;
        assert!((q[0] - (wz * t).cos()).abs() < 4e-5 && (q[1] + (wz * t).sin()).abs() < 4e-5);
        // Energy: only the translational part (½m|v|² = 10 J of 11.8 J) grows, by
        // (1 + (hω)²)^n − 1 ≈ n(hω)² = 4e-5 of itself.
        let de = (b.kinetic_energy(&q) - e0) / e0;
        let growth = ((1.0 + (h * wz) * (h * wz)).powi(n) - 1.0) * 10.0 / e0;
        assert!((de - growth).abs() < 0.01 * growth, "{de} vs {growth}");
    }

    #[test]
    fn wheel_space_inertia_of_triskar() {
        // Mw = r²·[(4m/9)·cos(αi − αj) + I/(9L²)].
        let k = triskar();
        let (m, i) = (20.0, 0.9);
        let mw = Base::new(frictionless(m, i), &k).wheel_space_inertia(&k);
        let angles = [60.0f64, 180.0, 300.0].map(f64::to_radians);
        for a in 0..3 {
            for b in 0..3 {
                let e = R * R * (4.0 * m / 9.0 * (angles[a] - angles[b]).cos() + i / (9.0 * L * L));
                assert!((mw[a][b] - e).abs() < 1e-12, "{a}{b}: {} vs {e}", mw[a][b]);
            }
        }
    }

    #[test]
    fn differential_drive_torques() {
        // Equal torques: straight line, a = 2τ/r / (m + 2J/r²); opposite: spin,
        // α = 2τ·(W/2)/r / (I + 2J(W/2)²/r²).
        let k = Kinematics::new(Layout::Differential { wheel_radius: R, track: 0.4 });
        let b = Base::new(frictionless(10.0, 0.3), &k);
        let j = 1e-3;
        let acc = b.accelerate(&k, &[0.0; 3], &[0.2, 0.2], &[j, j]);
        assert!((acc.q_dot[0] - 2.0 * 0.2 / R / (10.0 + 2.0 * j / (R * R))).abs() < 1e-12);
        assert!(acc.q_dot[1].abs() < 1e-12);
        let acc = b.accelerate(&k, &[0.0; 3], &[-0.2, 0.2], &[j, j]);
        let expect = 2.0 * 0.2 * 0.2 / R / (0.3 + 2.0 * j * 0.04 / (R * R));
        assert!(acc.q_dot[0].abs() < 1e-12 && (acc.q_dot[1] - expect).abs() < 1e-12);
    }
}
