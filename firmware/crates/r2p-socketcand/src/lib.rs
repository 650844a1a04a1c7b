//! The socketcand text protocol (<https://github.com/linux-can/socketcand>, `doc/protocol.md`)
//! as raw-frame clients use it — python-can's `socketcand` interface, `r2p`, `nc` — written
//! once, sans-IO and `no_std`, for both servers of the bus on TCP: the host's (r2p-canlink, in
//! front of the emulated bus) and the gateway module's (r2p-app-gateway, on the STM32F407 over
//! embassy-net and in the emulator over host TCP). Neither allocates here.
//!
//! Messages are `< ... >` with no line separators required (python-can sends none):
//!
//! | direction | message | meaning |
//! |---|---|---|
//! | server → client | `< hi >` | greeting on connect |
//! | client → server | `< open CHANNEL >` | select the bus; answered `< ok >` |
//! | client → server | `< rawmode >` | receive every frame; answered `< ok >` |
//! | client → server | `< send ID DLC B0 B1 … >` | send a frame (hex; 8-digit or > 7FF IDs are extended) |
//! | client → server | `< echo >` | answered `< echo >` |
//! | server → client | `< frame ID SECS.USECS DATA >` | a frame (ID 3 or 8 hex digits, DATA contiguous hex) |
//! | server → client | `< error TEXT >` | a message was not understood or not allowed now |
//!
//! - [`frame`]: a classic CAN frame as the link carries it;
//! - [`splitter`]: a byte stream into `< … >` messages, with a fixed buffer;
//! - [`command`]: a message into a [`Command`];
//! - [`session`]: one client's state (closed, BCM, raw) and what answers each message;
//! - [`format`]: the server's messages written into any `core::fmt::Write`.
#![no_std]

pub mod command;
pub mod format;
pub mod frame;
pub mod session;
pub mod splitter;

pub use command::{parse_command, Command, ParseError};
pub use frame::{CanFrame, FrameError};
pub use session::{Action, Session, SessionError};
pub use splitter::Splitter;

/// Longest message accepted, `<` and `>` included (a full `< send >` is under 50 bytes).
pub const MAX_MESSAGE: usize = 256;

/// socketcand's usual TCP port.
pub const DEFAULT_PORT: u16 = 29536;

/// The bus name clients `open` unless the server is told otherwise.
pub const DEFAULT_CHANNEL: &str = "vcan0";
