//! Brushed DC motor and its gearbox.
//!
//! Electrical: L di/dt = V − (R + Rs) i − Ke ω, with Rs the driver's switch resistance in the
//! current path. Mechanical: J dω/dt = Kt i − b ω − τc·s(ω) − τ_load, with Kt = Ke in SI units
//! and s(ω) = tanh(ω/ωs) a smoothed sign for the Coulomb (brush) friction, so that friction
//! does not chatter around standstill (ωs = 0.5 rad/s at the motor, 0.3 rpm at the wheel).
//!
//! Integrator: over a sub-step h the terminal voltage and ω are held, and the current follows
//! the exact solution of the linear electrical equation, i(h) = i∞ + (i(0) − i∞)·e^(−h/τe),
//! τe = L/(R + Rs). This exponential step is stable for any h, so the stiff electrical pole
//! (τe ≈ 0.19 ms for the RE 35, ~5000 s⁻¹) sets no step limit, and the charge ∫i dt and
//! ∫i² dt over the step are exact too (the energy books use them). ω then takes a
//! semi-implicit (symplectic) Euler step with the new current. The remaining coupling error
//! (ω held during the electrical step) is first order in h·λ, λ the slow electromechanical
//! pole: ~240 s⁻¹ for a free RE 35 rotor, ~20 s⁻¹ once the rotor drives the Triskar2 base
//! through its gearbox (the world's case). For the free rotor the scheme's two discrete poles
//! match the exact e^(λh) to 0.03 % at h = 50 µs and to 2 % at 1 ms (fast pole 4890 s⁻¹
//! included): no step the world uses comes near instability.

/// Electrical and mechanical constants of one motor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorParams {
    /// Name, as the robot file spells it.
    pub name: &'static str,
    /// Terminal resistance R, Ω.
    pub resistance_ohm: f64,
    /// Terminal inductance L, H.
    pub inductance_h: f64,
    /// Torque constant Kt, N·m/A (= back-EMF constant Ke, V·s/rad).
    pub torque_constant: f64,
    /// Rotor inertia J, kg·m².
    pub rotor_inertia: f64,
    /// Viscous friction b, N·m·s/rad.
    pub viscous_friction: f64,
    /// Coulomb friction τc, N·m.
    pub coulomb_friction: f64,
    /// Speed over which Coulomb friction builds up (the smoothing ωs), rad/s.
    pub coulomb_smoothing: f64,
}

/// No-load current of the RE 35 (24 V winding), A: friction torque at no-load speed is
/// Kt·I0, split half viscous and half Coulomb (the catalogue gives only the sum).
const RE35_NO_LOAD_A: f64 = 0.137;
const RE35_KT: f64 = 0.0302;
const RE35_R: f64 = 0.611;
/// No-load speed at 24 V, rad/s: (24 − R·I0)/Ke ≈ 792 rad/s (7560 rpm).
const RE35_NO_LOAD_RAD_S: f64 = (24.0 - RE35_R * RE35_NO_LOAD_A) / RE35_KT;

impl MotorParams {
    /// maxon RE 35 (∅35 mm, graphite brushes, 90 W class), 24 V winding — the paper's
    /// "70 W DC motors" at 24 V. From the maxon catalogue: R = 0.611 Ω, L = 0.119 mH,
    /// Kt = 30.2 mN·m/A (speed constant 316 rpm/V), rotor inertia 65.2 g·cm², no-load
    /// current 137 mA. (The 30 V winding's R 1.2 Ω, L 0.34 mH, Kt 38.9 mN·m/A scale to
    /// these by (Kt ratio)² within 15 %.) Check a current datasheet before relying on the
    /// third digit.
    pub const MAXON_RE35_24V: MotorParams = MotorParams {
        name: "maxon-re35-24v",
        resistance_ohm: RE35_R,
        inductance_h: 0.119e-3,
        torque_constant: RE35_KT,
        rotor_inertia: 65.2e-7,
        viscous_friction: RE35_KT * RE35_NO_LOAD_A / 2.0 / RE35_NO_LOAD_RAD_S,
        coulomb_friction: RE35_KT * RE35_NO_LOAD_A / 2.0,
        coulomb_smoothing: 0.5,
    };

    /// Every motor a robot file can name.
    pub const PRESETS: &'static [MotorParams] = &[MotorParams::MAXON_RE35_24V];

    /// The preset called `name`.
    pub fn preset(name: &str) -> Option<MotorParams> {
        Self::PRESETS.iter().copied().find(|p| p.name == name)
    }

