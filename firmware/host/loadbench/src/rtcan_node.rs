//! One node's RTCAN transmit path as the node runtime runs it (`r2p_node::Node::slot_tick`,
//! TDMA mode), reduced to the traffic of this experiment: no management protocol, no
//! reassembly, HRT phases given by the master's calendar at start-up.
//!
//! What is loaded when, for which window, and what is done with the controller's results is
//! the node runtime's own code: [`SlotTx`] (`r2p_node::slot_tx`), with the free-slot policy
//! ([`FreeSlots`]) of the run. Around it, as `Node::slot_tick` does at every slot boundary of
//! its [`SlotClock`]: (1) the results — a queued frame that went out leaves the [`TxQueue`], one
//! that did not stays with its deadline; (2) received syncs into the clock; (3) published
//! messages into the queue, SRT frames past their deadline expired; (4) as master, at a
//! cycle's start, the sync with the next cycle's reservation mask; (5) at most one frame:
//! nothing in slot 0, this node's HRT frame in a reserved slot of its stream, else the most
//! urgent queued frame for the window the free slot opens. And at a loaded frame's latest
//! start, the guard ([`SlotTx::on_guard`]). With `Setup::staged` (what-if), bxCAN's transmit
//! interrupt as the firmware runs it (`r2p_vbus::BxCanPort::load_staged`): it loads the frames
//! the node staged (`SlotTx::staged`, which hands them to the controller:
//! `CanController::stage`) once the controller is empty ([`STAGED_LOAD_US`]).

use std::collections::VecDeque;

use r2p_emu::SimPort;
use r2p_node::slot_tx::{Done, Slotted, Staged};
use r2p_node::{FreeSlots, SlotTx};
pub use r2p_vbus::bxcan::STAGED_LOAD_US;
use rtcan::controller::{Filter, TxOutcome};
use rtcan::cycle::{ClockState, SYNC_SLOT};
use rtcan::framed_cycle::{FramedCycle, Moment, FOLLOW_US};
use rtcan::id::{EXTENDED_ID_MAX, MESSAGE_ID_SHIFT, SYNC_MESSAGE_IDS};
use rtcan::schedule::occurs;
use rtcan::{
    CanController, Frame, FrameId, Laxity, MessageId, Micros, SlotClock, SyncFrame, Ticket,
    TxQueue, Urgency,
};

use crate::publish::Publishers;
use crate::record::{Carried, Counters, Sent};
use crate::setup::{Setup, TX_QUEUE};
use crate::traffic::{Kind, Traffic};

#[derive(Clone, Copy, Debug)]
struct Master {
    cycle: u32,
    next_sync: Micros,
}

/// One RTCAN node on a port of the virtual bus.
pub struct RtcanNode<'t> {
    traffic: &'t Traffic,
    setup: &'t Setup,
    can: SimPort,
    clock: SlotClock,
    tx: TxQueue<TX_QUEUE>,
    master: Option<Master>,
    /// The node runtime's slot transmit state; HRT frames tagged with their message.
    slot_tx: SlotTx<u32>,
    /// The queued frames loaded: their tickets, messages and fragments (a message may expire
    /// while its frame is on the wire).
    loaded: Vec<(Ticket, u32, u8)>,
    publishers: Publishers,
    /// This node's HRT streams and their occurrences still to send, oldest first.
    hrt: Vec<(u16, VecDeque<u32>)>,
    /// Per stream (all streams of the run): its messages in the transmit queue, oldest first.
    queued: Vec<VecDeque<u32>>,
    /// The next slot boundary.
    next_slot: Micros,
    /// What-if: reservations as long as their frames (`traffic.layout`), windows between them
    /// as the node runtime's slot path sees them ([`FramedCycle`]).
    framed: bool,
    /// When the node reacts to the last bus event or release (framed what-if).
    reaction: Option<Micros>,
    /// Frames in its mailboxes after its last activation or bus event (framed what-if).
    mailboxes: usize,
    /// The frames its last activation staged for the transmit interrupt (`SlotTx::staged`),
    /// each with the message and fragment it carries.
    staged: Vec<(Staged, u32, u8)>,
    /// When its transmit interrupt loads them ([`STAGED_LOAD_US`]).
    interrupt_at: Option<Micros>,
    /// When the node's timer fires next: the next slot boundary or a loaded frame's guard.
    wake_at: Micros,
    /// Frames this node's port sent, in order.
    pub sent: Vec<Sent>,
    /// What the node counted.
    pub counters: Counters,
}

