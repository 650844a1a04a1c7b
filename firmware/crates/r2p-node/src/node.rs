//! The node runtime: one module's end of the bus (docs/middleware.md, "Remote topics: the node
//! runtime").
//!
//! Sans-IO: [`Node`] never reads a clock or touches hardware. Two ways to drive it:
//!
//! - **TDMA** (a bus with a master: HRT streams, reserved slots): the slot timer calls
//!   [`Node::slot_tick`]`(now, &mut controller)` at every slot boundary
//!   ([`Node::next_slot_at`] says when). The node tracks the master's syncs, takes over as
//!   master when its rank says so, sends syncs as master, loads its HRT frames in their
//!   reserved slots and its SRT/NRT frames in the free ones, one at a time, none starting
//!   after its window's latest start ([`crate::slot_tx`]).
//! - **Unslotted** (a bus without TDMA cycle: no HRT, no node with a rank driving a cycle):
//!   [`Node::poll`]`(now, &mut controller)` — or its three parts [`Node::on_frame`],
//!   [`Node::tick`] and [`Node::transmit`] — hands every queued frame to the controller at
//!   once.
//!
//! Either from a task on a module, from an emulated bus in virtual time, or from a test. All
//! nodes of one bus use the same way; a node never mixes them.

use heapless::{Deque, String, Vec};
use r2p_management::message::{
    is_name_char, is_topic_char, BusClass, HrtResult, Message, ModuleState, ParamFault,
    SubscribeResult, Value, ENCODED_MAX, NAME_MAX, TOPIC_MAX, UID_LEN,
};
use r2p_management::{NodeId, NodeIdAllocator, MANAGEMENT_INDEX};
use r2p_middleware::Class;
use rtcan::controller::{ErrorCounters, Received, TxMode, TxOutcome};
use rtcan::cycle::{ClockState, ConfigError, SYNC_SLOT};
use rtcan::failover::{sync_timeout_us, Actions, Rank, Role};
use rtcan::fragment::{frame_count, MAX_MESSAGE_LEN};
use rtcan::frame::MAX_PAYLOAD;
use rtcan::schedule::{occurs, Reject};
use rtcan::{
    CanController, CycleConfig, Expect, Failover, Frame, FrameId, Laxity, LaxityEncoding,
    MessageId, Micros, Period, Phase, Reassembler, ReassemblyStats, Scheduler, SlotClock,
    SyncFrame, TxQueue, Urgency,
};

use crate::params::ParamStore;
use crate::remote::{Export, Import, ImportError};
use crate::slot_tx::{Done, FreeSlots, SlotTx, Slotted};

/// Heartbeats sent with state `Starting` after boot (peers re-advertise to a starting module).
pub const STARTING_HEARTBEATS: u32 = 2;
/// Events kept until the application takes them ([`Node::next_event`]).
pub const EVENT_QUEUE: usize = 8;
/// HRT streams a node's calendar holds when it is master ([`Scheduler`] capacity).
pub const MASTER_STREAMS: usize = 16;

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

/// Why the node refused a configuration, export, import or request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeError {
    /// The module name is longer than 16 characters or not printable ASCII.
    BadName,
    /// A topic name is empty, longer than 32 characters or uses characters outside `A-Za-z0-9_/`.
    BadTopicName,
    /// No room for another export or import (the node's const capacities, at most 255 exports).
    TooMany,
    /// A topic with this name is already exported (or imported).
    DuplicateTopic,
    /// Messages of this size cannot go through the node's buffers.
    TooLarge {
        /// The message size.
        size: usize,
        /// The largest size the node takes.
        max: usize,
    },
    /// A synchronous real-time (HRT) publisher's period is not a power of two (1…256) of
    /// communication cycles.
    HrtPeriod {
        /// The publisher's period.
        period_us: u32,
        /// The cycle's length.
        cycle_us: u32,
    },
    /// The rank is above 15 (`rtcan::failover::MAX_RANK`).
    BadRank,
    /// The cycle configuration is invalid (slots too short, bit rate, slot count).
    BadCycle(ConfigError),
    /// The transmit queue is full: the management message was not queued.
    TxFull,
}

/// Where a local subscription to a remote topic stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImportState {
    /// No module advertised the topic yet.
    Waiting,
    /// Asked `from` (which advertised it on its stream `index`); asked again every
    /// `request_timeout_us` until it answers.
    Requested {
        /// The publisher's node.
        from: NodeId,
        /// The stream index it advertised.
        index: u8,
        /// When the request was (last) queued.
        since: Micros,
    },
    /// Receiving the topic on `message`.
    Subscribed {
        /// The publisher's node.
        from: NodeId,
        /// The stream's message ID, as the publisher assigned it.
        message: MessageId,
    },
    /// The publisher's topic has another type (checked locally from its ADVERTISE, or answered
    /// by the publisher), or it refused. A later ADVERTISE is looked at again.
    Refused {
        /// The publisher's node.
        from: NodeId,
        /// Why.
        result: SubscribeResult,
    },
}

impl ImportState {
    /// The stream whose frames this import takes in: the one it receives, or the one it asked
    /// for (its first frames may follow the publisher's answer back to back, or run already
    /// for other subscribers).
    fn stream(&self) -> Option<MessageId> {
        match *self {
            ImportState::Subscribed { message, .. } => Some(message),
            ImportState::Requested { from, index, .. } => Some(from.message_id(index)),
            _ => None,
        }
    }
}

/// Where an HRT export's reservation stands ([`Node::hrt_state`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HrtState {
    /// No remote subscriber yet: nothing reserved.
    Idle,
    /// To be asked for at the next slot (first subscriber, or re-registration after a master
    /// change or a node-ID move) once a master is heard.
    Wanted,
    /// Asked the master at `since`; asked again every `request_timeout_us`.
    Requested {
        /// When the request was (last) queued.
        since: Micros,
    },
    /// Sending in slot `phase.slot` of the cycles c with c mod period = `phase.offset`.
    Granted {
        /// The reserved phase.
        phase: Phase,
    },
    /// The master refused (the subscriber got `NoSlot`); a new subscription asks again.
    Refused(HrtResult),
}

