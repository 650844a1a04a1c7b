//! Counters of what the node did and dropped: a frame or message the node cannot use is counted
//! and dropped, never a panic, and the counters are how a user finds out (the heartbeat's
//! `dropped` field sums them for the bus).

use rtcan::ReassemblyStats;

use super::Node;

/// What the node did and dropped (saturating counters).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NodeStats {
    /// Frames given to [`Node::on_frame`].
    pub frames_received: u32,
    /// Sync frames received (well-formed or not).
    pub sync_frames: u32,
    /// Frames with a sync identifier that are not a sync (payload not 8 bytes). Dropped.
    pub bad_syncs: u32,
    /// Syncs this node sent as master that went out (the controller reported them sent).
    pub syncs_sent: u32,
    /// HRT frames sent in their reserved slots.
    pub hrt_sent: u32,
    /// HRT occurrences missed: the frame could not be loaded, or did not go out in its slot
    /// (sent one-shot: an error frame is not retried); reported to the publisher as a deadline
    /// miss.
    pub hrt_missed: u32,
    /// SRT/NRT frames that did not go out in their window — lost a one-shot arbitration, ended
    /// in an error, or were withdrawn at the latest start — and went back to the queue.
    pub slot_retries: u32,
    /// Of those, the frames withdrawn because the bus was busy at their window's latest start
    /// (at it, or at the window's end after losing an arbitration they were in then).
    pub late_withdrawals: u32,
    /// HRT reservations the master refused to this node.
    pub hrt_refused: u32,
    /// As master: reservations released because their node went silent or rebooted
    /// (`node::liveness`).
    pub hrt_released: u32,
    /// Frames that are neither on a management stream nor on a subscribed stream: other
    /// modules' traffic, or garbage. Dropped.
    pub unknown_frames: u32,
    /// Management messages that did not decode. Dropped.
    pub malformed: u32,
    /// Well-formed management messages that make no sense here (a response nobody asked for,
    /// a message ID that is not the sender's, an advertisement on stream 0). Dropped.
    pub unexpected: u32,
    /// Topic messages whose bytes the local type refused. Dropped.
    pub bad_payloads: u32,
    /// Subscriptions refused, or not asked for, because the type hashes (or sizes) differ.
    pub type_mismatches: u32,
    /// Remote messages published locally.
    pub published: u32,
    /// Remote messages dropped because the local pool was empty.
    pub remote_pool_empty: u32,
    /// Local messages queued for the bus.
    pub queued: u32,
    /// Local messages that missed their deadline before going on the bus (reported to their
    /// publisher).
    pub deadline_misses: u32,
    /// Messages not queued because the transmit queue was full.
    pub tx_overflow: u32,
    /// Frames handed to the controller.
    pub frames_sent: u32,
    /// Frames queued under a node ID the node then had to give up (a conflict moved it):
    /// dropped, never sent on the streams of the module that keeps that ID.
    pub dropped_on_move: u32,
    /// Events dropped because the application did not take them.
    pub events_lost: u32,
    /// Syncs not followed (`rtcan::failover::Failover::on_sync`, docs/rtcan.md "Babblers"):
    /// while synced, those out of turn (off the followed cycle's grid or out of its sequence;
    /// to a master, from a rank no better than its own); while not synced, those no sync in
    /// sequence continued (a lone sync, or a master's first that one displaced). A babbler's,
    /// or a start-up race's or healed partition's other master: without them it stays 0.
    pub syncs_out_of_turn: u32,
}

pub(super) fn bump(c: &mut u32) {
    *c = c.saturating_add(1);
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
    /// Counters.
    pub fn stats(&self) -> NodeStats {
        self.stats
    }

    /// The reassembler's counters (every stream, management included).
    pub fn reassembly_stats(&self) -> ReassemblyStats {
        self.rx.stats()
    }

    /// Messages dropped as malformed or undeliverable (the heartbeat's `dropped` field).
    pub fn dropped(&self) -> u32 {
        let r = self.rx.stats();
        let s = self.stats;
        [
            s.malformed,
            s.unexpected,
            s.bad_payloads,
            r.foreign,
            r.out_of_order,
            r.truncated,
            r.timed_out,
            r.too_long,
            r.no_slot,
            r.bad_length,
            r.bad_crc,
        ]
        .iter()
        .fold(s.bad_syncs, |a, &b| a.saturating_add(b))
    }
}
