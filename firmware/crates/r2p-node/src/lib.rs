//! The R2P node runtime: local and remote topics are one API.
//!
//! A module's [`Node`] connects its middleware topics to the CAN bus through RTCAN and runs
//! the management protocol (docs/middleware.md, "Remote topics: the node runtime"):
//!
//! - a local topic is offered on the bus by subscribing a [`RemoteSubscriber`] to it and
//!   [`Node::export`]ing it: while a remote module is subscribed, every publication is encoded
//!   ([`Wire`]) and queued in the RTCAN transmit queue with the publisher's class;
//! - a remote topic is received by [`Node::import`]ing a [`RemotePublisher`] of the local topic
//!   of the same name: frames are reassembled, decoded and published locally, so local
//!   subscribers cannot tell the difference;
//! - the management protocol claims a node ID, sends heartbeats, advertises exports, asks for
//!   imports when they are advertised (same name and type hash), answers subscription,
//!   reboot and parameter requests ([`ParamStore`]);
//! - HRT streams (`Class::SyncRealTime`) get a slot of the TDMA cycle from the bus master
//!   (HRT_REQUEST / HRT_GRANT); the node follows the master's syncs, takes over as master when
//!   its rank says so, and sends each frame in its slot ([`Node::slot_tick`]).
//!
//! Sans-IO: on a bus with a TDMA cycle the slot timer drives it with
//! [`Node::slot_tick`]`(now, &mut controller)`; without one, [`Node::poll`]`(now, &mut
//! controller)` (module documentation of [`node`]). On a module, on an emulated bus in virtual
//! time, or in tests. `no_std`, no heap: capacities are const generics.
#![no_std]
#![warn(missing_docs)]

#[cfg(test)]
extern crate std;

pub mod hw_filters;
pub mod node;
mod node_send;
pub mod params;
pub mod remote;
pub mod slot_tx;
pub mod update;
pub mod wire;

#[cfg(test)]
mod addressing_tests;
#[cfg(test)]
mod advertising_tests;
#[cfg(test)]
mod babbler_tests;
#[cfg(test)]
mod failover_tests;
#[cfg(all(test, feature = "framed-reservations"))]
mod framed_tests;
#[cfg(test)]
mod guard_tests;
#[cfg(test)]
mod heartbeat_tests;
#[cfg(test)]
mod host_tests;
#[cfg(test)]
mod hrt_master_tests;
#[cfg(test)]
mod hrt_multiframe_tests;
#[cfg(test)]
mod hrt_stream_tests;
#[cfg(test)]
mod import_request_tests;
#[cfg(test)]
mod liveness_tests;
#[cfg(test)]
mod master_side_tests;
#[cfg(test)]
mod master_timing_tests;
#[cfg(test)]
mod panic_report_tests;
#[cfg(test)]
mod registration_bounds_tests;
#[cfg(test)]
mod subscriber_liveness_tests;
#[cfg(any(test, feature = "selftest"))]
mod tdma_tests;
/// The suite's loopback bus, public for the QEMU benchmark of the slot path (not an API).
#[cfg(any(test, feature = "selftest"))]
#[doc(hidden)]
pub mod testbus;
#[cfg(any(test, feature = "selftest"))]
mod tests;
#[cfg(test)]
mod unslotted_tests;
#[cfg(all(test, feature = "unsubscribe"))]
mod unsubscribe_tests;
#[cfg(test)]
mod update_tests;

pub use node::{
    Event, FramedLeads, FramedPaths, HrtState, ImportState, Node, NodeConfig, NodeError, NodeStats,
    SlotPath, CORTEX_M3_FRAMED_PATHS, CORTEX_M3_FRAMED_SLOT_PATH, CORTEX_M3_FRAMED_SYNC_PATH,
    CORTEX_M3_SLOT_PATH, CORTEX_M3_STAGED_SLOT_PATH, CORTEX_M3_STAGED_SYNC_PATH,
    CORTEX_M3_STAGED_TOP_UP_PATH, CORTEX_M3_SYNC_PATH, CORTEX_M3_TOP_UP_PATH, CORTEX_M4_SLOT_PATH,
    CORTEX_M4_SYNC_PATH, MODULE_FRAMED_LEADS, MODULE_SLOT_LEAD_US, MODULE_SYNC_LEAD_US,
};
pub use params::{NoParams, Param, ParamStore, RamParams, Typed};
pub use remote::{Export, Import, ImportError, RemotePublisher, RemoteSubscriber};
pub use slot_tx::{FreeSlots, SlotTx};
pub use update::{FirmwareId, UpdateSink};
pub use wire::{Wire, WireError};

/// The crate's test suite, compiled in for bare-metal runners (feature `selftest`).
#[cfg(any(test, feature = "selftest"))]
pub mod selftest {
    /// Every suite of the crate, in the order a runner should run them.
    pub const ALL: &[&[r2p_testkit::Case]] = &[
        crate::wire::tests::SUITE,
        crate::hw_filters::tests::SUITE,
        crate::params::tests::SUITE,
        crate::remote::tests::SUITE,
        crate::tests::SUITE,
        crate::tdma_tests::SUITE,
    ];
}