    /// Friction torque at speed `w` (opposes motion).
    pub fn friction(&self, w: f64) -> f64 {
        self.viscous_friction * w + self.coulomb_friction * (w / self.coulomb_smoothing).tanh()
    }

    /// Analytic steady state (current A, speed rad/s) at terminal voltage `volts` through
    /// `series_ohm` against a constant `load` torque, on the forward-running branch (ω > 0,
    /// where the smoothed Coulomb term is τc to within e^(−2ω/ωs)).
    pub fn steady_state(&self, volts: f64, series_ohm: f64, load: f64) -> (f64, f64) {
        let r = self.resistance_ohm + series_ohm;
        let k = self.torque_constant;
        let w =
            (k * volts / r - self.coulomb_friction - load) / (k * k / r + self.viscous_friction);
        ((volts - k * w) / r, w)
    }
}

/// What drives the motor's terminals for one sub-step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Terminal {
    /// A voltage source through a series resistance (a driven or braking H-bridge).
    Driven {
        /// Average terminal voltage, V.
        volts: f64,
        /// Resistance in series with the winding, Ω.
        series_ohm: f64,
    },
    /// Open terminals (driver disabled): current can only flow through the switches' body
    /// diodes back into the supply, which clamps the terminal voltage at ±`clamp_volts`
    /// against the current; with no current the winding floats.
    Open {
        /// Supply plus two diode drops, V.
        clamp_volts: f64,
    },
}

/// Integrals of one electrical sub-step, exact for the exponential solution.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ElectricalStep {
    /// ∫ i dt, C.
    pub charge: f64,
    /// ∫ |i| dt, C.
    pub abs_charge: f64,
    /// ∫ i² dt, A²·s.
    pub i2t: f64,
    /// ∫ V·i dt at the terminals, J.
    pub energy_in: f64,
    /// Resistance the current flowed through (winding + series), Ω.
    pub resistance: f64,
}

/// A motor's state: winding current, shaft speed and angle.
#[derive(Clone, Debug, PartialEq)]
pub struct Motor {
    /// Its constants.
    pub params: MotorParams,
    current: f64,
    speed: f64,
    angle: f64,
}

/// e^(−x) − 1, remembering the last argument: a robot's identical motors step by the same h
/// with the same τ, and a world step's sub-steps share h, so most calls repeat the one before
/// (the exponential was a twentieth of a simulation's time). A pure function: same results.
fn decay_m1(x: f64) -> f64 {
    thread_local! {
        static LAST: core::cell::Cell<(f64, f64)> = const { core::cell::Cell::new((0.0, 0.0)) };
    }
    LAST.with(|last| {
        let (lx, lv) = last.get();
        if lx.to_bits() == x.to_bits() {
            return lv;
        }
        let v = (-x).exp_m1();
        last.set((x, v));
        v
    })
}

/// i(t) = a + c·e^(−t/τ): its integrals over [0, h] (∫i, ∫i²) and e^(−h/τ).
fn exp_integrals(a: f64, c: f64, tau: f64, h: f64) -> (f64, f64, f64) {
    let em1 = decay_m1(h / tau); // e^(−h/τ) − 1, accurate for small h/τ
    let e1 = -em1; // 1 − e^(−h/τ)
    let e2 = -em1 * (2.0 + em1); // 1 − e^(−2h/τ) = (1 − e)(1 + e)
    (a * h + c * tau * e1, a * a * h + 2.0 * a * c * tau * e1 + c * c * tau / 2.0 * e2, 1.0 + em1)
}

impl Motor {
    /// A motor at rest with no current.
    pub fn new(params: MotorParams) -> Self {
        Self { params, current: 0.0, speed: 0.0, angle: 0.0 }
    }

    /// Winding current, A.
    pub fn current(&self) -> f64 {
        self.current
    }

    /// Shaft speed, rad/s.
    pub fn speed(&self) -> f64 {
        self.speed
    }

    /// Shaft angle, rad (unwrapped).
    pub fn angle(&self) -> f64 {
        self.angle
    }

    /// Back-EMF, V.
    pub fn back_emf(&self) -> f64 {
        self.params.torque_constant * self.speed
    }

    /// Torque the shaft delivers before its own inertia: Kt·i − friction, N·m.
    pub fn shaft_torque(&self) -> f64 {
        self.params.torque_constant * self.current - self.params.friction(self.speed)
    }

