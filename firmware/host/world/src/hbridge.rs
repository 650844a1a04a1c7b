//! H-bridge: two half-bridge legs (A, B) driven by complementary PWM with dead time, and an
//! enable line.
//!
//! Average-voltage model: the PWM period (50 µs at 20 kHz) is short against the winding's
//! L/R (≈ 0.19 ms), so the motor follows each leg's average voltage over a period, not the
//! individual edges. Leg X's high side is on for duty dX of the period and its low side for
//! the rest (TIM1 CHx / CHxN), except for a dead time td at each edge when both are off and
//! the phase current picks the rail through a body diode: current leaving the leg pulls it
//! low, current entering pulls it high. So a switching leg's average is Vs·(dX − td·f·s(iX)),
//! with s the sign of the leg's current, smoothed over ±`band` (the current reverses within
//! the dead time near zero). A leg at 0 % or 100 % does not switch and has no dead time. The
//! terminal voltage is V_A − V_B through two switches' on-resistance.
//!
//! The current ripple around that average is added where the current is measured
//! ([`HBridge::ripple`]): the edges put Vs·(pulse − d) across the inductance, a triangle of
//! up to Vs·T/(4L) peak-to-peak (sign-magnitude at d = 0.5; 2.5 A for the RE 35 at 24 V).
//! TIM1 counts up and down (centre-aligned, PWM mode 1: a high side is on while the count is
//! below its compare value), so every leg's pulse is centred on the bottom of the count and
//! the triangle crosses its average there and at the top: where TIM1's update events fall,
//! which trigger the motor image's current samples (ADC1's injected group:
//! firmware/targets/f103/motor/src/sensors.rs). A sample at any other instant reads the
//! average plus the ripple's value there.
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
    /// 20 kHz PWM (above hearing), 610 ns dead time (hardware/motor's: TIM1's 100 ns plus the
    /// HIP4082's turn-on delay, 270-750 ns at 25 °C, taken in the middle), 10 mΩ MOSFETs,
    /// 0.7 V diodes, 50 mA reversal band (the robot file sets the first three).
    pub const DEFAULT: HBridgeParams = HBridgeParams {
        pwm_hz: 20_000.0,
        dead_time_s: 610e-9,
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

    /// The winding current's deviation from its period average at PWM phase `phase` (in
    /// periods; 0: the bottom of TIM1's centre-aligned count, the middle of every high-side
    /// pulse; 0.5: its top), with supply `supply_v` and winding inductance `inductance_h`, A.
    ///
    /// Each leg's pulse (width dX, centred on phase 0) less its average, over the inductance,
    /// integrates to a zero-mean triangle, odd about phases 0 and ½ ([`pulse_integral`]): the
    /// deviation is Vs·T/L times leg A's less leg B's. Piecewise linear, i.e. neglecting the
    /// resistance's curvature over a period (R·T/L = 0.26 for the RE 35: the slopes change by
    /// up to that fraction along a segment, not where they cross the average, which stays at
    /// the centres by symmetry) and the dead time (1 % of the period). No ripple while the
    /// bridge is off or braking (no leg switches).
    pub fn ripple(&self, supply_v: f64, inductance_h: f64, phase: f64) -> f64 {
        if !self.active() || inductance_h <= 0.0 {
            return 0.0;
        }
        let k = supply_v.max(0.0) / (self.params.pwm_hz * inductance_h);
        k * (pulse_integral(self.input.duty_a, phase) - pulse_integral(self.input.duty_b, phase))
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

/// ∫₀^φ (p(x) − d) dx over a period of 1, for a unit pulse p of width `duty` d centred on 0:
/// φ(1 − d) inside the pulse, d/2 − dφ after it, (φ − 1)(1 − d) in the next pulse's first
/// half. Zero at φ = 0 and ½; ±d(1 − d)/2 at the pulse's edges.
pub fn pulse_integral(duty: f64, phase: f64) -> f64 {
    let d = duty.clamp(0.0, 1.0);
    let x = phase - phase.floor();
    if x <= d / 2.0 {
        x * (1.0 - d)
    } else if x <= 1.0 - d / 2.0 {
        d / 2.0 - d * x
    } else {
        (x - 1.0) * (1.0 - d)
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
        // td·f = 0.61 µs · 20 kHz = 1.22 % of the period per leg, two legs: 2.44 % of 24 V =
        // 0.59 V against the current.
        let b = bridge(HBridgeInput::signed(0.5));
        assert!((volts(b.terminal(24.0, 3.0)) - (0.5 - 0.0244) * 24.0).abs() < 1e-12);
        assert!((volts(b.terminal(24.0, -3.0)) - (0.5 + 0.0244) * 24.0).abs() < 1e-12);
        // Inside the reversal band the error scales with the current: none at 0 A.
        assert!((volts(b.terminal(24.0, 0.0)) - 12.0).abs() < 1e-12);
        assert!((volts(b.terminal(24.0, 0.025)) - (0.5 - 0.0122) * 24.0).abs() < 1e-12);
    }

    #[test]
    fn sign_magnitude_has_one_leg_of_dead_time_and_full_duty_none() {
        let b = bridge(HBridgeInput { duty_a: 0.3, duty_b: 0.0, enabled: true });
        assert!((volts(b.terminal(24.0, 2.0)) - (0.3 - 0.0122) * 24.0).abs() < 1e-12);
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
    fn the_ripple_is_a_triangle_crossing_its_average_at_the_pwm_centres() {
        // Sign-magnitude at d = 0.5 from 24 V into 0.119 mH at 20 kHz: the high side is on for
        // phases −0.25…0.25; half the peak-to-peak, Vs·d(1 − d)/(2·L·f), is 1.26 A.
        let l = 0.119e-3;
        let b = bridge(HBridgeInput { duty_a: 0.5, duty_b: 0.0, enabled: true });
        let half: f64 = 24.0 * 0.25 / (2.0 * l * 20_000.0);
        assert!((half - 1.2605).abs() < 1e-4, "{half}");
        for (phase, expect) in [
            (0.0, 0.0),
            (0.5, 0.0),
            (0.25, half),
            (0.125, half / 2.0),
            (0.75, -half),
            (-0.25, -half),
            (1.25, half),
            (0.625, -half / 2.0),
        ] {
            let got = b.ripple(24.0, l, phase);
            assert!((got - expect).abs() < 1e-12, "phase {phase}: {got} vs {expect}");
        }
        // Its mean over a period is zero: the average model's current is the ripple's centre.
        let mean: f64 = (0..1000).map(|k| b.ripple(24.0, l, (k as f64 + 0.5) / 1000.0)).sum();
        assert!(mean.abs() / 1000.0 < 1e-12, "{mean}");
        // Negative duty (leg B switches): the same triangle, inverted. Locked anti-phase at
        // d = 0 (both legs at 50 %): none, the legs' pulses coincide.
        let neg = bridge(HBridgeInput { duty_a: 0.0, duty_b: 0.5, enabled: true });
        assert!((neg.ripple(24.0, l, 0.25) + half).abs() < 1e-12);
        assert_eq!(bridge(HBridgeInput::signed(0.0)).ripple(24.0, l, 0.25), 0.0);
        // Both legs switching at 75 % and 25 % (`signed(0.5)`, pulses centred together): leg
        // A's triangle less leg B's, at twice the frequency and half sign-magnitude's height.
        let lap = bridge(HBridgeInput::signed(0.5));
        for (phase, expect) in [(0.125, -half / 2.0), (0.375, half / 2.0), (0.25, 0.0)] {
            let got = lap.ripple(24.0, l, phase);
            assert!((got - expect).abs() < 1e-12, "phase {phase}: {got} vs {expect}");
        }
        // Nothing switches: full duty, brake, coast, a fault.
        for input in [HBridgeInput::signed(1.0), HBridgeInput::brake(), HBridgeInput::coast()] {
            assert_eq!(bridge(input).ripple(24.0, l, 0.2), 0.0);
        }
        let mut f = bridge(HBridgeInput { duty_a: 0.5, duty_b: 0.0, enabled: true });
        f.fault = true;
        assert_eq!(f.ripple(24.0, l, 0.25), 0.0);
        assert_eq!(b.ripple(24.0, 0.0, 0.25), 0.0, "no inductance: no defined ripple");
    }

    #[test]
    fn the_pulse_integral_is_continuous_and_odd() {
        for d in [0.0, 0.1, 0.5, 0.95, 1.0] {
            for k in 0..=200 {
                let x = k as f64 / 200.0;
                assert!((pulse_integral(d, x) + pulse_integral(d, -x)).abs() < 1e-12, "odd");
                assert!((pulse_integral(d, x) - pulse_integral(d, x + 1e-9)).abs() < 1e-8);
            }
            assert!((pulse_integral(d, d / 2.0) - d * (1.0 - d) / 2.0).abs() < 1e-15);
            assert_eq!(pulse_integral(d, 0.5), d / 2.0 - d * 0.5);
        }
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
