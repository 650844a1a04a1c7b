//! What a module says about itself and its bus, once, when it builds its [`Node`](super::Node):
//! its identity, the protocol's timing, and the cycle every node of the bus shares.

use r2p_management::message::UID_LEN;
use rtcan::{CycleConfig, LaxityEncoding};

use crate::slot_tx::FreeSlots;
#[cfg(doc)]
use crate::Node;

/// What a node is and how it paces the protocol.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NodeConfig {
    /// The MCU's 96-bit unique ID: picks the first node ID and settles node-ID conflicts.
    pub uid: [u8; UID_LEN],
    /// Module name (printable ASCII, at most 16 characters; two modules may share it).
    pub name: &'static str,
    /// Time between heartbeats, µs.
    pub heartbeat_period_us: u32,
    /// Time to wait for a SUBSCRIBE_RESPONSE before asking again, µs.
    pub request_timeout_us: u32,
    /// A half-received message with no frame for this long is given up, µs.
    pub reassembly_timeout_us: u32,
    /// How SRT laxity is encoded in identifiers (the same on the whole bus).
    pub laxity: LaxityEncoding,
    /// The communication cycle (the same on the whole bus).
    pub cycle: CycleConfig,
    /// Master rank 0…15 (0 takes over first) for modules that may become bus master; `None`
    /// for the others. By convention the power-supply module is rank 0 (its firmware sets
    /// `rank: Some(0)`); other standbys take 1, 2, …; the default is `None`.
    pub rank: Option<u8>,
    /// Slots the node reserves for HRT streams when it is master, laid out by
    /// `rtcan::Scheduler` in short runs with a free slot after each; the others stay free for
    /// SRT/NRT traffic (including HRT registrations). Keep it well below the cycle's slot count,
    /// the same on every node with a rank.
    pub hrt_slots: u8,
    /// How the node sends SRT/NRT frames in the free slots (slotted mode): merged windows
    /// with retransmission, or one one-shot frame per free slot.
    pub free_slots: FreeSlots,
    /// How long before a slot boundary the slot timer calls [`Node::slot_tick`] (µs), which
    /// then acts for the boundary: the time the MCU takes from the timer's interrupt to the
    /// mailbox request, so the slot's frame reaches the controller at the boundary rather than
    /// that late (a worst-case frame, 160 µs, plus a 29 µs path would not fit a 166 µs slot).
    /// 0 on the host; [`MODULE_SLOT_LEAD_US`] on the modules.
    pub slot_lead_us: u32,
}

/// The modules' slot lead: the F103's slot path at 72 MHz, from the compare interrupt to the
/// HRT frame's mailbox request, 1 984–2 084 instructions under QEMU (`make bench`, the
/// slot-path image), 27.6–28.9 µs at one cycle per instruction; the shortest, rounded down, so
/// that a frame never reaches its mailbox before its boundary.
pub const MODULE_SLOT_LEAD_US: u32 = 27;

impl NodeConfig {
    /// Defaults: heartbeat every 100 ms, subscription retried after 300 ms, reassembly timeout
    /// 20 ms, logarithmic laxity with 100 µs ticks, the default cycle (10 ms, 60 slots), no
    /// rank, 30 HRT slots (in runs of two: slots 1, 2, 4, 5, …, 44), free slots merged into
    /// windows.
    pub const fn new(uid: [u8; UID_LEN], name: &'static str) -> Self {
        Self {
            uid,
            name,
            heartbeat_period_us: 100_000,
            request_timeout_us: 300_000,
            reassembly_timeout_us: 20_000,
            laxity: LaxityEncoding::Logarithmic { tick_us: 100 },
            cycle: CycleConfig::DEFAULT,
            rank: None,
            hrt_slots: 30,
            free_slots: FreeSlots::Merged,
            slot_lead_us: 0,
        }
    }
}
