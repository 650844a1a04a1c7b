//! The gateway module's application: the R2P bus on the network.
//!
//! - [`server`]: the socketcand server (the bus on TCP), `async` over any `embedded-io-async`
//!   stream, so the same code serves embassy-net sockets on the STM32F407 image
//!   (firmware/targets/f407/gateway) and host TCP streams on the emulated gateway
//!   (firmware/host/emu). The protocol itself is `r2p-socketcand`'s, shared with r2p-canlink.
//! - [`tap`]: the gateway's CAN controller as its node sees it, with every frame of the bus
//!   (received, and sent by the node) copied to the clients and the clients' frames sent on
//!   the bus and looped back to the node, as SocketCAN does for a host's sockets.
//! - [`link`]: the queues between the two, and their counters.
//! - [`params`]: the network's parameters (DHCP, static address, TCP port), kept in flash.
//! - [`App`]: the 1 kHz step: the LEDs (node state, bus traffic, network link) and
//!   `gateway/status` once a second (the node's heartbeat carries the bus side).
//!
//! - [`demand`]: the imports only ROS 2 wants follow its Zenoh subscribers (unsubscribed on the
//!   bus when nobody listens).
//!
//! Where ROS 2 comes in (issue 20 item 3): a Zenoh client is one more user of [`link`]'s
//! frames and of the middleware's topics, beside the socketcand server; nothing here changes.
#![no_std]
#![warn(missing_docs)]

#[cfg(any(test, feature = "std"))]
extern crate std;

mod app;
pub mod demand;
pub mod endpoints;
pub mod link;
pub mod params;
pub mod remote_base;
pub mod ros;
pub mod server;
pub mod tap;

#[cfg(test)]
mod tests;

pub use app::{App, Command, Mirrored, NetState, Sample};
pub use endpoints::{Endpoints, Storage};
pub use link::{BusLink, LinkFrame, LinkStats};
pub use remote_base::{RemoteBase, RemoteBaseStorage};
pub use tap::BusTap;

use r2p_node::NodeConfig;

/// The module's name: its node's name and its topics' prefix.
pub const NAME: &str = "gateway";

/// The node configuration: the standby sync master (rank 1, after the PSU's 0), with the slot
/// leads of the MCU it runs on at `sysclk_hz`: the grid's from the F407's own slot path
/// (`r2p_node::CORTEX_M4_SLOT_PATH`), those of frame-sized reservations from the Cortex-M3's
/// paths (the only ones measured; the grid's two builds are within a few instructions).
pub fn node_config(uid: [u8; 12], sysclk_hz: u32) -> NodeConfig {
    NodeConfig {
        rank: Some(1),
        slot_lead_us: r2p_node::CORTEX_M4_SLOT_PATH.lead_us(sysclk_hz),
        sync_lead_us: r2p_node::CORTEX_M4_SYNC_PATH.lead_us(sysclk_hz),
        framed_leads: r2p_node::FramedLeads::at(sysclk_hz),
        ..NodeConfig::module(uid, NAME)
    }
}
