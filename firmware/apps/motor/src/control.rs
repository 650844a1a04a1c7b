//! The cascaded controller: position (P) → speed (PI) at 200 Hz → current (PI) at 1 kHz →
//! H-bridge duty.
//!
//! Units are the output shaft's (after the gearbox) for position, speed and torque, the motor's
//! for current and voltage. Arithmetic is `f32`: the F103 has no FPU, so each operation is a
//! soft-float call (50–100 instructions), and a whole step costs 2 500–4 000 instructions
//! (README: about 5 % of the 1 ms period at 72 MHz). That leaves ample room, and `f32` keeps the
//! units, the parameters and the messages (all `float32`) free of the scaling mistakes fixed
//! point would invite.
//!
//! The position loop is P only: the speed loop's integrator already removes a constant load's
//! error (a steady position needs zero speed error on average, which the integrator enforces),
//! and an integrator in the position loop would add overshoot for nothing.

use r2p_msgs::WheelSetpoint;

use crate::params::Config;
use crate::pi::{Gains, Pi};

/// Period of the current loop, s.
pub const INNER_DT_S: f32 = 0.001;
/// Current-loop steps per speed/position-loop step (200 Hz).
pub const OUTER_DIVIDER: u32 = 5;
/// Period of the speed and position loops, s.
pub const OUTER_DT_S: f32 = INNER_DT_S * OUTER_DIVIDER as f32;
/// Below this motor supply (V) duty is computed as if it were this much (no division by ~0).
pub const VBUS_MIN: f32 = 3.0;

/// Share (0..1) of the braking current allowed at motor supply `vbus`: all of it up to
/// `start`, falling linearly to none at `stop` (with `stop` ≤ `start`: all below `stop`, none
/// from it on).
///
/// Why: the board has no brake chopper. Braking returns energy to the supply; when the supply
/// cannot take it (a charger or bench supply that does not sink, a pulled battery lead), it
/// charges the bulk capacitors (4 mF: 10 A of regenerated current lifts them 2.5 V per ms)
/// until the over-voltage comparator coasts the bridge (46.4–49.2 V), leaving the motor
/// uncontrolled. Cutting the braking current as VMOT nears the trip keeps the motor under
/// control: it slows on friction and on what the supply's other loads take.
pub fn regen_share(vbus: f32, start: f32, stop: f32) -> f32 {
    if vbus >= stop {
        0.0
    } else if vbus <= start {
        1.0
    } else {
        (stop - vbus) / (stop - start)
    }
}

/// Bounds (lo, hi) of the current setpoint, A: ±`limit`, the braking side cut to `brake` A.
/// Braking is a current against the rotation `speed`: only then can the supply receive power
/// (V·I = (e + R·I)·I < 0 needs I against the back-EMF e), so a current with the speed's sign,
/// or any current at standstill, returns nothing.
pub fn current_bounds(limit: f32, brake: f32, speed: f32) -> (f32, f32) {
    let brake = brake.min(limit);
    if speed > 0.0 {
        (-brake, limit)
    } else if speed < 0.0 {
        (-limit, brake)
    } else {
        (-limit, limit)
    }
}

/// The current setpoint's bounds for the measurements `m`: the current limit, its braking side
/// derated by the motor supply ([`regen_share`]).
fn bounds(cfg: &Config, m: &Measured) -> (f32, f32) {
    let share = regen_share(m.vbus, cfg.regen_start_v, cfg.regen_stop_v);
    current_bounds(cfg.current_limit, share * cfg.current_limit, m.speed_now)
}

/// What the motor is asked to do (output shaft).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Setpoint {
    /// Torque, N·m.
    Torque(f32),
    /// Speed, rad/s.
    Speed(f32),
    /// Position, rad.
    Position(f32),
}

impl Setpoint {
    /// `WheelSetpoint.mode` of a torque setpoint.
    pub const MODE_TORQUE: u8 = 0;
    /// `WheelSetpoint.mode` of a speed setpoint.
    pub const MODE_SPEED: u8 = 1;
    /// `WheelSetpoint.mode` of a position setpoint.
    pub const MODE_POSITION: u8 = 2;

