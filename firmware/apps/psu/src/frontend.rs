//! The PSU's analog front end: ADC counts to volts and amps, and back (for emulated boards and
//! tests). Every constant here must match the hardware/psu schematic; the world model
//! (firmware/host/world) has the same numbers for its emulated PSU board.
//!
//! | channel | pin | front end | full scale at 3.3 V | one count |
//! |---|---|---|---|---|
//! | `VIN_SENSE` | PA0 | 150 kΩ / 10 kΩ divider (× 1/16) | 52.8 V | 12.9 mV |
//! | `IIN_SENSE` | PA1 | 10 mΩ high-side shunt × 50 V/V amplifier (INA293A2) = 0.5 V/A | 6.6 A | 1.61 mA |
//! | `VOUT_SENSE` | PA2 | 10 kΩ / 10 kΩ divider (× 1/2) | 6.6 V | 1.61 mV |
//!
//! One count is VREF/4096 at the pin (3.3 V = 4096 LSB; the ADC tops out at code 4095).
//!
//! The current amplifier is unidirectional: charging current reads as 0 A.

/// ADC reference (VDDA = VREF+ on the STM32F103CB), V. Must match hardware/psu schematic.
pub const VREF_V: f32 = 3.3;
/// Largest code of the 12-bit ADC (it saturates there).
pub const ADC_MAX: u16 = 4095;
/// Volts per code: VREF / 4096, the reference manual's ideal transfer (code k is centred on
/// k LSB), as the world model's ADC (firmware/host/world/src/adc.rs) has it.
pub const LSB_V: f32 = VREF_V / 4096.0;

/// VIN divider, top resistor (battery side), Ω. Must match hardware/psu schematic.
pub const VIN_R_TOP_OHM: f32 = 150_000.0;
/// VIN divider, bottom resistor (to ground), Ω. Must match hardware/psu schematic.
pub const VIN_R_BOTTOM_OHM: f32 = 10_000.0;
/// Battery volts per volt at the pin (16): 52.8 V full scale, above a 10S pack on its charger
/// (42.4 V, 80 % of full scale).
pub const VIN_GAIN: f32 = (VIN_R_TOP_OHM + VIN_R_BOTTOM_OHM) / VIN_R_BOTTOM_OHM;

/// Current shunt, Ω. Must match hardware/psu schematic.
pub const SHUNT_OHM: f32 = 0.010;
/// Current-sense amplifier gain, V/V (INA293A2). Must match hardware/psu schematic.
pub const IIN_AMP_GAIN: f32 = 50.0;
/// Volts at the pin per amp through the shunt (0.5 V/A).
pub const IIN_V_PER_A: f32 = SHUNT_OHM * IIN_AMP_GAIN;

/// VOUT divider, top resistor (bus side), Ω. Must match hardware/psu schematic.
pub const VOUT_R_TOP_OHM: f32 = 10_000.0;
/// VOUT divider, bottom resistor, Ω. Must match hardware/psu schematic.
pub const VOUT_R_BOTTOM_OHM: f32 = 10_000.0;
/// Bus volts per volt at the pin (2).
pub const VOUT_GAIN: f32 = (VOUT_R_TOP_OHM + VOUT_R_BOTTOM_OHM) / VOUT_R_BOTTOM_OHM;

/// Volts at an ADC pin for a code (codes above [`ADC_MAX`] read as full scale).
pub fn pin_volts(counts: u16) -> f32 {
    f32::from(counts.min(ADC_MAX)) * LSB_V
}

/// The ADC code for `volts` at the pin: rounded to the nearest code, clamped to 0…4095.
pub fn pin_counts(volts: f32) -> u16 {
    let code = volts / LSB_V + 0.5;
    if code.is_nan() || code <= 0.0 {
        0
    } else if code >= ADC_MAX as f32 {
        ADC_MAX
    } else {
        code as u16
    }
}

/// Battery voltage from a `VIN_SENSE` code, V (uncalibrated).
pub fn vin_volts(counts: u16) -> f32 {
    pin_volts(counts) * VIN_GAIN
}

/// Battery current from an `IIN_SENSE` code, A (uncalibrated).
pub fn iin_amps(counts: u16) -> f32 {
    pin_volts(counts) / IIN_V_PER_A
}

/// Bus voltage from a `VOUT_SENSE` code, V (uncalibrated).
pub fn vout_volts(counts: u16) -> f32 {
    pin_volts(counts) * VOUT_GAIN
}

/// The `VIN_SENSE` code a battery at `volts` gives.
pub fn vin_counts(volts: f32) -> u16 {
    pin_counts(volts / VIN_GAIN)
}

/// The `IIN_SENSE` code a battery current of `amps` gives (negative reads 0).
pub fn iin_counts(amps: f32) -> u16 {
    pin_counts(amps * IIN_V_PER_A)
}

/// The `VOUT_SENSE` code a bus at `volts` gives.
pub fn vout_counts(volts: f32) -> u16 {
    pin_counts(volts / VOUT_GAIN)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_scale_matches_the_front_end_math() {
        // 3.3 V at the pin (4096 LSB): 52.8 V battery, 6.6 A, 6.6 V bus.
        assert!((VIN_GAIN * 4096.0 * LSB_V - 52.8).abs() < 1e-4);
        assert!((4096.0 * LSB_V / IIN_V_PER_A - 6.6).abs() < 1e-4);
        assert!((VOUT_GAIN * 4096.0 * LSB_V - 6.6).abs() < 1e-5);
        // The top code is one LSB below.
        assert!((vin_volts(4095) - 52.787).abs() < 1e-3);
        assert_eq!(vin_volts(0), 0.0);
        assert_eq!(pin_volts(5000), pin_volts(4095), "codes above full scale saturate");
    }

    #[test]
    fn a_count_is_the_stated_resolution() {
        assert!((vin_volts(1) - 0.012_891).abs() < 1e-6);
        assert!((iin_amps(1) - 0.001_611).abs() < 1e-6);
        assert!((vout_volts(1) - 0.001_611).abs() < 1e-6);
    }

    #[test]
    fn conversions_round_trip_within_half_a_count() {
        for v in [6.0f32, 7.4, 12.0, 24.0, 36.0, 42.4] {
            assert!((vin_volts(vin_counts(v)) - v).abs() <= 0.5 * vin_volts(1) + 1e-5, "{v} V");
        }
        for a in [0.0f32, 0.1, 2.0, 3.2, 6.5] {
            assert!((iin_amps(iin_counts(a)) - a).abs() <= 0.5 * iin_amps(1) + 1e-5, "{a} A");
        }
        assert_eq!(vout_counts(5.0), 3103); // 2.5 V at the pin: 3103.03 LSB
        assert_eq!(iin_counts(-1.0), 0);
        assert_eq!(vin_counts(55.0), 4095);
        assert_eq!(pin_counts(f32::NAN), 0);
    }
}
