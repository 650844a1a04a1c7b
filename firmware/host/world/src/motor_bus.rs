//! The motor boards' supply (VMOT): their leads to the battery, their bulk capacitors, their own
//! draw, and the over-voltage comparator that coasts the bridges.
//!
//! Normally the leads go straight to the battery, which is stiff (tens of mΩ) against the
//! boards' bulk capacitors: VMOT is the battery's terminal voltage, and braking current flows
//! back into it (charging). A supply that cannot sink is the other case the motor board must
//! survive (hardware/motor, decision 2: a charger or a bench supply, an OR-ing diode, the
//! battery lead pulled): then regenerated current has nowhere to go but the bulk capacitors,
//! which charge until the over-voltage comparator (TLV3011 → DRV_FAULT → TIM1_BKIN) turns every
//! switch off. [`MotorSupply::SourceOnly`] models it as a diode in the leads: it conducts while
//! the bus would fall below the battery less its drop, and blocks otherwise, the bus then being
//! the capacitors' charge over their capacitance.
//!
//! Not modelled: the leads' inductance and the capacitors' ESR (the 0.2 V p-p input ripple of
//! calc/motor.py: VMOT_SENSE reads the average), the TVS (SMCJ45A: 50 V breakdown minimum, above
//! the trip; it only matters once the trip has failed), the comparator's offset and tolerances
//! (the trip is taken at its nominal 47.8 V).

/// Bulk capacitance of one motor board, F: C101–C104, 4 × 1000 µF 63 V (hardware/motor; nominal,
/// calc/motor.py takes −20 % for its worst case).
pub const BOARD_BULK_F: f64 = 4.0 * 1000e-6;

/// What one motor board draws from VMOT by itself, A: the HIP4082's VDD through the Q106
/// emitter follower on its 13 V zener (calc/motor.py, row "Q106 dissipation at the over-voltage
/// trip": 8.7 mA) and the VMOT_SENSE and over-voltage dividers (160 kΩ and 385 kΩ: 0.4 mA at
/// 44 V; taken as constant).
pub const BOARD_LOAD_A: f64 = 0.0091;

/// VMOT at which the board's over-voltage comparator pulls DRV_FAULT low, V: TLV3011's 1.242 V
/// reference over 375 kΩ / 10 kΩ (calc/motor.py: 47.8 V nominal, 46.4–49.2 V with its ±1 %
/// reference and 1 % resistors). No hysteresis on revision A: it releases below the same
/// voltage (TIM1's break latches in the MCU until the firmware re-arms it).
pub const OVER_VOLTAGE_TRIP_V: f64 = 1.242 * (1.0 + 375e3 / 10e3);

/// Gate-driver under-voltage lockout: below this supply the bridge turns off and DRV_FAULT
/// is asserted (assumed, typical of 12–36 V gate drivers).
pub const DRIVER_UVLO_V: f64 = 6.0;

/// How the motor boards' supply leads reach the battery.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MotorSupply {
    /// Straight to the battery, which takes braking current back (it charges).
    Battery,
    /// Through a diode of forward drop `drop_v` (V): a supply that cannot sink. Braking current
    /// charges the bulk capacitors.
    SourceOnly {
        /// Forward drop, V (a Schottky: about 0.5 V; an ideal-diode controller: about 0.02 V).
        drop_v: f64,
    },
}

/// The motor boards' common supply node.
#[derive(Clone, Debug, PartialEq)]
pub struct MotorBus {
    /// How its leads reach the battery.
    pub supply: MotorSupply,
    /// The boards' bulk capacitors in parallel, F.
    pub capacitance_f: f64,
    /// The boards' own draw, A.
    pub load_a: f64,
    volts: f64,
}

impl MotorBus {
    /// The bus of `boards` motor boards, on the battery, charged to `volts`.
    pub fn new(boards: usize, volts: f64) -> Self {
        Self {
            supply: MotorSupply::Battery,
            capacitance_f: boards as f64 * BOARD_BULK_F,
            load_a: boards as f64 * BOARD_LOAD_A,
            volts,
        }
    }

    /// VMOT at the end of the last sub-step, V.
    pub fn volts(&self) -> f64 {
        self.volts
    }

    /// Whether the drivers are off on this bus voltage: under-voltage lockout or the
    /// over-voltage comparator (DRV_FAULT low).
    pub fn driver_off(&self) -> bool {
        self.volts < DRIVER_UVLO_V || self.volts >= OVER_VOLTAGE_TRIP_V
    }

    /// The current the leads draw from the battery over a sub-step of `h` s in which the
    /// bridges and the boards take `load_a` (negative: braking), with the battery's terminal
    /// at `battery_v` (the last sub-step's); `None` while a diode blocks.
    pub fn lead_current(&self, load_a: f64, h: f64, battery_v: f64) -> Option<f64> {
        match self.supply {
            MotorSupply::Battery => Some(load_a),
            MotorSupply::SourceOnly { drop_v } => {
                let held = self.volts - load_a * h / self.capacitance_f;
                (held <= battery_v - drop_v).then_some(load_a.max(0.0))
            }
        }
    }

