//! A no-heap loopback bus for the behaviour suite (it runs on QEMU too).
//!
//! Immediate mode ([`Bus::new`]): every frame a port sends reaches every other port at once, in
//! sending order, stamped with the bus's current time.
//!
//! Slotted mode ([`Bus::slotted`], for nodes driven by `slot_tick`): frames wait in their
//! port's three mailboxes; after every node had its slot tick, [`Bus::arbitrate`] sends one
//! frame — the lowest identifier among the mailboxes' oldest frames, as CAN arbitration would —
//! stamped with the slot's start (its start of frame); the losers are withdrawn if their port
//! is in one-shot mode, else stay pending until their node aborts them. Every port reports
//! what became of its frames (`take_tx_result`). The bus follows the syncs it carries and checks the slot policy: a frame
//! that is not HRT in the sync slot or a reserved slot, or an HRT frame in a free slot, is a
//! violation; HRT frames are logged with their cycle and slot.

#![allow(clippy::new_without_default)] // a test rig, public only for the QEMU slot-path benchmark

use core::cell::{Cell, RefCell};

use heapless::{Deque, Vec};
use rtcan::controller::{
    BusState, ErrorCounters, Filter, Received, TxError, TxMode, TxOutcome, TxResult, TX_RESULTS,
};
use rtcan::{CanController, CycleConfig, Frame, Laxity, MessageId, Micros, SyncFrame};

use crate::Node;

/// Frames a port can hold before the bus drops (and counts) more.
pub const DEPTH: usize = 48;
/// Transmit mailboxes per port in slotted mode (bxCAN has three).
pub const MAILBOXES: usize = 3;
/// HRT frames the slotted bus logs.
pub const HRT_LOG: usize = 24;

/// An HRT frame the slotted bus carried.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HrtSeen {
    /// Start of its slot.
    pub at: Micros,
    /// Cycles since the first sync the bus carried (across masters).
    pub cycle: u32,
    /// Slot index.
    pub slot: u8,
    /// Stream.
    pub message: MessageId,
    /// First payload byte.
    pub first: u8,
}

struct Slots {
    config: CycleConfig,
    /// Start of the current cycle and its number (counted by the bus).
    cycle: Cell<Option<(Micros, u32)>>,
    /// Reservations of the current cycle (announced by the previous sync), if known.
    mask: Cell<Option<u64>>,
    /// Reservations the last sync announced for the next cycle.
    next: Cell<Option<(u32, u64)>>,
    violations: Cell<u32>,
    hrt: RefCell<Vec<HrtSeen, HRT_LOG>>,
}

pub struct Bus<const PORTS: usize> {
    queues: RefCell<[Deque<Received, DEPTH>; PORTS]>,
    unplugged: Cell<[bool; PORTS]>,
    off: Cell<[bool; PORTS]>,
    mailboxes: RefCell<[Deque<Frame, MAILBOXES>; PORTS]>,
    modes: Cell<[TxMode; PORTS]>,
    results: RefCell<[Deque<TxResult, TX_RESULTS>; PORTS]>,
    /// Each port's acceptance filters, as its node programmed them (bxCAN's 14 banks; more
    /// widen to everything, as `rtcan-bxcan` does).
    filters: RefCell<[Option<Vec<Filter, { crate::hw_filters::BANKS }>>; PORTS]>,
    slots: Option<Slots>,
    pub now: Cell<Micros>,
    pub overflow: Cell<u32>,
}

impl<const PORTS: usize> Bus<PORTS> {
    pub fn new() -> Self {
        Self {
            queues: RefCell::new(core::array::from_fn(|_| Deque::new())),
            unplugged: Cell::new([false; PORTS]),
            off: Cell::new([false; PORTS]),
            mailboxes: RefCell::new(core::array::from_fn(|_| Deque::new())),
            modes: Cell::new([TxMode::Retransmit; PORTS]),
            results: RefCell::new(core::array::from_fn(|_| Deque::new())),
            filters: RefCell::new(core::array::from_fn(|_| None)),
            slots: None,
            now: Cell::new(0),
            overflow: Cell::new(0),
        }
    }

    /// A bus in slotted mode for cycle `config` (its slot length must be whole µs).
    pub fn slotted(config: CycleConfig) -> Self {
        Self {
            slots: Some(Slots {
                config,
                cycle: Cell::new(None),
                mask: Cell::new(None),
                next: Cell::new(None),
                violations: Cell::new(0),
                hrt: RefCell::new(Vec::new()),
            }),
            ..Self::new()
        }
    }

