//! Board-side analog front ends: how each module's board turns a quantity of the world into
//! the voltage on an MCU pin.
//!
//! **These values must match the schematics** (`hardware/psu/psu.kicad_sch`,
//! `hardware/motor/motor.kicad_sch`, `hardware/proximity/proximity.kicad_sch`): a resistor
//! changed there must be changed here, or the emulated boards read a different robot from the
//! one that is built. Dividers are taken as ideal (the ADC's sampling time is long enough for
//! their source impedance); amplifier outputs swing rail to rail on 3.3 V.

use crate::adc::Adc;
use crate::current_sensor::{HallCurrentSensor, HallSensorParams};

/// A resistive divider from a node to ground, tapped between `top_ohm` and `bottom_ohm`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Divider {
    /// Upper resistor (node to tap), Ω.
    pub top_ohm: f64,
    /// Lower resistor (tap to ground), Ω.
    pub bottom_ohm: f64,
}

impl Divider {
    /// Tap voltage per volt at the node.
    pub fn ratio(&self) -> f64 {
        self.bottom_ohm / (self.top_ohm + self.bottom_ohm)
    }

    /// Tap voltage for `volts` at the node.
    pub fn output(&self, volts: f64) -> f64 {
        volts * self.ratio()
    }

    /// Node voltage that puts `vref` on the tap (the ADC's full scale), V.
    pub fn full_scale(&self, vref: f64) -> f64 {
        vref / self.ratio()
    }
}

/// Every module's ADC (STM32F103, 12 bits, 3.3 V reference).
pub const ADC: Adc = Adc::STM32F103;

/// PSU `VIN_SENSE`: battery voltage through 150 kΩ / 10 kΩ (÷16): 52.8 V full scale, above
/// the PSU's 42.4 V maximum input (revision B).
pub const VIN_SENSE: Divider = Divider { top_ohm: 150e3, bottom_ohm: 10e3 };

/// PSU `IIN_SENSE`: the PSU's input current (from the battery) through a 10 mΩ high-side shunt...
pub const IIN_SHUNT_OHM: f64 = 0.010;
/// ...amplified 50 V/V by an INA293A2 (0.5 V/A, 6.6 A full scale). Unidirectional: a charging (negative)
/// current reads 0 V.
pub const IIN_GAIN: f64 = 50.0;

/// PSU `IIN_SENSE` voltage for battery current `amps`.
pub fn iin_sense(amps: f64) -> f64 {
    (amps * IIN_SHUNT_OHM * IIN_GAIN).clamp(0.0, ADC.vref)
}

/// PSU `VOUT_SENSE`: the 5 V bus through 10 kΩ / 10 kΩ (÷2).
pub const VOUT_SENSE: Divider = Divider { top_ohm: 10e3, bottom_ohm: 10e3 };

/// Motor `VMOT_SENSE`: the motor supply (battery) through 150 kΩ / 10 kΩ (÷16; hardware/motor).
pub const VMOT_SENSE: Divider = Divider { top_ohm: 150e3, bottom_ohm: 10e3 };

/// Motor `MOTOR_CURRENT`: an ACS725 ±30 A Hall sensor in the motor lead (hardware/motor, U102),
/// on 3.3 V, its output straight to the pin (0 A at 1.65 V, 44 mV/A).
pub const MOTOR_CURRENT: HallCurrentSensor =
    HallCurrentSensor { params: HallSensorParams::ACS725_30AB, vcc: 3.3 };

/// Proximity `PROX_CH0..3`: each sensor output straight to the pin, with a 100 kΩ pull-down
/// that holds an unconnected (or unpowered) channel at 0 V. The sensors' outputs stay below
/// 3.3 V (Sharp ≤ 3.2 V, MaxSonar ≤ 2.5 V at 5 V), so there is no divider.
pub const PROX_PULLDOWN_OHM: f64 = 100e3;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_scales() {
        assert!((VIN_SENSE.full_scale(3.3) - 52.8).abs() < 1e-12);
        assert!((VMOT_SENSE.full_scale(3.3) - 52.8).abs() < 1e-12);
        assert!((VOUT_SENSE.output(5.0) - 2.5).abs() < 1e-12);
        assert!((iin_sense(2.0) - 1.0).abs() < 1e-12);
        assert_eq!(iin_sense(20.0), 3.3, "clips at 13.2 A");
        assert_eq!(iin_sense(-2.0), 0.0, "unidirectional");
        // ADC codes of the nominal values: 24 V → 1.5 V → 1862; 5 V bus → 3103.
        assert_eq!(ADC.convert_ideal(VIN_SENSE.output(24.0)), 1862);
        assert_eq!(ADC.convert_ideal(VOUT_SENSE.output(5.0)), 3103);
    }
}
