//! Battery pack: open-circuit voltage against state of charge, internal resistance, capacity.
//!
//! Model: V = OCV(SOC) − R·I (I > 0 discharging), SOC falls by ∫I dt / capacity. The OCV
//! curve is the resting voltage per cell, interpolated, times the number of cells in series.
//! Not modelled: the rate dependence of capacity (Peukert), the slow voltage recovery after a
//! load step (RC branches), temperature, ageing. Below 0 % the pack holds the 0 % voltage
//! and reports itself depleted; the consumed charge keeps counting, as a coulomb counter does.

/// Cell chemistry: its resting voltage curve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Chemistry {
    /// Sealed lead–acid (2 V nominal cells; six make a 12 V block).
    LeadAcid,
    /// Lithium polymer (3.7 V nominal cells).
    LiPo,
}

/// Resting voltage of one lead–acid cell against SOC: the widely published 12 V table
/// (12.7 V full, 12.4 V at 75 %, 12.2 V at 50 %, 12.0 V at 25 %, 11.8 V empty) per cell.
const LEAD_ACID_OCV: &[(f64, f64)] = &[
    (0.00, 11.8 / 6.0),
    (0.25, 12.0 / 6.0),
    (0.50, 12.2 / 6.0),
    (0.75, 12.4 / 6.0),
    (1.00, 12.7 / 6.0),
];

/// Resting voltage of one LiPo cell against SOC (common hobby table, 3.27 V empty, 4.20 V
/// full).
const LIPO_OCV: &[(f64, f64)] = &[
    (0.00, 3.27),
    (0.05, 3.61),
    (0.10, 3.69),
    (0.20, 3.73),
    (0.30, 3.77),
    (0.40, 3.80),
    (0.50, 3.84),
    (0.60, 3.87),
    (0.70, 3.95),
    (0.80, 4.02),
    (0.90, 4.11),
    (1.00, 4.20),
];

impl Chemistry {
    /// The name the robot file uses.
    pub fn name(self) -> &'static str {
        match self {
            Chemistry::LeadAcid => "lead-acid",
            Chemistry::LiPo => "lipo",
        }
    }

    /// The chemistry called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        [Chemistry::LeadAcid, Chemistry::LiPo].into_iter().find(|c| c.name() == name)
    }

    /// Resting voltage of one cell at `soc` (clamped to 0..1).
    pub fn cell_ocv(self, soc: f64) -> f64 {
        let t = match self {
            Chemistry::LeadAcid => LEAD_ACID_OCV,
            Chemistry::LiPo => LIPO_OCV,
        };
        let s = soc.clamp(0.0, 1.0);
        let i = t.iter().position(|p| p.0 >= s).unwrap_or(t.len() - 1).max(1);
        let ((s0, v0), (s1, v1)) = (t[i - 1], t[i]);
        v0 + (v1 - v0) * (s - s0) / (s1 - s0)
    }
}

/// A pack's constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BatteryParams {
    /// Chemistry.
    pub chemistry: Chemistry,
    /// Cells in series.
    pub cells: u32,
    /// Capacity, A·h.
    pub capacity_ah: f64,
    /// Internal resistance of the pack, Ω.
    pub internal_resistance_ohm: f64,
}

/// A pack's state.
#[derive(Clone, Debug, PartialEq)]
pub struct Battery {
    /// Its constants.
    pub params: BatteryParams,
    soc: f64,
    charge_used_ah: f64,
    current: f64,
}

impl Battery {
    /// A pack at state of charge `soc` (0..1) with nothing consumed yet.
    pub fn new(params: BatteryParams, soc: f64) -> Self {
        Self { params, soc, charge_used_ah: 0.0, current: 0.0 }
    }

    /// State of charge, 0..1 (negative once depleted).
    pub fn soc(&self) -> f64 {
        self.soc
    }

    /// Whether the pack is empty.
    pub fn depleted(&self) -> bool {
        self.soc <= 0.0
    }

