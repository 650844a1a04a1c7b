//! Lets real CAN tools join R2P's emulated bus over TCP on the host (no SocketCAN needed):
//!
//! - [`hub`]: the [`Hub`] trait participants talk to and [`BroadcastHub`], an in-memory bus;
//! - [`server`]: a socketcand-protocol server ([`socketcand`] is its wire format), which
//!   python-can's `socketcand` interface and socketcand clients connect to;
//! - [`candump`]: candump log files, read by `canplayer`, `log2asc` and `can.LogReader`;
//! - [`pcap`]: pcap files with the SocketCAN link type, read by Wireshark and tshark;
//! - [`replay`]: reading either trace format and sending a trace onto a bus again;
//! - [`socketcan`] (Linux): kernel CAN interfaces, and a bridge from one to a [`Hub`];
//! - [`service`]: stop conditions, logging and listen errors for programs serving the hub.

pub mod candump;
pub mod frame;
pub mod hub;
pub mod pcap;
pub mod replay;
pub mod server;
pub mod service;
#[cfg(target_os = "linux")]
pub mod socketcan;
pub mod socketcand;

pub use frame::{CanFrame, FrameError, Stamped};
pub use hub::{BroadcastHub, Hub, ParticipantId, Subscription};
pub use server::{Config, Server};