    /// The setpoint a message asks for; `None` for an unknown mode or a value that is not a
    /// finite number (the message is ignored, and does not feed the watchdog).
    pub fn from_msg(m: &WheelSetpoint) -> Option<Self> {
        if !m.value.is_finite() {
            return None;
        }
        match m.mode {
            Self::MODE_TORQUE => Some(Self::Torque(m.value)),
            Self::MODE_SPEED => Some(Self::Speed(m.value)),
            Self::MODE_POSITION => Some(Self::Position(m.value)),
            _ => None,
        }
    }

    fn mode(self) -> u8 {
        match self {
            Self::Torque(_) => Self::MODE_TORQUE,
            Self::Speed(_) => Self::MODE_SPEED,
            Self::Position(_) => Self::MODE_POSITION,
        }
    }
}

/// The measurements the loops use.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Measured {
    /// Output-shaft position, rad.
    pub position: f32,
    /// Output-shaft speed, rad/s (filtered, updated at 200 Hz): the speed loop's.
    pub speed: f32,
    /// Output-shaft speed over the last 5 ms, rad/s, updated every step: the back-EMF
    /// feed-forward's (a feed-forward updated at 200 Hz would kick the current every 5 ms).
    pub speed_now: f32,
    /// Motor current, A (this step's sample).
    pub current: f32,
    /// Motor supply, V.
    pub vbus: f32,
}

/// The three loops' state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cascade {
    speed_pi: Pi,
    current_pi: Pi,
    current_ref: f32,
    speed_ref: f32,
    mode: Option<u8>,
}

impl Cascade {
    /// Loops at rest.
    pub const fn new() -> Self {
        Self {
            speed_pi: Pi::new(),
            current_pi: Pi::new(),
            current_ref: 0.0,
            speed_ref: 0.0,
            mode: None,
        }
    }

    /// Empties the integrators and zeroes the setpoints (the bridge went off).
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// The current setpoint, A (within ± `current_limit`).
    pub fn current_ref(&self) -> f32 {
        self.current_ref
    }

    /// The speed setpoint of the speed loop, rad/s (speed and position modes).
    pub fn speed_ref(&self) -> f32 {
        self.speed_ref
    }

    /// The 200 Hz step: `sp` and the measurements give the current setpoint.
    pub fn outer(&mut self, cfg: &Config, sp: Setpoint, m: &Measured) {
        if self.mode != Some(sp.mode()) {
            // Bumpless: the speed loop starts from the current the motor is getting.
            self.speed_pi.preset(self.current_ref);
            self.mode = Some(sp.mode());
        }
        match sp {
            Setpoint::Torque(t) => {
                let (lo, hi) = bounds(cfg, m);
                let amps = t / (cfg.torque_constant * cfg.gear_ratio);
                self.current_ref = amps.clamp(lo, hi);
                self.speed_ref = m.speed;
                self.speed_pi.preset(self.current_ref);
            }
            Setpoint::Speed(w) => self.speed_loop(cfg, w, m),
            Setpoint::Position(x) => self.speed_loop(cfg, cfg.position_kp * (x - m.position), m),
        }
    }

    fn speed_loop(&mut self, cfg: &Config, w: f32, m: &Measured) {
        let max = cfg.max_speed;
        self.speed_ref = w.clamp(-max, max);
        let gains = Gains { kp: cfg.speed_kp, ki: cfg.speed_ki };
        let (lo, hi) = bounds(cfg, m);
        let err = self.speed_ref - m.speed;
        let p_err = cfg.speed_weight * self.speed_ref - m.speed;
        self.current_ref = self.speed_pi.step_weighted(gains, err, p_err, OUTER_DT_S, 0.0, lo, hi);
    }