    /// Charge drawn since the start, A·h (what a coulomb counter would show).
    pub fn charge_used_ah(&self) -> f64 {
        self.charge_used_ah
    }

    /// Open-circuit voltage now, V.
    pub fn ocv(&self) -> f64 {
        f64::from(self.params.cells) * self.params.chemistry.cell_ocv(self.soc)
    }

    /// Terminal voltage while delivering `current` A, V.
    pub fn terminal_voltage(&self, current: f64) -> f64 {
        self.ocv() - self.params.internal_resistance_ohm * current
    }

    /// Current of the last sub-step, A.
    pub fn current(&self) -> f64 {
        self.current
    }

    /// Terminal voltage at the last sub-step's current, V.
    pub fn voltage(&self) -> f64 {
        self.terminal_voltage(self.current)
    }

    /// Delivers `charge` coulombs over `dt` seconds (an average current of charge/dt).
    pub fn draw(&mut self, charge: f64, dt: f64) {
        self.current = if dt > 0.0 { charge / dt } else { 0.0 };
        let ah = charge / 3600.0;
        self.charge_used_ah += ah;
        self.soc -= ah / self.params.capacity_ah;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pack() -> Battery {
        Battery::new(
            BatteryParams {
                chemistry: Chemistry::LeadAcid,
                cells: 12,
                capacity_ah: 12.0,
                internal_resistance_ohm: 0.04,
            },
            1.0,
        )
    }

    #[test]
    fn ocv_curves() {
        assert!((pack().ocv() - 25.4).abs() < 1e-12, "two 12.7 V blocks");
        assert!((Chemistry::LeadAcid.cell_ocv(0.5) * 12.0 - 24.4).abs() < 1e-12);
        assert!((Chemistry::LeadAcid.cell_ocv(0.625) * 6.0 - 12.3).abs() < 1e-12);
        assert!((Chemistry::LiPo.cell_ocv(1.0) * 6.0 - 25.2).abs() < 1e-12, "6S full");
        assert!((Chemistry::LiPo.cell_ocv(0.0) - 3.27).abs() < 1e-12);
        assert!((Chemistry::LiPo.cell_ocv(0.45) - 3.82).abs() < 1e-12);
        // Clamped outside 0..1.
        assert_eq!(Chemistry::LiPo.cell_ocv(-0.2), 3.27);
        assert_eq!(Chemistry::LiPo.cell_ocv(1.5), 4.2);
    }

    #[test]
    fn constant_current_discharge() {
        // 6 A for one hour from a 12 A·h pack: 6 A·h used, half charge, and the terminal
        // sits R·I = 0.24 V under the half-charge OCV (24.4 V).
        let mut b = pack();
        let dt = 0.001;
        for _ in 0..3_600_000 {
            b.draw(6.0 * dt, dt);
        }
        // 3.6 M additions of 1.7e-6 A·h: rounding ≤ n·ulp(6) ≈ 3e-9.
        assert!((b.charge_used_ah() - 6.0).abs() < 1e-8, "{}", b.charge_used_ah());
        assert!((b.soc() - 0.5).abs() < 1e-9);
        assert!((b.voltage() - (24.4 - 0.24)).abs() < 1e-7, "{}", b.voltage());
    }

    #[test]
    fn depletion_holds_empty_voltage_and_keeps_counting() {
        let mut b = pack();
        b.draw(13.0 * 3600.0, 3600.0);
        assert!(b.depleted());
        assert!((b.charge_used_ah() - 13.0).abs() < 1e-12);
        assert!((b.ocv() - 23.6).abs() < 1e-12);
    }

    #[test]
    fn charging_raises_soc() {
        let mut b = Battery::new(pack().params, 0.5);
        b.draw(-1.2 * 3600.0, 3600.0);
        assert!((b.soc() - 0.6).abs() < 1e-12);
        assert!(b.voltage() > b.ocv(), "charging current lifts the terminal above OCV");
    }
}
