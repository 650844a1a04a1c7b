//! `r2p`, the R2P host tool: watches and talks to an R2P robot's CAN bus — a real one through
//! SocketCAN, an emulated one (or any socketcand server) over TCP, or a recorded trace.
//!
//! - [`link`]: where frames come from ([`socketcand_client`], SocketCAN, an in-process hub,
//!   a trace);
//! - [`watch`]: a passive decoder of the bus (RTCAN identifiers, management messages,
//!   advertised topics, nodes), and [`describe`]: its lines and JSON;
//! - [`host`]: a real `r2p_node::Node` on the host, with an import and an export whose type
//!   is learnt at run time, and the [`session::Session`] that drives it beside the watcher;
//! - [`types`]: the message types, found by type hash, decoded and encoded;
//! - the commands: [`monitor`], [`listing`] (`nodes`, `topics`), [`echo`], [`publish`]
//!   (`pub`), [`param`], [`magcal`] (`imu calibrate`, its fit in the `r2p-magcal` crate),
//!   [`traces`] (`replay`, `convert`), [`sim`], [`flash`], [`ui`] (the web page: [`ui_view`],
//!   [`ui_bus`], [`ui_actions`]); [`args`]: the bus options
//!   and output they share; [`cli`] parses the command line and runs them.

pub mod args;
pub mod cli;
pub mod describe;
pub mod echo;
pub mod error;
pub mod flash;
pub mod host;
pub mod keys;
pub mod link;
pub mod listing;
pub mod magcal;
pub mod mcap_log;
pub mod monitor;
pub mod param;
pub mod publish;
pub mod record;
pub mod session;
pub mod sim;
pub mod socketcand_client;
pub mod timing;
pub mod traces;
pub mod types;
pub mod ui;
pub mod ui_actions;
pub mod ui_bus;
pub mod ui_view;
pub mod update;
pub mod watch;

pub use error::CliError;
