//! A brushed DC motor behind an H-bridge, with a gearbox, a quadrature encoder and the Hall
//! current sensor, simulated in f64 with 10 µs steps (its electrical time constant is 0.19 ms).
//!
//! Triskar2's drive as the world model (firmware/host/world, robots/triskar2.toml) has it:
//! maxon RE 35 24 V (R = 0.611 Ω, L = 0.119 mH, k = 0.0302 N·m/A, no-load current 0.137 A
//! split into viscous and Coulomb friction), 15:1 gearbox (taken lossless here), 500-line
//! encoder (2000 counts per motor turn), 24 V. Inertia at the motor shaft 8e-5 kg·m²
//! (assumed: the rotor's 6.5e-6 plus a third of the 20 kg base at a 5 cm wheel through 15:1).
//! No-load output speed 24 / 0.0302 / 15 = 53 rad/s; stall current 39 A (so the current limit
//! matters).

use r2p_app_motor::frontend;
use r2p_app_motor::{Command, Sample};
use std::f64::consts::TAU;

#[derive(Clone, Debug)]
pub struct Motor {
    pub r: f64,
    pub l: f64,
    pub k: f64,
    pub j: f64,
    pub b: f64,
    /// Coulomb (brush) friction, N·m, smoothed over ±0.5 rad/s as the world model does.
    pub coulomb: f64,
    pub gear: f64,
    pub counts_per_rev: f64,
    pub vbus: f64,
    /// Load torque at the output shaft, N·m (opposes positive rotation when positive).
    pub load: f64,
    /// The rotor is blocked.
    pub stalled: bool,
    /// The encoder cable is connected (unplugged: the count freezes).
    pub encoder_connected: bool,
    /// The Hall sensor's output at 0 A, ADC counts.
    pub hall_zero: f64,
    /// State: current (A), motor speed (rad/s), motor angle (rad).
    pub i: f64,
    pub w: f64,
    pub theta: f64,
    frozen_count: u16,
    /// Largest |current| seen since the last reset of this field.
    pub peak_current: f64,
}

impl Default for Motor {
    fn default() -> Self {
        Self {
            r: 0.611,
            l: 0.119e-3,
            k: 0.0302,
            j: 8e-5,
            b: 0.0302 * 0.137 / 2.0 / 792.0,
            coulomb: 0.0302 * 0.137 / 2.0,
            gear: 15.0,
            counts_per_rev: 2000.0,
            vbus: 24.0,
            load: 0.0,
            stalled: false,
            encoder_connected: true,
            hall_zero: 2048.0,
            i: 0.0,
            w: 0.0,
            theta: 0.0,
            frozen_count: 0,
            peak_current: 0.0,
        }
    }
}

impl Motor {
    pub fn count(&self) -> u16 {
        ((self.theta / TAU * self.counts_per_rev).floor() as i64) as u16
    }

    pub fn sample(&mut self) -> Sample {
        if self.encoder_connected {
            self.frozen_count = self.count();
        }
        Sample {
            encoder_count: self.frozen_count,
            current_adc: frontend::current_counts(
                self.i as f32,
                self.hall_zero as f32,
                frontend::HALL_MV_PER_A,
            ),
            vmot_adc: frontend::vmot_counts(self.vbus as f32),
            ..Default::default()
        }
    }

    pub fn output_speed(&self) -> f64 {
        self.w / self.gear
    }

    pub fn output_position(&self) -> f64 {
        self.theta / self.gear
    }

    /// Applies `cmd` for `dt` seconds.
    pub fn advance(&mut self, cmd: &Command, dt: f64) {
        const H: f64 = 1e-5;
        let n = (dt / H).round() as usize;
        let duty = f64::from(cmd.duty).clamp(-1.0, 1.0);
        for _ in 0..n {
            let emf = self.k * self.w;
            if !cmd.bridge_enable {
                // Every switch open: a current flows on through the body diodes against the
                // supply until it reaches zero; then the motor is open-circuit.
                if self.i != 0.0 {
                    let v = -self.i.signum() * self.vbus;
                    let next = self.i + H * (v - self.r * self.i - emf) / self.l;
                    self.i = if next.signum() != self.i.signum() { 0.0 } else { next };
                }
            } else {
                let v = if cmd.brake { 0.0 } else { duty * self.vbus };
                self.i += H * (v - self.r * self.i - emf) / self.l;
            }
            self.peak_current = self.peak_current.max(self.i.abs());
            if self.stalled {
                self.w = 0.0;
            } else {
                let friction = self.b * self.w + self.coulomb * (self.w / 0.5).tanh();
                let torque = self.k * self.i - friction - self.load / self.gear;
                self.w += H * torque / self.j;
            }
            self.theta += H * self.w;
        }
    }
}
