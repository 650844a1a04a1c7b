//! One node's RTCAN transmit path, as the node runtime runs it (`r2p_node::Node::slot_tick`,
//! TDMA mode), reduced to the traffic of this experiment: no management protocol, no
//! reassembly, HRT phases given by the master's calendar at start-up.
//!
//! At every slot boundary of its [`SlotClock`]: (1) abort what is still pending — a queued
//! frame that went out leaves the [`TxQueue`], one that lost arbitration stays; (2) take
//! received syncs into the clock; (3) move published messages into the queue, expire SRT
//! frames past their deadline; (4) as master, at a cycle's start, send the sync with the next
//! cycle's reservation mask; (5) load at most one frame: nothing in slot 0, this node's HRT
//! frame in a reserved slot of its stream, else the most urgent queued frame with the laxity
//! code of the time left ([`TxQueue::peek`]).
//!
//! How queued frames meet the controller is the [`Transmit`] mode: as the firmware does it
//! today, or one of two what-ifs that the load sweep measures against it.

use std::collections::VecDeque;

use r2p_emu::SimPort;
use rtcan::controller::Filter;
use rtcan::cycle::{ClockState, SYNC_SLOT};
use rtcan::id::{EXTENDED_ID_MAX, MESSAGE_ID_SHIFT, SYNC_MESSAGE_IDS};
use rtcan::schedule::occurs;
use rtcan::{
    CanController, Frame, FrameId, Laxity, MessageId, Micros, SlotClock, Sync, TxQueue, Urgency,
};

use crate::publish::Publishers;
use crate::record::{Carried, Counters, Sent};
use crate::setup::{Setup, TX_QUEUE};
use crate::traffic::{Kind, Traffic};

/// How queued (SRT/NRT) frames are handed to the controller.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transmit {
    /// The firmware today: one frame per free slot, loaded at the slot's start; the controller
    /// retransmits automatically (bxCAN's default), so a frame that loses the slot's arbitration
    /// tries again as soon as the bus is idle — after the winner, past the slot's end, into the
    /// next slot, which may be a reserved one or the next cycle's sync slot.
    Retransmit,
    /// What-if: one-shot transmission (bxCAN `NART` = 1): a frame that loses arbitration is
    /// withdrawn at once and waits for the next free slot; free slots never overflow.
    OneShot,
    /// What-if: consecutive free slots merged into one arbitration window (as TTCAN merges
    /// arbitrating windows): a node loads its next frame as soon as its previous one is sent,
    /// losers retry at once, and every pending frame is withdrawn a worst-case frame time
    /// before the next reserved slot or sync, so nothing overflows into them.
    Merged,
}

/// What the node loaded at the current slot's start.
#[derive(Clone, Copy, Debug)]
enum Inflight {
    None,
    Sync { raw_id: u32 },
    Hrt { msg: u32, raw_id: u32 },
    Queued { at: Micros, msg: u32, fragment: u8, raw_id: u32 },
}

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
    inflight: Inflight,
    publishers: Publishers,
    /// This node's HRT streams and their occurrences still to send, oldest first.
    hrt: Vec<(u16, VecDeque<u32>)>,
    /// Per stream (all streams of the run): its messages in the transmit queue, oldest first.
    queued: Vec<VecDeque<u32>>,
    mode: Transmit,
    /// Merged mode: no queued frame may be pending from this time until the next reserved slot.
    guard: Option<Micros>,
    /// The next slot boundary.
    next_slot: Micros,
    /// Frames this node's port sent, in order.
    pub sent: Vec<Sent>,
    /// What the node counted.
    pub counters: Counters,
}

/// Message ID → stream index.
fn stream_of(message: MessageId) -> usize {
    usize::from(message.0 - SYNC_MESSAGE_IDS)
}

