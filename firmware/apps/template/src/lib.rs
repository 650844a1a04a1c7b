//! The module template's application: the least a module does on the shared core, and the
//! crate `scripts/new-module NAME` copies into `firmware/apps/NAME` (docs/adding-a-module.md).
//!
//! Its node sends heartbeats (the node runtime does, every module alike) and publishes one
//! topic, `template/count`: the number of steps run, at the `rate_hz` parameter. The status LEDs
//! show the node's state. A new module replaces the count by its own readings and commands.
//!
//! Sans-IO (module application contract, docs/architecture.md): the MCU image
//! (firmware/targets/f103/template) and the emulated board run the same [`App::step`] every
//! millisecond with a [`Sample`] and apply the [`Command`] it returns.
#![no_std]
#![warn(missing_docs)]

#[cfg(any(test, feature = "std"))]
extern crate std;

mod app;
pub mod endpoints;
pub mod params;

#[cfg(test)]
mod tests;

pub use app::{App, Command, Sample};
pub use endpoints::{Endpoints, Storage};

use r2p_node::NodeConfig;

/// The module's name: its node's name and its topics' prefix.
pub const NAME: &str = "template";

/// The node configuration: no master rank, the modules' slot lead.
pub fn node_config(uid: [u8; 12]) -> NodeConfig {
    NodeConfig {
        slot_lead_us: r2p_node::MODULE_SLOT_LEAD_US,
        sync_lead_us: r2p_node::MODULE_SYNC_LEAD_US,
        framed_leads: r2p_node::MODULE_FRAMED_LEADS,
        ..NodeConfig::module(uid, NAME)
    }
}