    #[cfg_attr(not(test), allow(dead_code))] // used by the host tests only
    /// Powers module `me` off (it neither sends nor receives; what it had pending is lost) or
    /// on again.
    pub fn power(&self, me: usize, on: bool) {
        let mut o = self.off.get();
        o[me] = !on;
        self.off.set(o);
        self.queues.borrow_mut()[me].clear();
        self.mailboxes.borrow_mut()[me].clear();
        self.results.borrow_mut()[me].clear();
        self.filters.borrow_mut()[me] = None;
        let mut m = self.modes.get();
        m[me] = TxMode::Retransmit;
        self.modes.set(m);
    }

    /// Records what became of port `me`'s frame `frame`.
    fn report(&self, me: usize, frame: &Frame, outcome: TxOutcome) {
        let mut r = self.results.borrow_mut();
        if r[me].is_full() {
            r[me].pop_front();
        }
        let _ = r[me].push_back(TxResult::new(frame.id(), outcome));
    }

    pub fn is_on(&self, me: usize) -> bool {
        !self.off.get()[me]
    }

    /// Slot-policy violations seen (slotted mode).
    pub fn violations(&self) -> u32 {
        self.slots.as_ref().map_or(0, |s| s.violations.get())
    }

    /// HRT frames carried (slotted mode), oldest first.
    pub fn hrt_log(&self) -> Vec<HrtSeen, HRT_LOG> {
        self.slots.as_ref().map(|s| s.hrt.borrow().clone()).unwrap_or_default()
    }

    pub fn clear_hrt_log(&self) {
        if let Some(s) = &self.slots {
            s.hrt.borrow_mut().clear();
        }
    }

    /// Slotted mode: sends the frame that wins this slot's arbitration, if any.
    pub fn arbitrate(&self) {
        let winner = {
            let boxes = self.mailboxes.borrow();
            (0..PORTS)
                .filter_map(|p| boxes[p].front().map(|f| (f.id().to_raw(), p)))
                .min()
                .map(|(_, p)| p)
        };
        let Some(p) = winner else { return };
        let Some(frame) = self.mailboxes.borrow_mut()[p].pop_front() else { return };
        self.check(&frame);
        self.send(p, frame);
        self.report(p, &frame, TxOutcome::Sent);
        for q in (0..PORTS).filter(|&q| q != p && self.modes.get()[q] == TxMode::OneShot) {
            let lost = self.mailboxes.borrow_mut()[q].pop_front();
            if let Some(f) = lost {
                self.report(q, &f, TxOutcome::LostArbitration);
            }
        }
    }

    fn check(&self, frame: &Frame) {
        let Some(s) = &self.slots else { return };
        let now = self.now.get();
        if let Ok(sync) = SyncFrame::from_frame(frame) {
            let number = s.cycle.get().map_or(0, |(_, n)| n + 1);
            let mask = match s.next.get() {
                Some((n, m))
                    if n == number
                        && s.cycle
                            .get()
                            .is_some_and(|(t, _)| now - t == Micros::from(s.config.cycle_us)) =>
                {
                    Some(m)
                }
                _ => None,
            };
            s.cycle.set(Some((now, number)));
            s.mask.set(mask);
            s.next.set(Some((number + 1, sync.reservations)));
            return;
        }
        let Some((start, number)) = s.cycle.get() else { return };
        let into = now - start;
        if into >= Micros::from(s.config.cycle_us) {
            return; // no sync this cycle (master lost): nothing known
        }
        let slot = (0..s.config.slots)
            .rev()
            .find(|&j| Micros::from(s.config.slot_offset_us(j)) <= into)
            .unwrap_or(0);
        let reserved = s.mask.get().map(|m| m & (1 << slot) != 0);
        let hrt = frame.id().laxity == Laxity::HRT;
        let bad = if hrt {
            reserved == Some(false) || slot == 0
        } else {
            slot == 0 || reserved == Some(true)
        };
        if bad {
            s.violations.set(s.violations.get() + 1);
        }
        if hrt {
            let seen = HrtSeen {
                at: now,
                cycle: number,
                slot,
                message: frame.id().message,
                first: frame.payload().first().copied().unwrap_or(0),
            };
            let _ = s.hrt.borrow_mut().push(seen);
        }
    }

    /// The frame port `me` loaded first and the bus has not sent yet.
    pub fn loaded(&self, me: usize) -> Option<Frame> {
        self.mailboxes.borrow()[me].front().copied()
    }