/// The framed what-if's reaction to a frame of its own leaving its mailbox (the
/// transmit-complete interrupt, `Node::wakes_on_transmit`): the short path (`Node::top_up`) to
/// the node's next SRT/NRT frame in its mailbox. Measured on QEMU, Cortex-M3 (`slot-path
/// --features framed`, its `top_up_transmit_min_insn`): 1 699 instructions at the shortest
/// from the call, ~190 more from the interrupt, 27 µs at 72 MHz (up to 3 923 + 190, 57 µs).
/// `tests/test_slot_lead.py` checks it against the bench. The whole slot tick took 40 µs.
pub const TRANSMIT_REACTION_US: Micros = 27;

/// The same for a message's release (a publish, `Node::releases_waiting`), whose path also
/// queues it: `top_up_publish_min_insn`, 1 854 + 190 instructions, 29 µs.
pub const RELEASE_REACTION_US: Micros = 29;

/// Message ID → stream index.
fn stream_of(message: MessageId) -> usize {
    usize::from(message.0 - SYNC_MESSAGE_IDS)
}

impl<'t> RtcanNode<'t> {
    /// Node `index` on `can`, using the free slots as `free_slots` says; node 0 is the master.
    pub fn new(
        traffic: &'t Traffic,
        setup: &'t Setup,
        index: usize,
        mut can: SimPort,
        free_slots: FreeSlots,
        framed: bool,
    ) -> Self {
        let master = (index == 0).then_some(Master { cycle: 0, next_sync: 0 });
        // Slaves hear syncs only (laxity 0, fragment 0, message ID < 0x100); the master nothing.
        let sync_only = Filter {
            value: 0,
            mask: EXTENDED_ID_MAX & !((u32::from(SYNC_MESSAGE_IDS) - 1) << MESSAGE_ID_SHIFT),
        };
        let filters = [sync_only];
        can.set_filters(if master.is_some() { &[] } else { &filters });
        let is_hrt = |s: u16| matches!(traffic.streams[usize::from(s)].kind, Kind::Hrt { .. });
        let hrt = (0..traffic.streams.len() as u16)
            .filter(|&s| is_hrt(s) && traffic.streams[usize::from(s)].node == index)
            .map(|s| {
                let occ = (0..traffic.messages.len() as u32)
                    .filter(|&m| traffic.messages[m as usize].stream == s)
                    .collect();
                (s, occ)
            })
            .collect();
        Self {
            traffic,
            setup,
            can,
            clock: SlotClock::new(setup.cycle),
            tx: TxQueue::new(setup.laxity),
            master,
            slot_tx: if framed {
                SlotTx::new(&setup.cycle, free_slots)
                    .fitted(&setup.cycle)
                    .laxity_drift(setup.laxity_drift)
                    .staging(setup.staged)
            } else {
                SlotTx::new(&setup.cycle, free_slots)
            },
            loaded: Vec::new(),
            publishers: Publishers::new(traffic, setup, index, |s| !is_hrt(s)),
            hrt,
            queued: vec![VecDeque::new(); traffic.streams.len()],
            next_slot: 0,
            framed,
            reaction: None,
            mailboxes: 0,
            staged: Vec::new(),
            interrupt_at: None,
            wake_at: 0,
            sent: Vec::new(),
            counters: Counters::default(),
        }
    }

    /// When the node's timer fires next (`Node::next_slot_at`), or it reacts to a bus event.
    pub fn next_wake(&self) -> Micros {
        let wake = self.reaction.map_or(self.wake_at, |r| r.min(self.wake_at));
        self.interrupt_at.map_or(wake, |i| i.min(wake))
    }