impl<'t> RtcanNode<'t> {
    /// Node `index` on `can`; node 0 is the master.
    pub fn new(
        traffic: &'t Traffic,
        setup: &'t Setup,
        index: usize,
        mut can: SimPort,
        mode: Transmit,
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
            inflight: Inflight::None,
            publishers: Publishers::new(traffic, setup, index, |s| !is_hrt(s)),
            hrt,
            queued: vec![VecDeque::new(); traffic.streams.len()],
            mode,
            guard: None,
            next_slot: 0,
            sent: Vec::new(),
            counters: Counters::default(),
        }
    }

    /// When the node's timer fires next: its next slot boundary, or before it the merged
    /// window's guard time.
    pub fn next_wake(&self) -> Micros {
        match self.guard {
            Some(g) if g < self.next_slot => g,
            _ => self.next_slot,
        }
    }

    /// The node's timer at `now`: the slot timer at a slot boundary, else the guard time.
    pub fn wake(&mut self, now: Micros) {
        self.counters.activations += 1;
        if now >= self.next_slot {
            self.slot_tick(now);
            self.next_slot = self.next_slot_at(now).max(now + 1);
        } else if self.guard.is_some_and(|g| now >= g) {
            self.guard = None;
            self.withdraw();
        }
    }

    /// Takes back a queued frame still waiting for the bus (one on the wire goes on).
    fn withdraw(&mut self) {
        if matches!(self.inflight, Inflight::Queued { .. }) && self.can.abort_pending() > 0 {
            self.inflight = Inflight::None;
            self.counters.retries += 1;
        }
    }

    /// A queued frame that went out leaves the queue.
    fn confirm_queued(&mut self, at: Micros, msg: u32, fragment: u8, raw_id: u32) {
        let popped = self.tx.pop(at).map(|f| f.id().to_raw());
        assert_eq!(popped, Some(raw_id), "the queue's head changed under a loaded frame");
        self.sent.push(Sent { raw_id, what: Carried::Message { msg, fragment } });
        if fragment == 0 {
            let s = usize::from(self.traffic.messages[msg as usize].stream);
            self.queued[s].pop_front();
        }
    }

    /// The slot timer at boundary `now` (module documentation, steps 1–5).
    fn slot_tick(&mut self, now: Micros) {
        self.guard = None;
        let aborted = self.can.abort_pending();
        match core::mem::replace(&mut self.inflight, Inflight::None) {
            Inflight::Queued { at, msg, fragment, raw_id } if aborted == 0 => {
                self.confirm_queued(at, msg, fragment, raw_id);
            }
            Inflight::Queued { .. } => self.counters.retries += 1,
            Inflight::Hrt { msg, raw_id } if aborted == 0 => {
                self.sent.push(Sent { raw_id, what: Carried::Message { msg, fragment: 0 } });
            }
            Inflight::Sync { raw_id } if aborted == 0 => {
                self.sent.push(Sent { raw_id, what: Carried::Sync });
            }
            Inflight::Hrt { .. } | Inflight::Sync { .. } | Inflight::None => {}
        }
        while let Some(r) = self.can.try_receive() {
            if let (None, Ok(sync)) = (self.master, Sync::from_frame(&r.frame)) {
                let first = self.clock.state(r.at) == ClockState::Unsynced;
                if !self.clock.on_sync(r.at, &sync).continuous && !first {
                    self.counters.resyncs += 1;
                }
            }
        }
        self.tick(now);

        if let Some(mut m) = self.master {
            if now >= m.next_sync {
                let mask = self.traffic.scheduler.mask(m.cycle.wrapping_add(1));
                let sync = Sync::new(m.cycle, mask, false);
                let frame = sync.to_frame();
                if self.can.try_transmit(&frame).is_ok() {
                    self.clock.on_sync(now, &sync);
                    self.inflight = Inflight::Sync { raw_id: frame.id().to_raw() };
                }
                let cycle_us = Micros::from(self.setup.cycle.cycle_us);
                m.cycle = m.cycle.wrapping_add(1);
                m.next_sync += cycle_us;
                if m.next_sync <= now {
                    m.next_sync = now + cycle_us;
                }
                self.master = Some(m);
            }
        }
        if !matches!(self.inflight, Inflight::None) {
            return;
        }
        match self.clock.state(now) {
            ClockState::Running(p) if p.slot == SYNC_SLOT => {}
            ClockState::Running(p) if self.clock.mask(p.cycle) & (1 << p.slot) != 0 => {
                self.send_hrt(p.cycle, p.slot);
            }
            ClockState::Running(p) => {
                if self.mode == Transmit::Merged {
                    self.guard = self.guard_time(p.cycle, p.slot);
                }
                self.send_queued(now);
            }
            ClockState::Unsynced | ClockState::Lost => {}
        }
    }

    /// Merged mode: the last instant a frame may still start and end before the next reserved
    /// slot (or the next cycle's sync slot) begins.
    fn guard_time(&self, cycle: u32, slot: u8) -> Option<Micros> {
        let mask = self.clock.mask(cycle);
        let slots = self.setup.cycle.slots;
        let next = (slot + 1..slots).find(|&j| mask & (1 << j) != 0).unwrap_or(slots);
        let frame_us = Micros::from(self.setup.cycle.frame_us());
        self.clock.slot_start(cycle, next).map(|r| r.saturating_sub(frame_us))
    }

    /// Merged mode, after every bus event: once this node's queued frame is sent, the next one
    /// goes to the controller while the window lasts.
    pub fn on_bus_event(&mut self, now: Micros) {
        let Inflight::Queued { at, msg, fragment, raw_id } = self.inflight else { return };
        if self.mode != Transmit::Merged || self.can.port().pending() > 0 {
            return;
        }
        self.counters.activations += 1;
        self.inflight = Inflight::None;
        self.confirm_queued(at, msg, fragment, raw_id);
        if self.guard.is_some_and(|g| now < g) {
            self.send_queued(now);
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

    /// Loads this node's HRT frame if slot `slot` of cycle `cycle` is one of its streams'.
    fn send_hrt(&mut self, cycle: u32, slot: u8) {
        let traffic = self.traffic;
        for (s, occurrences) in &mut self.hrt {
            let stream = &traffic.streams[usize::from(*s)];
            let Kind::Hrt { period, phase } = stream.kind else { continue };
            if phase.slot != slot || !occurs(period, phase, cycle) {
                continue;
            }
            while occurrences.front().is_some_and(|&m| traffic.messages[m as usize].cycle < cycle) {
                occurrences.pop_front();
                self.counters.hrt_skipped += 1;
            }
            let Some(&m) = occurrences.front() else { return };
            let msg = &traffic.messages[m as usize];
            if msg.cycle != cycle {
                return;
            }
            occurrences.pop_front();
            let id = FrameId { laxity: Laxity::HRT, message: stream.message, fragment: 0 };
            let frame = Frame::new(id, &msg.payload).expect("HRT payloads fit one frame");
            if self.can.try_transmit(&frame).is_ok() {
                self.inflight = Inflight::Hrt { msg: m, raw_id: id.to_raw() };
            } else {
                self.counters.hrt_skipped += 1;
            }
            return;
        }
    }

    /// Loads the most urgent queued frame.
    fn send_queued(&mut self, now: Micros) {
        let Some(frame) = self.tx.peek(now) else { return };
        let id = frame.id();
        let Some(&msg) = self.queued[stream_of(id.message)].front() else {
            unreachable!("a queued frame belongs to a queued message")
        };
        if self.can.try_transmit(&frame).is_ok() {
            self.inflight =
                Inflight::Queued { at: now, msg, fragment: id.fragment, raw_id: id.to_raw() };
        }
    }

    /// One-shot mode, right after the slot's arbitration: a queued frame that lost is withdrawn
    /// and waits for the next free slot.
    pub fn withdraw_if_lost(&mut self) {
        if self.mode == Transmit::OneShot {
            self.withdraw();
        }
    }

    /// When the slot timer fires next (`Node::next_slot_at`).
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
