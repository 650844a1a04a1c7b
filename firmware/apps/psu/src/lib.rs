//! Default application of the R2P power-supply module (PSU): 6–42 V in, 5 V / 2.4 A bus out.
//!
//! It measures the battery (voltage, current) and the bus output through the ADC, counts the
//! charge drawn, estimates the time left, and publishes them (`psu/battery`, `psu/state`); it
//! trips the bus output off on over-current or an eFuse fault (latched), reports under-voltage,
//! and switches the output on `psu/power` commands, with an SRT `psu/event` for each. Its node
//! is the bus's default sync master (rank 0, [`node_config`]).
//!
//! Sans-IO (module application contract): the MCU image (firmware/targets/f103/psu) and the
//! emulated board run the same [`App::step`] every millisecond with a [`Sample`] of raw
//! readings and apply the [`Command`] it returns. The README's generated section lists the
//! topics, parameters and LEDs.
#![no_std]
#![warn(missing_docs)]

#[cfg(any(test, feature = "std"))]
extern crate std;

mod app;
pub mod charge;
pub mod endpoints;
pub mod event;
pub mod frontend;
pub mod params;
pub mod protection;
#[cfg(any(test, feature = "std"))]
pub mod readme;

#[cfg(test)]
mod bus_tests;
#[cfg(test)]
mod tests;

pub use app::{App, Command, Sample};
pub use endpoints::{names, Endpoints, Names, Storage, NAMES};

use r2p_node::{NodeConfig, ParamStore};

/// The PSU's node configuration: its name from the `instance` parameter, master rank 0 (the
/// PSU is in every robot, so it drives the bus's TDMA cycle by default).
pub fn node_config(uid: [u8; 12], params: &dyn ParamStore) -> NodeConfig {
    NodeConfig {
        rank: Some(0),
        slot_lead_us: r2p_node::MODULE_SLOT_LEAD_US,
        sync_lead_us: r2p_node::MODULE_SYNC_LEAD_US,
        framed_leads: r2p_node::MODULE_FRAMED_LEADS,
        ..NodeConfig::module(uid, names(params).node)
    }
}
