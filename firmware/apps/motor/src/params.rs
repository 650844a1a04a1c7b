//! The parameter table: index constants, [`DEFAULTS`] with their ranges (the store refuses an
//! out-of-range PARAM_SET with a reason and keeps the old value), and [`Config`], the typed
//! copy the application works from.
//!
//! The application re-reads one parameter per control step, round robin, so a change made over
//! the bus applies within [`COUNT`] ms at a constant cost per step. `instance` names the topics
//! and the node, so it applies at the next reboot.

use r2p_management::message::Value;
use r2p_node::{Param, ParamStore};

/// One table row: its index constant, `Config` field, type, default, range, unit, doc.
macro_rules! params {
    ($( $idx:literal $konst:ident $field:ident : $ty:ident = $def:expr, $min:expr, $max:expr,
        $unit:literal, $doc:literal; )*) => {
        /// Parameter indices (PARAM_GET / PARAM_SET `index`).
        pub mod index {
            $( #[doc = $doc] pub const $konst: u16 = $idx; )*
        }

        /// How many parameters the module has.
        pub const COUNT: usize = [$($idx),*].len();

        // The table's order is the index order: DEFAULTS[i] is parameter i.
        const _: () = {
            let order: [u16; COUNT] = [$($idx),*];
            let mut i = 0;
            while i < COUNT {
                assert!(order[i] as usize == i, "parameter indices must be 0, 1, 2, … in table order");
                i += 1;
            }
        };

        /// Every parameter with its default and range, in index order: the table a
        /// `RamParams` or the flash store is built from.
        pub const DEFAULTS: [Param; COUNT] = [ $( Param::$ty(stringify!($field), $def, $min, $max), )* ];

        /// Unit and description of each parameter, in index order (for the README).
        pub const DOCS: [(&str, &str); COUNT] = [ $( ($unit, $doc), )* ];

        /// The parameters as the application uses them.
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Config {
            $( #[doc = $doc] pub $field: $ty, )*
        }

        impl Config {
            /// The defaults.
            pub const DEFAULT: Self = Self { $( $field: $def, )* };

            /// Takes `value` for parameter `index`; a wrong type or index changes nothing.
            pub fn apply(&mut self, index: u16, value: Value) {
                match index {
                    $( $idx => if let Some(v) = <$ty as FromValue>::from_value(value) {
                        self.$field = v;
                    }, )*
                    _ => {}
                }
            }
        }
    };
}

params! {
    0 INSTANCE instance: u32 = 0, 0, 7, "",
        "Module instance: 0 names the node `motor` and its topics `motor/…`, n names them `motor<n>` (applies at reboot).";
    1 PUBLISH_HZ publish_hz: u32 = 100, 1, 200, "Hz",
        "Rate of `state`.";
    2 WATCHDOG_MS watchdog_ms: u32 = 250, 20, 10_000, "ms",
        "A setpoint must arrive within this time once the first one came, or the motor stops (fault bit 2).";
    3 CURRENT_KP current_kp: f32 = 0.03, 0.0, 50.0, "V/A",
        "Current loop (1 kHz) proportional gain.";
    4 CURRENT_KI current_ki: f32 = 300.0, 0.0, 20_000.0, "V/(A·s)",
        "Current loop integral gain.";
    5 SPEED_KP speed_kp: f32 = 2.6, 0.0, 100.0, "A/(rad/s)",
        "Speed loop (200 Hz) proportional gain, output-shaft speed.";
    6 SPEED_KI speed_ki: f32 = 80.0, 0.0, 10_000.0, "A/rad",
        "Speed loop integral gain.";
    7 SPEED_WEIGHT speed_weight: f32 = 0.3, 0.0, 1.0, "",
        "Share of the speed setpoint in the speed loop's proportional term (1: plain PI; less: less overshoot on setpoint steps, same disturbance rejection).";
    8 POSITION_KP position_kp: f32 = 16.0, 0.0, 1_000.0, "(rad/s)/rad",
        "Position loop (200 Hz) gain: speed setpoint per rad of error.";
    9 MAX_SPEED max_speed: f32 = 50.0, 0.1, 1_000.0, "rad/s",
        "Output-shaft speed limit of the speed and position modes.";
    10 CURRENT_LIMIT current_limit: f32 = 10.0, 0.1, 23.0, "A",
        "Clamps the current setpoint in every mode (the board's 23 A peak for 10 s; 20 A continuous on its heatsink).";
    11 TRIP_CURRENT trip_current: f32 = 14.0, 1.0, 24.5, "A",
        "Over-current trip threshold on the measured current (keep above `current_limit`).";
    12 TRIP_MS trip_ms: u32 = 5, 1, 100, "ms",
        "How long the current must stay above `trip_current` to trip (fault bit 0).";
    13 ENCODER_LINES encoder_lines: u32 = 500, 1, 250_000, "lines/rev",
        "Encoder lines per motor revolution (TIM3 counts 4 edges per line).";
    14 GEAR_RATIO gear_ratio: f32 = 15.0, 0.01, 10_000.0, "",
        "Motor revolutions per output-shaft revolution.";
    15 HALL_MV_PER_A hall_mv_per_a: f32 = 44.0, 5.0, 500.0, "mV/A",
        "Hall current sensor sensitivity (ACS725LLCTR-30AB-T at 3.3 V: 44).";
    16 TORQUE_CONSTANT torque_constant: f32 = 0.0302, 0.001, 10.0, "N·m/A",
        "Motor torque constant (= back-EMF constant in V·s/rad): torque setpoints (gearbox losses not compensated) and back-EMF feed-forward.";
    17 MOTOR_RESISTANCE motor_resistance: f32 = 0.611, 0.01, 100.0, "Ω",
        "Motor terminal resistance: the encoder-loss check estimates back-EMF with it.";
    18 ENCODER_TIMEOUT_MS encoder_timeout_ms: u32 = 100, 10, 5_000, "ms",
        "Driving with back-EMF above `encoder_emf_v` and no encoder edge for this long: encoder loss (fault bit 1).";
    19 ENCODER_EMF_V encoder_emf_v: f32 = 3.0, 0.5, 50.0, "V",
        "Back-EMF (duty × VMOT − R × I) above which the motor must be turning.";
    // at most 0.95: the board's HIP4082 has bootstrap high sides, refreshed only while the low
    // side conducts (hardware/motor, calc/motor.py "bootstrap refresh"); 100 % would starve them
    20 DUTY_LIMIT duty_limit: f32 = 0.95, 0.05, 0.95, "",
        "Largest duty magnitude the current loop commands.";
    // No brake chopper on the board (hardware/motor, decision 2): regenerated current that the
    // supply cannot take charges the bulk capacitors, and the over-voltage comparator coasts the
    // bridge at 46.4–49.2 V (calc/motor.py). The default start is the highest steady input,
    // VIN_MAX 44.1 V (calc/motor.py: 10S Li-ion on a charger, 3 × 12 V lead-acid charging), so a
    // charging battery is never derated; the default stop, 45.5 V, reads at most 46.4 V with the
    // VMOT_SENSE divider's 1 % resistors (ratio 16 ± 1.9 %), below the trip's minimum.
    21 REGEN_START_V regen_start_v: f32 = 44.1, 12.0, 52.8, "V",
        "VMOT above which the braking (regenerative) current is derated, linearly to none at `regen_stop_v` (state bit 5 while derated): the board has no brake chopper and coasts at its 46.4–49.2 V over-voltage trip.";
    22 REGEN_STOP_V regen_stop_v: f32 = 45.5, 12.0, 52.8, "V",
        "VMOT at and above which no braking current is allowed (keep above `regen_start_v` and below the over-voltage trip's 46.4 V less the VMOT_SENSE divider's 1.9 % tolerance).";
}

/// The store's value as a Rust type.
pub trait FromValue: Sized {
    /// `Some` if `v` has this type.
    fn from_value(v: Value) -> Option<Self>;
}

impl FromValue for u32 {
    fn from_value(v: Value) -> Option<Self> {
        match v {
            Value::U32(x) => Some(x),
            _ => None,
        }
    }
}

impl FromValue for f32 {
    fn from_value(v: Value) -> Option<Self> {
        match v {
            Value::F32(x) => Some(x),
            _ => None,
        }
    }
}

impl Config {
    /// Every parameter from `store` (a missing one keeps its default).
    pub fn load(store: &dyn ParamStore) -> Self {
        let mut c = Self::DEFAULT;
        for i in 0..COUNT as u16 {
            c.reload(store, i);
        }
        c
    }

    /// Re-reads parameter `index` from `store`.
    pub fn reload(&mut self, store: &dyn ParamStore, index: u16) {
        if let Ok(v) = store.get(index) {
            self.apply(index, v);
        }
    }
}

impl Default for Config {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use r2p_node::RamParams;

    #[test]
    fn the_table_is_in_index_order_and_defaults_are_in_range() {
        let store = RamParams::new(DEFAULTS);
        for (i, p) in DEFAULTS.iter().enumerate() {
            assert_eq!(p.check(p.value), Ok(()), "{} default out of its own range", p.name);
            assert_eq!(store.get(i as u16), Ok(p.value));
        }
        assert_eq!(DEFAULTS[usize::from(index::DUTY_LIMIT)].name, "duty_limit");
        assert_eq!(Config::load(&RamParams::new(DEFAULTS)), Config::DEFAULT);
    }

    #[test]
    fn load_and_reload_follow_the_store() {
        let store = RamParams::new(DEFAULTS);
        store.set(index::SPEED_KP, Value::F32(2.5)).unwrap();
        store.set(index::PUBLISH_HZ, Value::U32(50)).unwrap();
        let mut c = Config::load(&store);
        assert_eq!((c.speed_kp, c.publish_hz), (2.5, 50));
        store.set(index::TRIP_MS, Value::U32(9)).unwrap();
        c.reload(&store, index::TRIP_MS);
        assert_eq!(c.trip_ms, 9);
        c.apply(index::TRIP_MS, Value::F32(3.0));
        assert_eq!(c.trip_ms, 9, "a wrong type is ignored");
    }
}
