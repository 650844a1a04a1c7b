//! The master's reservations follow their nodes' lives (issue 22; docs/middleware.md, "HRT
//! reservations"): a node that holds HRT slots and then goes silent for
//! [`PEER_TIMEOUT_HEARTBEATS`] of the master's heartbeat periods, or that rebooted (its heartbeat
//! says `Starting` again after `Running`, or its uptime went back), loses them, and the slots
//! go back to the calendar for others. Before, a node that left or moved kept its slots until
//! the next master change.
//!
//! Master-side only: every entry point does nothing in a node built without master support
//! (`MASTER = false`), so modules that cannot be master carry none of it.

use r2p_management::message::ModuleState;
use r2p_management::NodeId;
use rtcan::{MessageId, Micros};

use super::hrt::MASTER_STREAMS;
use super::stats::bump;
use super::Node;

/// Heartbeat periods (the master's own `heartbeat_period_us`) of silence after which a node's
/// reservations are released: 10, so a few heartbeats lost to errors or a busy bus never cost a
/// live node its slots (the bus's modules share the default period, 100 ms: one second).
pub const PEER_TIMEOUT_HEARTBEATS: u64 = 10;

/// Nodes holding reservations the master follows: 8 (a robot's HRT publishers: Triskar2 has
/// two), 96 bytes in every node. A ninth is granted its slots but not followed: they stay until
/// the next master change, as before.
pub(super) const OWNERS: usize = 8;

/// A node holding reservations in the master's calendar, as its heartbeats say (12 bytes: the
/// master keeps one per node, in every node's RAM).
#[derive(Clone, Copy, Debug)]
pub(super) struct Owner {
    node: NodeId,
    starting: bool,
    /// When its last heartbeat came: the low 32 bits of the µs clock (71 minutes; compared
    /// with wrapping arithmetic once a heartbeat period).
    heard: u32,
    uptime_s: u32,
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
    /// [`PEER_TIMEOUT_HEARTBEATS`] of this node's heartbeat periods, µs: a peer silent that long
    /// left (at most 2³¹ µs, so the wrapping 32-bit times compare).
    pub(super) fn peer_timeout_us(&self) -> u32 {
        (PEER_TIMEOUT_HEARTBEATS * Micros::from(self.config.heartbeat_period_us))
            .min(Micros::from(u32::MAX / 2)) as u32
    }

    /// The master granted `node` a reservation at `now`: it is followed from then on.
    pub(super) fn owner_granted(&mut self, node: NodeId, now: Micros) {
        if !MASTER || self.owners.iter().any(|o| o.node == node) {
            return;
        }
        // A full table: this node is not followed ([`OWNERS`]).
        let _ = self.owners.push(Owner { node, heard: now as u32, uptime_s: 0, starting: true });
    }

    /// A heartbeat of `node` at `now`: refreshes it; a reboot releases its reservations (it
    /// registers its streams again).
    pub(super) fn owner_heard(
        &mut self,
        node: NodeId,
        state: ModuleState,
        uptime_s: u32,
        now: Micros,
    ) {
        if !MASTER {
            return;
        }
        let Some(o) = self.owners.iter_mut().find(|o| o.node == node) else { return };
        let starting = state == ModuleState::Starting;
        let rebooted = uptime_s < o.uptime_s || (starting && !o.starting);
        (o.heard, o.uptime_s, o.starting) = (now as u32, uptime_s, starting);
        if rebooted {
            self.release(node);
        }
    }

    /// Releases the reservations of every node silent for the timeout at `now`.
    pub(super) fn expire_owners(&mut self, now: Micros) {
        if !MASTER || self.master.is_none() {
            return;
        }
        let timeout = self.peer_timeout_us();
        let now = now as u32;
        while let Some(o) = self.owners.iter().find(|o| now.wrapping_sub(o.heard) > timeout) {
            let node = o.node;
            self.release(node);
            self.owners.retain(|o| o.node != node);
        }
    }

    /// Removes `node`'s reservations from the calendar (the next syncs' masks no longer show
    /// them), counting each.
    fn release(&mut self, node: NodeId) {
        let mine = |s: MessageId| NodeId::of(s).is_some_and(|(n, _)| n == node);
        let streams: heapless::Vec<MessageId, MASTER_STREAMS> =
            self.scheduler.iter().map(|r| r.stream).filter(|s| mine(*s)).collect();
        for s in streams {
            self.scheduler.remove(s);
            bump(&mut self.stats.hrt_released);
        }
        self.calendar_released();
    }
}