/// Something the application may act on, taken with [`Node::next_event`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// A node-ID conflict moved this module; its topics were re-advertised.
    NodeIdChanged(NodeId),
    /// A REBOOT for this module (or every module) arrived. [`Node::take_reboot_request`] also
    /// says so; rebooting is the application's business.
    RebootRequested {
        /// Who asked.
        from: NodeId,
    },
    /// A remote module subscribed to export `export`.
    RemoteSubscriber {
        /// Index of the export (order of [`Node::export`]).
        export: usize,
        /// The subscriber's node.
        from: NodeId,
        /// The queue length it asked for.
        queue_len: u8,
    },
    /// Import `import` is now received on `message`.
    Subscribed {
        /// Index of the import (order of [`Node::import`]).
        import: usize,
        /// The publisher's node.
        from: NodeId,
        /// The stream.
        message: MessageId,
    },
    /// Import `import` was refused (type mismatch, unknown topic, no HRT slot).
    SubscriptionRefused {
        /// Index of the import.
        import: usize,
        /// The publisher's node.
        from: NodeId,
        /// Why.
        result: SubscribeResult,
    },
    /// A PARAM_SET changed a local parameter (persist it if the module keeps parameters).
    ParamChanged {
        /// Parameter index.
        index: u16,
        /// New value.
        value: Value,
    },
    /// Answer to [`Node::get_param`] or [`Node::set_param`].
    ParamValue {
        /// The node that answered.
        from: NodeId,
        /// Parameter index.
        index: u16,
        /// Its value.
        value: Value,
    },
    /// Refusal of [`Node::get_param`] or [`Node::set_param`].
    ParamError {
        /// The node that answered.
        from: NodeId,
        /// Parameter index.
        index: u16,
        /// Why.
        fault: ParamFault,
    },
}

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
    /// Of those, the frames withdrawn at their window's latest start because the bus was busy
    /// until then.
    pub late_withdrawals: u32,
    /// HRT reservations the master refused to this node.
    pub hrt_refused: u32,
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
    /// Events dropped because the application did not take them.
    pub events_lost: u32,
}

/// `us / 1_000_000`, saturated to `u32`, without the 64-bit division routine (about 1 KiB on a
/// Cortex-M3): `⌊us / 10⁶⌋ = ⌊⌊us / 64⌋ / 15 625⌋`, the second by long division in 16-bit
/// digits so every step fits the hardware's 32-bit divide.
fn whole_seconds(us: Micros) -> u32 {
    const D: u32 = 15_625;
    let x = us >> 6;
    let (mut q, mut r) = (0u64, 0u32);
    for shift in [48, 32, 16, 0] {
        let cur = (r << 16) | ((x >> shift) as u32 & 0xFFFF);
        q = (q << 16) | u64::from(cur / D);
        r = cur % D;
    }
    u32::try_from(q).unwrap_or(u32::MAX)
}

fn bump(c: &mut u32) {
    *c = c.saturating_add(1);
}

/// A set of node IDs (bit n = node n).
#[derive(Clone, Copy, Default)]
struct NodeSet([u32; 8]);

impl NodeSet {
    fn contains(&self, n: NodeId) -> bool {
        self.0[usize::from(n.get() / 32)] & (1 << (n.get() % 32)) != 0
    }
    /// Nodes are never removed: a peer that leaves stays known (its return in `Starting`
    /// state is what triggers advertisements), and an asked node may still answer.
    fn insert(&mut self, n: NodeId) {
        self.0[usize::from(n.get() / 32)] |= 1 << (n.get() % 32);
    }
    fn len(&self) -> usize {
        self.0.iter().map(|w| w.count_ones() as usize).sum()
    }
}

struct ExportSlot<'a> {
    export: &'a dyn Export,
    advertise: bool,
    hrt: Option<HrtStream>,
}

#[derive(Clone, Copy)]
struct HrtStream {
    period: Period,
    state: HrtState,
    /// A subscriber waiting for the reservation before it is answered (others ask again).
    waiting: Option<(NodeId, u8)>,
}

/// The cycle this node runs as master.
#[derive(Clone, Copy)]
struct MasterCycle {
    cycle: u32,
    next_sync: Micros,
    epoch: bool,
}

struct ImportSlot<'a> {
    import: &'a dyn Import,
    state: ImportState,
}

/// A module's connection to the bus: remote subscribers and publishers of its topics, and the
/// management protocol (node ID, heartbeats, advertisements, subscriptions, reboot,
/// parameters).
///
/// Capacities: `EXPORTS` local topics offered on the bus, `IMPORTS` remote topics subscribed,
/// `TXQ` frames in the RTCAN transmit queue (at least 8), `RX` streams reassembled at once
/// (management streams and topics), `BUF` bytes per message (at least 64, the longest
/// management message, and at least every topic's size).
pub struct Node<
    'a,
    const EXPORTS: usize,
    const IMPORTS: usize,
    const TXQ: usize,
    const RX: usize,
    const BUF: usize,
> {
    config: NodeConfig,
    name: String<NAME_MAX>,
    ids: NodeIdAllocator,
    params: &'a dyn ParamStore,
    exports: Vec<ExportSlot<'a>, EXPORTS>,
    imports: Vec<ImportSlot<'a>, IMPORTS>,
    tx: TxQueue<TXQ>,
    rx: Reassembler<RX, BUF>,
    boot: Option<Micros>,
    next_heartbeat: Micros,
    heartbeats: u32,
    state: ModuleState,
    errors: ErrorCounters,
    /// Nodes heard from.
    peers: NodeSet,
    /// Nodes this module sent parameter requests to (their answers become events).
    asked: NodeSet,
    reboot: bool,
    events: Deque<Event, EVENT_QUEUE>,
    stats: NodeStats,
    clock: SlotClock,
    failover: Failover,
    scheduler: Scheduler<MASTER_STREAMS>,
    master: Option<MasterCycle>,
    /// What is loaded in the controller in slotted mode (HRT exports by index).
    slot_tx: SlotTx<usize>,
    /// Last sync heard or sent (boot time before the first).
    last_sync: Micros,
    /// Fingerprint of the subscribed streams the controller's acceptance filters were last
    /// programmed for (`hw_filters`); `None` before the first time.
    filters_for: Option<u32>,
    /// As master: the sync loaded into the controller and when, until its result is taken.
    sync_loaded: Option<(Micros, SyncFrame)>,
}

