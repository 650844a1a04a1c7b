//! The PSU module's power path: a buck converter from the battery to the 5 V bus, behind an
//! output switch with a current limit.
//!
//! Model: the converter regulates 5.0 V exactly while its input is at least 5.5 V, drawing
//! P_out/η from the battery (η constant); below 5.5 V it drops out and the bus is off. The
//! output switch (BUS_EN) trips when the bus load exceeds its limit (2.65 A nominal) and stays off, with BUS_FAULT
//! asserted, until BUS_EN is cycled (latch-off, as the eFuse class of switch does). The bus
//! load is the modules' own consumption (robot file) plus the rangers powered from it.

/// Constants of the PSU's power path (hardware/psu revision B: 6–42 V in, 5 V / 2.4 A out,
/// eFuse limit 2.41–2.89 A).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PsuParams {
    /// Regulated bus voltage, V.
    pub bus_voltage_v: f64,
    /// Converter efficiency (assumed 85 %, a synchronous buck at 24 V → 5 V, 1 A).
    pub efficiency: f64,
    /// Lowest input the converter regulates from, V.
    pub min_input_v: f64,
    /// Output switch current limit, A.
    pub current_limit_a: f64,
}

impl PsuParams {
    /// The R2P PSU module.
    pub const R2P: PsuParams =
        PsuParams { bus_voltage_v: 5.0, efficiency: 0.85, min_input_v: 5.5, current_limit_a: 2.65 };
}

/// State of the PSU's power path.
#[derive(Clone, Debug, PartialEq)]
pub struct Psu {
    /// Its constants.
    pub params: PsuParams,
    enabled: bool,
    tripped: bool,
    /// Whether the converter had enough input at the last sub-step.
    input_ok: bool,
}

impl Psu {
    /// A PSU with its output switch on (BUS_EN's reset state is high).
    pub fn new(params: PsuParams) -> Self {
        Self { params, enabled: true, tripped: false, input_ok: true }
    }

    /// BUS_EN: switches the output on or off; switching off clears a trip.
    pub fn set_enabled(&mut self, on: bool) {
        if !on {
            self.tripped = false;
        }
        self.enabled = on;
    }

    /// Whether BUS_EN is on.
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Whether the output switch has tripped on over-current (BUS_FAULT asserted).
    pub fn tripped(&self) -> bool {
        self.tripped
    }

    /// Whether the bus is powered.
    pub fn output_on(&self) -> bool {
        self.enabled && !self.tripped && self.input_ok
    }

    /// Bus voltage, V.
    pub fn bus_voltage(&self) -> f64 {
        if self.output_on() {
            self.params.bus_voltage_v
        } else {
            0.0
        }
    }

    /// Trips the switch if `load_a` exceeds its limit.
    pub fn check_load(&mut self, load_a: f64) {
        if self.enabled && load_a > self.params.current_limit_a {
            self.tripped = true;
        }
    }

    /// Power the converter would draw from its input for `load_a` on the bus, W.
    pub fn input_power(&self, load_a: f64) -> f64 {
        if self.enabled && !self.tripped {
            self.params.bus_voltage_v * load_a / self.params.efficiency
        } else {
            0.0
        }
    }

    /// Records whether the converter's input can sustain it this sub-step.
    pub fn set_input_ok(&mut self, ok: bool) {
        self.input_ok = ok;
    }
}

/// Battery terminal voltage with a motor load `motor_a` (A) and a constant-power load
/// `power_w` (W, the converter) on a source of open-circuit voltage `ocv` and resistance
/// `r`: the larger root of V² − (ocv − r·I)V + r·P = 0. `None` if the source cannot deliver
/// that power (the converter then drops out).
pub fn supply_voltage(ocv: f64, r: f64, motor_a: f64, power_w: f64) -> Option<f64> {
    let b = ocv - r * motor_a;
    let disc = b * b - 4.0 * r * power_w;
    (disc >= 0.0).then(|| (b + disc.sqrt()) / 2.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_power_load_on_a_resistive_source() {
        // 24 V, 0.04 Ω, 2 A of motors and 10 W: V·(24 − 0.04·2 − V)/0.04 = 10 → V ≈ 23.90.
        let v = supply_voltage(24.0, 0.04, 2.0, 10.0).unwrap();
        let i = 2.0 + 10.0 / v;
        assert!((v - (24.0 - 0.04 * i)).abs() < 1e-12, "{v}");
        // No resistance: the OCV.
        assert_eq!(supply_voltage(24.0, 0.0, 50.0, 100.0), Some(24.0));
        // More power than the source's maximum b²/(4r) = 3600 W: drops out.
        assert_eq!(supply_voltage(24.0, 0.04, 0.0, 3700.0), None);
    }

    #[test]
    fn switch_trips_and_latches_until_cycled() {
        let mut p = Psu::new(PsuParams::R2P);
        assert_eq!(p.bus_voltage(), 5.0);
        // 1 A on the bus: 5 W / 0.85 from the battery.
        assert!((p.input_power(1.0) - 5.0 / 0.85).abs() < 1e-12);
        p.check_load(4.5);
        assert!(p.tripped() && p.bus_voltage() == 0.0 && p.input_power(1.0) == 0.0);
        p.check_load(0.5);
        assert!(p.tripped(), "latched");
        p.set_enabled(false);
        p.set_enabled(true);
        assert!(!p.tripped() && p.bus_voltage() == 5.0);
        p.set_input_ok(false);
        assert_eq!(p.bus_voltage(), 0.0, "brown-out");
    }
}
