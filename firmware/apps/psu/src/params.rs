//! The PSU's parameters: the table the node serves over the bus (PARAM_GET / PARAM_SET, ranges
//! checked by the store) and the [`Config`] the application reads from it every step.

use r2p_module::param_doc::{boot, doc, ParamDoc};
use r2p_node::{Param, ParamStore, Typed};

/// Module instance: selects the node name and topic prefix from [`crate::NAMES`] (at boot).
pub const INSTANCE: u16 = 0;
/// Battery capacity, Ah; 0 = unknown.
pub const CAPACITY_AH: u16 = 1;
/// `battery` publication rate, Hz.
pub const BATTERY_RATE_HZ: u16 = 2;
/// Time constant of the reported voltage and current, ms.
pub const FILTER_TAU_MS: u16 = 3;
/// Over-current threshold, A.
pub const OC_THRESHOLD_A: u16 = 4;
/// How long the current must stay above the threshold to trip, ms.
pub const OC_TIME_MS: u16 = 5;
/// Under-voltage threshold, V.
pub const UV_THRESHOLD_V: u16 = 6;
/// Under-voltage hysteresis, V.
pub const UV_HYSTERESIS_V: u16 = 7;
/// Deadline of the `event` topic's SRT messages, ms (at boot).
pub const EVENT_DEADLINE_MS: u16 = 8;
/// Calibration gain of the battery voltage.
pub const VIN_GAIN: u16 = 9;
/// Calibration offset of the battery voltage, V.
pub const VIN_OFFSET_V: u16 = 10;
/// Calibration gain of the battery current.
pub const IIN_GAIN: u16 = 11;
/// Calibration offset of the battery current, A.
pub const IIN_OFFSET_A: u16 = 12;
/// Calibration gain of the bus voltage.
pub const VOUT_GAIN: u16 = 13;
/// Calibration offset of the bus voltage, V.
pub const VOUT_OFFSET_V: u16 = 14;

/// Number of parameters.
pub const COUNT: usize = 15;

/// The parameter table with its defaults and ranges (index = position = the constants above).
pub const DEFAULTS: [Param; COUNT] = [
    Param::u32("instance", 0, 0, 3),
    Param::f32("capacity_ah", 0.0, 0.0, 1000.0),
    Param::u32("battery_rate_hz", 10, 1, 100),
    Param::u32("filter_tau_ms", 1000, 1, 60_000),
    Param::f32("oc_threshold_a", 5.0, 0.1, 6.5),
    Param::u32("oc_time_ms", 100, 1, 10_000),
    Param::f32("uv_threshold_v", 6.0, 0.0, 50.0),
    Param::f32("uv_hysteresis_v", 0.5, 0.05, 5.0),
    Param::u32("event_deadline_ms", 10, 1, 1000),
    Param::f32("vin_gain", 1.0, 0.8, 1.2),
    Param::f32("vin_offset_v", 0.0, -1.0, 1.0),
    Param::f32("iin_gain", 1.0, 0.8, 1.2),
    Param::f32("iin_offset_a", 0.0, -0.5, 0.5),
    Param::f32("vout_gain", 1.0, 0.8, 1.2),
    Param::f32("vout_offset_v", 0.0, -0.5, 0.5),
];

/// Documentation of each parameter (index = position).
pub const DOCS: [ParamDoc; COUNT] = [
    boot("", "module name: 0 `psu`, 1 `psu1`, 2 `psu2`, 3 `psu3` (node name and topic prefix)"),
    doc("Ah", "battery capacity; 0 = unknown (remaining time reads unknown)"),
    doc("Hz", "rate of `battery`"),
    doc("ms", "time constant of the low-pass filter on the reported voltage and current"),
    doc("A", "over-current trip level of the battery current"),
    doc("ms", "time above the over-current level before the output is switched off"),
    doc("V", "under-voltage event below this battery voltage"),
    doc("V", "the voltage must rise this far above the threshold to clear under-voltage"),
    boot("ms", "deadline of `event` messages (SRT)"),
    doc("", "battery voltage calibration: V = gain × V_adc + offset"),
    doc("V", "battery voltage calibration offset"),
    doc("", "battery current calibration: A = gain × A_adc + offset"),
    doc("A", "battery current calibration offset"),
    doc("", "bus voltage calibration: V = gain × V_adc + offset"),
    doc("V", "bus voltage calibration offset"),
];

/// A linear calibration `gain × x + offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calibration {
    /// Multiplies the front end's value.
    pub gain: f32,
    /// Added after the gain.
    pub offset: f32,
}

