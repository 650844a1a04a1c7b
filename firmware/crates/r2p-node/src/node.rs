//! The node runtime: one module's end of the bus (docs/middleware.md, "Remote topics: the node
//! runtime").
//!
//! Sans-IO: [`Node`] never reads a clock or touches hardware. Drive it with
//! [`Node::poll`]`(now, &mut controller)` — or its three parts [`Node::on_frame`],
//! [`Node::tick`] and [`Node::transmit`] — from a task on a module, from an emulated bus in
//! virtual time, or from a test.

use heapless::{Deque, String, Vec};
use r2p_management::message::{
    is_name_char, is_topic_char, BusClass, Message, ModuleState, ParamFault, SubscribeResult,
    Value, ENCODED_MAX, NAME_MAX, TOPIC_MAX, UID_LEN,
};
use r2p_management::{NodeId, NodeIdAllocator, MANAGEMENT_INDEX};
use r2p_middleware::Class;
use rtcan::controller::{ErrorCounters, Received};
use rtcan::fragment::{frame_count, MAX_MESSAGE_LEN};
use rtcan::{
    CanController, Expect, LaxityEncoding, MessageId, Micros, Reassembler, ReassemblyStats,
    TxQueue, Urgency,
};

use crate::params::ParamStore;
use crate::remote::{Export, Import, ImportError};

/// Heartbeats sent with state `Starting` after boot (peers re-advertise to a starting module).
pub const STARTING_HEARTBEATS: u32 = 2;
/// Events kept until the application takes them ([`Node::next_event`]).
pub const EVENT_QUEUE: usize = 8;

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
}

