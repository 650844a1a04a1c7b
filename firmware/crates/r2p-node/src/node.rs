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
//!
//! This file holds the [`Node`] itself and the unslotted path (receive, timers, transmit); each
//! other concern has a file of its own under `node/`, all of them `impl` blocks of the same
//! `Node`:
//!
//! - `config.rs`: [`NodeConfig`], what a module says about itself and its bus;
//! - `error.rs`: [`NodeError`], why a configuration, export, import or request was refused;
//! - `events.rs`: [`Event`], what the application may act on;
//! - `stats.rs`: [`NodeStats`], what the node did and dropped;
//! - `topics.rs`: exports and imports, the topics a node carries, and how published messages
//!   enter the transmit queue;
//! - `management.rs`: the management protocol (heartbeats, advertisements, subscriptions,
//!   reboot, parameters);
//! - `tdma.rs`: the slot timer's path through the TDMA cycle, as slave or master;
//! - `framed.rs` and `framed_tx.rs`: frame-sized reservations (issue 22): where the master
//!   places them, and the slot path that sends in them;
//! - `hrt.rs`: HRT streams, their reservations with the master and their frames;
//! - `liveness.rs` and `calendar.rs`: the master's reservations following their nodes, and a
//!   standby's copy of them.

mod calendar;
mod config;
mod error;
mod events;
mod framed;
mod framed_tx;
mod hrt;
mod liveness;
mod management;
mod publishers;
mod stats;
mod subscribers;
mod tdma;
mod topics;

pub use config::{
    FramedLeads, FramedPaths, NodeConfig, SlotPath, CORTEX_M3_FRAMED_PATHS,
    CORTEX_M3_FRAMED_SLOT_PATH, CORTEX_M3_FRAMED_SYNC_PATH, CORTEX_M3_SLOT_PATH,
    CORTEX_M3_STAGED_SLOT_PATH, CORTEX_M3_STAGED_SYNC_PATH, CORTEX_M3_STAGED_TOP_UP_PATH,
    CORTEX_M3_SYNC_PATH, CORTEX_M3_TOP_UP_PATH, CORTEX_M4_SLOT_PATH, CORTEX_M4_SYNC_PATH,
    MODULE_FRAMED_LEADS, MODULE_SLOT_LEAD_US, MODULE_SYNC_LEAD_US,
};
pub use error::NodeError;
pub use events::{Event, EVENT_QUEUE};
pub use hrt::{HrtState, MASTER_STREAMS};
pub use liveness::PEER_TIMEOUT_HEARTBEATS;
pub use management::{PANIC_REPORT_EVERY, STARTING_HEARTBEATS, UNSUBSCRIBE};
pub use stats::NodeStats;
pub use topics::{nrt_reserve, ImportState};

use heapless::{Deque, String, Vec};
use r2p_management::message::{
    is_name_char, DecodeError, Message, ModuleState, ENCODED_MAX, NAME_MAX, PANIC_TEXT_MAX,
};
use r2p_management::{NodeId, NodeIdAllocator, MANAGEMENT_INDEX};
use rtcan::controller::{ErrorCounters, Received, TxMode};
use rtcan::failover::{Failover, Rank};
use rtcan::{CanController, Expect, Micros, Reassembler, Scheduler, SlotClock, SyncFrame, TxQueue};

use crate::params::ParamStore;
use crate::remote::ImportError;
use crate::slot_tx::SlotTx;

use management::{whole_seconds, NodeSet};
use stats::bump;
use tdma::MasterCycle;
use topics::{ExportSlot, ImportSlot};

