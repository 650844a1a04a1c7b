//! A subscriber follows its publishers (issue 22; docs/middleware.md, "Remote topics: the node
//! runtime"): each import remembers when its publisher was last heard — a message of the
//! stream, or, for a stream without an advertised period, one of the publisher's heartbeats —
//! and the node raises [`Event::PublisherSilent`] once when that is longer ago than two of the
//! stream's periods (HRT) or the peer timeout ([`PEER_TIMEOUT_HEARTBEATS`] of this node's
//! heartbeat periods: the module left). When a publisher that left is heard again (its cable
//! back in) it is asked again; one that restarts is asked again when it advertises while
//! starting (`management.rs`), since a rebooted publisher has no subscribers.

use r2p_management::NodeId;
use rtcan::Micros;

#[cfg(doc)]
use super::liveness::PEER_TIMEOUT_HEARTBEATS;
use super::{Event, ImportState, Node};

impl<
        'a,
        const EXPORTS: usize,
        const IMPORTS: usize,
        const TXQ: usize,
        const RX: usize,
        const BUF: usize,
        const MASTER: bool,
    > Node<'a, EXPORTS, IMPORTS, TXQ, RX, BUF, MASTER>
{
    /// Import `i`'s publisher was heard at `now` (a message, or the subscription's answer).
    pub(super) fn publisher_heard(&mut self, i: usize, now: Micros) {
        if let Some(s) = self.imports.get_mut(i) {
            s.heard = now as u32;
            s.seen = now as u32;
            s.silent = false;
        }
    }

    /// A heartbeat of `node` at `now`: alive, for the imports whose streams have no period. One
    /// not heard for the peer timeout is asked again: its module or this one was away, and the
    /// publisher may have dropped this subscriber (`subscribers.rs`; an HRT stream then gave
    /// its slot back) or rebooted.
    pub(super) fn publisher_alive(&mut self, node: NodeId, now: Micros) {
        let timeout = self.peer_timeout_us();
        for s in self.imports.iter_mut() {
            let ImportState::Subscribed { from, message } = s.state else { continue };
            if from != node {
                continue;
            }
            let away = (now as u32).wrapping_sub(s.seen) > timeout;
            s.seen = now as u32;
            if s.period_us == 0 {
                s.heard = now as u32;
                s.silent = false;
            }
            if away {
                // Asked at the next tick (its retry is due at once).
                s.state = ImportState::Requested { from, index: message.0 as u8, since: 0 };
            }
        }
    }

    /// Once a heartbeat period: raises [`Event::PublisherSilent`] for each import whose
    /// publisher has been silent too long.
    pub(super) fn check_publishers(&mut self, now: Micros) {
        let timeout = self.peer_timeout_us();
        for i in 0..self.imports.len() {
            let s = &mut self.imports[i];
            let ImportState::Subscribed { from, .. } = s.state else { continue };
            let limit = if s.period_us > 0 { s.period_us.saturating_mul(2) } else { timeout };
            if s.silent || (now as u32).wrapping_sub(s.heard) <= limit {
                continue;
            }
            s.silent = true;
            self.event(Event::PublisherSilent { import: i, from });
        }
    }
}
