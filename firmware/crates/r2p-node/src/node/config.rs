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
    /// Frame-sized reservations (issue 22, docs/rtcan.md "Frame-sized reservations"): the
    /// blocks the master lays them out in, which together hold `hrt_slots` slots' time; 0 for
    /// the slot grid (the default, every image). Needs the feature `framed-reservations`; the
    /// same on every node of a bus (a grant of the other layout is ignored and counted).
    pub hrt_blocks: u8,
    /// How the node sends SRT/NRT frames in the free slots (slotted mode): merged windows
    /// with retransmission, or one one-shot frame per free slot.
    pub free_slots: FreeSlots,
    /// How long before a slot boundary the slot timer calls [`Node::slot_tick`] (µs), which
    /// then acts for the boundary: the time the MCU takes from the timer's interrupt to the
    /// mailbox request, so the slot's frame reaches the controller at the boundary rather than
    /// that late (a worst-case frame, 160 µs, plus a 26 µs path would not fit a 166 µs slot).
    /// 0 on the host; [`MODULE_SLOT_LEAD_US`] on the modules.
    pub slot_lead_us: u32,
    /// How long before its cycle's start a master's slot timer calls [`Node::slot_tick`] (µs),
    /// which then acts for the start: the time from the timer's interrupt to the sync's mailbox
    /// request. The sync is loaded first in its tick, on a shorter path than a slot's frame,
    /// so that every cycle starts where the master times it (loaded after the received frames
    /// and the timers, it started up to 33 µs late, by a different amount each cycle). 0 on
    /// the host; [`MODULE_SYNC_LEAD_US`] on the modules. On frame-sized reservations
    /// [`FramedLeads::sync_us`] takes its place.
    pub sync_lead_us: u32,
    /// The slot timer's leads on frame-sized reservations (with [`hrt_blocks`](Self::hrt_blocks)
    /// above 0), which take the place of [`slot_lead_us`](Self::slot_lead_us) there: the paths
    /// to an HRT frame's and to the master's sync's request are shorter than the grid's and
    /// differ, and each must reach its mailbox within its reservation's guard bits. All 0 on
    /// the host; [`MODULE_FRAMED_LEADS`] on the modules.
    pub framed_leads: FramedLeads,
    /// Whether the node listens for one heartbeat period after boot, silent, before it claims
    /// a node ID: the IDs it hears in use are skipped, so a module plugged into a running robot
    /// takes a free one (docs/middleware.md, "Claiming a node ID"). On for modules
    /// ([`NodeConfig::module`]); off in [`NodeConfig::new`] (tests that start on a quiet bus,
    /// tools that listen before they start their node).
    pub listen_first: bool,
}

/// The slot path's length in instructions, from the slot timer's compare interrupt to the HRT
/// frame's mailbox request (the node in a task of an interrupt executor, as module-core's and
/// the gateway's slot timers run it): the shortest and the longest of 400 slots under QEMU
/// (`make bench`, the slot-path image, `-icount`), built for the core it runs on.
/// `tests/test_slot_lead.py` measures both again and fails when a lead or the emulator's path
/// would change.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotPath {
    /// The shortest path (instructions).
    pub min_instructions: u32,
    /// The longest path (instructions).
    pub max_instructions: u32,
}

/// The slot path built for the F103's Cortex-M3 (thumbv7m).
pub const CORTEX_M3_SLOT_PATH: SlotPath =
    SlotPath { min_instructions: 1_829, max_instructions: 1_934 };
/// The slot path built for the F407's Cortex-M4F (thumbv7em, hard float).
pub const CORTEX_M4_SLOT_PATH: SlotPath =
    SlotPath { min_instructions: 1_834, max_instructions: 1_939 };

/// The slot-grid master's path to its sync's request, built for the F103's Cortex-M3: the sync
/// goes first in its tick (before the received frames and the timers), QEMU (`slot-path`,
/// `sync_*_insn`) plus the interrupt's ~190 instructions as on the slot path.
pub const CORTEX_M3_SYNC_PATH: SlotPath = SlotPath { min_instructions: 679, max_instructions: 694 };
/// The same path built for the F407's Cortex-M4F.
pub const CORTEX_M4_SYNC_PATH: SlotPath = SlotPath { min_instructions: 679, max_instructions: 694 };

