//! The management protocol (docs/middleware.md, "Management state machines"): heartbeats,
//! advertisements, subscription requests and answers, reboot and parameter requests. Each
//! message is queued on the module's management stream; HRT registrations, which only make
//! sense within a cycle, are in `hrt.rs`.

use heapless::String;
use r2p_management::message::{
    is_name_char, BusClass, Message, ModuleState, SubscribeResult, Value, ENCODED_MAX, UPDATE_MAX,
};
use r2p_management::{NodeId, MANAGEMENT_INDEX};
use r2p_middleware::Class;
use rtcan::{MessageId, Micros, Urgency};

use super::stats::bump;
use super::{Event, HrtState, ImportState, Node, NodeError};

/// The queue length of a SUBSCRIBE_REQUEST that unsubscribes (issue 22): a subscription
/// without a queue is none, so the message needs no type of its own (and the F103 images no
/// second decoder); requests that subscribe ask for at least 1. The publisher answers it like
/// a request, which ends the subscriber's retries.
pub const UNSUBSCRIBE: u8 = 0;

/// Heartbeats sent with state `Starting` after boot (peers re-advertise to a starting module).
pub const STARTING_HEARTBEATS: u32 = 2;

/// Heartbeats from one PANIC_REPORT to the next (the first follows the first heartbeat): with
/// the default 100 ms period, one 9-frame report every 0.8 s, under 0.1 % of a 1 Mbit/s bus,
/// and heard by any tool that listens for a second (`r2p nodes`).
pub const PANIC_REPORT_EVERY: u32 = 8;

/// A set of node IDs (bit n = node n).
#[derive(Clone, Copy, Default)]
pub(super) struct NodeSet([u32; 8]);

impl NodeSet {
    pub(super) fn contains(&self, n: NodeId) -> bool {
        self.0[usize::from(n.get() / 32)] & (1 << (n.get() % 32)) != 0
    }
    /// Known peers are never removed: a peer that leaves stays known (its return in `Starting`
    /// state is what triggers advertisements), and an asked node may still answer.
    pub(super) fn insert(&mut self, n: NodeId) {
        self.0[usize::from(n.get() / 32)] |= 1 << (n.get() % 32);
    }
    /// For the set of peers whose last heartbeat said `Starting`.
    pub(super) fn remove(&mut self, n: NodeId) {
        self.take(n);
    }
    /// Removes `n`; true if it was in the set.
    pub(super) fn take(&mut self, n: NodeId) -> bool {
        let (word, bit) = (&mut self.0[usize::from(n.get() / 32)], 1 << (n.get() % 32));
        let had = *word & bit != 0;
        *word &= !bit;
        had
    }
    pub(super) fn len(&self) -> usize {
        self.0.iter().map(|w| w.count_ones() as usize).sum()
    }
    pub(super) fn is_empty(&self) -> bool {
        self.0 == [0; 8]
    }
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
    /// Asks `target` (or every node: 255) to reboot.
    pub fn request_reboot(&mut self, target: u8) -> Result<(), NodeError> {
        self.send(&Message::Reboot { target })
    }

    /// Reads parameter `index` of `target`; the answer comes as [`Event::ParamValue`] or
    /// [`Event::ParamError`].
    pub fn get_param(&mut self, target: NodeId, index: u16) -> Result<(), NodeError> {
        self.asked.insert(target);
        self.decode = Message::decode;
        self.send(&Message::ParamGet { target: target.get(), index })
    }

