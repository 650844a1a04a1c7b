//! `PsuEvent` codes (firmware/msgs/PsuEvent.msg).

/// The battery current stayed above `oc_threshold_a` for `oc_time_ms`.
pub const OVER_CURRENT: u8 = 1;
/// The battery voltage fell below `uv_threshold_v`.
pub const UNDER_VOLTAGE: u8 = 2;
/// The battery voltage rose above `uv_threshold_v + uv_hysteresis_v` again.
pub const VOLTAGE_RECOVERED: u8 = 3;
/// The bus output was switched off (`cause` says why).
pub const OUTPUT_OFF: u8 = 4;
/// The bus output was switched on (by command).
pub const OUTPUT_ON: u8 = 5;

/// Switched by a `power` command.
pub const CAUSE_COMMAND: u8 = 0;
/// Switched off by the over-current protection (latched).
pub const CAUSE_OVER_CURRENT: u8 = 1;
/// Switched off because the eFuse flagged a fault on `BUS_FAULT` (latched).
pub const CAUSE_EFUSE: u8 = 2;
