//! A publisher follows its remote subscribers (issue 22; docs/middleware.md, "Remote topics:
//! the node runtime"): each export remembers which modules subscribed and when one of them
//! was last heard (their heartbeats). When none has been heard for the peer timeout
//! ([`PEER_TIMEOUT_HEARTBEATS`] of this node's heartbeat periods: their modules left) the node
//! raises [`Event::SubscribersLeft`] and the export stops queueing messages
//! ([`Export::deactivate`]), so its frames stop taking the bus, and an HRT export gives its
//! slot back to the master (HRT_REQUEST with period 0). A subscriber that comes back asks again
//! (its side of liveness, `publishers.rs`) and the stream starts again. An unsubscribing node
//! (`Node::unsubscribe`) leaves the set at once; if it was the last, the next check stops.
//!
//! One time per export, not one per subscriber: a stream goes to every subscriber at once (one
//! CAN frame), so only the last one leaving changes what the bus carries — and it costs every
//! image half the flash of per-subscriber tables (footprint-f103: +464 B against +784 B).

use r2p_management::message::Message;
use r2p_management::NodeId;
use rtcan::Micros;

#[cfg(doc)]
use super::liveness::PEER_TIMEOUT_HEARTBEATS;
use super::management::NodeSet;
use super::{Event, HrtState, Node};
#[cfg(doc)]
use crate::remote::Export;

/// An export's remote subscribers and when one of them was last heard (the low 32 bits of the
/// µs clock, compared with wrapping arithmetic once a heartbeat period).
#[derive(Clone, Copy, Default)]
pub(super) struct Subscribers {
    nodes: NodeSet,
    heard: u32,
    /// One of them unsubscribed: once the set is empty the next check stops the export (nothing
    /// else empties the set of a running stream but that check itself). A word, not a `bool`:
    /// the struct then clears in whole words (a 37-byte clear links the byte-wise `memclr`).
    left: u32,
}

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
    /// `from` subscribed to export `i` at `now` (its stream runs for it).
    pub(super) fn subscriber_added(&mut self, i: usize, from: NodeId, now: Micros) {
        if let Some(e) = self.exports.get_mut(i) {
            e.subscribers.nodes.insert(from);
            e.subscribers.heard = now as u32;
        }
    }

    /// `from` unsubscribed from export `i` (a request with queue length 0): forgotten at once.
    /// If it was the last, the next check stops the export (at most a heartbeat period later;
    /// the stop lives in one place, for the F103 images' flash).
    pub(super) fn subscriber_removed(&mut self, i: usize, from: NodeId) {
        let e = &mut self.exports[i];
        let s = &mut e.subscribers;
        let mut had = s.nodes.take(from);
        if let Some(h) = e.hrt.as_mut() {
            if h.waiting.is_some_and(|(w, _)| w == from) {
                h.waiting = None; // it asked, then left before the master answered
                had = true;
            }
        }
        s.left |= u32::from(had); // looked at once the set is empty
    }

    /// A heartbeat of `node` at `now`: alive, for every export it subscribed to.
    pub(super) fn subscriber_alive(&mut self, node: NodeId, now: Micros) {
        for e in self.exports.iter_mut().filter(|e| e.subscribers.nodes.contains(node)) {
            e.subscribers.heard = now as u32;
        }
    }

    /// Once a heartbeat period: an export none of whose subscribers has been heard for the peer
    /// timeout, or whose last subscriber unsubscribed, stops, and an HRT one gives its slot back.
    pub(super) fn check_subscribers(&mut self, now: Micros) {
        let timeout = self.peer_timeout_us();
        for i in 0..self.exports.len() {
            let s = &mut self.exports[i].subscribers;
            let stop = if s.nodes.is_empty() {
                s.left != 0
            } else {
                (now as u32).wrapping_sub(s.heard) > timeout
            };
            if !stop {
                continue;
            }
            s.nodes = NodeSet::default();
            s.left = 0;
            self.event(Event::SubscribersLeft { export: i });
            self.stop_export(i);
        }
    }

    /// Export `i` has no subscriber left: nothing more is queued, and its HRT slot (if any)
    /// goes back to the master's calendar.
    fn stop_export(&mut self, i: usize) {
        let e = &mut self.exports[i];
        e.export.deactivate();
        let Some(h) = e.hrt.as_mut() else { return };
        let held = matches!(h.state, HrtState::Granted { .. } | HrtState::Requested { .. });
        h.state = HrtState::Idle;
        if !held {
            return;
        }
        let message = self.ids.node_id().message_id(i as u8 + 1);
        if MASTER && self.master.is_some() {
            self.scheduler.remove(message);
            self.calendar_released();
        } else {
            // Period 0: a release (a master that does not know it refuses it as not
            // harmonic, and the slot stays until this node goes silent or reboots).
            let release =
                Message::HrtRequest { message_id: message.0, period_cycles: 0, frames: 1, size: 0 };
            let _ = self.send(&release);
        }
    }
}