    /// The 1 kHz step: the duty (−`duty_limit`..`duty_limit`) that drives the current to its
    /// setpoint. The voltage is computed first (gains in V/A, independent of the supply), with
    /// the back-EMF as feed-forward, then divided by the measured supply.
    ///
    /// The braking side of the setpoint is derated here, every millisecond, by the supply
    /// measured now, and while it is derated it bounds the voltage too: turning forward, a
    /// braking current of at most B needs v ≥ e − R·B. Braking into a supply that cannot take
    /// it lifts the bulk capacitors by volts per millisecond; the PI alone would follow a
    /// lowered bound only over several steps, the voltage bound holds the current to it from
    /// this step on (the winding's L/R is 0.2 ms).
    pub fn inner(&mut self, cfg: &Config, m: &Measured) -> f32 {
        let (lo, hi) = bounds(cfg, m);
        self.current_ref = self.current_ref.clamp(lo, hi);
        let vbus = m.vbus.max(VBUS_MIN);
        let vmax = cfg.duty_limit * vbus;
        let emf = cfg.torque_constant * cfg.gear_ratio * m.speed_now;
        let (mut vlo, mut vhi) = (-vmax, vmax);
        if lo > -cfg.current_limit {
            vlo = (emf + cfg.motor_resistance * lo).clamp(-vmax, vmax);
        }
        if hi < cfg.current_limit {
            vhi = (emf + cfg.motor_resistance * hi).clamp(-vmax, vmax);
        }
        let gains = Gains { kp: cfg.current_kp, ki: cfg.current_ki };
        let err = self.current_ref - m.current;
        let v = self.current_pi.step(gains, err, INNER_DT_S, emf, vlo, vhi);
        v / vbus
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn setpoint_messages_map_to_modes_and_bad_ones_are_refused() {
        let sp = |mode, value| Setpoint::from_msg(&WheelSetpoint { mode, value });
        assert_eq!(sp(0, 0.5), Some(Setpoint::Torque(0.5)));
        assert_eq!(sp(1, -3.0), Some(Setpoint::Speed(-3.0)));
        assert_eq!(sp(2, 6.0), Some(Setpoint::Position(6.0)));
        assert_eq!(sp(3, 1.0), None);
        assert_eq!(sp(1, f32::NAN), None);
        assert_eq!(sp(2, f32::INFINITY), None);
    }

    #[test]
    fn the_current_limit_clamps_every_mode() {
        let cfg = Config::DEFAULT;
        let m = Measured { vbus: 24.0, ..Default::default() };
        let mut c = Cascade::new();
        c.outer(&cfg, Setpoint::Torque(100.0), &m);
        assert_eq!(c.current_ref(), cfg.current_limit);
        c.outer(&cfg, Setpoint::Speed(-1000.0), &m);
        assert_eq!(c.current_ref(), -cfg.current_limit);
        assert_eq!(c.speed_ref(), -cfg.max_speed, "the speed limit clamps too");
        c.outer(&cfg, Setpoint::Position(1000.0), &m);
        assert_eq!(c.current_ref(), cfg.current_limit);
        // 1 N·m at the output = 1 / (0.0302 × 15) = 2.208 A.
        c.outer(&cfg, Setpoint::Torque(1.0), &m);
        assert!((c.current_ref() - 2.207_506).abs() < 1e-5);
    }

    #[test]
    fn the_braking_share_falls_linearly_from_start_to_stop() {
        let share = |v| regen_share(v, 44.0, 46.0);
        assert_eq!(share(24.0), 1.0);
        assert_eq!(share(44.0), 1.0, "all of it up to the start");
        assert_eq!(share(44.5), 0.75);
        assert_eq!(share(45.0), 0.5);
        assert_eq!(share(46.0), 0.0, "none from the stop on");
        assert_eq!(share(52.0), 0.0);
        // A stop at or below the start: a step at the stop, never a division by zero.
        assert_eq!(regen_share(44.9, 45.0, 45.0), 1.0);
        assert_eq!(regen_share(45.0, 45.0, 45.0), 0.0);
        assert_eq!(regen_share(44.0, 46.0, 45.0), 1.0);
        assert_eq!(regen_share(45.5, 46.0, 45.0), 0.0);
        // The defaults: 44.1 V (the board's highest steady input) to 45.5 V.
        let cfg = Config::DEFAULT;
        assert_eq!((cfg.regen_start_v, cfg.regen_stop_v), (44.1, 45.5));
    }

    #[test]
    fn only_the_current_against_the_rotation_is_derated() {
        assert_eq!(current_bounds(10.0, 4.0, 3.0), (-4.0, 10.0), "turning forward: brake ≥ −4 A");
        assert_eq!(current_bounds(10.0, 4.0, -3.0), (-10.0, 4.0), "turning backward");
        assert_eq!(current_bounds(10.0, 4.0, 0.0), (-10.0, 10.0), "standstill returns nothing");
        assert_eq!(current_bounds(10.0, 25.0, 3.0), (-10.0, 10.0), "never beyond the limit");
        assert_eq!(current_bounds(10.0, 0.0, -1e-3), (-10.0, 0.0));
    }

    #[test]
    fn a_high_supply_cuts_braking_in_every_mode_and_in_the_current_loop() {
        let cfg = Config::DEFAULT;
        // Turning forward at 10 rad/s, asked to stop: the speed loop wants −10 A.
        let m = |vbus| Measured { vbus, speed: 10.0, speed_now: 10.0, ..Default::default() };
        let mut c = Cascade::new();
        c.outer(&cfg, Setpoint::Speed(0.0), &m(24.0));
        assert_eq!(c.current_ref(), -cfg.current_limit);
        // Half-way between start and stop: half the braking current, at the next 1 kHz step.
        c.inner(&cfg, &m(44.8));
        assert!((c.current_ref() + 0.5 * cfg.current_limit).abs() < 1e-4, "{}", c.current_ref());
        // At the stop, none; the speed loop's integrator does not wind up against the bound.
        for _ in 0..100 {
            c.outer(&cfg, Setpoint::Speed(0.0), &m(45.5));
            assert!(c.inner(&cfg, &m(45.5)) >= 0.0, "no braking voltage");
            assert_eq!(c.current_ref(), 0.0);
        }
        // The supply falls back: braking again at once (the integrator held at the bound).
        c.outer(&cfg, Setpoint::Speed(0.0), &m(30.0));
        assert_eq!(c.current_ref(), -cfg.current_limit);
        // Torque mode: a braking torque is derated, a driving one is not.
        let mut c = Cascade::new();
        c.outer(&cfg, Setpoint::Torque(-100.0), &m(44.8));
        assert!((c.current_ref() + 0.5 * cfg.current_limit).abs() < 1e-4, "{}", c.current_ref());
        c.outer(&cfg, Setpoint::Torque(100.0), &m(45.5));
        assert_eq!(c.current_ref(), cfg.current_limit);
    }

    #[test]
    fn while_derated_the_braking_bound_bounds_the_voltage_at_once() {
        let cfg = Config::DEFAULT;
        let r = cfg.motor_resistance;
        for dir in [1.0f32, -1.0] {
            // Turning at 10 rad/s, asked to stop, the current not following (the PI winds to
            // a strong braking voltage).
            let m = |vbus| Measured {
                vbus,
                speed: 10.0 * dir,
                speed_now: 10.0 * dir,
                ..Default::default()
            };
            let emf = cfg.torque_constant * cfg.gear_ratio * 10.0 * dir;
            let mut c = Cascade::new();
            c.outer(&cfg, Setpoint::Speed(0.0), &m(24.0));
            let mut v = 0.0;
            for _ in 0..20 {
                v = c.inner(&cfg, &m(24.0)) * 24.0;
            }
            // Not derated: no voltage bound but the duty limit.
            assert!((v - emf) * dir < -r * cfg.current_limit, "dir {dir}: {v} V vs e = {emf} V");
            // Half-way: the voltage that holds half the limit's braking current, this step.
            let v = c.inner(&cfg, &m(44.8)) * 44.8;
            let want = emf - dir * r * 0.5 * cfg.current_limit;
            assert!((v - want).abs() < 1e-3, "dir {dir}: {v} V vs {want} V");
            // At the stop: no braking voltage at all, the back-EMF.
            let v = c.inner(&cfg, &m(45.5)) * 45.5;
            assert!((v - emf).abs() < 1e-3, "dir {dir}: {v} V vs {emf} V");
        }
    }

    #[test]
    fn duty_is_voltage_over_supply_within_the_duty_limit() {
        let cfg = Config::DEFAULT;
        let mut c = Cascade::new();
        let m = Measured { vbus: 24.0, speed_now: 10.0, ..Default::default() };
        // No current error: the duty is the back-EMF feed-forward, 0.0302 × 15 × 10 / 24.
        assert!((c.inner(&cfg, &m) - 0.188_75).abs() < 1e-5);
        c.outer(&cfg, Setpoint::Torque(100.0), &Measured { vbus: 24.0, ..m });
        for _ in 0..100 {
            assert!(c.inner(&cfg, &m) <= cfg.duty_limit);
        }
        assert_eq!(c.inner(&cfg, &m), cfg.duty_limit);
    }
}