impl Calibration {
    /// The calibrated value of `x`.
    pub fn apply(self, x: f32) -> f32 {
        x * self.gain + self.offset
    }
}

/// The parameters the application runs with, read from the store.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Battery capacity, Ah (0 = unknown).
    pub capacity_ah: f32,
    /// Time between two `battery` messages, µs.
    pub battery_period_us: u64,
    /// Low-pass time constant, µs. A `u32` (the parameter is at most 60 s): as an `f32` it needs
    /// no 64-bit conversion helper (106 B of flash).
    pub filter_tau_us: u32,
    /// Over-current level, A.
    pub oc_threshold_a: f32,
    /// Over-current time, µs.
    pub oc_time_us: u64,
    /// Under-voltage level, V.
    pub uv_threshold_v: f32,
    /// Under-voltage hysteresis, V.
    pub uv_hysteresis_v: f32,
    /// Battery voltage calibration.
    pub vin: Calibration,
    /// Battery current calibration.
    pub iin: Calibration,
    /// Bus voltage calibration.
    pub vout: Calibration,
}

impl Config {
    /// Reads every parameter (a missing or mistyped one falls back to its default).
    pub fn read(store: &dyn ParamStore) -> Self {
        let t = typed(store);
        let f = |i| t.f32(i);
        let u = |i| u64::from(t.u32(i));
        Self {
            capacity_ah: f(CAPACITY_AH),
            battery_period_us: 1_000_000 / u(BATTERY_RATE_HZ).max(1),
            filter_tau_us: t.u32(FILTER_TAU_MS).saturating_mul(1000),
            oc_threshold_a: f(OC_THRESHOLD_A),
            oc_time_us: u(OC_TIME_MS) * 1000,
            uv_threshold_v: f(UV_THRESHOLD_V),
            uv_hysteresis_v: f(UV_HYSTERESIS_V),
            vin: Calibration { gain: f(VIN_GAIN), offset: f(VIN_OFFSET_V) },
            iin: Calibration { gain: f(IIN_GAIN), offset: f(IIN_OFFSET_A) },
            vout: Calibration { gain: f(VOUT_GAIN), offset: f(VOUT_OFFSET_V) },
        }
    }
}

/// The parameters as the application reads them: each as its type, the default from
/// [`DEFAULTS`] if the store lacks it.
pub fn typed(store: &dyn ParamStore) -> Typed<'_> {
    Typed::new(store, &DEFAULTS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use r2p_management::message::ParamFault;
    use r2p_management::message::Value;
    use r2p_node::{NoParams, RamParams};

    #[test]
    fn defaults_are_in_range_and_named_uniquely() {
        for (i, p) in DEFAULTS.iter().enumerate() {
            assert_eq!(p.check(p.value), Ok(()), "{}", p.name);
            assert!(DEFAULTS[..i].iter().all(|q| q.name != p.name), "{} twice", p.name);
        }
    }

    #[test]
    fn config_follows_the_store_and_falls_back_to_defaults() {
        let store = RamParams::new(DEFAULTS);
        let c = Config::read(&store);
        assert_eq!(c.battery_period_us, 100_000);
        assert_eq!(c.oc_time_us, 100_000);
        assert_eq!(c.iin, Calibration { gain: 1.0, offset: 0.0 });
        store.set(BATTERY_RATE_HZ, Value::U32(50)).unwrap();
        store.set(IIN_OFFSET_A, Value::F32(-0.25)).unwrap();
        let c = Config::read(&store);
        assert_eq!(c.battery_period_us, 20_000);
        assert_eq!(c.iin.apply(2.0), 1.75);
        assert_eq!(Config::read(&NoParams).uv_threshold_v, 6.0);
    }

    #[test]
    fn out_of_range_values_are_refused() {
        let store = RamParams::new(DEFAULTS);
        assert_eq!(store.set(OC_THRESHOLD_A, Value::F32(20.0)), Err(ParamFault::OutOfRange));
        assert_eq!(store.set(INSTANCE, Value::U32(4)), Err(ParamFault::OutOfRange));
        assert_eq!(store.set(BATTERY_RATE_HZ, Value::U32(0)), Err(ParamFault::OutOfRange));
        assert_eq!(store.set(CAPACITY_AH, Value::U32(2)), Err(ParamFault::WrongType));
        assert_eq!(Config::read(&store), Config::read(&RamParams::new(DEFAULTS)));
    }
}
