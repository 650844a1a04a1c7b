//! A session on a bus: the link, the [`Watcher`] decoding every frame on it, and, once joined,
//! the [`HostNode`] that takes the same frames and sends through the link.

use std::time::{Duration, Instant};

use crate::error::CliError;
use crate::host::HostNode;
use crate::link::{Link, Recv};
use crate::watch::{Report, Watcher};

/// A link, the watcher decoding everything on it, and (once joined) the host node.
pub struct Session {
    link: Box<dyn Link>,
    watch: Watcher,
    host: Option<HostNode>,
    start: Instant,
    last_tx: Option<Instant>,
    ended: bool,
    /// Frames decoded while the host node listened before joining (returned by the next step).
    heard: Vec<Report>,
}

/// Frames taken per step at most (then the node runs).
const BATCH: usize = 256;

/// How long the host node listens before it sends anything: one and a half default heartbeat
/// periods, so every running module has heartbeated and the node's first claim avoids their
/// node IDs (a tool never disturbs a running module; docs/middleware.md, "Node ID").
pub const LISTEN: Duration = Duration::from_millis(150);

impl Session {
    /// A session on `link`; nothing is sent until [`Session::join`].
    pub fn new(link: Box<dyn Link>) -> Self {
        Self {
            link,
            watch: Watcher::new(),
            host: None,
            start: Instant::now(),
            last_tx: None,
            ended: false,
            heard: Vec::new(),
        }
    }

    /// What the link is.
    pub fn describe(&self) -> String {
        self.link.describe()
    }

    /// True if reading a trace back.
    pub fn is_trace(&self) -> bool {
        self.link.is_trace()
    }

    /// True once a trace has no more frames.
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// The watcher.
    pub fn watcher(&self) -> &Watcher {
        &self.watch
    }

    /// Puts the host node on the bus: it listens for [`LISTEN`] (taking the node IDs it hears
    /// as in use), then heartbeats at once, so modules re-advertise to it.
    pub fn join(&mut self) -> Result<&mut HostNode, CliError> {
        self.join_as(HostNode::new)
    }

    /// [`Session::join`] with the host node's unique ID given (tests).
    #[cfg(test)]
    pub(crate) fn join_with_uid(
        &mut self,
        uid: [u8; r2p_management::message::UID_LEN],
    ) -> Result<&mut HostNode, CliError> {
        self.join_as(|start| HostNode::with_uid(start, uid))
    }

    fn join_as(
        &mut self,
        make: impl FnOnce(Instant) -> Result<HostNode, CliError>,
    ) -> Result<&mut HostNode, CliError> {
        if self.link.is_trace() {
            return Err(CliError::new(format!(
                "this command needs a live bus, not the {}: use --socketcand or --socketcan",
                self.link.describe()
            )));
        }
        if self.host.is_none() {
            self.host = Some(make(self.start)?);
            let t0 = Instant::now();
            while t0.elapsed() < LISTEN && !self.ended {
                let mut reports = self.read(LISTEN.saturating_sub(t0.elapsed()))?;
                self.host.as_mut().expect("just made").listen();
                self.heard.append(&mut reports);
            }
        }
        Ok(self.host.as_mut().expect("just made"))
    }

    /// The host node, once joined.
    pub fn host(&mut self) -> Option<&mut HostNode> {
        self.host.as_mut()
    }

    /// Lets the host node send what it has queued (at most `limit`), so that leaving does not
    /// cut a message short: modules would count its first frames as dropped.
    pub fn flush(&mut self, limit: Duration) -> Result<(), CliError> {
        let start = Instant::now();
        while self.host.as_ref().is_some_and(|h| h.tx_pending() > 0) && start.elapsed() < limit {
            self.step(Duration::from_millis(1))?;
        }
        Ok(())
    }

    /// Waits up to `wait` for frames, decodes every frame that came (at most [`BATCH`]), lets
    /// the host node take them and run, and returns the decoded frames.
    pub fn step(&mut self, wait: Duration) -> Result<Vec<Report>, CliError> {
        let mut reports = std::mem::take(&mut self.heard);
        reports.append(&mut self.read(wait)?);
        if let Some(h) = &mut self.host {
            let gap = self.link.tx_gap();
            let budget = if gap.is_zero() {
                usize::MAX
            } else {
                usize::from(self.last_tx.is_none_or(|t| t.elapsed() >= gap))
            };
            if h.poll(self.link.as_mut(), budget)? > 0 {
                self.last_tx = Some(Instant::now());
            }
        }
        Ok(reports)
    }

    /// Waits up to `wait` for frames and decodes every frame that came (at most [`BATCH`]);
    /// the host node takes them (it runs later).
    fn read(&mut self, wait: Duration) -> Result<Vec<Report>, CliError> {
        let mut reports = Vec::new();
        let mut timeout = wait;
        while reports.len() < BATCH {
            match self.link.recv(timeout)? {
                Recv::Frame(s) => {
                    let r = self.watch.feed(&s);
                    if let Some(h) = &mut self.host {
                        h.take(&r);
                    }
                    reports.push(r);
                    timeout = Duration::ZERO;
                }
                Recv::Timeout => break,
                Recv::End => {
                    self.ended = true;
                    break;
                }
            }
        }
        Ok(reports)
    }
}

/// How long a session that joined the bus keeps sending its queue when it ends.
const FLUSH_ON_EXIT: Duration = Duration::from_millis(300);

impl Drop for Session {
    fn drop(&mut self) {
        let _ = self.flush(FLUSH_ON_EXIT);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_trace_cannot_be_joined() {
        let link = crate::link::TraceLink::new("t.log".into(), Vec::new());
        let mut s = Session::new(Box::new(link));
        let e = s.join().err().unwrap();
        assert!(e.to_string().contains("needs a live bus, not the trace t.log"), "{e}");
        assert!(s.step(Duration::ZERO).unwrap().is_empty() && s.ended());
    }
}
