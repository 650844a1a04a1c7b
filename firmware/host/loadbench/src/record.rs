//! What the nodes report of a run: every frame they got onto the bus (in the order their port
//! sent them, to be matched with the bus's event log) and what they counted on the way.

use std::ops::AddAssign;

/// A frame a node's port sent successfully.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sent {
    /// Its raw identifier (checked against the bus log).
    pub raw_id: u32,
    /// What it carried.
    pub what: Carried,
}

/// The content of a sent frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Carried {
    /// An RTCAN sync frame.
    Sync,
    /// A frame of message `msg` (index in `Traffic::messages`) with `fragment` frames to follow.
    Message {
        /// The message.
        msg: u32,
        /// Frames still to follow.
        fragment: u8,
    },
}

/// Counters of one node (or a whole run, summed).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Counters {
    /// RTCAN: queued frames that did not go out in their window (lost a one-shot arbitration,
    /// or were withdrawn at the latest start) and went back to the queue. Fixed priority: frames
    /// swapped out of the mailbox for a more urgent one.
    pub retries: u64,
    /// RTCAN: of those, frames withdrawn at their window's latest start (the bus was busy).
    pub late: u64,
    /// Messages lost to a full publisher queue.
    pub overflows: u64,
    /// Messages (or their remaining frames) dropped because their deadline passed unsent.
    pub expired: u64,
    /// HRT occurrences the node never loaded (its clock skipped the slot).
    pub hrt_skipped: u64,
    /// Syncs a slave's clock did not find where it expected them (a late sync): the clock
    /// re-phased and took the cycle's reservations as unknown (every slot reserved).
    pub resyncs: u64,
    /// Node activations (slot ticks, or services after a bus event or release).
    pub activations: u64,
    /// Frames the transmit interrupt loaded from those the node staged (`Setup::staged`).
    pub staged: u64,
}

impl AddAssign for Counters {
    fn add_assign(&mut self, o: Self) {
        self.retries += o.retries;
        self.late += o.late;
        self.overflows += o.overflows;
        self.expired += o.expired;
        self.staged += o.staged;
        self.hrt_skipped += o.hrt_skipped;
        self.resyncs += o.resyncs;
        self.activations += o.activations;
    }
}
