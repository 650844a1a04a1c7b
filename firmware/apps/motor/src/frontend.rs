//! The analog front end: ADC counts to amperes and volts, and back (for emulated boards).
//!
//! **Must match hardware/motor schematic** (and the world model's constants in
//! firmware/host/world/src/frontends.rs: `MOTOR_CURRENT`, `VMOT_SENSE`): the Hall-effect current
//! sensor, the motor-supply divider and the ADC reference. The Hall sensor's sensitivity is also a parameter (`hall_mv_per_a`) so another
//! sensor variant needs no new firmware; its zero is calibrated at start-up.

/// ADC resolution: 12 bits, one count = `VREF_MV / ADC_COUNTS` (STM32F1 ADC, right aligned).
pub const ADC_COUNTS: u16 = 4096;
/// ADC reference (VDDA = VREF+ = the 3.3 V rail on the F103CB in LQFP-48), mV.
pub const VREF_MV: f32 = 3300.0;
/// Hall sensor fitted (hardware/motor, U102): Allegro ACS725LLCTR-30AB-T, ±30 A, supplied from
/// the same 3.3 V rail as VDDA (ratiometric: its zero and gain track the ADC reference).
pub const HALL_SENSOR: &str = "ACS725LLCTR-30AB-T";
/// Its sensitivity at 3.3 V, mV/A: the default of the `hall_mv_per_a` parameter (±30 A is
/// ±1.32 V around mid-scale; one ADC count is 18 mA).
pub const HALL_MV_PER_A: f32 = 44.0;
/// Its output at 0 A is VCC/2: mid-scale, in ADC counts.
pub const HALL_ZERO_COUNTS: u16 = ADC_COUNTS / 2;
/// Largest distance of the calibrated zero from mid-scale (±120 mV, ±1.3 A: the sensor's
/// zero error is ±1.5 % of VCC): further away, the sensor is missing or broken.
pub const HALL_ZERO_TOLERANCE: u16 = 150;
/// Motor-supply divider VMOT → VMOT_SENSE: 150 kΩ over 10 kΩ (÷16: 24 V → 1.5 V, full scale
/// 52.8 V, above the 36 V input's regeneration and ringing; the PSU's VIN_SENSE parts).
pub const VMOT_DIVIDER_TOP_OHM: f32 = 150_000.0;
/// Lower resistor of the VMOT divider.
pub const VMOT_DIVIDER_BOTTOM_OHM: f32 = 10_000.0;
/// VMOT / VMOT_SENSE.
pub const VMOT_RATIO: f32 =
    (VMOT_DIVIDER_TOP_OHM + VMOT_DIVIDER_BOTTOM_OHM) / VMOT_DIVIDER_BOTTOM_OHM;

const MV_PER_COUNT: f32 = VREF_MV / ADC_COUNTS as f32;
const VMOT_V_PER_COUNT: f32 = MV_PER_COUNT * VMOT_RATIO / 1000.0;

/// Motor current, A, from the sensor's ADC counts, the calibrated zero (counts) and the
/// sensitivity (mV/A). Positive current drives the motor forward (positive duty).
pub fn amps(counts: u16, zero: f32, mv_per_a: f32) -> f32 {
    (f32::from(counts) - zero) * MV_PER_COUNT / mv_per_a
}

/// Motor supply, V, from VMOT_SENSE's ADC counts.
pub fn vmot_volts(counts: u16) -> f32 {
    f32::from(counts) * VMOT_V_PER_COUNT
}

/// The ADC counts the current sensor gives for `amps` with zero at `zero` counts (rounded,
/// clipped to the ADC's range): what an emulated board feeds the application.
pub fn current_counts(amps: f32, zero: f32, mv_per_a: f32) -> u16 {
    to_counts(zero + amps * mv_per_a / MV_PER_COUNT)
}

/// The ADC counts VMOT_SENSE gives for a motor supply of `volts` (rounded, clipped).
pub fn vmot_counts(volts: f32) -> u16 {
    to_counts(volts / VMOT_V_PER_COUNT)
}

fn to_counts(x: f32) -> u16 {
    let max = f32::from(ADC_COUNTS - 1);
    // `as` saturates and maps NaN to 0; round half away from zero by hand (no libm).
    (x.clamp(0.0, max) + 0.5) as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_invert_each_other_within_one_count() {
        for a in [-30.0f32, -15.0, -10.0, -0.5, 0.0, 0.5, 10.0, 15.0, 30.0] {
            let c = current_counts(a, 2048.0, HALL_MV_PER_A);
            assert!((amps(c, 2048.0, HALL_MV_PER_A) - a).abs() <= 0.5 * MV_PER_COUNT / 44.0 + 1e-5);
        }
        // 24 V → 24 / 16 = 1.5 V → 1862 counts (as the world model's ADC reads it).
        assert_eq!(vmot_counts(24.0), 1862);
        assert!((vmot_volts(1862) - 24.0).abs() < 0.02);
        // One count of current is 0.806 mV / 44 mV/A = 18.3 mA.
        assert!((amps(2049, 2048.0, 44.0) - 0.018_310).abs() < 1e-6);
        // ±30 A stays inside the ADC's range (the sensor's ±30 A is its linear range).
        assert!((1..4095).contains(&current_counts(30.0, 2048.0, 44.0)));
        assert!((1..4095).contains(&current_counts(-30.0, 2048.0, 44.0)));
        assert_eq!(current_counts(1000.0, 2048.0, 44.0), 4095, "clipped at full scale");
        assert_eq!(current_counts(-1000.0, 2048.0, 44.0), 0);
    }
}