    /// Magnetic energy in the winding, ½·L·i², J.
    pub fn magnetic_energy(&self) -> f64 {
        0.5 * self.params.inductance_h * self.current * self.current
    }

    /// Sets the winding current (an initial condition).
    pub fn set_current(&mut self, current: f64) {
        self.current = current;
    }

    /// Sets speed and angle (a world coupling the shaft to a load sets them after solving
    /// the coupled mechanics).
    pub fn set_mechanical(&mut self, speed: f64, angle: f64) {
        self.speed = speed;
        self.angle = angle;
    }

    /// Advances the current by `h` seconds with `terminal` applied and ω held (exact
    /// exponential step; see the module documentation).
    pub fn update_current(&mut self, terminal: Terminal, h: f64) -> ElectricalStep {
        let p = &self.params;
        let emf = p.torque_constant * self.speed;
        match terminal {
            Terminal::Driven { volts, series_ohm } => {
                let r = p.resistance_ohm + series_ohm;
                let tau = p.inductance_h / r;
                let inf = (volts - emf) / r;
                let (q, i2t, decay) = exp_integrals(inf, self.current - inf, tau, h);
                let i0 = self.current;
                self.current = inf + (i0 - inf) * decay;
                // ∫|i|: split at the zero crossing if the current changes sign in the step.
                let abs_charge = if i0 * self.current >= 0.0 {
                    q.abs()
                } else {
                    let t0 = tau * ((i0 - inf) / -inf).ln();
                    let (q0, _, _) = exp_integrals(inf, i0 - inf, tau, t0);
                    q0.abs() + (q - q0).abs()
                };
                ElectricalStep { charge: q, abs_charge, i2t, energy_in: volts * q, resistance: r }
            }
            Terminal::Open { clamp_volts } => self.open_step(clamp_volts, emf, h),
        }
    }

    /// Driver off: current freewheels through the diodes until it reaches zero; it restarts
    /// only if the back-EMF exceeds the clamp (generating into the supply).
    fn open_step(&mut self, clamp: f64, emf: f64, h: f64) -> ElectricalStep {
        let p = self.params;
        let r = p.resistance_ohm;
        let tau = p.inductance_h / r;
        let mut out = ElectricalStep { resistance: r, ..Default::default() };
        let mut left = h;
        // At most two phases: decay to zero, then (if |emf| > clamp) conduction the other way.
        for _ in 0..2 {
            if left <= 0.0 {
                break;
            }
            let dir = if self.current != 0.0 {
                self.current.signum()
            } else if emf.abs() > clamp {
                -emf.signum()
            } else {
                break; // floating winding, no current
            };
            let volts = -dir * clamp;
            let inf = (volts - emf) / r;
            let c = self.current - inf;
            // Time at which the current would reach zero, if it heads there.
            let t_zero = if inf * dir < 0.0 { tau * (c / -inf).ln() } else { f64::INFINITY };
            let t = left.min(t_zero);
            let (q, i2t, decay) = exp_integrals(inf, c, tau, t);
            out.charge += q;
            out.abs_charge += q.abs();
            out.i2t += i2t;
            out.energy_in += volts * q;
            self.current = if t_zero <= left { 0.0 } else { inf + c * decay };
            left -= t;
        }
        out
    }

    /// Standalone step of `h` seconds: the current with `terminal` applied, then the shaft
    /// against the constant `load` torque (semi-implicit Euler).
    pub fn step(&mut self, terminal: Terminal, load: f64, h: f64) -> ElectricalStep {
        let e = self.update_current(terminal, h);
        let acc = (self.shaft_torque() - load) / self.params.rotor_inertia;
        self.speed += h * acc;
        self.angle += h * self.speed;
        e
    }
}

/// A gearbox: output speed = input speed / ratio; torque through it loses (1 − η) of the
/// power in whichever direction the power flows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gearbox {
    /// Reduction ratio N (input turns per output turn).
    pub ratio: f64,
    /// Efficiency η (0..1], taken constant (the catalogue's maximum).
    pub efficiency: f64,
}

impl Gearbox {
    /// maxon GP 42 C planetary, two stages, 15:1, 81 % maximum efficiency (catalogue).
    pub const MAXON_GP42C_15: Gearbox = Gearbox { ratio: 15.0, efficiency: 0.81 };