impl NodeConfig {
    /// Defaults: heartbeat every 100 ms, subscription retried after 300 ms, reassembly timeout
    /// 20 ms, logarithmic laxity with 100 µs ticks.
    pub const fn new(uid: [u8; UID_LEN], name: &'static str) -> Self {
        Self {
            uid,
            name,
            heartbeat_period_us: 100_000,
            request_timeout_us: 300_000,
            reassembly_timeout_us: 20_000,
            laxity: LaxityEncoding::Logarithmic { tick_us: 100 },
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
    /// Synchronous real-time (HRT) publishers need the TDMA slot timer, which does not exist
    /// yet: export them with `Class::AsyncRealTime { deadline_us: period }` meanwhile.
    HrtNotDriven,
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
    /// Sync frames (ignored until the TDMA cycle is driven).
    pub sync_frames: u32,
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
    fn set(&mut self, n: NodeId, on: bool) {
        let w = &mut self.0[usize::from(n.get() / 32)];
        if on {
            *w |= 1 << (n.get() % 32);
        } else {
            *w &= !(1 << (n.get() % 32));
        }
    }
    fn len(&self) -> usize {
        self.0.iter().map(|w| w.count_ones() as usize).sum()
    }
}

struct ExportSlot<'a> {
    export: &'a dyn Export,
    advertise: bool,
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
    /// Peers heard `Starting` since their last `Running`: re-advertised to once.
    greeted: NodeSet,
    /// Nodes this module sent parameter requests to (their answers become events).
    asked: NodeSet,
    reboot: bool,
    events: Deque<Event, EVENT_QUEUE>,
    stats: NodeStats,
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
            greeted: NodeSet::default(),
            asked: NodeSet::default(),
            reboot: false,
            events: Deque::new(),
            stats: NodeStats::default(),
        })
    }

    /// Offers a local topic on the bus through its remote subscriber; returns its stream index
    /// (1…): the stream's message ID is `node ID << 8 | index`. It is advertised at the next
    /// [`tick`](Self::tick).
    pub fn export(&mut self, export: &'a dyn Export) -> Result<u8, NodeError> {
        check_topic(export.topic())?;
        let max = self.max_export_size();
        if export.size() > max {
            return Err(NodeError::TooLarge { size: export.size(), max });
        }
        if matches!(export.class(), Class::SyncRealTime { .. }) {
            return Err(NodeError::HrtNotDriven);
        }
        if self.exports.iter().any(|e| e.export.topic() == export.topic()) {
            return Err(NodeError::DuplicateTopic);
        }
        if self.exports.len() >= usize::from(u8::MAX) {
            return Err(NodeError::TooMany);
        }
        self.exports
            .push(ExportSlot { export, advertise: true })
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
        ]
        .iter()
        .fold(0u32, |a, &b| a.saturating_add(b))
    }

    /// Asks `target` (or every node: 255) to reboot.
    pub fn request_reboot(&mut self, target: u8) -> Result<(), NodeError> {
        self.send(&Message::Reboot { target })
    }

    /// Reads parameter `index` of `target`; the answer comes as [`Event::ParamValue`] or
    /// [`Event::ParamError`].
    pub fn get_param(&mut self, target: NodeId, index: u16) -> Result<(), NodeError> {
        self.asked.set(target, true);
        self.send(&Message::ParamGet { target: target.get(), index })
    }

    /// Sets parameter `index` of `target`; the answer comes as [`Event::ParamValue`] (the value
    /// now held) or [`Event::ParamError`] (refused, unchanged).
    pub fn set_param(&mut self, target: NodeId, index: u16, value: Value) -> Result<(), NodeError> {
        self.asked.set(target, true);
        self.send(&Message::ParamSet { target: target.get(), index, value })
    }

    /// Receives what the controller has, runs the protocol's timers, sends what is due.
    pub fn poll<C: CanController + ?Sized>(&mut self, now: Micros, can: &mut C) {
        while let Some(r) = can.try_receive() {
            self.on_frame(&r);
        }
        self.tick(now);
        self.transmit(now, can);
    }

    /// Takes one received frame: management messages are reassembled and handled, subscribed
    /// streams reassembled and published locally, everything else counted and dropped.
    pub fn on_frame(&mut self, r: &Received) {
        bump(&mut self.stats.frames_received);
        let id = r.frame.id();
        if id.sync_cycle().is_some() {
            bump(&mut self.stats.sync_frames);
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
                Ok(msg) => self.on_management(from, msg, r.at),
                Err(_) => bump(&mut self.stats.malformed),
            }
            return;
        }
        let subscribed = self.imports.iter().find(
            |s| matches!(s.state, ImportState::Subscribed { message, .. } if message == id.message),
        );
        let Some(import) = subscribed.map(|s| s.import) else {
            bump(&mut self.stats.unknown_frames);
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
        let boot = *self.boot.get_or_insert(now);
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
                uptime_s: (now.saturating_sub(boot) / 1_000_000).min(u32::MAX as u64) as u32,
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
    fn drain_exports(&mut self, now: Micros) {
        let me = self.ids.node_id();
        let mut buf = [0u8; BUF];
        for (i, slot) in self.exports.iter().enumerate() {
            let e = slot.export;
            if e.active_len() == 0 {
                continue;
            }
            let frames = frame_count(e.size()).unwrap_or(usize::MAX);
            let message = me.message_id(i as u8 + 1);
            while e.pending() > 0 && self.tx.free() >= frames {
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
        let class = match e.class() {
            Class::AsyncRealTime { deadline_us } => BusClass::Srt { deadline_us },
            // SyncRealTime is refused by `export`; NonRealTime:
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
                    self.next_heartbeat = now; // claim the new ID at once
                    self.event(Event::NodeIdChanged(new));
                }
                let starting = state == ModuleState::Starting;
                if !self.peers.contains(from) || (starting && !self.greeted.contains(from)) {
                    // A module that just arrived (or rebooted) missed our advertisements.
                    self.readvertise();
                }
                self.peers.set(from, true);
                self.greeted.set(from, starting);
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

fn check_topic(name: &str) -> Result<(), NodeError> {
    if name.is_empty() || name.len() > TOPIC_MAX || !name.bytes().all(is_topic_char) {
        Err(NodeError::BadTopicName)
    } else {
        Ok(())
    }
}