    /// The battery as the loads on its terminal see it over a sub-step of `h` s, (open-circuit
    /// voltage, resistance), with the bulk capacitors on that node while the leads conduct:
    /// implicit Euler makes them a conductance C/h to their present voltage in parallel with
    /// the battery's `ocv` behind `r`. A stiff battery and 4 mF per board form a time constant
    /// of a fraction of a millisecond (0.48 ms for three boards on 40 mΩ), so they smooth the
    /// terminal's steps and their charge is part of the battery's current.
    pub fn source(&self, conducting: bool, ocv: f64, r: f64, h: f64) -> (f64, f64) {
        if !conducting || r <= 0.0 || h <= 0.0 {
            return (ocv, r);
        }
        let drop = match self.supply {
            MotorSupply::Battery => 0.0,
            MotorSupply::SourceOnly { drop_v } => drop_v,
        };
        let g = 1.0 / r + self.capacitance_f / h;
        ((ocv / r + self.capacitance_f * (self.volts + drop) / h) / g, 1.0 / g)
    }

    /// VMOT during the sub-step: the battery's terminal `battery_v` (less the diode) while the
    /// leads conduct, the capacitors' voltage while they block.
    pub fn voltage(&self, conducting: bool, battery_v: f64) -> f64 {
        match (self.supply, conducting) {
            (MotorSupply::Battery, _) => battery_v,
            (MotorSupply::SourceOnly { drop_v }, true) => battery_v - drop_v,
            (MotorSupply::SourceOnly { .. }, false) => self.volts,
        }
    }

    /// Ends the sub-step: the bus follows the battery at `volts` while conducting, or loses
    /// `charge_out` (C, drawn by the bridges and the boards; negative: returned) from its
    /// capacitors while blocked. Returns the charge its capacitors took from the leads (C).
    pub fn settle(&mut self, conducting: bool, volts: f64, charge_out: f64) -> f64 {
        if conducting {
            let taken = self.capacitance_f * (volts - self.volts);
            self.volts = volts;
            taken
        } else {
            self.volts -= charge_out / self.capacitance_f;
            0.0
        }
    }

    /// Energy in the bulk capacitors, J.
    pub fn stored_energy_j(&self) -> f64 {
        0.5 * self.capacitance_f * self.volts * self.volts
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_trip_is_the_boards_nominal_47_8_v() {
        assert!((OVER_VOLTAGE_TRIP_V - 47.817).abs() < 1e-3, "{OVER_VOLTAGE_TRIP_V}");
        let mut b = MotorBus::new(1, 47.0);
        assert!(!b.driver_off());
        b.settle(false, 0.0, -0.004 * 0.9);
        assert!(b.volts() >= OVER_VOLTAGE_TRIP_V && b.driver_off(), "{}", b.volts());
        assert!(MotorBus::new(1, 5.9).driver_off(), "under-voltage lockout");
    }

    #[test]
    fn on_the_battery_the_bus_follows_it_and_regeneration_flows_back() {
        let b = MotorBus::new(3, 24.0);
        assert_eq!((b.capacitance_f, b.load_a), (0.012, 3.0 * 0.0091));
        assert_eq!(b.lead_current(-8.0, 50e-6, 24.3), Some(-8.0));
        assert_eq!(b.voltage(true, 24.3), 24.3);
    }

    #[test]
    fn the_capacitors_smooth_the_battery_while_the_leads_conduct() {
        // 12 mF at 24 V on a 25 V, 40 mΩ battery for 50 µs: conductances 25 S and 240 S.
        let b = MotorBus::new(3, 24.0);
        let (v, r) = b.source(true, 25.0, 0.04, 50e-6);
        assert!((r - 1.0 / 265.0).abs() < 1e-12 && (v - (625.0 + 5760.0) / 265.0).abs() < 1e-9);
        assert_eq!(b.source(false, 25.0, 0.04, 50e-6), (25.0, 0.04), "blocked: the battery alone");
        assert_eq!(b.source(true, 25.0, 0.0, 50e-6), (25.0, 0.0), "an ideal source holds it");
    }

    #[test]
    fn behind_a_diode_braking_charges_the_capacitors() {
        let mut b = MotorBus::new(1, 24.0);
        b.supply = MotorSupply::SourceOnly { drop_v: 0.5 };
        // Driving from a bus at the battery less the drop: the diode conducts.
        let settled = b.volts();
        b.settle(true, 23.5, 0.0);
        assert_eq!(b.lead_current(5.0, 50e-6, 24.0), Some(5.0));
        assert_eq!(b.voltage(true, 24.0), 23.5);
        // Braking: 10 A back for 1 ms lifts 4 mF by 2.5 V; the diode blocks meanwhile.
        assert_eq!(b.lead_current(-10.0, 50e-6, 24.0), None);
        for _ in 0..20 {
            assert_eq!(b.voltage(false, 24.0), b.volts());
            assert_eq!(b.settle(false, 24.0, -10.0 * 50e-6), 0.0);
        }
        assert!((b.volts() - 26.0).abs() < 1e-9, "{}", b.volts());
        // Above the battery, a small load is served by the capacitors, not the battery.
        assert_eq!(b.lead_current(1.0, 50e-6, 24.0), None);
        // The charge the capacitors took from the leads while following the battery.
        let mut c = MotorBus::new(1, settled);
        assert!((c.settle(true, 25.0, 0.0) - 0.004).abs() < 1e-12);
        assert!((c.stored_energy_j() - 0.5 * 0.004 * 625.0).abs() < 1e-12);
    }
}