    /// The bus moved at `now` (framed what-if). If a frame of its own left a mailbox (sent, or
    /// lost a one-shot arbitration), its transmit-complete interrupt runs the short path:
    /// [`TRANSMIT_REACTION_US`] later (`Setup::reactions_us`) its next frames are loaded, as
    /// `Node::wakes_on_transmit` asks of the firmware; with `Setup::staged`, the interrupt
    /// itself runs the staged loads first (which load only if the controller is now empty).
    /// Received frames wake it at no other time than its timer. (The interrupt's mask until
    /// the call it woke ends needs no model here: that call is one instant at the window's
    /// end, and sees every frame that left the controller in the window.)
    pub fn on_bus_event(&mut self, now: Micros) {
        if self.can.port().pending() < self.mailboxes {
            self.react_at(now + self.setup.reactions_us.0);
            if self.can.has_staged() {
                self.interrupt_at = Some(now + STAGED_LOAD_US);
            }
        }
        self.mailboxes = self.can.port().pending();
    }

    /// Runs the short path at `at` (unless it runs sooner).
    fn react_at(&mut self, at: Micros) {
        self.reaction = Some(self.reaction.map_or(at, |r| r.min(at)));
    }

    /// The node's timer at `now`: a loaded frame's guard, a slot boundary, or both.
    pub fn wake(&mut self, now: Micros) {
        if self.interrupt_at.is_some_and(|i| i <= now) {
            self.interrupt_at = None;
            self.load_staged(now);
            if now < self.wake_at && self.reaction.is_none_or(|r| r > now) {
                return;
            }
        }
        self.counters.activations += 1;
        if self.slot_tx.at_guard(now) {
            self.slot_tx.on_guard(&mut self.can);
        }
        if self.framed {
            // Woken by a transmit-complete or a release, not by its timer: the short path.
            let short = self.reaction.is_some_and(|r| r <= now) && now < self.wake_at;
            self.reaction = self.reaction.filter(|&r| r > now);
            self.framed_tick(now, short);
            let staged = self.slot_tx.staged().map(|s| {
                let (msg, fragment) = self.message_of(now, s.ticket);
                (s, msg, fragment)
            });
            self.staged = staged.collect();
            return;
        }
        if now >= self.next_slot {
            self.slot_tick(now);
            self.next_slot = self.next_slot_at(now).max(now + 1);
        }
        self.wake_at = self.slot_tx.next_wake(now, self.next_slot);
    }

    /// The slot timer at boundary `now` (module documentation, steps 1–5).
    fn slot_tick(&mut self, now: Micros) {
        self.settle_receive_publish(now);

        if self.send_sync_if_due(now) == Some(true) {
            return;
        }
        match self.clock.state(now) {
            ClockState::Running(p) if p.slot == SYNC_SLOT => {}
            ClockState::Running(p) if self.clock.mask(p.cycle) & (1 << p.slot) != 0 => {
                self.send_hrt(p.cycle, p.slot);
            }
            ClockState::Running(p) => {
                let Some(end) = self.slot_tx.window_end(&self.clock, p) else { return };
                if self.slot_tx.load_queued(now, end, &mut self.can, &self.tx) {
                    self.note_loaded(now);
                }
            }
            ClockState::Unsynced | ClockState::Lost => {}
        }
    }

    /// Steps 1–3: the controller's results, received syncs into the clock, publishing.
    fn settle_receive_publish(&mut self, now: Micros) {
        for done in self.slot_tx.settle(now, &mut self.can, &self.tx).into_iter().flatten() {
            self.on_done(done);
        }
        while let Some(r) = self.can.try_receive() {
            if let (None, Ok(sync)) = (self.master, SyncFrame::from_frame(&r.frame)) {
                let first = self.clock.state(r.at) == ClockState::Unsynced;
                if !self.clock.on_sync(r.at, &sync).continuous && !first {
                    self.counters.resyncs += 1;
                }
            }
        }
        self.tick(now);
    }

