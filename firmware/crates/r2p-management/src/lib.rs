//! The R2P management protocol (docs/middleware.md, "Management protocol").
//!
//! Every module talks about itself on its own management stream: heartbeats, topic
//! advertisements, subscription requests and responses, reboot and parameter access. This
//! crate is the protocol's wire format and its node-ID allocation — the parts every
//! implementation must agree on byte for byte — with no I/O: the middleware sends and receives
//! these messages over RTCAN.
#![no_std]
#![warn(missing_docs)]

#[cfg(test)]
extern crate std;

pub mod ids;
pub mod message;
pub mod node_id;

pub use ids::{NodeId, MANAGEMENT_INDEX};
pub use message::{DecodeError, Message};
pub use node_id::NodeIdAllocator;

/// The crate's test suite, compiled in for bare-metal runners (feature `selftest`).
#[cfg(any(test, feature = "selftest"))]
pub mod selftest {
    /// Every suite of the crate, in the order a runner should run them.
    pub const ALL: &[&[r2p_testkit::Case]] =
        &[crate::ids::tests::SUITE, crate::message::tests::SUITE, crate::node_id::tests::SUITE];
}
