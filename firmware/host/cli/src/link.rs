//! Where the CLI's frames come from and go to: a socketcand server over TCP, a kernel CAN
//! interface (SocketCAN), an in-process hub (an emulated bus started in the same process), or
//! a trace file read back (offline: nothing can be sent).

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use r2p_canlink::replay::read_trace;
use r2p_canlink::{CanFrame, Hub, ParticipantId, Stamped, Subscription};

use crate::error::CliError;
use crate::socketcand_client;

/// What [`Link::recv`] got.
#[derive(Debug)]
pub enum Recv {
    /// A frame.
    Frame(Stamped),
    /// Nothing within the timeout.
    Timeout,
    /// A trace has no more frames.
    End,
}

/// A connection to a bus.
pub trait Link {
    /// The next frame, waiting at most `timeout` (a trace never waits).
    fn recv(&mut self, timeout: Duration) -> Result<Recv, CliError>;
    /// Sends a frame.
    fn send(&mut self, frame: &CanFrame) -> Result<(), CliError>;
    /// What the link is, for messages (`socketcand 127.0.0.1:29536`).
    fn describe(&self) -> String;
    /// Least time between two frames a host node sends. A socketcand server may hold several
    /// frames in a CAN controller's mailboxes, and many controllers send the lowest identifier
    /// first (bxCAN by default); a message's later fragments have lower identifiers, so frames
    /// are spaced to keep a message in order (the emulated bus sends in load order anyway).
    fn tx_gap(&self) -> Duration {
        Duration::ZERO
    }
    /// True for a trace read back: no live bus, nothing can be sent.
    fn is_trace(&self) -> bool {
        false
    }
}

/// A socketcand connection.
pub struct SocketcandLink(socketcand_client::Client);

impl SocketcandLink {
    /// Connects to `addr` and opens `channel`.
    pub fn connect(addr: &str, channel: &str) -> Result<Self, CliError> {
        socketcand_client::Client::connect(addr, channel).map(Self)
    }
}

/// Spacing of frames sent through socketcand (see [`Link::tx_gap`]): a frame lasts at most
/// 160 µs at 1 Mbit/s, so a millisecond leaves room for the bus's own traffic.
pub const SOCKETCAND_TX_GAP: Duration = Duration::from_millis(1);

impl Link for SocketcandLink {
    fn recv(&mut self, timeout: Duration) -> Result<Recv, CliError> {
        Ok(self.0.recv(timeout)?.map_or(Recv::Timeout, Recv::Frame))
    }
    fn send(&mut self, frame: &CanFrame) -> Result<(), CliError> {
        self.0.send(frame)
    }
    fn describe(&self) -> String {
        format!("socketcand {}", self.0.addr())
    }
    fn tx_gap(&self) -> Duration {
        SOCKETCAND_TX_GAP
    }
}

/// A kernel CAN interface.
#[cfg(target_os = "linux")]
pub struct SocketCanLink(r2p_canlink::socketcan::SocketCan);

#[cfg(target_os = "linux")]
impl SocketCanLink {
    /// Opens `iface`, or says why it cannot be opened and what to do.
    pub fn open(iface: &str) -> Result<Self, CliError> {
        r2p_canlink::socketcan::SocketCan::open(iface)
            .map(Self)
            .map_err(|e| CliError::new(format!("--socketcan {iface}: {e}")))
    }
}

#[cfg(target_os = "linux")]
impl Link for SocketCanLink {
    fn recv(&mut self, timeout: Duration) -> Result<Recv, CliError> {
        match self.0.recv_timeout(timeout) {
            Ok(Some(frame)) => Ok(Recv::Frame(Stamped { time: r2p_canlink::frame::now(), frame })),
            Ok(None) => Ok(Recv::Timeout),
            Err(e) => Err(CliError::new(format!("receiving on {}: {e}", self.0.iface()))),
        }
    }
    fn send(&mut self, frame: &CanFrame) -> Result<(), CliError> {
        self.0.send(frame).map_err(|e| CliError::new(format!("sending on {}: {e}", self.0.iface())))
    }
    fn describe(&self) -> String {
        format!("SocketCAN {}", self.0.iface())
    }
}

/// A participant of an in-process hub (e.g. an emulated bus bridged to a `BroadcastHub`).
pub struct HubLink {
    hub: Arc<dyn Hub>,
    me: ParticipantId,
    sub: Subscription,
}

impl HubLink {
    /// Joins `hub` with a receive queue of `queue` frames.
    pub fn join(hub: Arc<dyn Hub>, queue: usize) -> Self {
        let me = hub.join();
        let sub = hub.subscribe(me, queue);
        Self { hub, me, sub }
    }
}

impl Link for HubLink {
    fn recv(&mut self, timeout: Duration) -> Result<Recv, CliError> {
        Ok(self.sub.recv_timeout(timeout).map_or(Recv::Timeout, Recv::Frame))
    }
    fn send(&mut self, frame: &CanFrame) -> Result<(), CliError> {
        self.hub.send(self.me, *frame);
        Ok(())
    }
    fn describe(&self) -> String {
        "in-process bus".into()
    }
}

/// A trace file read back frame by frame.
pub struct TraceLink {
    name: String,
    frames: std::vec::IntoIter<Stamped>,
}

impl TraceLink {
    /// Reads `path` (a candump log or a pcap file).
    pub fn open(path: &Path) -> Result<Self, CliError> {
        Ok(Self::new(path.display().to_string(), Self::read(path)?))
    }

    /// The frames of the trace at `path` (a candump log or a pcap file); the error names the
    /// option, the file and what is wrong with it, and says what a trace is.
    pub fn read(path: &Path) -> Result<Vec<Stamped>, CliError> {
        let (_, frames) = read_trace(path).map_err(|e| {
            CliError::new(format!(
                "--trace: {e}: give a candump log or a pcap file (r2p monitor --write and r2p \
                 sim --log record them), or a live bus (--socketcand or --socketcan)"
            ))
        })?;
        Ok(frames)
    }

    /// A trace of `frames`, called `name`.
    pub fn new(name: String, frames: Vec<Stamped>) -> Self {
        Self { name, frames: frames.into_iter() }
    }
}

impl Link for TraceLink {
    fn recv(&mut self, _timeout: Duration) -> Result<Recv, CliError> {
        Ok(self.frames.next().map_or(Recv::End, Recv::Frame))
    }
    fn send(&mut self, _frame: &CanFrame) -> Result<(), CliError> {
        Err(CliError::new(format!(
            "the trace {} is read back, not a bus: nothing can be sent (use --socketcand or \
             --socketcan)",
            self.name
        )))
    }
    fn describe(&self) -> String {
        format!("trace {}", self.name)
    }
    fn is_trace(&self) -> bool {
        true
    }
}