    /// Step 4: as master, at a cycle's start, the sync with the next cycle's reservations.
    /// `Some(loaded)` if one was due, `None` otherwise.
    fn send_sync_if_due(&mut self, now: Micros) -> Option<bool> {
        let mut m = self.master.filter(|m| now >= m.next_sync)?;
        let next = m.cycle.wrapping_add(1);
        let mask =
            if self.framed { self.traffic.framed_mask(next) } else { self.traffic.mask(next) };
        let sync = SyncFrame::new(m.cycle, mask, false);
        let loaded = self.slot_tx.load_slotted(&mut self.can, Slotted::Sync, &sync.to_frame());
        if loaded {
            self.clock.on_sync(now, &sync);
        }
        let cycle_us = Micros::from(self.setup.cycle.cycle_us);
        m.cycle = m.cycle.wrapping_add(1);
        m.next_sync += cycle_us;
        if m.next_sync <= now {
            m.next_sync = now + cycle_us;
        }
        self.master = Some(m);
        Some(loaded)
    }

    /// The what-if's activation ([`FramedCycle`]): the same steps as [`Self::slot_tick`], at
    /// reservation starts and ends, releases and bus events instead of slot boundaries. In a
    /// reservation: its HRT frame at its start; between reservations: the queue's frames for
    /// the window up to the next one. The `short` path (`Node::top_up`) only takes the
    /// controller's results (`SlotTx::settle_sent`), queues the released messages and loads;
    /// received frames (the master's syncs among them) and sending the sync wait for the timer.
    fn framed_tick(&mut self, now: Micros, short: bool) {
        if short {
            for done in self.slot_tx.settle_sent(now, &mut self.can).into_iter().flatten() {
                self.on_done(done);
            }
            self.tick(now);
        } else {
            self.settle_receive_publish(now);
            self.send_sync_if_due(now);
        }
        let slot_us = Micros::from(self.setup.cycle.slot_us().max(1));
        let mut next = now + slot_us;
        if let Some(m) = self.master {
            next = next.min(m.next_sync);
        }
        if let ClockState::Running(p) = self.clock.state(now) {
            let (Some(c0), Some(c1)) = (
                self.clock.slot_start(p.cycle, 0),
                self.clock.slot_start(p.cycle, self.setup.cycle.slots),
            ) else {
                self.wake_at = self.slot_tx.next_wake(now, next);
                self.mailboxes = self.can.port().pending();
                return;
            };
            let cycle = FramedCycle::new(&self.traffic.layout, self.clock.mask(p.cycle));
            let t = (now - c0) as u32;
            match cycle.at(t) {
                Moment::Reserved { slot: Some(slot), start_us }
                    if slot != SYNC_SLOT && now == c0 + Micros::from(start_us) =>
                {
                    self.send_hrt(p.cycle, slot);
                }
                Moment::Reserved { .. } => {}
                Moment::Free { end_us } => {
                    let end = (c0 + Micros::from(end_us)).min(c1);
                    if self.slot_tx.load_queued(now, end, &mut self.can, &self.tx) {
                        self.note_loaded(now);
                    }
                }
            }
            if self.setup.hrt_follow {
                for (slot, load_at, end_us) in self.follow_loads(p.cycle) {
                    let at = c0 + Micros::from(load_at);
                    if now == at {
                        // Loaded while the frame before is on the wire: kept until its own
                        // reservation's end (`SlotTx::hold_slotted`, as the node runtime does
                        // with free frames behind it).
                        self.slot_tx.hold_slotted(c0 + Micros::from(end_us));
                        self.send_hrt(p.cycle, slot);
                    } else if at > now {
                        next = next.min(at);
                    }
                }
            }
            // As `Node::next_slot_at` on frame-sized reservations: the next edge, or the next
            // grid boundary (where the node tops its window up).
            let grid = self.clock.slot_start(p.cycle, p.slot + 1).filter(|&g| g > now);
            next = next.min((c0 + Micros::from(cycle.next_edge(t))).min(c1));
            next = grid.map_or(next, |g| next.min(g));
        }
        // A message's release (the application's publish) wakes it too (`releases_waiting`).
        if let Some(r) = self.publishers.next_release(self.traffic) {
            self.react_at((r + self.setup.reactions_us.1).max(now + 1));
        }
        self.wake_at = self.slot_tx.next_wake(now, next);
        self.mailboxes = self.can.port().pending();
    }