    /// Sets parameter `index` of `target`; the answer comes as [`Event::ParamValue`] (the value
    /// now held) or [`Event::ParamError`] (refused, unchanged).
    pub fn set_param(&mut self, target: NodeId, index: u16, value: Value) -> Result<(), NodeError> {
        self.asked.insert(target);
        self.decode = Message::decode;
        self.send(&Message::ParamSet { target: target.get(), index, value })
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

    /// Reports that this boot followed a panic, `text` being what the module kept of it
    /// across the reset (r2p-panic's report, `panic, calls: …`): sent as PANIC_REPORT after
    /// the first heartbeat and every [`PANIC_REPORT_EVERY`] heartbeats after, until the next
    /// reset. Bytes a management string cannot carry become a space (line breaks, tabs) or `?`
    /// (one per non-ASCII character); the text is cut to [`PANIC_TEXT_MAX`] bytes.
    pub fn set_panic_report(&mut self, text: &[u8]) {
        let mut s = String::new();
        for &b in text {
            let c = match b {
                b if is_name_char(b) => b as char,
                b'\n' | b'\r' | b'\t' => ' ',
                0x80..=0xBF => continue, // the rest of a UTF-8 sequence: one `?` for it
                _ => '?',
            };
            if s.push(c).is_err() {
                break;
            }
        }
        self.panic_report = Some(s);
    }

    /// Says which image runs (its signed trailer's version and digest): sent as FIRMWARE after
    /// the first heartbeat and every [`PANIC_REPORT_EVERY`] heartbeats after, so `r2p nodes`
    /// shows it.
    pub fn set_firmware(&mut self, firmware: crate::FirmwareId) {
        self.firmware = Some(firmware);
    }

    /// Sends transfer message `data` (r2p-boot's `transfer`, at most [`UPDATE_MAX`] bytes) to
    /// `target` as an UPDATE message: what a tool updating a module sends.
    pub fn send_update(&mut self, target: NodeId, data: &[u8]) -> Result<(), NodeError> {
        let data = heapless::Vec::from_slice(data)
            .map_err(|_| NodeError::TooLarge { size: data.len(), max: UPDATE_MAX })?;
        self.send(&Message::Update { target: target.get(), data })
    }

    /// Receives firmware updates through `sink`: UPDATE messages addressed to this module go to
    /// it and its answers go back to their sender. Without a sink they are ignored (the sender
    /// times out: the image cannot be updated over the bus).
    pub fn set_update_sink(&mut self, sink: &'a dyn crate::UpdateSink) {
        self.update = Some(sink);
    }

    /// After heartbeat number `self.heartbeats` was queued: the panic report and the firmware
    /// message, when they are due.
    pub(super) fn repeat_reports(&mut self) {
        if self.heartbeats.is_multiple_of(PANIC_REPORT_EVERY) {
            if let Some(text) = self.panic_report.clone() {
                let _ = self.send(&Message::PanicReport { text }); // again at the next one due
            }
            if let Some(f) = self.firmware.clone() {
                let (version, digest, kind, on_trial) = (f.version, f.digest, f.kind, f.on_trial);
                let _ = self.send(&Message::Firmware { version, digest, kind, on_trial });
            }
        }
    }

    pub(super) fn advertisement(&self, i: usize) -> Message {
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
    pub(super) fn send(&mut self, msg: &Message) -> Result<(), NodeError> {
        let mut buf = [0u8; ENCODED_MAX];
        let n =
            msg.encode(&mut buf).map_err(|_| NodeError::TooLarge { size: 0, max: ENCODED_MAX })?;
        let stream = self.ids.node_id().management();
        self.tx.push_message(stream, &buf[..n], Urgency::Nrt).map_err(|_| {
            bump(&mut self.stats.tx_overflow);
            NodeError::TxFull
        })
    }

    pub(super) fn event(&mut self, e: Event) {
        if self.events.push_back(e).is_err() {
            bump(&mut self.stats.events_lost);
        }
    }

    /// Asks `from` for import `i` (advertised on its stream `index`), or, while the import is
    /// `Leaving`, tells it to stop: a request with queue length 0 ([`UNSUBSCRIBE`]).
    pub(super) fn request(&mut self, i: usize, from: NodeId, index: u8, now: Micros) {
        let import = self.imports[i].import;
        let leaving = cfg!(feature = "unsubscribe")
            && matches!(self.imports[i].state, ImportState::Leaving { .. });
        let msg = Message::SubscribeRequest {
            target: from.get(),
            topic: String::try_from(import.topic()).unwrap_or_default(),
            type_hash: import.type_hash(),
            queue_len: if leaving {
                UNSUBSCRIBE
            } else {
                import.queue_len().clamp(1, usize::from(u8::MAX)) as u8
            },
        };
        // If the queue is full the request is retried after the timeout like a lost one.
        let _ = self.send(&msg);
        self.imports[i].state = if leaving {
            ImportState::Leaving { from, index, since: now }
        } else {
            ImportState::Requested { from, index, since: now }
        };
    }

    fn readvertise(&mut self) {
        for e in self.exports.iter_mut() {
            e.advertise = true;
        }
    }

    pub(super) fn on_management(&mut self, from: NodeId, msg: Message, now: Micros) {
        let me = self.ids.node_id();
        let for_me = |target: u8| target == me.get();
        if !self.claimed {
            // Listening before the claim: only which node IDs are in use matters (everyone
            // re-advertises when this node's first heartbeat says `Starting`).
            if let Message::Heartbeat { uid, .. } = msg {
                self.ids.heard(from, &uid);
            }
            return;
        }
        match msg {
            Message::Heartbeat { uid, state, uptime_s, .. } => {
                if uid == self.config.uid {
                    return; // our own heartbeat echoed back
                }
                self.owner_heard(from, state, uptime_s, now);
                // The conflict rule compares what the two modules' heartbeats say: ours have
                // said `Starting` until the first STARTING_HEARTBEATS are sent.
                let starting = state == ModuleState::Starting;
                let me_starting = self.heartbeats <= STARTING_HEARTBEATS;
                if let Some(new) = self.ids.on_heartbeat(from, &uid, starting, me_starting) {
                    // What was queued under the old node ID would go out on streams that are
                    // the other module's now: dropped and counted (advertisements and the
                    // heartbeat are sent again on the new streams; data at its next publish).
                    let moved = |m| NodeId::of(m).is_some_and(|(node, _)| node == me);
                    let n = self.tx.remove_messages(moved);
                    self.stats.dropped_on_move =
                        self.stats.dropped_on_move.saturating_add(n as u32);
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
                self.publisher_alive(from, now);
                self.subscriber_alive(from, now);
                if starting {
                    self.starting.insert(from);
                } else {
                    self.starting.remove(from);
                }
            }
            Message::Reboot { target } if for_me(target) || target == NodeId::BROADCAST => {
                self.reboot = true;
                self.event(Event::RebootRequested { from });
            }
            Message::Advertise { topic, type_hash, size, index, class } => {
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
                    if cfg!(feature = "unsubscribe") {
                        match &mut self.imports[i].state {
                            ImportState::Unsubscribed { publisher } => {
                                *publisher = Some((from, index)); // for `resubscribe`
                                continue;
                            }
                            ImportState::Leaving { .. } => continue,
                            _ => {}
                        }
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
                    // A publisher that is starting (again: it rebooted) has no subscribers
                    // whatever this node believes: ask again (it answers with the same stream).
                    if !already || self.starting.contains(from) {
                        self.imports[i].period_us = match class {
                            BusClass::Hrt { period_cycles } => {
                                u32::from(period_cycles) * self.config.cycle.cycle_us
                            }
                            _ => 0,
                        };
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
                    Some(i) if queue_len == UNSUBSCRIBE => {
                        self.subscriber_removed(i, from);
                        (SubscribeResult::Ok, me.message_id(i as u8 + 1).0)
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
                        self.subscriber_added(i, from, now);
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
                        && match s.state {
                            ImportState::Requested { from: f, .. } => f == from,
                            ImportState::Leaving { from: f, .. } => {
                                cfg!(feature = "unsubscribe") && f == from
                            }
                            _ => false,
                        }
                });
                let Some(i) = asked else {
                    bump(&mut self.stats.unexpected);
                    return;
                };
                if let (true, ImportState::Leaving { index, .. }) =
                    (cfg!(feature = "unsubscribe"), self.imports[i].state)
                {
                    // Whatever the answer: the publisher no longer counts this node.
                    self.imports[i].state =
                        ImportState::Unsubscribed { publisher: Some((from, index)) };
                    return;
                }
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
                        self.publisher_heard(i, now);
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
            Message::Update { target, data } if for_me(target) && from != me => {
                let Some(sink) = self.update else {
                    return; // no bootloader behind this image: the sender times out
                };
                let mut answer = [0u8; ENCODED_MAX];
                let n = sink.handle(from.get(), &data, &mut answer).min(UPDATE_MAX);
                if n > 0 {
                    let data = heapless::Vec::from_slice(&answer[..n]).unwrap_or_default();
                    let _ = self.send(&Message::Update { target: from.get(), data });
                }
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

/// `us / 1_000_000`, saturated to `u32`, without the 64-bit division routine (about 1 KiB on a
/// Cortex-M3): `⌊us / 10⁶⌋ = ⌊⌊us / 64⌋ / 15 625⌋`, the second by long division in 16-bit
/// digits so every step fits the hardware's 32-bit divide.
pub(super) fn whole_seconds(us: Micros) -> u32 {
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

#[cfg(test)]
mod tests {
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

    #[test]
    fn taking_a_node_says_whether_it_was_in_the_set() {
        // An unsubscription from a node not in the set must not look like the last one leaving
        // (subscribers.rs): `take` tells the two apart.
        let (a, b) = (NodeId::new(5).unwrap(), NodeId::new(37).unwrap());
        let mut set = NodeSet::default();
        set.insert(a);
        assert!(!set.take(b), "never inserted");
        assert!(set.contains(a));
        assert!(set.take(a));
        assert!(!set.take(a), "taken already");
        assert!(set.is_empty());
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