/// A module's connection to the bus: remote subscribers and publishers of its topics, and the
/// management protocol (node ID, heartbeats, advertisements, subscriptions, reboot,
/// parameters).
///
/// Capacities: `EXPORTS` local topics offered on the bus, `IMPORTS` remote topics subscribed,
/// `TXQ` frames in the RTCAN transmit queue (at least 8), `RX` streams reassembled at once
/// (management streams and topics), `BUF` bytes per message (at least 64, the longest
/// management message, and at least every topic's size). `MASTER`: whether the node carries
/// the bus master's side of the protocol (sending syncs, granting HRT slots), which only a node
/// with a [`NodeConfig::rank`] can use; `false` leaves that code out of the image (2 KB on a
/// Cortex-M3, measured on the motor module's) and makes a rank a configuration error.
pub struct Node<
    'a,
    const EXPORTS: usize,
    const IMPORTS: usize,
    const TXQ: usize,
    const RX: usize,
    const BUF: usize,
    const MASTER: bool = true,
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
    /// Whether the node ID is claimed: until then the node listens, silent
    /// ([`NodeConfig::listen_first`]).
    claimed: bool,
    state: ModuleState,
    errors: ErrorCounters,
    /// Nodes heard from.
    peers: NodeSet,
    /// Nodes whose last heartbeat said `Starting` (a publisher among them lost its subscribers).
    starting: NodeSet,
    /// Nodes this module sent parameter requests to (their answers become events).
    asked: NodeSet,
    /// How management messages are read: without the replies only a tool reads until this node
    /// asks for a parameter (`Message::decode` then), so a module's image, which never asks,
    /// carries no code for them.
    decode: fn(&[u8]) -> Result<Message, DecodeError>,
    reboot: bool,
    /// The panic that preceded this boot, repeated after heartbeats ([`Node::set_panic_report`]).
    panic_report: Option<String<PANIC_TEXT_MAX>>,
    /// The running image, repeated with the panic report ([`Node::set_firmware`]).
    firmware: Option<crate::FirmwareId>,
    /// Where UPDATE messages for this module go ([`Node::set_update_sink`]); none: ignored.
    update: Option<&'a dyn crate::UpdateSink>,
    events: Deque<Event, EVENT_QUEUE>,
    stats: NodeStats,
    clock: SlotClock,
    failover: Failover,
    scheduler: Scheduler<MASTER_STREAMS>,
    /// Frame-sized reservations (`hrt_blocks` > 0): where each slot's reservation lies, placed
    /// here as master, heard in the grants otherwise (`framed.rs`).
    #[cfg(feature = "framed-reservations")]
    layout: Option<rtcan::layout::Layout>,
    /// Frame-sized reservations: the reservation start this node last loaded an HRT frame
    /// for (the slot timer may fire again inside that reservation).
    #[cfg(feature = "framed-reservations")]
    hrt_loaded_for: Micros,
    /// The board's wake on a publish for the bus (`Node::wake_on_release`).
    #[cfg(feature = "framed-reservations")]
    release_wake: Option<fn()>,
    /// The nodes holding reservations in `scheduler`, followed by their heartbeats (master).
    owners: Vec<liveness::Owner, { liveness::OWNERS }>,
    /// As standby: syncs in a row whose masks `scheduler` (its copy of the master's calendar)
    /// predicted, up to a hyperperiod (`calendar.rs`).
    calendar_agree: u16,
    /// As master: the reservation the next calendar beacon repeats (`hrt.rs`).
    beacon: u8,
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
        const MASTER: bool,
    > Node<'a, EXPORTS, IMPORTS, TXQ, RX, BUF, MASTER>
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
        #[cfg(feature = "framed-reservations")]
        let layout = match config.hrt_blocks {
            0 => None,
            blocks => {
                let l =
                    rtcan::layout::Layout::for_hrt_slots(config.cycle, blocks, config.hrt_slots);
                Some(l.map_err(|_| NodeError::BadBlocks(blocks))?)
            }
        };
        let slot_tx = SlotTx::new(&config.cycle, config.free_slots);
        // Frames fitted around reservations as long as their frames (`framed.rs`).
        #[cfg(feature = "framed-reservations")]
        let slot_tx = if layout.is_some() { slot_tx.fitted(&config.cycle) } else { slot_tx };
        // ... staging for the controller's transmit interrupt what it cannot load yet.
        #[cfg(feature = "staged-reloads")]
        let slot_tx = slot_tx.staging(layout.is_some());
        #[cfg(not(feature = "framed-reservations"))]
        if config.hrt_blocks != 0 {
            return Err(NodeError::BadBlocks(config.hrt_blocks));
        }
        let rank = match config.rank {
            None => None,
            Some(_) if !MASTER => return Err(NodeError::NotMasterCapable),
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
            claimed: !config.listen_first,
            state: ModuleState::Running,
            errors: ErrorCounters::default(),
            peers: NodeSet::default(),
            starting: NodeSet::default(),
            asked: NodeSet::default(),
            decode: Message::decode_requests,
            reboot: false,
            panic_report: None,
            firmware: None,
            update: None,
            events: Deque::new(),
            stats: NodeStats::default(),
            clock: SlotClock::new(config.cycle),
            failover: Failover::new(rank, config.cycle.cycle_us, 0),
            scheduler: Scheduler::new(config.hrt_slots, config.cycle.slots),
            #[cfg(feature = "framed-reservations")]
            layout,
            #[cfg(feature = "framed-reservations")]
            hrt_loaded_for: Micros::MAX,
            #[cfg(feature = "framed-reservations")]
            release_wake: None,
            owners: Vec::new(),
            calendar_agree: 0,
            beacon: 0,
            master: None,
            slot_tx,
            filters_for: None,
            last_sync: 0,
            sync_loaded: None,
        })
    }

    /// What the module said about itself when it built the node.
    pub fn config(&self) -> &NodeConfig {
        &self.config
    }

    /// This module's node ID (it may change when a conflict is settled: [`Event::NodeIdChanged`]).
    pub fn node_id(&self) -> NodeId {
        self.ids.node_id()
    }

    /// Number of distinct nodes heard from.
    pub fn peer_count(&self) -> usize {
        self.peers.len()
    }

    /// Frames waiting in the transmit queue.
    pub fn tx_pending(&self) -> usize {
        self.tx.len()
    }

    /// Programs the controller's acceptance filters for the syncs, the management streams and
    /// the subscribed (or requested) streams, when those changed (docs/architecture.md; `hw_filters`).
    pub(super) fn program_filters<C: CanController + ?Sized>(&mut self, can: &mut C) {
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

    pub(super) fn receive<const CYCLE: bool>(&mut self, r: &Received) {
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
                Some(m) => (self.decode)(m.data),
            };
            match decoded {
                Ok(msg @ (Message::HrtRequest { .. } | Message::HrtGrant { .. })) => {
                    if CYCLE {
                        self.on_hrt_management(from, msg, r.at);
                    }
                }
                Ok(msg) => self.on_management(from, msg, r.at),
                Err(DecodeError::Reply(_)) => {} // for the tools on the bus
                Err(_) => bump(&mut self.stats.malformed),
            }
            return;
        }
        let subscribed = self.imports.iter().position(
            |s| matches!(s.state, ImportState::Subscribed { message, .. } if message == id.message),
        );
        let Some((k, import)) = subscribed.map(|k| (k, self.imports[k].import)) else {
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
                Ok(_) => {
                    bump(&mut self.stats.published);
                    self.publisher_heard(k, r.at);
                }
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
        if !self.claimed {
            if now < boot.saturating_add(Micros::from(self.config.heartbeat_period_us)) {
                return; // listening: nothing is sent before the node ID is claimed
            }
            // The claim: the first node ID this node uses, so no `NodeIdChanged` (what
            // `node_id` said before it was only the candidate).
            self.claimed = true;
            self.ids.claim();
        }

        if now >= self.next_heartbeat {
            // Once a heartbeat period, not every slot: off the slot path's usual length.
            self.expire_owners(now);
            self.calendar_beacon();
            self.check_publishers(now);
            self.check_subscribers(now);
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
                self.repeat_reports();
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
            let (from, index, since) = match self.imports[i].state {
                ImportState::Requested { from, index, since } => (from, index, since),
                ImportState::Leaving { from, index, since } if cfg!(feature = "unsubscribe") => {
                    (from, index, since)
                }
                _ => continue,
            };
            if now.saturating_sub(since) >= timeout {
                self.request(i, from, index, now);
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

    /// Boot time, set by the first call that tells the time.
    pub(super) fn start(&mut self, now: Micros) -> Micros {
        if let Some(b) = self.boot {
            return b;
        }
        self.boot = Some(now);
        self.last_sync = now;
        self.failover = Failover::new(self.failover.rank(), self.config.cycle.cycle_us, now);
        now
    }
}