    /// The transmit interrupt at `now` (`Setup::staged`; `BxCanPort::load_staged`): the frames
    /// it loaded are the node's loaded frames, as `Node::slot_tick` takes them in.
    fn load_staged(&mut self, now: Micros) {
        let n = self.can.load_staged(now);
        let staged = std::mem::take(&mut self.staged);
        self.loaded
            .extend(staged.into_iter().take(n).map(|(s, msg, fragment)| (s.ticket, msg, fragment)));
        self.slot_tx.staged_went_in(self.can.staged_loaded());
        self.counters.staged += n as u64;
        self.mailboxes = self.can.port().pending();
    }

    /// The message and fragment of the queued frame `ticket`: the queue's frames in sending
    /// order, a stream's messages in its publisher's order.
    fn message_of(&self, now: Micros, ticket: Ticket) -> (u32, u8) {
        let mut nth = std::collections::HashMap::<usize, usize>::new();
        for (t, frame) in self.tx.upcoming(now) {
            let id = frame.id();
            let stream = stream_of(id.message);
            let k = *nth.entry(stream).or_insert(0);
            if t == ticket {
                let msg = self.queued[stream].get(k).copied().expect("a queued frame's message");
                return (msg, id.fragment);
            }
            if rtcan::fragment::is_last_frame(id.fragment) {
                nth.insert(stream, k + 1);
            }
        }
        unreachable!("a loaded or staged frame is queued")
    }

    /// Records which message and fragment each newly loaded frame carries: the queue's frames
    /// in sending order, a stream's messages in its publisher order.
    fn note_loaded(&mut self, now: Micros) {
        let new: Vec<Ticket> = self
            .slot_tx
            .queued()
            .map(|(t, _)| t)
            .filter(|t| !self.loaded.iter().any(|l| l.0 == *t))
            .collect();
        for ticket in new {
            let (msg, fragment) = self.message_of(now, ticket);
            self.loaded.push((ticket, msg, fragment));
        }
    }

    /// A loaded frame's fate (step 1).
    fn on_done(&mut self, done: Done<u32>) {
        if done.is_retry(self.slot_tx.policy()) {
            self.counters.retries += 1;
        }
        match done {
            Done::Slotted { what, id, outcome: TxOutcome::Sent, .. } => {
                let what = match what {
                    Slotted::Sync => Carried::Sync,
                    Slotted::Hrt(msg) => Carried::Message { msg, fragment: 0 },
                };
                self.sent.push(Sent { raw_id: id.to_raw(), what });
            }
            Done::Slotted { what: Slotted::Hrt(_), .. } => self.counters.hrt_skipped += 1,
            Done::Slotted { .. } => {}
            Done::Queued { ticket, id, outcome, late } => {
                let at = self.loaded.iter().position(|l| l.0 == ticket);
                let (_, msg, fragment) = self.loaded.remove(at.expect("a queued frame was loaded"));
                if outcome != TxOutcome::Sent {
                    self.counters.late += u64::from(late);
                    return;
                }
                self.sent
                    .push(Sent { raw_id: id.to_raw(), what: Carried::Message { msg, fragment } });
                // Unless the message expired while this frame was on the wire (then it was
                // taken out of the queue and counted already).
                if self.tx.remove(ticket) && rtcan::fragment::is_last_frame(fragment) {
                    self.queued[stream_of(id.message)].pop_front();
                }
            }
        }
    }

    /// Publishes, fills the transmit queue, expires (the node runtime's `tick`).
    fn tick(&mut self, now: Micros) {
        let (traffic, counters) = (self.traffic, &mut self.counters);
        let cycle_us = self.setup.cycle.cycle_us;
        self.publishers.release_until(traffic, now, |_, _| counters.overflows += 1);
        let (tx, queued) = (&mut self.tx, &mut self.queued);
        let free = tx.free();
        self.publishers.drain(
            traffic,
            now,
            free,
            |m| {
                let msg = &traffic.messages[m as usize];
                let stream = &traffic.streams[usize::from(msg.stream)];
                let urgency = match traffic.deadline_us(msg, cycle_us) {
                    Some(deadline) => Urgency::Srt { deadline },
                    None => Urgency::Nrt,
                };
                tx.push_message(stream.message, &msg.payload, urgency)
                    .expect("drain checked the free frames");
                queued[usize::from(msg.stream)].push_back(m);
            },
            |_, _| counters.expired += 1,
        );
        tx.expire(now, |missed| {
            queued[stream_of(missed.message)].pop_front();
            counters.expired += 1;
        });
    }

