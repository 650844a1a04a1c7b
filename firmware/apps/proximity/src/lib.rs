//! Default application of the R2P proximity module: up to four analog rangers (Sharp
//! GP2Y0A21YK and GP2Y0A02YK infrared, MaxBotix LV-MaxSonar-EZ sonar), chosen per channel by
//! parameter.
//!
//! Each channel is sampled every millisecond, filtered (median of 5, then a low-pass),
//! converted through its sensor's datasheet transfer curve ([`curves`]) and reported as a
//! distance, or as out of range (too near / too far) or no sensor — never as a made-up
//! distance. The four are published on `proximity/ranges`; a channel that reads nearer than a
//! threshold publishes an SRT `proximity/obstacle` with a deadline, once per approach: the
//! paper's Listing 1.
//!
//! Sans-IO (module application contract): the MCU image (firmware/targets/f103/proximity) and
//! the emulated board run the same [`App::step`] every millisecond with a [`Sample`] of ADC
//! codes and apply the [`Command`] it returns. The README's generated section lists the
//! topics, parameters and LEDs.
#![no_std]
#![warn(missing_docs)]

#[cfg(any(test, feature = "std"))]
extern crate std;

mod app;
pub mod channel;
pub mod curves;
pub mod endpoints;
pub mod frontend;
pub mod params;
#[cfg(any(test, feature = "std"))]
pub mod readme;

#[cfg(test)]
mod bus_tests;
#[cfg(test)]
mod tests;

pub use app::{App, Command, Sample};
pub use endpoints::{names, Endpoints, Names, Storage, NAMES};

use r2p_node::{NodeConfig, ParamStore};

/// The proximity module's node configuration: its name from the `instance` parameter, no
/// master rank.
pub fn node_config(uid: [u8; 12], params: &dyn ParamStore) -> NodeConfig {
    NodeConfig {
        slot_lead_us: r2p_node::MODULE_SLOT_LEAD_US,
        sync_lead_us: r2p_node::MODULE_SYNC_LEAD_US,
        framed_leads: r2p_node::MODULE_FRAMED_LEADS,
        ..NodeConfig::module(uid, names(params).node)
    }
}