/// The short path on frame-sized reservations ([`Node::top_up`](crate::Node::top_up)), built
/// for the F103's Cortex-M3: from its call to the window's first frame's request, 1 699–3 923
/// instructions (QEMU, `slot-path --features framed`, after a transmit-complete), plus the
/// interrupt's ~190 as on the slot path. The F407's build of the slot path is within a few
/// instructions of this core's, so the emulator takes it for both.
pub const CORTEX_M3_TOP_UP_PATH: SlotPath =
    SlotPath { min_instructions: 1_889, max_instructions: 4_113 };

/// The frame-sized HRT frame's path built for the F103's Cortex-M3: from the slot timer's
/// compare interrupt to the request of the HRT frame that starts the node's reservation
/// (`framed_tx.rs`), QEMU (`slot-path --features framed`, `to_request_*_insn`) plus the
/// interrupt's ~185 instructions as on the grid's path.
pub const CORTEX_M3_FRAMED_SLOT_PATH: SlotPath =
    SlotPath { min_instructions: 1_369, max_instructions: 1_379 };
/// The frame-sized master's path to its sync's request, loaded first in its tick (before the
/// controller's results and the received frames): QEMU (`sync_*_insn`) plus the interrupt's.
pub const CORTEX_M3_FRAMED_SYNC_PATH: SlotPath =
    SlotPath { min_instructions: 714, max_instructions: 724 };

/// The frame-sized paths with staged reloads (feature `staged-reloads`): the node stages what
/// it cannot load and hands it to the controller's transmit interrupt (`SlotTx::staging`), and
/// takes that interrupt's loads first in each call. QEMU (`slot-path --features staged`; the
/// harness's controller has no such interrupt, so the node's side only) plus the interrupt's
/// ~190 instructions: the HRT frame's path 15–20 instructions longer than without, the
/// sync's too (its lead at 72 MHz 10 µs, not 9), the short path's 20–25.
pub const CORTEX_M3_STAGED_SLOT_PATH: SlotPath =
    SlotPath { min_instructions: 1_384, max_instructions: 1_399 };
/// The frame-sized master's path to its sync's request with staged reloads.
pub const CORTEX_M3_STAGED_SYNC_PATH: SlotPath =
    SlotPath { min_instructions: 729, max_instructions: 744 };
/// The short path (`Node::top_up`) with staged reloads.
pub const CORTEX_M3_STAGED_TOP_UP_PATH: SlotPath =
    SlotPath { min_instructions: 1_904, max_instructions: 4_133 };

/// The frame-sized paths of this build of the node, on the F103's Cortex-M3 (the F407 takes
/// them too, `FramedLeads::at`): the staged ones with `staged-reloads`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FramedPaths {
    /// To the request of the HRT frame that starts a reservation.
    pub slot: SlotPath,
    /// A master's to its sync's request.
    pub sync: SlotPath,
    /// The short path's (`Node::top_up`) to a window's first frame.
    pub top_up: SlotPath,
}

/// [`FramedPaths`] without staged reloads.
#[cfg(not(feature = "staged-reloads"))]
pub const CORTEX_M3_FRAMED_PATHS: FramedPaths = FramedPaths {
    slot: CORTEX_M3_FRAMED_SLOT_PATH,
    sync: CORTEX_M3_FRAMED_SYNC_PATH,
    top_up: CORTEX_M3_TOP_UP_PATH,
};
/// [`FramedPaths`] with staged reloads.
#[cfg(feature = "staged-reloads")]
pub const CORTEX_M3_FRAMED_PATHS: FramedPaths = FramedPaths {
    slot: CORTEX_M3_STAGED_SLOT_PATH,
    sync: CORTEX_M3_STAGED_SYNC_PATH,
    top_up: CORTEX_M3_STAGED_TOP_UP_PATH,
};

/// The slot timer's leads on frame-sized reservations (µs, [`NodeConfig::framed_leads`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FramedLeads {
    /// Before every slot-timer event but the master's sync (an HRT reservation's start, a
    /// window's opening, a grid boundary) and before the short path's.
    pub slot_us: u32,
    /// Before the master's sync.
    pub sync_us: u32,
}

