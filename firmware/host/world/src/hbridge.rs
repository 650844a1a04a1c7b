//! H-bridge: two half-bridge legs (A, B) driven by complementary PWM with dead time, and an
//! enable line.
//!
//! Average-voltage model: the PWM period (50 µs at 20 kHz) is short against the winding's
//! L/R (≈ 0.19 ms), so the motor follows each leg's average voltage over a period, not the
//! individual edges. The current ripple around that average (at most Vs·T/(2L) ≈ 5 A
//! peak-to-peak, locked anti-phase at zero duty, RE 35 at 24 V) is not modelled: it is
//! symmetric about the average, which is what a current sample taken at the centre of a
//! centre-aligned PWM period reads, as the motor image takes it (ADC1's injected group on
//! TIM1's update events: firmware/targets/f103/motor/src/sensors.rs). Leg X's high side is on for duty dX of the period
//! and its low side for the rest (TIM1 CHx / CHxN), except for a dead time td at each edge
//! when both are off and the phase current picks the rail through a body diode: current
//! leaving the leg pulls it low, current entering pulls it high. So a switching leg's average
//! is Vs·(dX − td·f·s(iX)), with s the sign of the leg's current, smoothed over ±`band` (the
//! current reverses within the dead time near zero). A leg at 0 % or 100 % does not switch
//! and has no dead time. The terminal voltage is V_A − V_B through two switches' on-resistance.
//!
//! - Locked anti-phase drive of a signed duty d: dA = (1 + d)/2, dB = (1 − d)/2 → d·Vs, and
//!   both legs' dead times: −2·td·f·Vs·s(i).
//! - Sign–magnitude: dA = d, dB = 0 → d·Vs, one leg's dead time.
//! - Brake: dA = dB = 0, both low sides on: the winding is shorted through 2·Rds(on).
//! - Coast: enable low (or a driver fault): all switches off; current, if any, returns to the
//!   supply through the diodes until it reaches zero (see [`Terminal::Open`]).
//!
//! Supply current: power in = power out on average, Vs·Is = V_term·i (the switches' losses
//! show up in the winding's circuit as their resistance); coasting returns |i| to the supply
//! and loses two diode drops.

use crate::motor::{ElectricalStep, Terminal};

/// Electrical characteristics of the bridge and its PWM.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HBridgeParams {
    /// PWM frequency, Hz.
    pub pwm_hz: f64,
    /// Dead time at each edge, s.
    pub dead_time_s: f64,
    /// On-resistance of one switch, Ω.
    pub switch_resistance_ohm: f64,
    /// Body-diode forward drop, V.
    pub diode_drop_v: f64,
    /// Current over which the dead-time error changes sign, A.
    pub dead_time_band_a: f64,
}

impl HBridgeParams {
    /// 20 kHz PWM (above hearing), 500 ns dead time, 10 mΩ MOSFETs, 0.7 V diodes, 50 mA
    /// reversal band: a discrete 40 V MOSFET bridge of the 70 W class (assumed values; the
    /// robot file sets the first three).
    pub const DEFAULT: HBridgeParams = HBridgeParams {
        pwm_hz: 20_000.0,
        dead_time_s: 500e-9,
        switch_resistance_ohm: 0.010,
        diode_drop_v: 0.7,
        dead_time_band_a: 0.05,
    };
}

/// What the firmware drives: the two legs' high-side duties and the enable line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HBridgeInput {
    /// Leg A high-side duty, 0..1 (TIM1 CH1 compare / period).
    pub duty_a: f64,
    /// Leg B high-side duty, 0..1 (TIM1 CH2).
    pub duty_b: f64,
    /// Driver enabled (DRV_EN high).
    pub enabled: bool,
}

impl HBridgeInput {
    /// Locked anti-phase drive of signed duty `d` (−1..1, clamped): average d·Vs.
    pub fn signed(d: f64) -> Self {
        let d = d.clamp(-1.0, 1.0);
        Self { duty_a: (1.0 + d) / 2.0, duty_b: (1.0 - d) / 2.0, enabled: true }
    }

    /// Both low sides on: the motor brakes.
    pub fn brake() -> Self {
        Self { duty_a: 0.0, duty_b: 0.0, enabled: true }
    }

    /// Driver disabled: the motor coasts.
    pub fn coast() -> Self {
        Self { duty_a: 0.0, duty_b: 0.0, enabled: false }
    }
}

/// An H-bridge and the inputs it was last given.
#[derive(Clone, Debug, PartialEq)]
pub struct HBridge {
    /// Its characteristics.
    pub params: HBridgeParams,
    /// Its inputs (held until changed, like timer compare registers).
    pub input: HBridgeInput,
    /// A driver fault (over-temperature, under-voltage, injected) forces all switches off.
    pub fault: bool,
}

impl HBridge {
    /// A disabled bridge.
    pub fn new(params: HBridgeParams) -> Self {
        Self { params, input: HBridgeInput::coast(), fault: false }
    }

    /// Whether the switches follow the inputs (enabled and no fault).
    pub fn active(&self) -> bool {
        self.input.enabled && !self.fault
    }

    /// Average voltage of a leg at `duty` carrying `leg_current` out of its midpoint, as a
    /// fraction of the supply.
    fn leg_fraction(&self, duty: f64, leg_current: f64) -> f64 {
        let d = duty.clamp(0.0, 1.0);
        if d == 0.0 || d == 1.0 {
            return d;
        }
        let p = &self.params;
        let s = (leg_current / p.dead_time_band_a).clamp(-1.0, 1.0);
        (d - p.dead_time_s * p.pwm_hz * s).clamp(0.0, 1.0)
    }