    /// Torque multiplier from input to output: N·η when the motor drives the load (power
    /// flows out), N/η when the load drives the motor (power flows in, e.g. braking).
    pub fn torque_factor(&self, motoring: bool) -> f64 {
        if motoring {
            self.ratio * self.efficiency
        } else {
            self.ratio / self.efficiency
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: MotorParams = MotorParams::MAXON_RE35_24V;

    fn driven(volts: f64) -> Terminal {
        Terminal::Driven { volts, series_ohm: 0.0 }
    }

    /// Slowest pole of the linear (Coulomb-free) rotor-only motor, s⁻¹ (positive).
    fn slow_pole(p: &MotorParams) -> f64 {
        let (a, b) = (p.resistance_ohm / p.inductance_h, p.viscous_friction / p.rotor_inertia);
        let k = p.torque_constant * p.torque_constant / (p.inductance_h * p.rotor_inertia);
        // s² + (a + b)s + (ab + k) = 0
        let (tr, det) = (a + b, a * b + k);
        (tr - (tr * tr - 4.0 * det).sqrt()) / 2.0
    }

    #[test]
    fn datasheet_consistency() {
        // Electrical time constant in the 0.1–1 ms range; mechanical τm = R·J/Kt² ≈ 4.4 ms.
        let te = P.inductance_h / P.resistance_ohm;
        assert!((te - 0.1948e-3).abs() < 1e-6, "{te}");
        let tm = P.resistance_ohm * P.rotor_inertia / (P.torque_constant * P.torque_constant);
        assert!((tm - 4.368e-3).abs() < 1e-5, "{tm}");
        // Friction at no-load speed is Kt·I0.
        assert!((P.friction(RE35_NO_LOAD_RAD_S) - P.torque_constant * 0.137).abs() < 1e-12);
    }

    #[test]
    fn locked_rotor_current_rises_exponentially_to_stall() {
        let mut m = Motor::new(P);
        let te = P.inductance_h / P.resistance_ohm;
        let e = m.update_current(driven(24.0), te);
        let stall = 24.0 / P.resistance_ohm; // 39.3 A
        assert!((m.current() - stall * (1.0 - (-1.0f64).exp())).abs() < 1e-12 * stall);
        // Charge is the exact integral: stall·(te − te·(1 − e⁻¹)).
        let q = stall * (te - te * (1.0 - (-1.0f64).exp()));
        assert!((e.charge - q).abs() < 1e-12 * q.abs(), "{} vs {q}", e.charge);
        for _ in 0..100 {
            m.update_current(driven(24.0), te);
        }
        assert!((m.current() - stall).abs() < 1e-9 * stall);
        // Stall torque Kt·V/R = 1.186 N·m (no friction at standstill).
        assert!((m.shaft_torque() - P.torque_constant * stall).abs() < 1e-9);
        assert!((m.shaft_torque() - 1.1862).abs() < 1e-3);
    }

    /// Runs a free motor at `volts` against `load` for 30 slow time constants.
    fn settle(volts: f64, load: f64) -> Motor {
        let h = 20e-6;
        let t = 30.0 / slow_pole(&P);
        let mut m = Motor::new(P);
        for _ in 0..(t / h).ceil() as usize {
            m.step(driven(volts), load, h);
        }
        m
    }

    #[test]
    fn free_run_matches_analytic_steady_state() {
        let m = settle(24.0, 0.0);
        let (i, w) = P.steady_state(24.0, 0.0, 0.0);
        // The scheme's fixed point is the analytic one; what is left after 30 slow time
        // constants is e^−30 ≈ 1e-13 of the step plus rounding.
        assert!((m.speed() - w).abs() < 1e-9 * w, "{} vs {w}", m.speed());
        assert!((m.current() - i).abs() < 1e-9 * w, "{} vs {i}", m.current());
        // No-load numbers: 792 rad/s (7560 rpm) at 0.137 A.
        assert!((w - RE35_NO_LOAD_RAD_S).abs() < 1e-9 * w);
        assert!((i - RE35_NO_LOAD_A).abs() < 1e-9);
    }

    #[test]
    fn loaded_steady_state_matches_analytic() {
        // 0.1 N·m, about the RE 35's continuous torque.
        let m = settle(24.0, 0.1);
        let (i, w) = P.steady_state(24.0, 0.0, 0.1);
        assert!((m.speed() - w).abs() < 1e-9 * w && (m.current() - i).abs() < 1e-9 * i);
        assert!((i - (0.1 + P.friction(w)) / P.torque_constant).abs() < 1e-9);
        assert!((w - 725.05).abs() < 0.01, "{w}"); // ≈ 6924 rpm
    }

    /// Largest speed error over a 20 ms step response from rest against the exact solution
    /// of the linear second-order system (Coulomb friction off), at sub-step `h`.
    fn step_response_error(h: f64) -> f64 {
        let p = MotorParams { coulomb_friction: 0.0, ..P };
        let (a, b) = (p.resistance_ohm / p.inductance_h, p.viscous_friction / p.rotor_inertia);
        let k = p.torque_constant * p.torque_constant / (p.inductance_h * p.rotor_inertia);
        let (tr, det) = (a + b, a * b + k);
        let disc = (tr * tr - 4.0 * det).sqrt();
        let (l1, l2) = ((-tr + disc) / 2.0, (-tr - disc) / 2.0);
        let (_, w_inf) = p.steady_state(24.0, 0.0, 0.0);
        let exact =
            |t: f64| w_inf * (1.0 + (l2 * (l1 * t).exp() - l1 * (l2 * t).exp()) / (l1 - l2));
        let mut m = Motor::new(p);
        let n = (0.02 / h).round() as usize;
        (1..=n)
            .map(|s| {
                m.step(driven(24.0), 0.0, h);
                (m.speed() - exact(s as f64 * h)).abs()
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn transient_converges_at_first_order() {
        // A first-order scheme halves its error with the step: a wrong term (a missing
        // back-EMF, a wrong sign) would leave an error that does not shrink.
        let (e1, e2) = (step_response_error(4e-6), step_response_error(2e-6));
        let ratio = e1 / e2;
        assert!((1.8..2.2).contains(&ratio), "error ratio {ratio} ({e1}, {e2})");
        // And at 2 µs it is within 0.5 % of the 792 rad/s final speed.
        assert!(e2 < 0.005 * 792.0, "{e2}");
    }

    #[test]
    fn open_terminals_current_decays_to_zero_and_stops() {
        // 10 A flowing at standstill, driver off: the diodes clamp at −(24 + 1.4) V, so
        // i(t) = i∞ + (10 − i∞)e^(−t/τ) with i∞ = −25.4/R, zero at τ·ln((10 − i∞)/(−i∞)).
        let mut m = Motor::new(P);
        m.current = 10.0;
        let clamp = 25.4;
        let tau = P.inductance_h / P.resistance_ohm;
        let inf = -clamp / P.resistance_ohm;
        let t0 = tau * ((10.0 - inf) / -inf).ln();
        let e = m.update_current(Terminal::Open { clamp_volts: clamp }, t0 * 0.999);
        assert!(m.current() > 0.0);
        let e2 = m.update_current(Terminal::Open { clamp_volts: clamp }, t0 * 0.002);
        assert_eq!(m.current(), 0.0, "stops at zero, does not reverse");
        // Charge returned: ∫i dt up to t0 = i∞·t0 + (10 − i∞)·τ·(1 − e^(−t0/τ)).
        let q = inf * t0 + (10.0 - inf) * tau * (1.0 - (-t0 / tau).exp());
        assert!((e.charge + e2.charge - q).abs() < 1e-12, "{} vs {q}", e.charge + e2.charge);
        // Spinning slower than the clamp: stays at zero.
        m.speed = 0.9 * clamp / P.torque_constant;
        m.update_current(Terminal::Open { clamp_volts: clamp }, 1e-3);
        assert_eq!(m.current(), 0.0);
        // Spinning faster than the clamp: generates into the supply (negative current).
        m.speed = 1.1 * clamp / P.torque_constant;
        m.update_current(Terminal::Open { clamp_volts: clamp }, 5e-3); // 25 τe: e^−25 left
        let expect = (clamp - 1.1 * clamp) / P.resistance_ohm;
        assert!((m.current() - expect).abs() < 1e-3 * expect.abs(), "{}", m.current());
    }

    #[test]
    fn gearbox_loses_power_both_ways() {
        let g = Gearbox::MAXON_GP42C_15;
        // Motoring: out = η·in in power.
        let (t_in, w_in) = (0.1, 600.0);
        let p_out = g.torque_factor(true) * t_in * w_in / g.ratio;
        assert!((p_out - 0.81 * t_in * w_in).abs() < 1e-12);
        // Back-driven: the motor receives η of what the wheel puts in.
        let p_wheel = g.torque_factor(false) * -t_in * w_in / g.ratio;
        assert!((-t_in * w_in - 0.81 * p_wheel).abs() < 1e-9);
    }
}