    pub fn port(&self, me: usize) -> Port<'_, PORTS> {
        Port { bus: self, me }
    }

    /// A port whose controller refuses to send (mailboxes full), e.g. a module cut off.
    pub fn unplug(&self, me: usize, unplugged: bool) {
        let mut u = self.unplugged.get();
        u[me] = unplugged;
        self.unplugged.set(u);
    }

    /// Opens every port's filters, as a controller whose node asked for more filters than it
    /// has banks: what reaches the node is then its software's to sort (until it programs
    /// other filters).
    #[cfg_attr(not(test), allow(dead_code))] // used by the host tests only
    pub fn accept_everything(&self) {
        self.filters.borrow_mut().iter_mut().for_each(|f| *f = None);
    }

    /// Puts `frame` on the bus as if some other module had sent it.
    pub fn inject(&self, frame: Frame) {
        self.send(usize::MAX, frame);
    }

    fn send(&self, from: usize, frame: Frame) {
        let at = self.now.get();
        let off = self.off.get();
        let filters = self.filters.borrow();
        let raw = frame.id().to_raw();
        for (i, q) in self.queues.borrow_mut().iter_mut().enumerate() {
            let accepted = filters[i].as_ref().is_none_or(|f| f.iter().any(|f| f.accepts(raw)));
            if i != from && !off[i] && accepted && q.push_back(Received { frame, at }).is_err() {
                self.overflow.set(self.overflow.get() + 1);
            }
        }
    }
}

pub struct Port<'b, const PORTS: usize> {
    bus: &'b Bus<PORTS>,
    me: usize,
}

impl<const PORTS: usize> CanController for Port<'_, PORTS> {
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        if self.bus.unplugged.get()[self.me] || self.bus.off.get()[self.me] {
            return Err(TxError::MailboxesFull);
        }
        if self.bus.slots.is_some() {
            let mut boxes = self.bus.mailboxes.borrow_mut();
            return boxes[self.me].push_back(*frame).map_err(|_| TxError::MailboxesFull);
        }
        self.bus.send(self.me, *frame);
        self.bus.report(self.me, frame, TxOutcome::Sent);
        Ok(())
    }
    fn set_tx_mode(&mut self, mode: TxMode) {
        let mut m = self.bus.modes.get();
        m[self.me] = mode;
        self.bus.modes.set(m);
    }
    fn take_tx_result(&mut self) -> Option<TxResult> {
        self.bus.results.borrow_mut()[self.me].pop_front()
    }
    fn try_receive(&mut self) -> Option<Received> {
        self.bus.queues.borrow_mut()[self.me].pop_front()
    }
    fn set_filters(&mut self, filters: &[Filter]) {
        self.bus.filters.borrow_mut()[self.me] = Vec::from_slice(filters).ok();
    }
    fn abort_pending(&mut self) -> usize {
        let mut n = 0;
        while let Some(f) = self.bus.mailboxes.borrow_mut()[self.me].pop_front() {
            self.bus.report(self.me, &f, TxOutcome::Aborted);
            n += 1;
        }
        n
    }
    fn bus_state(&self) -> BusState {
        BusState::ErrorActive
    }
    fn error_counters(&self) -> ErrorCounters {
        ErrorCounters::default()
    }
}

/// The node type of the suite: 2 exports, 2 imports, 24 queued frames, 4 reassembly slots of
/// 64 bytes (about 1.7 KB: three fit QEMU's RAM easily).
pub type TestNode<'a> = Node<'a, 2, 2, 24, 4, 64>;

/// Polls every node (node i on port i) every millisecond from the bus's time until `until`.
pub fn run<const PORTS: usize>(bus: &Bus<PORTS>, nodes: &mut [&mut TestNode<'_>], until: Micros) {
    while bus.now.get() < until {
        let now = bus.now.get();
        for (i, n) in nodes.iter_mut().enumerate() {
            n.poll(now, &mut bus.port(i));
        }
        bus.now.set(now + 1_000);
    }
}

/// Slotted mode: every powered node has its slot tick at each slot boundary, then the bus
/// sends the slot's frame; from the bus's time until `until`.
pub fn run_slots<const PORTS: usize>(
    bus: &Bus<PORTS>,
    nodes: &mut [&mut TestNode<'_>],
    until: Micros,
) {
    let step = bus.slots.as_ref().map_or(1_000, |s| Micros::from(s.config.slot_us()));
    while bus.now.get() < until {
        let now = bus.now.get();
        for (i, n) in nodes.iter_mut().enumerate() {
            if bus.is_on(i) {
                n.slot_tick(now, &mut bus.port(i));
            }
        }
        bus.arbitrate();
        bus.now.set(now + step);
    }
}

/// A unique ID that differs in its last bytes.
pub fn uid(n: u32) -> [u8; 12] {
    let mut u = [0u8; 12];
    u[8..].copy_from_slice(&n.to_be_bytes());
    u
}