    /// What the motor's terminals see with supply `supply_v` and winding current `current`
    /// (A → B positive) at the start of the sub-step.
    pub fn terminal(&self, supply_v: f64, current: f64) -> Terminal {
        let vs = supply_v.max(0.0);
        if !self.active() {
            return Terminal::Open { clamp_volts: vs + 2.0 * self.params.diode_drop_v };
        }
        let fa = self.leg_fraction(self.input.duty_a, current);
        let fb = self.leg_fraction(self.input.duty_b, -current);
        Terminal::Driven {
            volts: (fa - fb) * vs,
            series_ohm: 2.0 * self.params.switch_resistance_ohm,
        }
    }

    /// Charge drawn from the supply over a sub-step in which `terminal` drove the motor
    /// through `step` (negative: returned to the supply).
    pub fn supply_charge(&self, terminal: Terminal, supply_v: f64, step: &ElectricalStep) -> f64 {
        match terminal {
            Terminal::Driven { volts, .. } if supply_v > 0.0 => volts / supply_v * step.charge,
            Terminal::Driven { .. } => 0.0,
            Terminal::Open { .. } => -step.abs_charge,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motor::{Motor, MotorParams};

    fn bridge(input: HBridgeInput) -> HBridge {
        HBridge { input, ..HBridge::new(HBridgeParams::DEFAULT) }
    }

    fn volts(t: Terminal) -> f64 {
        match t {
            Terminal::Driven { volts, .. } => volts,
            Terminal::Open { .. } => panic!("open"),
        }
    }

    #[test]
    fn locked_antiphase_average_with_dead_time() {
        // td·f = 0.5 µs · 20 kHz = 1 % of the period per leg, two legs: 2 % of 24 V = 0.48 V
        // against the current.
        let b = bridge(HBridgeInput::signed(0.5));
        assert!((volts(b.terminal(24.0, 3.0)) - (0.5 - 0.02) * 24.0).abs() < 1e-12);
        assert!((volts(b.terminal(24.0, -3.0)) - (0.5 + 0.02) * 24.0).abs() < 1e-12);
        // Inside the reversal band the error scales with the current: none at 0 A.
        assert!((volts(b.terminal(24.0, 0.0)) - 12.0).abs() < 1e-12);
        assert!((volts(b.terminal(24.0, 0.025)) - (0.5 - 0.01) * 24.0).abs() < 1e-12);
    }

    #[test]
    fn sign_magnitude_has_one_leg_of_dead_time_and_full_duty_none() {
        let b = bridge(HBridgeInput { duty_a: 0.3, duty_b: 0.0, enabled: true });
        assert!((volts(b.terminal(24.0, 2.0)) - (0.3 - 0.01) * 24.0).abs() < 1e-12);
        let b = bridge(HBridgeInput::signed(1.0));
        assert_eq!(volts(b.terminal(24.0, 5.0)), 24.0);
        let b = bridge(HBridgeInput::signed(-1.0));
        assert_eq!(volts(b.terminal(24.0, -5.0)), -24.0);
    }

    #[test]
    fn brake_shorts_the_winding_through_two_switches() {
        let b = bridge(HBridgeInput::brake());
        assert_eq!(b.terminal(24.0, 4.0), Terminal::Driven { volts: 0.0, series_ohm: 0.02 });
        // A motor held at 500 rad/s settles at −Ke·ω/(R + 2·Rds).
        let p = MotorParams::MAXON_RE35_24V;
        let mut m = Motor::new(p);
        m.set_mechanical(500.0, 0.0);
        for _ in 0..200 {
            m.update_current(b.terminal(24.0, m.current()), 20e-6);
        }
        let expect = -p.torque_constant * 500.0 / (p.resistance_ohm + 0.02);
        assert!((m.current() - expect).abs() < 1e-6 * expect.abs(), "{}", m.current());
    }

    #[test]
    fn coast_and_fault_open_the_bridge() {
        assert_eq!(
            bridge(HBridgeInput::coast()).terminal(24.0, 1.0),
            Terminal::Open { clamp_volts: 25.4 }
        );
        let mut b = bridge(HBridgeInput::signed(0.8));
        b.fault = true;
        assert!(matches!(b.terminal(24.0, 1.0), Terminal::Open { .. }));
    }

    #[test]
    fn supply_current_balances_power() {
        let b = bridge(HBridgeInput::signed(0.6));
        let t = b.terminal(24.0, 2.0);
        let mut m = Motor::new(MotorParams::MAXON_RE35_24V);
        m.set_mechanical(300.0, 0.0);
        let e = m.update_current(t, 20e-6);
        let q = b.supply_charge(t, 24.0, &e);
        // Energy from the supply equals energy into the terminals.
        assert!((24.0 * q - e.energy_in).abs() < 1e-12 * e.energy_in.abs());
        // Coasting returns charge: with 5 A freewheeling, the supply receives ∫|i|.
        let c = bridge(HBridgeInput::coast());
        let t = c.terminal(24.0, 5.0);
        let mut m = Motor::new(MotorParams::MAXON_RE35_24V);
        m.set_current(5.0);
        let e = m.update_current(t, 20e-6);
        assert!(e.abs_charge > 0.0);
        assert_eq!(c.supply_charge(t, 24.0, &e), -e.abs_charge);
    }
}