impl FramedLeads {
    /// The leads of a core clocked at `sysclk_hz`, from this build's
    /// [`CORTEX_M3_FRAMED_PATHS`]: the only builds measured, taken for the F407 too (its grid
    /// path is within a few instructions of the M3's, as for the short path).
    pub const fn at(sysclk_hz: u32) -> Self {
        Self {
            slot_us: CORTEX_M3_FRAMED_PATHS.slot.lead_us(sysclk_hz),
            sync_us: CORTEX_M3_FRAMED_PATHS.sync.lead_us(sysclk_hz),
        }
    }
}

/// The F103 modules' leads on frame-sized reservations at 72 MHz: 19 µs and 9 µs (10 µs with
/// staged reloads; the grid's is 25 µs).
pub const MODULE_FRAMED_LEADS: FramedLeads = FramedLeads::at(72_000_000);

impl SlotPath {
    /// The slot lead for a core clocked at `sysclk_hz` (µs): the shortest path at one cycle per
    /// instruction (no core runs faster; flash wait states only add), rounded down, so that a
    /// frame never reaches its mailbox before its boundary.
    pub const fn lead_us(self, sysclk_hz: u32) -> u32 {
        (self.min_instructions as u64 * 1_000_000 / sysclk_hz as u64) as u32
    }

    /// The longest path at `sysclk_hz` and one cycle per instruction, rounded up (µs): what the
    /// emulator takes from a board's tick to its frame's mailbox request.
    pub const fn longest_us(self, sysclk_hz: u32) -> u32 {
        (self.max_instructions as u64 * 1_000_000).div_ceil(sysclk_hz as u64) as u32
    }
}

/// The F103 modules' slot lead: [`CORTEX_M3_SLOT_PATH`] at 72 MHz, 25.4–26.9 µs, so 25 µs. The
/// F407 gateway's is [`CORTEX_M4_SLOT_PATH`] at 168 MHz, 10 µs (`SlotPath::lead_us`).
pub const MODULE_SLOT_LEAD_US: u32 = CORTEX_M3_SLOT_PATH.lead_us(72_000_000);

/// The F103 modules' sync lead: [`CORTEX_M3_SYNC_PATH`] at 72 MHz. The F407 gateway's is
/// [`CORTEX_M4_SYNC_PATH`] at 168 MHz.
pub const MODULE_SYNC_LEAD_US: u32 = CORTEX_M3_SYNC_PATH.lead_us(72_000_000);

impl NodeConfig {
    /// Defaults: heartbeat every 100 ms, subscription retried after 300 ms, reassembly timeout
    /// 20 ms, logarithmic laxity with 100 µs ticks, the default cycle (10 ms, 60 slots), no
    /// rank, 30 HRT slots (in runs of two: slots 1, 2, 4, 5, …, 44), free slots merged into
    /// windows, the node ID claimed at once.
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
            hrt_blocks: 0,
            free_slots: FreeSlots::Merged,
            slot_lead_us: 0,
            sync_lead_us: 0,
            framed_leads: FramedLeads { slot_us: 0, sync_us: 0 },
            listen_first: false,
        }
    }

    /// [`NodeConfig::new`] for a module: it listens for one heartbeat period before it claims
    /// its node ID ([`NodeConfig::listen_first`]), as every module image and emulated module
    /// board does.
    pub const fn module(uid: [u8; UID_LEN], name: &'static str) -> Self {
        Self { listen_first: true, ..Self::new(uid, name) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_mcu_leads_by_its_shortest_slot_path_rounded_down() {
        // 1 829 / 72 = 25.4 µs; 1 834 / 168 = 10.9 µs.
        assert_eq!(MODULE_SLOT_LEAD_US, 25);
        assert_eq!(CORTEX_M4_SLOT_PATH.lead_us(168_000_000), 10);
        // Exactly on a microsecond: not rounded.
        let p = SlotPath { min_instructions: 144, max_instructions: 144 };
        assert_eq!(p.lead_us(72_000_000), 2);
        assert_eq!(p.longest_us(72_000_000), 2);
    }

    #[test]
    fn the_emulated_path_is_the_longest_rounded_up() {
        // 1 934 / 72 = 26.9 µs; 1 939 / 168 = 11.5 µs.
        assert_eq!(CORTEX_M3_SLOT_PATH.longest_us(72_000_000), 27);
        assert_eq!(CORTEX_M4_SLOT_PATH.longest_us(168_000_000), 12);
        let p = SlotPath { min_instructions: 145, max_instructions: 145 };
        assert_eq!(p.longest_us(72_000_000), 3);
    }
}
