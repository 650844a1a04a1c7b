//! The proximity module's analog inputs: ADC counts to sensor volts, and back (for emulated
//! boards and tests). Every constant here must match the hardware/proximity schematic; the
//! world model (firmware/host/world) has the same numbers for its emulated board.
//!
//! Each channel's connector brings the sensor's 5 V (switched by `SENSOR_PWR_EN`), ground and
//! its analog output, which goes straight to an ADC pin (PA0–PA3) with a 100 kΩ pull-down: an
//! empty connector reads 0 V. Every supported sensor's output stays below 3.3 V at 5 V supply
//! (Sharp peak ~3.1 V, MaxSonar 2.48 V at 254 in), so there is no divider.

/// ADC reference (VDDA), V. Must match hardware/proximity schematic.
pub const VREF_V: f32 = 3.3;
/// Largest code of the 12-bit ADC.
pub const ADC_MAX: u16 = 4095;
/// Volts per code: VREF / 4096 (reference manual; as the world model's ADC).
pub const LSB_V: f32 = VREF_V / 4096.0;
/// Sensor volts per volt at the pin (no divider). Must match hardware/proximity schematic.
pub const INPUT_GAIN: f32 = 1.0;
/// Pull-down on each input, Ω: holds an empty channel at 0 V. Must match hardware/proximity
/// schematic.
pub const PULL_DOWN_OHM: f32 = 100_000.0;
/// The sensors' supply, V: the one the datasheet curves assume (the MaxSonar's output scales
/// with it). Must match hardware/proximity schematic.
pub const SENSOR_SUPPLY_V: f32 = r2p_drivers::rangers::SUPPLY_V;

/// Sensor output volts for a code.
pub fn volts(counts: u16) -> f32 {
    f32::from(counts.min(ADC_MAX)) * LSB_V * INPUT_GAIN
}

/// The code a sensor output of `volts` gives (nearest, clamped to 0…4095).
pub fn counts(volts: f32) -> u16 {
    let code = volts / INPUT_GAIN / LSB_V + 0.5;
    if code.is_nan() || code <= 0.0 {
        0
    } else if code >= ADC_MAX as f32 {
        ADC_MAX
    } else {
        code as u16
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_and_volts() {
        assert_eq!(counts(1.65), 2048);
        assert!((volts(2048) - 1.65).abs() < 1e-6);
        assert_eq!(counts(3.5), 4095);
        assert_eq!(counts(-0.1), 0);
        for v in [0.03f32, 0.4, 1.3, 2.3, 3.1] {
            assert!((volts(counts(v)) - v).abs() <= LSB_V / 2.0 + 1e-6, "{v}");
        }
    }
}
