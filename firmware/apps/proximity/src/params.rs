//! The proximity module's parameters: the table the node serves over the bus (PARAM_GET /
//! PARAM_SET, ranges checked by the store) and the [`Config`] the application reads from it
//! every step.

use r2p_module::param_doc::{doc, ParamDoc};
use r2p_node::{Param, ParamStore, Typed};

/// Module instance: selects the node name and topic prefix from [`crate::NAMES`] (at boot).
pub const INSTANCE: u16 = 0;
/// `ranges` publication rate, Hz.
pub const RATE_HZ: u16 = 1;
/// Sensor type of channel 0 (channels 1–3 follow): 0 none, 1 GP2Y0A21YK, 2 GP2Y0A02YK,
/// 3 LV-MaxSonar-EZ.
pub const SENSOR0: u16 = 2;
/// Time constant of the channels' low-pass filter, ms (0 = median only).
pub const FILTER_TAU_MS: u16 = 6;
/// Obstacle threshold, m.
pub const OBSTACLE_M: u16 = 7;
/// Obstacle hysteresis, m.
pub const OBSTACLE_HYSTERESIS_M: u16 = 8;
/// Deadline of the `obstacle` event's SRT messages, ms (at boot).
pub const OBSTACLE_DEADLINE_MS: u16 = 9;
/// Sensor supply (`SENSOR_PWR_EN`).
pub const SENSOR_POWER: u16 = 10;

/// Number of parameters.
pub const COUNT: usize = 11;
/// Number of sensor channels.
pub const CHANNELS: usize = 4;

/// The parameter table with its defaults and ranges (index = position = the constants above).
pub const DEFAULTS: [Param; COUNT] = [
    Param::u32("instance", 0, 0, 3),
    Param::u32("rate_hz", 20, 1, 100),
    Param::u32("sensor0", 1, 0, 3),
    Param::u32("sensor1", 1, 0, 3),
    Param::u32("sensor2", 1, 0, 3),
    Param::u32("sensor3", 1, 0, 3),
    Param::u32("filter_tau_ms", 10, 0, 1000),
    Param::f32("obstacle_m", 0.25, 0.05, 6.5),
    Param::f32("obstacle_hysteresis_m", 0.05, 0.0, 1.0),
    Param::u32("obstacle_deadline_ms", 10, 1, 1000),
    Param::bool("sensor_power", true),
];

const SENSOR_DOC: ParamDoc = doc(
    "",
    "sensor on the channel: 0 none, 1 Sharp GP2Y0A21YK (10–80 cm), 2 Sharp GP2Y0A02YK \
     (20–150 cm), 3 MaxBotix LV-MaxSonar-EZ analog (6–254 in)",
);

/// Documentation of each parameter (index = position).
pub const DOCS: [ParamDoc; COUNT] = [
    ParamDoc {
        unit: "",
        at_boot: true,
        doc: "module name: 0 `proximity`, 1 `proximity1`, 2 `proximity2`, 3 `proximity3` (node name and topic prefix)",
    },
    doc("Hz", "rate of `ranges`"),
    SENSOR_DOC,
    SENSOR_DOC,
    SENSOR_DOC,
    SENSOR_DOC,
    doc("ms", "time constant of each channel's low-pass filter, after the 5-sample median; 0 = median only"),
    doc("m", "an `obstacle` event when a channel reads nearer than this (or too near to measure)"),
    doc("m", "the channel must read this much farther (or too far, or no sensor) before it can report again"),
    ParamDoc { unit: "ms", at_boot: true, doc: "deadline of `obstacle` messages (SRT; Listing 1 of the paper)" },
    doc("", "sensor supply (`SENSOR_PWR_EN`) on"),
];

/// The parameters the application runs with, read from the store.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Time between two `ranges` messages, µs.
    pub period_us: u64,
    /// Sensor type per channel.
    pub sensors: [u32; CHANNELS],
    /// Low-pass time constant, µs (0: off). A `u32` (the parameter is at most 1 s): as an `f32`
    /// it needs no 64-bit conversion helper (106 B of flash).
    pub filter_tau_us: u32,
    /// Obstacle threshold, m.
    pub obstacle_m: f32,
    /// Obstacle hysteresis, m.
    pub obstacle_hysteresis_m: f32,
    /// Sensor supply on.
    pub sensor_power: bool,
}

impl Config {
    /// Reads every parameter (a missing or mistyped one falls back to its default).
    pub fn read(store: &dyn ParamStore) -> Self {
        let t = typed(store);
        let u = |i| t.u32(i);
        Self {
            period_us: 1_000_000 / u64::from(u(RATE_HZ).max(1)),
            sensors: core::array::from_fn(|c| u(SENSOR0 + c as u16)),
            filter_tau_us: u(FILTER_TAU_MS).saturating_mul(1000),
            obstacle_m: t.f32(OBSTACLE_M),
            obstacle_hysteresis_m: t.f32(OBSTACLE_HYSTERESIS_M),
            sensor_power: t.bool(SENSOR_POWER),
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
        store.set(SENSOR0 + 2, Value::U32(3)).unwrap();
        store.set(SENSOR_POWER, Value::Bool(false)).unwrap();
        let c = Config::read(&store);
        assert_eq!(c.sensors, [1, 1, 3, 1]);
        assert_eq!(c.period_us, 50_000);
        assert!(!c.sensor_power);
        assert_eq!(Config::read(&NoParams).obstacle_m, 0.25);
        assert!(Config::read(&NoParams).sensor_power);
    }

    #[test]
    fn out_of_range_values_are_refused() {
        let store = RamParams::new(DEFAULTS);
        assert_eq!(store.set(SENSOR0, Value::U32(4)), Err(ParamFault::OutOfRange));
        assert_eq!(store.set(OBSTACLE_M, Value::F32(0.0)), Err(ParamFault::OutOfRange));
        assert_eq!(store.set(OBSTACLE_M, Value::F32(f32::NAN)), Err(ParamFault::OutOfRange));
        assert_eq!(store.set(SENSOR_POWER, Value::U32(1)), Err(ParamFault::WrongType));
        assert_eq!(Config::read(&store), Config::read(&RamParams::new(DEFAULTS)));
    }
}