    /// `Setup::hrt_follow`: this node's HRT slots in `cycle` whose reservation starts where
    /// another reservation of the cycle (the sync's too) ends, each with the instant to load
    /// its frame, µs into the cycle: [`FOLLOW_US`] after that reservation's start, when its
    /// frame is on the wire; and its own reservation's end.
    fn follow_loads(&self, cycle: u32) -> Vec<(u8, u32, u32)> {
        let layout = &self.traffic.layout;
        let announced = (self.clock.mask(cycle) | 1 << SYNC_SLOT) & layout.placed();
        let ends = |q: u8| layout.span(q).map(|s| (s.start_us, s.start_us + s.len_us));
        let mut loads = Vec::new();
        for (s, _) in &self.hrt {
            let Kind::Hrt { framed, .. } = self.traffic.streams[usize::from(*s)].kind else {
                continue;
            };
            // Announced: reserved this cycle (`send_hrt` finds whether a message is due).
            let Some((start, end)) = ends(framed.slot) else { continue };
            if announced & 1 << framed.slot == 0 {
                continue;
            }
            let before = (0..64u8).filter(|&q| announced & 1 << q != 0 && q != framed.slot);
            if let Some((prev, _)) = before.filter_map(ends).find(|&(_, end)| end == start) {
                loads.push((framed.slot, u32::from(prev) + FOLLOW_US, u32::from(end)));
            }
        }
        loads
    }

    /// Loads this node's HRT frame if slot `slot` of cycle `cycle` is one of its streams'.
    fn send_hrt(&mut self, cycle: u32, slot: u8) {
        let traffic = self.traffic;
        for (s, occurrences) in &mut self.hrt {
            let stream = &traffic.streams[usize::from(*s)];
            let Kind::Hrt { period, phase, framed } = stream.kind else { continue };
            let phase = if self.framed { framed } else { phase };
            if phase.slot != slot || !occurs(period, phase, cycle) {
                continue;
            }
            // The cycle whose reservation carries the message (framed: its calendar's offset).
            let carried_in = |m: u32| {
                let msg = &traffic.messages[m as usize];
                if self.framed {
                    traffic.framed_cycle(msg).expect("an HRT message")
                } else {
                    msg.cycle
                }
            };
            while occurrences.front().is_some_and(|&m| carried_in(m) < cycle) {
                occurrences.pop_front();
                self.counters.hrt_skipped += 1;
            }
            let Some(&m) = occurrences.front() else { return };
            let msg = &traffic.messages[m as usize];
            if carried_in(m) != cycle {
                return;
            }
            occurrences.pop_front();
            let id = FrameId { laxity: Laxity::HRT, message: stream.message, fragment: 0 };
            let frame = Frame::new(id, &msg.payload).expect("HRT payloads fit one frame");
            if !self.slot_tx.load_slotted(&mut self.can, Slotted::Hrt(m), &frame) {
                self.counters.hrt_skipped += 1;
            }
            return;
        }
    }

    /// When the slot timer fires next (`Node::next_slot_at`, without the guard).
    fn next_slot_at(&self, now: Micros) -> Micros {
        let slot_us = Micros::from(self.setup.cycle.slot_us().max(1));
        let by_clock = match self.clock.state(now) {
            ClockState::Running(p) => {
                self.clock.slot_start(p.cycle, p.slot + 1).unwrap_or(now + slot_us)
            }
            _ => now + slot_us,
        };
        match self.master {
            Some(m) => by_clock.min(m.next_sync.max(now)),
            None => by_clock,
        }
    }
}