impl<
        'a,
        const EXPORTS: usize,
        const IMPORTS: usize,
        const TXQ: usize,
        const RX: usize,
        const BUF: usize,
    > Node<'a, EXPORTS, IMPORTS, TXQ, RX, BUF>
{
    /// A node for the module `config` describes, answering parameter requests from `params`
    /// ([`NoParams`](crate::NoParams) if it has none). It claims its node ID and advertises at
    /// the first [`tick`](Self::tick).
    pub fn new(config: NodeConfig, params: &'a dyn ParamStore) -> Result<Self, NodeError> {
        const {
            assert!(BUF >= ENCODED_MAX, "BUF must hold a management message (64 bytes)");
            assert!(TXQ >= ENCODED_MAX / 8, "TXQ must hold a management message (8 frames)");
        }
        if config.name.len() > NAME_MAX || !config.name.bytes().all(is_name_char) {
            return Err(NodeError::BadName);
        }
        let name = String::try_from(config.name).map_err(|_| NodeError::BadName)?;
        config.cycle.validate().map_err(NodeError::BadCycle)?;
        let rank = match config.rank {
            None => None,
            Some(r) => Some(Rank::new(r).ok_or(NodeError::BadRank)?),
        };
        Ok(Self {
            config,
            name,
            ids: NodeIdAllocator::new(config.uid),
            params,
            exports: Vec::new(),
            imports: Vec::new(),
            tx: TxQueue::new(config.laxity),
            rx: Reassembler::new(config.reassembly_timeout_us as Micros),
            boot: None,
            next_heartbeat: 0,
            heartbeats: 0,
            state: ModuleState::Running,
            errors: ErrorCounters::default(),
            peers: NodeSet::default(),
            asked: NodeSet::default(),
            reboot: false,
            events: Deque::new(),
            stats: NodeStats::default(),
            clock: SlotClock::new(config.cycle),
            failover: Failover::new(rank, config.cycle.cycle_us, 0),
            scheduler: Scheduler::new(config.hrt_slots, config.cycle.slots),
            master: None,
            slot_tx: SlotTx::new(&config.cycle, config.free_slots),
            filters_for: None,
            last_sync: 0,
            sync_loaded: None,
        })
    }

    /// Offers a local topic on the bus through its remote subscriber; returns its stream index
    /// (1…): the stream's message ID is `node ID << 8 | index`. It is advertised at the next
    /// [`tick`](Self::tick).
    ///
    /// A `Class::SyncRealTime { period_us }` publisher becomes an HRT stream: its period must
    /// be a power of two (1…256) of cycles ([`NodeError::HrtPeriod`]) and its messages must fit
    /// one frame (8 bytes). Its slot is asked of the master when the first remote module
    /// subscribes; it is sent only by [`slot_tick`](Self::slot_tick).
    pub fn export(&mut self, export: &'a dyn Export) -> Result<u8, NodeError> {
        check_topic(export.topic())?;
        let max = self.max_export_size();
        if export.size() > max {
            return Err(NodeError::TooLarge { size: export.size(), max });
        }
        let hrt = match export.class() {
            Class::SyncRealTime { period_us } => {
                let cycle_us = self.config.cycle.cycle_us;
                let bad = NodeError::HrtPeriod { period_us, cycle_us };
                if cycle_us == 0 || period_us % cycle_us != 0 {
                    return Err(bad);
                }
                let period = Period::from_cycles(period_us / cycle_us).map_err(|_| bad)?;
                if export.size() > MAX_PAYLOAD {
                    return Err(NodeError::TooLarge { size: export.size(), max: MAX_PAYLOAD });
                }
                Some(HrtStream { period, state: HrtState::Idle, waiting: None })
            }
            _ => None,
        };
        if self.exports.iter().any(|e| e.export.topic() == export.topic()) {
            return Err(NodeError::DuplicateTopic);
        }
        if self.exports.len() >= usize::from(u8::MAX) {
            return Err(NodeError::TooMany);
        }
        self.exports
            .push(ExportSlot { export, advertise: true, hrt })
            .map_err(|_| NodeError::TooMany)?;
        Ok(self.exports.len() as u8)
    }

    /// Subscribes a local topic to the remote topic of the same name through its remote
    /// publisher; returns its import index. The subscription is asked for when a module
    /// advertises the topic with the same type hash and size.
    pub fn import(&mut self, import: &'a dyn Import) -> Result<usize, NodeError> {
        check_topic(import.topic())?;
        if import.size() > BUF {
            return Err(NodeError::TooLarge { size: import.size(), max: BUF });
        }
        if self.imports.iter().any(|i| i.import.topic() == import.topic()) {
            return Err(NodeError::DuplicateTopic);
        }
        self.imports
            .push(ImportSlot { import, state: ImportState::Waiting })
            .map_err(|_| NodeError::TooMany)?;
        Ok(self.imports.len() - 1)
    }

    /// The largest message an export may have: it must fit the encoding buffer and, as one
    /// message, the transmit queue.
    fn max_export_size(&self) -> usize {
        BUF.min(TXQ * 8).min(MAX_MESSAGE_LEN)
    }

    /// This module's node ID (it may change when a conflict is settled: [`Event::NodeIdChanged`]).
    pub fn node_id(&self) -> NodeId {
        self.ids.node_id()
    }

    /// Counters.
    pub fn stats(&self) -> NodeStats {
        self.stats
    }

    /// The reassembler's counters (every stream, management included).
    pub fn reassembly_stats(&self) -> ReassemblyStats {
        self.rx.stats()
    }

    /// Where import `import` stands.
    pub fn import_state(&self, import: usize) -> Option<ImportState> {
        self.imports.get(import).map(|i| i.state)
    }

    /// Where HRT export `export`'s reservation stands (`None` for other exports).
    pub fn hrt_state(&self, export: usize) -> Option<HrtState> {
        self.exports.get(export).and_then(|e| e.hrt).map(|h| h.state)
    }

    /// This node's role in the cycle (master, standby candidate or slave).
    pub fn role(&self) -> Role {
        self.failover.role()
    }

    /// The node's view of the cycle.
    pub fn clock(&self) -> &SlotClock {
        &self.clock
    }

    /// Number of distinct nodes heard from.
    pub fn peer_count(&self) -> usize {
        self.peers.len()
    }

    /// Frames waiting in the transmit queue.
    pub fn tx_pending(&self) -> usize {
        self.tx.len()
    }

    /// The next event, oldest first.
    pub fn next_event(&mut self) -> Option<Event> {
        self.events.pop_front()
    }

    /// True once if a REBOOT for this module arrived since the last call.
    pub fn take_reboot_request(&mut self) -> bool {
        core::mem::take(&mut self.reboot)
    }

    /// The state heartbeats report once the first [`STARTING_HEARTBEATS`] are sent (default
    /// `Running`).
    pub fn set_state(&mut self, state: ModuleState) {
        self.state = state;
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

    /// Asks `target` (or every node: 255) to reboot.
    pub fn request_reboot(&mut self, target: u8) -> Result<(), NodeError> {
        self.send(&Message::Reboot { target })
    }

    /// Reads parameter `index` of `target`; the answer comes as [`Event::ParamValue`] or
    /// [`Event::ParamError`].
    pub fn get_param(&mut self, target: NodeId, index: u16) -> Result<(), NodeError> {
        self.asked.insert(target);
        self.send(&Message::ParamGet { target: target.get(), index })
    }

    /// Sets parameter `index` of `target`; the answer comes as [`Event::ParamValue`] (the value
    /// now held) or [`Event::ParamError`] (refused, unchanged).
    pub fn set_param(&mut self, target: NodeId, index: u16, value: Value) -> Result<(), NodeError> {
        self.asked.insert(target);
        self.send(&Message::ParamSet { target: target.get(), index, value })
    }

    /// Programs the controller's acceptance filters for the syncs, the management streams and
    /// the subscribed (or requested) streams, when those changed (docs/architecture.md; `hw_filters`).
    fn program_filters<C: CanController + ?Sized>(&mut self, can: &mut C) {
        let subscribed = || self.imports.iter().filter_map(|s| s.state.stream());
        let fingerprint = crate::hw_filters::fingerprint(subscribed());
        if self.filters_for == Some(fingerprint) {
            return;
        }
        let (banks, fit) = crate::hw_filters::banks(subscribed());
        can.set_filters(&banks[..fit.used]);
        self.filters_for = Some(fingerprint);
    }

    /// Receives what the controller has, runs the protocol's timers, sends what is due.
    pub fn poll<C: CanController + ?Sized>(&mut self, now: Micros, can: &mut C) {
        self.program_filters(can);
        while let Some(r) = can.try_receive() {
            self.on_frame(&r);
        }
        self.tick(now);
        self.transmit(now, can);
    }

    /// Takes one received frame: management messages are reassembled and handled, subscribed
    /// streams reassembled and published locally, everything else counted and dropped.
    ///
    /// Unslotted mode: sync frames are counted (and checked) but not followed, HRT
    /// registrations are ignored. [`slot_tick`](Self::slot_tick) takes the received frames
    /// itself and follows the cycle (so a node that only polls links none of the cycle's code).
    pub fn on_frame(&mut self, r: &Received) {
        self.receive::<false>(r);
    }

    fn receive<const CYCLE: bool>(&mut self, r: &Received) {
        bump(&mut self.stats.frames_received);
        self.start(r.at);
        let id = r.frame.id();
        if id.sync_cycle().is_some() {
            bump(&mut self.stats.sync_frames);
            match SyncFrame::from_frame(&r.frame) {
                Ok(sync) if CYCLE => self.on_sync(r.at, &sync),
                Ok(_) => {}
                Err(_) => bump(&mut self.stats.bad_syncs),
            }
            return;
        }
        let Some((from, index)) = NodeId::of(id.message) else {
            bump(&mut self.stats.unknown_frames);
            return;
        };
        if index == MANAGEMENT_INDEX {
            let decoded = match self.rx.accept(&r.frame, r.at, Expect::Any) {
                None => return,
                Some(m) => Message::decode(m.data),
            };
            match decoded {
                Ok(msg @ (Message::HrtRequest { .. } | Message::HrtGrant { .. })) => {
                    if CYCLE {
                        self.on_hrt_management(from, msg);
                    }
                }
                Ok(msg) => self.on_management(from, msg, r.at),
                Err(_) => bump(&mut self.stats.malformed),
            }
            return;
        }
        let subscribed = self.imports.iter().find(
            |s| matches!(s.state, ImportState::Subscribed { message, .. } if message == id.message),
        );
        let Some(import) = subscribed.map(|s| s.import) else {
            // A stream this node asked for runs already for other subscribers, and its frames
            // pass the filters (programmed at the request) before the publisher's answer
            // arrives: not unknown, only early.
            let requested = self.imports.iter().any(|s| s.state.stream() == Some(id.message));
            if !requested {
                bump(&mut self.stats.unknown_frames);
            }
            return;
        };
        if let Some(m) = self.rx.accept(&r.frame, r.at, Expect::Exactly(import.size())) {
            match import.publish_bytes(m.data) {
                Ok(_) => bump(&mut self.stats.published),
                Err(ImportError::Decode(_)) => bump(&mut self.stats.bad_payloads),
                Err(ImportError::PoolEmpty) => bump(&mut self.stats.remote_pool_empty),
            }
        }
    }

    /// Runs the protocol at time `now`: heartbeat, pending advertisements, subscription
    /// retries, encoding of published messages into the transmit queue, deadline expiry.
    pub fn tick(&mut self, now: Micros) {
        let boot = self.start(now);
        self.rx.expire(now);

        if now >= self.next_heartbeat {
            let state = if self.heartbeats < STARTING_HEARTBEATS {
                ModuleState::Starting
            } else {
                self.state
            };
            let hb = Message::Heartbeat {
                uid: self.config.uid,
                name: self.name.clone(),
                state,
                uptime_s: whole_seconds(now.saturating_sub(boot)),
                tx_errors: self.errors.tx,
                rx_errors: self.errors.rx,
                dropped: self.dropped().min(u16::MAX as u32) as u16,
            };
            if self.send(&hb).is_ok() {
                self.heartbeats = self.heartbeats.saturating_add(1);
                self.next_heartbeat =
                    now.saturating_add(Micros::from(self.config.heartbeat_period_us));
            }
        }

        for i in 0..self.exports.len() {
            if self.exports[i].advertise {
                let msg = self.advertisement(i);
                if self.send(&msg).is_err() {
                    break; // retried at the next tick
                }
                self.exports[i].advertise = false;
            }
        }

        let timeout = Micros::from(self.config.request_timeout_us);
        for i in 0..self.imports.len() {
            if let ImportState::Requested { from, index, since } = self.imports[i].state {
                if now.saturating_sub(since) >= timeout {
                    self.request(i, from, index, now);
                }
            }
        }

        self.drain_exports(now);

        let (exports, stats) = (&self.exports, &mut self.stats);
        self.tx.expire(now, |m| {
            bump(&mut stats.deadline_misses);
            if let Some((_, index)) = NodeId::of(m.message) {
                if let Some(e) = exports.get(usize::from(index).wrapping_sub(1)) {
                    e.export.report_deadline_miss();
                }
            }
        });
    }

    /// Hands queued frames to the controller until it has no free mailbox. Returns how many.
    ///
    /// Fragments of one message must leave in order: the controller must send its mailboxes
    /// in FIFO order (bxCAN `TXFP` = 1), as docs/rtcan.md requires.
    pub fn transmit<C: CanController + ?Sized>(&mut self, now: Micros, can: &mut C) -> usize {
        self.errors = can.error_counters();
        self.slot_tx.set_mode(can, TxMode::Retransmit);
        let mut n = 0;
        while let Some(frame) = self.tx.peek(now) {
            if can.try_transmit(&frame).is_err() {
                break;
            }
            self.tx.pop(now);
            n += 1;
        }
        self.stats.frames_sent = self.stats.frames_sent.saturating_add(n as u32);
        n
    }

    /// Moves published messages from the remote subscribers into the transmit queue, as far
    /// as it has room for whole messages (the rest wait in the remote subscriber's queue).
    ///
    /// NRT messages leave half the queue free ([`nrt_reserve`]): under overload NRT frames
    /// cannot leave, and without a reserve a backlog of them would fill the queue and keep an
    /// SRT message out of it — out of arbitration — until it expired (docs/rtcan.md, "Under
    /// load").
    fn drain_exports(&mut self, now: Micros) {
        let me = self.ids.node_id();
        let mut buf = [0u8; BUF];
        for (i, slot) in self.exports.iter().enumerate() {
            let e = slot.export;
            if e.active_len() == 0 || slot.hrt.is_some() {
                continue; // HRT streams go in their reserved slots (`slot_tick`)
            }
            let frames = frame_count(e.size()).unwrap_or(usize::MAX);
            let reserve =
                if e.class().deadline_us().is_none() { nrt_reserve(TXQ, frames) } else { 0 };
            let message = me.message_id(i as u8 + 1);
            while e.pending() > 0 && self.tx.free() >= frames.saturating_add(reserve) {
                let Some(encoded) = e.pop_encoded(&mut buf) else { break };
                let Ok((n, at)) = encoded else {
                    bump(&mut self.stats.bad_payloads);
                    continue;
                };
                let urgency = match e.class().deadline_us() {
                    None => Urgency::Nrt,
                    Some(d) => {
                        Urgency::Srt { deadline: at.unwrap_or(now).saturating_add(Micros::from(d)) }
                    }
                };
                if matches!(urgency, Urgency::Srt { deadline } if deadline <= now) {
                    bump(&mut self.stats.deadline_misses);
                    e.report_deadline_miss();
                    continue;
                }
                match self.tx.push_message(message, &buf[..n], urgency) {
                    Ok(()) => bump(&mut self.stats.queued),
                    Err(_) => bump(&mut self.stats.tx_overflow),
                }
            }
        }
    }

    fn advertisement(&self, i: usize) -> Message {
        let e = self.exports[i].export;
        let class = match (e.class(), self.exports[i].hrt) {
            (_, Some(h)) => BusClass::Hrt { period_cycles: h.period.cycles() as u16 },
            (Class::AsyncRealTime { deadline_us }, _) => BusClass::Srt { deadline_us },
            _ => BusClass::Nrt,
        };
        Message::Advertise {
            topic: String::try_from(e.topic()).unwrap_or_default(),
            type_hash: e.type_hash(),
            size: e.size() as u16,
            index: i as u8 + 1,
            class,
        }
    }

    /// Queues a management message on this module's management stream.
    fn send(&mut self, msg: &Message) -> Result<(), NodeError> {
        let mut buf = [0u8; ENCODED_MAX];
        let n =
            msg.encode(&mut buf).map_err(|_| NodeError::TooLarge { size: 0, max: ENCODED_MAX })?;
        let stream = self.ids.node_id().management();
        self.tx.push_message(stream, &buf[..n], Urgency::Nrt).map_err(|_| {
            bump(&mut self.stats.tx_overflow);
            NodeError::TxFull
        })
    }

    fn event(&mut self, e: Event) {
        if self.events.push_back(e).is_err() {
            bump(&mut self.stats.events_lost);
        }
    }

    /// Asks `from` for import `i` (advertised on its stream `index`).
    fn request(&mut self, i: usize, from: NodeId, index: u8, now: Micros) {
        let import = self.imports[i].import;
        let msg = Message::SubscribeRequest {
            target: from.get(),
            topic: String::try_from(import.topic()).unwrap_or_default(),
            type_hash: import.type_hash(),
            queue_len: import.queue_len().min(usize::from(u8::MAX)) as u8,
        };
        // If the queue is full the request is retried after the timeout like a lost one.
        let _ = self.send(&msg);
        self.imports[i].state = ImportState::Requested { from, index, since: now };
    }

    fn readvertise(&mut self) {
        for e in self.exports.iter_mut() {
            e.advertise = true;
        }
    }

    fn on_management(&mut self, from: NodeId, msg: Message, now: Micros) {
        let me = self.ids.node_id();
        let for_me = |target: u8| target == me.get();
        match msg {
            Message::Heartbeat { uid, state, .. } => {
                if uid == self.config.uid {
                    return; // our own heartbeat echoed back
                }
                if let Some(new) = self.ids.on_heartbeat(from, &uid) {
                    self.readvertise();
                    self.re_register(); // the streams' message IDs changed
                    self.next_heartbeat = now; // claim the new ID at once
                    self.event(Event::NodeIdChanged(new));
                }
                // A module that just arrived or is starting (again) missed our advertisements.
                // Every `Starting` heartbeat counts, not only the first of a start: a tool
                // that leaves within its start and a new one that takes its node ID look the
                // same from here, and the second heartbeat of a start retries a lost first.
                if !self.peers.contains(from) || state == ModuleState::Starting {
                    self.readvertise();
                }
                self.peers.insert(from);
            }
            Message::Reboot { target } if for_me(target) || target == NodeId::BROADCAST => {
                self.reboot = true;
                self.event(Event::RebootRequested { from });
            }
            Message::Advertise { topic, type_hash, size, index, .. } => {
                if from == me {
                    return; // a module with our node ID: the conflict is being settled
                }
                for i in 0..self.imports.len() {
                    let import = self.imports[i].import;
                    if import.topic() != topic.as_str() {
                        continue;
                    }
                    if index == MANAGEMENT_INDEX {
                        bump(&mut self.stats.unexpected);
                        continue;
                    }
                    if type_hash != import.type_hash() || usize::from(size) != import.size() {
                        bump(&mut self.stats.type_mismatches);
                        let result = SubscribeResult::TypeMismatch;
                        self.imports[i].state = ImportState::Refused { from, result };
                        self.event(Event::SubscriptionRefused { import: i, from, result });
                        continue;
                    }
                    let already = match self.imports[i].state {
                        ImportState::Subscribed { message, .. } => {
                            message == from.message_id(index)
                        }
                        ImportState::Requested { from: f, index: x, .. } => f == from && x == index,
                        _ => false,
                    };
                    if !already {
                        self.request(i, from, index, now);
                    }
                }
            }
            Message::SubscribeRequest { target, topic, type_hash, queue_len } if for_me(target) => {
                if from == me {
                    return;
                }
                let found = self.exports.iter().position(|e| e.export.topic() == topic.as_str());
                let (result, message_id) = match found {
                    None => (SubscribeResult::UnknownTopic, 0),
                    Some(i) if self.exports[i].export.type_hash() != type_hash => {
                        bump(&mut self.stats.type_mismatches);
                        (SubscribeResult::TypeMismatch, 0)
                    }
                    Some(i) => {
                        if let Some(h) = self.exports[i].hrt.as_mut() {
                            if !matches!(h.state, HrtState::Granted { .. }) {
                                // Answered when the master grants or refuses the slot.
                                h.waiting = Some((from, queue_len));
                                if matches!(h.state, HrtState::Idle | HrtState::Refused(_)) {
                                    h.state = HrtState::Wanted;
                                }
                                return;
                            }
                        }
                        self.exports[i].export.activate(queue_len);
                        self.event(Event::RemoteSubscriber { export: i, from, queue_len });
                        (SubscribeResult::Ok, me.message_id(i as u8 + 1).0)
                    }
                };
                let _ = self.send(&Message::SubscribeResponse {
                    target: from.get(),
                    topic,
                    result,
                    message_id,
                });
            }
            Message::SubscribeResponse { target, topic, result, message_id } if for_me(target) => {
                let asked = self.imports.iter().position(|s| {
                    s.import.topic() == topic.as_str()
                        && matches!(s.state, ImportState::Requested { from: f, .. } if f == from)
                });
                let Some(i) = asked else {
                    bump(&mut self.stats.unexpected);
                    return;
                };
                if result != SubscribeResult::Ok {
                    if result == SubscribeResult::TypeMismatch {
                        bump(&mut self.stats.type_mismatches);
                    }
                    self.imports[i].state = ImportState::Refused { from, result };
                    self.event(Event::SubscriptionRefused { import: i, from, result });
                    return;
                }
                let message = MessageId(message_id);
                match NodeId::of(message) {
                    Some((owner, index)) if owner == from && index != MANAGEMENT_INDEX => {
                        self.imports[i].state = ImportState::Subscribed { from, message };
                        self.event(Event::Subscribed { import: i, from, message });
                    }
                    _ => bump(&mut self.stats.unexpected), // not a stream of the publisher
                }
            }
            Message::ParamGet { target, index } if for_me(target) => {
                let reply = match self.params.get(index) {
                    Ok(value) => Message::ParamValue { index, value },
                    Err(fault) => Message::ParamError { index, fault },
                };
                let _ = self.send(&reply);
            }
            Message::ParamSet { target, index, value } if for_me(target) => {
                let reply = match self.params.set(index, value) {
                    Ok(value) => {
                        self.event(Event::ParamChanged { index, value });
                        Message::ParamValue { index, value }
                    }
                    Err(fault) => Message::ParamError { index, fault },
                };
                let _ = self.send(&reply);
            }
            Message::ParamValue { index, value } if self.asked.contains(from) => {
                self.event(Event::ParamValue { from, index, value });
            }
            Message::ParamError { index, fault } if self.asked.contains(from) => {
                self.event(Event::ParamError { from, index, fault });
            }
            // Requests for other nodes and answers to other nodes' requests: bus traffic.
            _ => {}
        }
    }
}

/// The TDMA cycle (docs/middleware.md, "Remote topics: the node runtime", "The TDMA cycle
/// and HRT streams").
impl<
        'a,
        const EXPORTS: usize,
        const IMPORTS: usize,
        const TXQ: usize,
        const RX: usize,
        const BUF: usize,
    > Node<'a, EXPORTS, IMPORTS, TXQ, RX, BUF>
{
    /// The slot timer: call at every slot boundary and at the latest start of a loaded frame's
    /// window, both as [`next_slot_at`](Self::next_slot_at) says, with `now` that time.
    ///
    /// At a loaded frame's latest start, it only withdraws the frame if it has not started. At
    /// a slot boundary, in order:
    ///
    /// 1. the controller's results: an SRT/NRT frame that went out leaves the queue, one that
    ///    did not stays in it with its deadline (and is loaded again with its laxity for then);
    ///    an HRT frame that did not go out is a missed occurrence;
    /// 2. take received frames (syncs feed the [`SlotClock`] and the failover state machine);
    /// 3. the protocol's timers ([`tick`](Self::tick)), master takeover, HRT registrations;
    /// 4. as master, at a cycle's start: send the sync with the next cycle's reservations;
    /// 5. load this slot's frame: in slot 0 nothing (the sync's); in a reserved slot this
    ///    node's HRT frame if the slot is its stream's, else nothing; in a free slot the most
    ///    urgent SRT/NRT frame for the window the slot opens ([`FreeSlots`]). Without a cycle
    ///    (no sync heard for `sync_timeout_us`, or none since boot for that long) every slot
    ///    is free and a window of its own.
    ///
    /// `now` is the time the timer fired; the node acts for `now` + [`NodeConfig::slot_lead_us`],
    /// the time its frames reach the controller.
    pub fn slot_tick<C: CanController + ?Sized>(&mut self, now: Micros, can: &mut C) {
        let now = now + Micros::from(self.config.slot_lead_us);
        self.start(now);
        self.program_filters(can);
        if self.slot_tx.at_guard(now) {
            self.slot_tx.on_guard(can);
            if !self.at_boundary(now) {
                return;
            }
        }
        for done in self.slot_tx.settle(now, can, &self.tx).into_iter().flatten() {
            self.on_done(done);
        }
        while let Some(r) = can.try_receive() {
            self.receive::<true>(&r);
        }
        self.errors = can.error_counters();
        self.tick(now);
        let a = self.failover.poll(now);
        self.apply(a);
        self.register_hrt(now);

        if let Some(mut m) = self.master {
            if now >= m.next_sync {
                let sync =
                    SyncFrame::new(m.cycle, self.scheduler.mask(m.cycle.wrapping_add(1)), m.epoch);
                let ok = self.slot_tx.load_slotted(can, Slotted::Sync, &sync.to_frame());
                if ok {
                    self.clock.on_sync(now, &sync);
                    self.last_sync = now;
                    // Its outcome comes from the controller (`on_done`); `syncs_sent` and the
                    // failover count it then.
                    self.sync_loaded = Some((now, sync));
                }
                let cycle_us = Micros::from(self.config.cycle.cycle_us);
                m.cycle = m.cycle.wrapping_add(1);
                m.next_sync += cycle_us;
                if m.next_sync <= now {
                    m.next_sync = now + cycle_us; // the timer was late by a cycle: restart
                }
                self.master = Some(m);
                if ok {
                    return;
                }
                // Not even loaded (mailboxes full, bus-off): a failed sync.
                let a = self.failover.on_sync_sent(now, &sync, false);
                self.apply(a);
            }
        }

        match self.clock.state(now) {
            ClockState::Running(p) if p.slot == SYNC_SLOT => {}
            ClockState::Running(p) if self.clock.mask(p.cycle) & (1 << p.slot) != 0 => {
                let mine = self.exports.iter().position(|e| {
                    e.hrt.is_some_and(|h| match h.state {
                        HrtState::Granted { phase } => {
                            phase.slot == p.slot && occurs(h.period, phase, p.cycle)
                        }
                        _ => false,
                    })
                });
                if let Some(i) = mine {
                    self.send_hrt(i, can);
                }
            }
            ClockState::Running(p) => {
                if let Some(end) = self.slot_tx.window_end(&self.clock, p) {
                    self.send_queued(now, end, can);
                }
            }
            ClockState::Unsynced | ClockState::Lost => {
                let quiet = now.saturating_sub(self.last_sync);
                if quiet >= sync_timeout_us(self.config.cycle.cycle_us) {
                    // No cycle on the bus: every slot is free.
                    let slot_us = Micros::from(self.config.cycle.slot_us());
                    self.send_queued(now, now + slot_us, can);
                }
            }
        }
    }

    /// True if `now` is a slot boundary (a slot's start as the clock sees it, or the master's
    /// next sync), not only a loaded frame's latest start (they meet when a slot is exactly
    /// one worst-case frame long).
    fn at_boundary(&self, now: Micros) -> bool {
        let slot_start = match self.clock.state(now) {
            ClockState::Running(p) => self.clock.slot_start(p.cycle, p.slot),
            _ => None,
        };
        slot_start == Some(now) || self.master.is_some_and(|m| now >= m.next_sync)
    }

    /// A loaded frame's fate (step 1 of [`slot_tick`](Self::slot_tick)).
    fn on_done(&mut self, done: Done<usize>) {
        if done.is_retry(self.slot_tx.policy()) {
            bump(&mut self.stats.slot_retries);
        }
        match done {
            Done::Slotted { what: Slotted::Hrt(_), outcome: TxOutcome::Sent, .. } => {
                bump(&mut self.stats.hrt_sent)
            }
            Done::Slotted { what: Slotted::Hrt(i), .. } => self.hrt_miss(i),
            Done::Slotted { what: Slotted::Sync, outcome, start_of_frame, .. } => {
                // The controller's result of the sync loaded at `at`: sent (TXOK), or it lost
                // arbitration, ended in an error frame (no ACK, bit error) or was withdrawn.
                // More than L failures in a row make the master step down (docs/rtcan.md,
                // "Master failover").
                if let Some((at, sync)) = self.sync_loaded.take() {
                    let sent = outcome == TxOutcome::Sent;
                    if sent {
                        bump(&mut self.stats.syncs_sent);
                    }
                    // The cycle starts at the sync's start of frame, for the master as for
                    // the slaves that stamp it on reception.
                    if let (true, Some(sof)) = (sent, start_of_frame) {
                        if self.master.is_some() {
                            self.clock.restamp_last_sync(sync.cycle, sof);
                            self.last_sync = self.last_sync.max(sof);
                        }
                    }
                    let a = self.failover.on_sync_sent(at, &sync, sent);
                    self.apply(a);
                }
            }
            Done::Queued { ticket, outcome: TxOutcome::Sent, .. } => {
                self.tx.remove(ticket);
                bump(&mut self.stats.frames_sent);
            }
            Done::Queued { late, .. } => {
                if late {
                    bump(&mut self.stats.late_withdrawals);
                }
            }
        }
    }

    /// When the slot timer should call [`slot_tick`](Self::slot_tick) next: the next slot
    /// boundary of the cycle as this node's clock sees it (as master: of its own cycle), or one
    /// nominal slot later while no cycle runs — or before it, the latest start of the window
    /// of a frame the node has loaded; [`NodeConfig::slot_lead_us`] early.
    pub fn next_slot_at(&self, now: Micros) -> Micros {
        let lead = Micros::from(self.config.slot_lead_us);
        self.next_boundary(now + lead).saturating_sub(lead).max(now)
    }

    /// The next boundary (or guard) after `now`, in the time the node acts for.
    fn next_boundary(&self, now: Micros) -> Micros {
        let slot_us = Micros::from(self.config.cycle.slot_us().max(1));
        let by_clock = match self.clock.state(now) {
            ClockState::Running(p) => {
                self.clock.slot_start(p.cycle, p.slot + 1).unwrap_or(now + slot_us)
            }
            // No cycle: the nominal slot after the last boundary (a loaded frame's window).
            _ => self.slot_tx.window_end_loaded().filter(|&e| e > now).unwrap_or(now + slot_us),
        };
        let boundary = match self.master {
            Some(m) => by_clock.min(m.next_sync.max(now)),
            None => by_clock,
        };
        self.slot_tx.next_wake(now, boundary)
    }

    /// HRT_REQUEST (answered as master) and HRT_GRANT (for this node's streams).
    fn on_hrt_management(&mut self, from: NodeId, msg: Message) {
        let me = self.ids.node_id();
        match msg {
            Message::HrtRequest { message_id, period_cycles, frames } if self.master.is_some() => {
                let message = MessageId(message_id);
                let granted = match NodeId::of(message) {
                    Some((owner, index)) if owner == from && index != MANAGEMENT_INDEX => {
                        if frames != 1 {
                            Err(HrtResult::TooManyFrames)
                        } else {
                            self.scheduler
                                .register(message, u32::from(period_cycles))
                                .map_err(hrt_result)
                        }
                    }
                    _ => Err(HrtResult::Conflict),
                };
                let (offset, slot, result) = match granted {
                    Ok(p) => (p.offset, p.slot, HrtResult::Ok),
                    Err(r) => (0, 0, r),
                };
                let _ = self.send(&Message::HrtGrant {
                    message_id,
                    period_cycles,
                    offset,
                    slot,
                    result,
                });
            }
            Message::HrtGrant { message_id, period_cycles, offset, slot, result } => {
                let Some((owner, index)) = NodeId::of(MessageId(message_id)) else {
                    bump(&mut self.stats.unexpected);
                    return;
                };
                if owner != me {
                    return; // another node's grant
                }
                let i = usize::from(index).wrapping_sub(1);
                let asked = self.exports.get(i).and_then(|e| e.hrt).is_some_and(|h| {
                    matches!(h.state, HrtState::Requested { .. })
                        && h.period.cycles() == u32::from(period_cycles)
                });
                let slots = self.config.cycle.slots;
                let valid = result != HrtResult::Ok
                    || (u32::from(offset) < u32::from(period_cycles) && slot > 0 && slot < slots);
                if !asked || !valid {
                    bump(&mut self.stats.unexpected);
                    return;
                }
                let r =
                    if result == HrtResult::Ok { Ok(Phase { offset, slot }) } else { Err(result) };
                self.on_grant(i, r);
            }
            _ => {}
        }
    }

    /// Boot time, set by the first call that tells the time.
    fn start(&mut self, now: Micros) -> Micros {
        if let Some(b) = self.boot {
            return b;
        }
        self.boot = Some(now);
        self.last_sync = now;
        self.failover = Failover::new(self.failover.rank(), self.config.cycle.cycle_us, now);
        now
    }

    fn on_sync(&mut self, at: Micros, sync: &SyncFrame) {
        self.clock.on_sync(at, sync);
        self.last_sync = at;
        let a = self.failover.on_sync(at, sync);
        self.apply(a);
    }

    fn apply(&mut self, a: Actions) {
        if let Some(s) = a.start_syncing {
            self.master = Some(MasterCycle { cycle: s.cycle, next_sync: s.at, epoch: s.epoch });
            self.scheduler.clear();
            self.clock.reset();
        }
        if a.stop_syncing {
            self.master = None;
        }
        if a.re_register {
            self.re_register();
        }
    }

    /// The calendar holding this node's reservations is gone (new master, new epoch) or their
    /// message IDs changed: ask again.
    fn re_register(&mut self) {
        for e in self.exports.iter_mut() {
            if let Some(h) = e.hrt.as_mut() {
                if matches!(h.state, HrtState::Granted { .. } | HrtState::Requested { .. }) {
                    h.state = HrtState::Wanted;
                }
            }
        }
    }

    /// Asks for the reservations that are wanted (or whose request timed out) while a master
    /// is heard; as master, registers them in its own calendar.
    fn register_hrt(&mut self, now: Micros) {
        if self.master.is_none() && !(self.failover.synced() && self.clock.hrt_allowed(now)) {
            return;
        }
        let timeout = Micros::from(self.config.request_timeout_us);
        let me = self.ids.node_id();
        for i in 0..self.exports.len() {
            let Some(h) = self.exports[i].hrt else { continue };
            let due = match h.state {
                HrtState::Wanted => true,
                HrtState::Requested { since } => now.saturating_sub(since) >= timeout,
                _ => false,
            };
            if !due {
                continue;
            }
            let message = me.message_id(i as u8 + 1);
            let cycles = h.period.cycles();
            if self.master.is_some() {
                let r = self.scheduler.register(message, cycles).map_err(hrt_result);
                self.exports[i].hrt =
                    Some(HrtStream { state: HrtState::Requested { since: now }, ..h });
                self.on_grant(i, r);
            } else {
                let msg = Message::HrtRequest {
                    message_id: message.0,
                    period_cycles: cycles as u16,
                    frames: 1,
                };
                if self.send(&msg).is_err() {
                    break; // retried at the next slot
                }
                self.exports[i].hrt =
                    Some(HrtStream { state: HrtState::Requested { since: now }, ..h });
            }
        }
    }

    /// The master answered HRT export `i`'s request; answers the subscriber waiting for it.
    fn on_grant(&mut self, i: usize, r: Result<Phase, HrtResult>) {
        let Some(mut h) = self.exports[i].hrt else { return };
        let waiting = h.waiting.take();
        let e = self.exports[i].export;
        let me = self.ids.node_id();
        let (state, result, message_id) = match r {
            Ok(phase) => {
                (HrtState::Granted { phase }, SubscribeResult::Ok, me.message_id(i as u8 + 1).0)
            }
            Err(res) => {
                bump(&mut self.stats.hrt_refused);
                (HrtState::Refused(res), SubscribeResult::NoSlot, 0)
            }
        };
        h.state = state;
        self.exports[i].hrt = Some(h);
        let Some((from, queue_len)) = waiting else { return };
        if result == SubscribeResult::Ok {
            e.activate(queue_len);
            self.event(Event::RemoteSubscriber { export: i, from, queue_len });
        }
        let _ = self.send(&Message::SubscribeResponse {
            target: from.get(),
            topic: String::try_from(e.topic()).unwrap_or_default(),
            result,
            message_id,
        });
    }

    /// Loads HRT export `i`'s newest message in its reserved slot; older ones missed their
    /// deadline (each occurrence carries one message: the implicit deadline is the period).
    fn send_hrt<C: CanController + ?Sized>(&mut self, i: usize, can: &mut C) {
        let e = self.exports[i].export;
        let id = FrameId {
            laxity: Laxity::HRT,
            message: self.ids.node_id().message_id(i as u8 + 1),
            fragment: 0,
        };
        let mut buf = [0u8; MAX_PAYLOAD];
        let mut frame = None;
        while let Some(encoded) = e.pop_encoded(&mut buf) {
            if frame.is_some() {
                bump(&mut self.stats.deadline_misses);
                e.report_deadline_miss(); // superseded by a newer message
            }
            match encoded.ok().and_then(|(n, _)| Frame::new(id, &buf[..n]).ok()) {
                Some(f) => frame = Some(f),
                None => bump(&mut self.stats.bad_payloads),
            }
        }
        let Some(frame) = frame else { return };
        if self.slot_tx.load_slotted(can, Slotted::Hrt(i), &frame) {
            bump(&mut self.stats.queued);
        } else {
            self.hrt_miss(i);
        }
    }

    fn hrt_miss(&mut self, i: usize) {
        bump(&mut self.stats.hrt_missed);
        bump(&mut self.stats.deadline_misses);
        self.exports[i].export.report_deadline_miss();
    }

    /// Loads the most urgent SRT/NRT frame for the window ending at `end` (one at a time).
    fn send_queued<C: CanController + ?Sized>(&mut self, now: Micros, end: Micros, can: &mut C) {
        self.slot_tx.load_queued(now, end, can, &self.tx);
    }
}

/// Frames of a `txq`-frame transmit queue an NRT message of `frames` frames must leave free
/// for SRT messages: half the queue, less if the message could not enter an empty queue then.
pub const fn nrt_reserve(txq: usize, frames: usize) -> usize {
    let half = txq / 2;
    let room = txq.saturating_sub(frames);
    if half < room {
        half
    } else {
        room
    }
}

fn hrt_result(r: Reject) -> HrtResult {
    match r {
        Reject::NotHarmonic => HrtResult::NotHarmonic,
        Reject::NoFreePhase => HrtResult::NoFreePhase,
        Reject::Full => HrtResult::Full,
        Reject::ReservedId | Reject::Conflict => HrtResult::Conflict,
    }
}

fn check_topic(name: &str) -> Result<(), NodeError> {
    if name.is_empty() || name.len() > TOPIC_MAX || !name.bytes().all(is_topic_char) {
        Err(NodeError::BadTopicName)
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod whole_seconds_tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn edges() {
        for us in [0, 1, 999_999, 1_000_000, 1_000_001, 63, 64, 15_625 * 64 - 1] {
            assert_eq!(u64::from(whole_seconds(us)), us / 1_000_000);
        }
        let max = u64::from(u32::MAX) * 1_000_000;
        assert_eq!(whole_seconds(max + 999_999), u32::MAX);
        assert_eq!(whole_seconds(max - 1), u32::MAX - 1);
        assert_eq!(whole_seconds(max + 1_000_000), u32::MAX);
        assert_eq!(whole_seconds(u64::MAX), u32::MAX);
    }

    proptest! {
        #[test]
        fn matches_division(us in any::<u64>(), small in 0u64..(1 << 40)) {
            for x in [us, small] {
                prop_assert_eq!(whole_seconds(x), (x / 1_000_000).min(u64::from(u32::MAX)) as u32);
            }
        }
    }
}

#[cfg(test)]
mod nrt_reserve_tests {
    use super::nrt_reserve;

    #[test]
    fn half_the_queue_unless_the_message_could_never_enter() {
        assert_eq!(nrt_reserve(32, 2), 16);
        assert_eq!(nrt_reserve(32, 8), 16);
        // A message of 6 frames in an 8-frame queue enters an empty queue: reserve 2, not 4.
        assert_eq!(nrt_reserve(8, 6), 2);
        assert_eq!(nrt_reserve(8, 8), 0);
        for txq in 8..64 {
            for frames in 1..=txq {
                assert!(frames + nrt_reserve(txq, frames) <= txq, "{txq} {frames}");
            }
        }
    }
}
