//! The bus: virtual time, arbitration, delivery, fault confinement and fault injection.

use std::collections::hash_map::DefaultHasher;
use std::collections::VecDeque;
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex, MutexGuard};

use rtcan::controller::{
    BusState, ErrorCounters, Filter, Received, TxError, TxMode, TxOutcome, TxResult, TX_RESULTS,
};
use rtcan::{CanController, Frame};

use crate::bits::{arbitration_loss_bits, FrameBits, RECOVERY_RUNS, RECOVERY_RUN_BITS};
use crate::rng::SplitMix64;

/// In which order a port's loaded mailboxes go out.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TxOrder {
    /// The order they were loaded in: bxCAN with transmit FIFO priority (`TXFP` = 1), as
    /// `rtcan-bxcan` sets it and `rtcan::CanController` requires. The default.
    #[default]
    Loaded,
    /// Lowest identifier first, then oldest: bxCAN's reset setting (`TXFP` = 0), a plain CAN
    /// node's.
    Identifier,
}

/// Transmit mailboxes per port (bxCAN has three).
pub const MAILBOXES: usize = 3;
/// Buses of up to this many segments find their next start in one pass over the nodes.
const FAST_SEGMENTS: usize = 16;

/// Bus parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Bit rate in bit/s (classic CAN: at most 1 Mbit/s).
    pub bit_rate: u32,
    /// Receive FIFO depth per port; frames arriving at a full FIFO are lost and counted.
    pub rx_depth: usize,
    /// Seed of the generator that decides probabilistic faults.
    pub seed: u64,
}

impl Default for Config {
    /// 1 Mbit/s, a 6-frame receive FIFO (bxCAN's two 3-frame FIFOs), seed 0.
    fn default() -> Self {
        Self { bit_rate: rtcan::cycle::DEFAULT_BIT_RATE, rx_depth: 6, seed: 0 }
    }
}

/// What an injected fault does to a frame it matches.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FaultAction {
    /// The frame completes and the sender sees success, but receivers miss it: every
    /// receiver (`None`) or only the given port.
    Drop(Option<usize>),
    /// The frame is corrupted on the wire: receivers see a CRC error and send an error frame,
    /// the error counters move and the sender retransmits.
    Corrupt,
}

/// A fault rule: which frames it hits, how often and how many times.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FaultRule {
    /// What happens to a frame the rule hits.
    pub action: FaultAction,
    /// Only frames with this raw identifier (`None`: any).
    pub id: Option<u32>,
    /// Only frames sent by this port (`None`: any).
    pub from: Option<usize>,
    /// Probability of hitting a matching frame, in parts per million (1 000 000: always).
    pub probability_ppm: u32,
    /// Hits left before the rule retires (`None`: never retires).
    pub remaining: Option<u32>,
}

impl FaultRule {
    /// A rule that always hits every frame, forever.
    pub const fn new(action: FaultAction) -> Self {
        Self { action, id: None, from: None, probability_ppm: 1_000_000, remaining: None }
    }

    /// Drop every frame (receivers miss it).
    pub const fn drop_frames() -> Self {
        Self::new(FaultAction::Drop(None))
    }

    /// Corrupt every frame (error frame, retransmission).
    pub const fn corrupt() -> Self {
        Self::new(FaultAction::Corrupt)
    }

    /// Only frames with raw identifier `raw_id`.
    pub const fn id(mut self, raw_id: u32) -> Self {
        self.id = Some(raw_id);
        self
    }

    /// Only frames sent by `port`.
    pub const fn from(mut self, port: usize) -> Self {
        self.from = Some(port);
        self
    }

    /// Hit a matching frame with probability `ppm` / 1 000 000 (drawn from the seeded
    /// generator).
    pub const fn probability_ppm(mut self, ppm: u32) -> Self {
        self.probability_ppm = ppm;
        self
    }

    /// Retire after `n` hits.
    pub const fn times(mut self, n: u32) -> Self {
        self.remaining = Some(n);
        self
    }

    fn matches(&self, raw_id: u32, sender: usize) -> bool {
        self.id.is_none_or(|id| id == raw_id) && self.from.is_none_or(|p| p == sender)
    }
}

/// Why a frame ended in an error frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ErrorCause {
    /// Injected corruption: receivers saw a CRC error.
    Corrupted,
    /// No other node acknowledged the frame (the sender is alone on its segment).
    NoAck,
    /// The sender was powered off while sending: receivers saw a truncated frame.
    SenderLost,
}

/// What happened on the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EventKind {
    /// A frame completed and was confirmed to its sender. `missed_by` is the injected drop, if
    /// any (`Some(None)`: every receiver missed it).
    Sent {
        /// Start of frame.
        start_ns: u64,
        /// The frame.
        frame: Frame,
        /// Receivers that missed it by injection.
        missed_by: Option<Option<usize>>,
    },
    /// A one-shot frame lost arbitration and was withdrawn (logged at the bit where it lost;
    /// a frame that will retry loses silently, as on a real bus).
    LostArbitration {
        /// Start of frame (the winner's).
        start_ns: u64,
        /// The withdrawn frame.
        frame: Frame,
    },
    /// A frame ended in an error frame; the sender will retry unless it was aborted or sent
    /// one-shot.
    Error {
        /// Start of frame.
        start_ns: u64,
        /// The frame.
        frame: Frame,
        /// Why.
        cause: ErrorCause,
    },
    /// The port went bus-off.
    BusOff,
    /// The port recovered from bus-off.
    Recovered,
    /// The port was powered off.
    PowerOff,
    /// The port was powered on.
    PowerOn,
}

/// One entry of the event log: when (ns of virtual time), which port (the sender for frames)
/// and what.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Event {
    /// Virtual time in ns: end of EOF for a sent frame, end of the error delimiter for an
    /// error, the moment of the change otherwise.
    pub time_ns: u64,
    /// The port concerned.
    pub port: usize,
    /// What happened.
    pub kind: EventKind,
}

#[derive(Clone, Copy, Debug)]
struct Mailbox {
    frame: Frame,
    loaded_at: u64,
    seq: u64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Source {
    Mailbox(usize, u64),
    Babble,
}

#[derive(Clone, Debug)]
struct Node {
    powered: bool,
    epoch: u64,
    segment: usize,
    mailboxes: [Option<Mailbox>; MAILBOXES],
    /// Received frames with their bits from SOF to the end of EOF (counted once, at the start).
    fifo: VecDeque<(Received, u32)>,
    filters: Vec<Filter>,
    tec: u16,
    rec: u16,
    /// Recessive runs counted since going bus-off.
    bus_off: Option<u32>,
    babble: Option<(Frame, u64)>,
    overflows: u64,
    received: u64,
    /// A frame of this node is on the wire (possibly on a segment it has since left).
    sending: bool,
    tx_mode: TxMode,
    tx_order: TxOrder,
    /// Results of finished frames not taken yet, oldest first (at most `TX_RESULTS`).
    results: VecDeque<Finished>,
}

/// A finished frame's result, not taken yet.
#[derive(Clone, Copy, Debug)]
struct Finished {
    result: TxResult,
    /// A sent frame's start of frame (ns).
    sof_ns: Option<u64>,
    /// The mailbox it left, and its load's sequence number.
    mailbox: usize,
    seq: u64,
}

impl Node {
    fn new() -> Self {
        Self {
            powered: true,
            epoch: 0,
            segment: 0,
            mailboxes: [None; MAILBOXES],
            fifo: VecDeque::new(),
            filters: vec![Filter::ACCEPT_ALL],
            tec: 0,
            rec: 0,
            bus_off: None,
            babble: None,
            overflows: 0,
            received: 0,
            sending: false,
            tx_mode: TxMode::Retransmit,
            tx_order: TxOrder::Loaded,
            results: VecDeque::new(),
        }
    }

    fn reset(&mut self) {
        self.epoch += 1;
        self.mailboxes = [None; MAILBOXES];
        self.fifo.clear();
        self.filters = vec![Filter::ACCEPT_ALL];
        self.tec = 0;
        self.rec = 0;
        self.bus_off = None;
        self.tx_mode = TxMode::Retransmit;
        self.results.clear();
    }

    /// Frees mailbox `i` if it still holds the frame loaded as `seq`, and records `outcome`
    /// (and, for a sent frame, its start of frame `sof_ns`).
    fn finish(&mut self, i: usize, seq: u64, outcome: TxOutcome, sof_ns: Option<u64>) -> bool {
        let Some(m) = self.mailboxes[i].filter(|m| m.seq == seq) else { return false };
        self.mailboxes[i] = None;
        if self.results.len() == TX_RESULTS {
            self.results.pop_front();
        }
        let result = TxResult::new(m.frame.id(), outcome);
        self.results.push_back(Finished { result, sof_ns, mailbox: i, seq });
        true
    }

    /// Takes part in bus traffic (sends, receives, acknowledges).
    fn active(&self) -> bool {
        self.powered && self.bus_off.is_none()
    }

    fn state(&self) -> BusState {
        if !self.powered || self.bus_off.is_some() {
            BusState::BusOff
        } else if self.tec >= 128 || self.rec >= 128 {
            BusState::ErrorPassive
        } else {
            BusState::ErrorActive
        }
    }

    /// The request this node would arbitrate with at `t`: its oldest loaded mailbox
    /// ([`TxOrder::Loaded`]) or its lowest identifier, then oldest ([`TxOrder::Identifier`]);
    /// a babbler's frame competes by identifier.
    fn candidate(&self, t: u64) -> Option<(u32, u64, Source, Frame)> {
        if !self.active() || self.sending {
            return None;
        }
        let boxes = self.mailboxes.iter().enumerate().filter_map(|(i, m)| {
            m.filter(|m| m.loaded_at <= t)
                .map(|m| (m.frame.id().to_raw(), m.seq, Source::Mailbox(i, m.seq), m.frame))
        });
        let boxes = match self.tx_order {
            TxOrder::Loaded => boxes.min_by_key(|&(_, seq, _, _)| seq),
            TxOrder::Identifier => boxes.min_by_key(|&(id, seq, _, _)| (id, seq)),
        };
        let babble = self
            .babble
            .filter(|&(_, since)| since <= t)
            .map(|(f, _)| (f.id().to_raw(), 0, Source::Babble, f));
        boxes.into_iter().chain(babble).min_by_key(|&(id, seq, _, _)| (id, seq))
    }

    fn earliest_request(&self) -> Option<u64> {
        if !self.active() || self.sending {
            return None;
        }
        let boxes = self.mailboxes.iter().flatten().map(|m| m.loaded_at);
        boxes.chain(self.babble.map(|(_, since)| since)).min()
    }
}

#[derive(Clone, Copy, Debug)]
enum Outcome {
    Ok(Option<Option<usize>>),
    Error(ErrorCause),
}

#[derive(Clone, Copy, Debug)]
struct InFlight {
    sender: usize,
    epoch: u64,
    source: Source,
    frame: Frame,
    start: u64,
    end: u64,
    idle: u64,
    /// The frame's bits from SOF to the end of EOF, stuffing included.
    eof_bits: u32,
    outcome: Outcome,
    aborted: bool,
}

#[derive(Clone, Copy, Debug, Default)]
struct Segment {
    busy: Option<InFlight>,
    idle_at: u64,
    recessive_since: u64,
}

#[derive(Clone, Copy, Debug)]
enum Due {
    End(usize),
    Start(usize),
    Recover(usize),
    Withdraw(usize),
}

/// A frame that is losing arbitration: until the end of the bit where it loses, it is on the
/// wire (an abort request cannot take it back); then it is withdrawn if it was sent one-shot
/// or its abort was requested meanwhile, else it waits for the next idle.
#[derive(Clone, Copy, Debug)]
struct Withdrawal {
    at: u64,
    port: usize,
    mailbox: usize,
    seq: u64,
    start: u64,
    withdraw: bool,
}

struct Inner {
    config: Config,
    now: u64,
    seq: u64,
    nodes: Vec<Node>,
    segments: Vec<Segment>,
    faults: Vec<FaultRule>,
    rng: SplitMix64,
    trace: Vec<Event>,
    /// Pending withdrawals of one-shot losers, in the order they were decided.
    withdrawals: Vec<Withdrawal>,
}

impl Inner {
    fn bits_ns(&self, bits: u64) -> u64 {
        (u128::from(bits) * 1_000_000_000 / u128::from(self.config.bit_rate)) as u64
    }

    fn ns_bits(&self, ns: u64) -> u64 {
        (u128::from(ns) * u128::from(self.config.bit_rate) / 1_000_000_000) as u64
    }

    fn log(&mut self, time_ns: u64, port: usize, kind: EventKind) {
        self.trace.push(Event { time_ns, port, kind });
    }

    fn start_time(&self, seg: usize) -> Option<u64> {
        let s = &self.segments[seg];
        if s.busy.is_some() {
            return None;
        }
        let first = self
            .nodes
            .iter()
            .filter(|n| n.segment == seg)
            .filter_map(Node::earliest_request)
            .min()?;
        // Never in the past: a node that left a busy segment may find an idle one.
        Some(first.max(s.idle_at).max(self.now))
    }

    fn recovery_time(&self, port: usize) -> Option<u64> {
        let n = &self.nodes[port];
        let counted = n.bus_off.filter(|_| n.powered)?;
        let s = &self.segments[n.segment];
        if s.busy.is_some() {
            return None;
        }
        let runs = u64::from(RECOVERY_RUNS.saturating_sub(counted));
        let t = s.recessive_since + self.bits_ns(runs * u64::from(RECOVERY_RUN_BITS));
        Some(t.max(self.now))
    }

    /// The next thing that happens, earliest first; at equal times recoveries, then
    /// withdrawals and ends, then starts, each by index.
    fn next_due(&self) -> Option<(u64, Due)> {
        let mut best: Option<(u64, u8, usize, Due)> = None;
        let mut consider = |t: u64, rank: u8, i: usize, d: Due| {
            if best.is_none_or(|(bt, br, bi, _)| (t, rank, i) < (bt, br, bi)) {
                best = Some((t, rank, i, d));
            }
        };
        for p in 0..self.nodes.len() {
            if let Some(t) = self.recovery_time(p) {
                consider(t, 0, p, Due::Recover(p));
            }
        }
        for (i, w) in self.withdrawals.iter().enumerate() {
            consider(w.at, 1, i, Due::Withdraw(i));
        }
        // Each idle segment's earliest request, from one pass over the nodes (start_time's,
        // which the simulation asks several times per event: per segment it was nodes × segments).
        let mut first = [u64::MAX; FAST_SEGMENTS];
        let fast = self.segments.len() <= FAST_SEGMENTS;
        if fast {
            for n in &self.nodes {
                if let Some(t) = n.earliest_request() {
                    first[n.segment] = first[n.segment].min(t);
                }
            }
        }
        for (i, s) in self.segments.iter().enumerate() {
            if let Some(f) = &s.busy {
                consider(f.end, 1, i, Due::End(i));
            } else if fast {
                if first[i] != u64::MAX {
                    consider(first[i].max(s.idle_at).max(self.now), 2, i, Due::Start(i));
                }
            } else if let Some(t) = self.start_time(i) {
                consider(t, 2, i, Due::Start(i));
            }
        }
        best.map(|(t, _, _, d)| (t, d))
    }

    fn run(&mut self, until: u64) {
        while let Some((t, due)) = self.next_due() {
            if t > until {
                break;
            }
            self.now = self.now.max(t);
            match due {
                Due::Recover(p) => self.recover(p, t),
                Due::Withdraw(i) => self.withdraw(i),
                Due::End(seg) => self.end(seg),
                Due::Start(seg) => self.start(seg, t),
            }
        }
        self.now = self.now.max(until);
    }

    fn recover(&mut self, port: usize, t: u64) {
        let n = &mut self.nodes[port];
        n.bus_off = None;
        n.tec = 0;
        n.rec = 0;
        self.log(t, port, EventKind::Recovered);
    }

    fn withdraw(&mut self, i: usize) {
        let w = self.withdrawals.remove(i);
        if !w.withdraw {
            return;
        }
        let n = &mut self.nodes[w.port];
        let frame = n.mailboxes[w.mailbox].filter(|m| m.seq == w.seq).map(|m| m.frame);
        if let Some(frame) = frame {
            n.finish(w.mailbox, w.seq, TxOutcome::LostArbitration, None);
            self.log(w.at, w.port, EventKind::LostArbitration { start_ns: w.start, frame });
        }
    }

    fn start(&mut self, seg: usize, t: u64) {
        // Bus-off nodes on this segment count the recessive run that this SOF ends.
        let run_bits = self.ns_bits(t - self.segments[seg].recessive_since);
        let runs = (run_bits / u64::from(RECOVERY_RUN_BITS)) as u32;
        for n in self.nodes.iter_mut().filter(|n| n.segment == seg && n.powered) {
            if let Some(c) = &mut n.bus_off {
                *c = c.saturating_add(runs);
            }
        }
        let candidates: Vec<_> = (0..self.nodes.len())
            .filter(|&p| self.nodes[p].segment == seg)
            .filter_map(|p| self.nodes[p].candidate(t).map(|c| (c, p)))
            .collect();
        let winner = candidates.iter().copied().min_by_key(|&((id, _, _, _), p)| (id, p));
        let Some(((raw_id, _, source, frame), sender)) = winner else {
            return;
        };
        // Losers send until the bit where they lose; one-shot ones are withdrawn then, the
        // others wait for the next idle.
        for &((id, _, src, _), p) in &candidates {
            if let (Source::Mailbox(mailbox, seq), true) = (src, p != sender) {
                let at = t + self.bits_ns(arbitration_loss_bits(raw_id, id).into());
                let withdraw = self.nodes[p].tx_mode == TxMode::OneShot;
                self.withdrawals.push(Withdrawal { at, port: p, mailbox, seq, start: t, withdraw });
            }
        }
        let ackers = self
            .nodes
            .iter()
            .enumerate()
            .any(|(p, n)| p != sender && n.segment == seg && n.active());
        let outcome = if !ackers {
            Outcome::Error(ErrorCause::NoAck)
        } else {
            match self.fault_for(raw_id, sender) {
                Some(FaultAction::Corrupt) => Outcome::Error(ErrorCause::Corrupted),
                Some(FaultAction::Drop(who)) => Outcome::Ok(Some(who)),
                None => Outcome::Ok(None),
            }
        };
        self.nodes[sender].sending = true;
        let bits = FrameBits::of(&frame);
        let (to_end, total) = match outcome {
            Outcome::Ok(_) => (bits.to_eof_end(), bits.total()),
            Outcome::Error(_) => (bits.to_error_end(), bits.error_total()),
        };
        self.segments[seg].busy = Some(InFlight {
            sender,
            epoch: self.nodes[sender].epoch,
            source,
            frame,
            start: t,
            end: t + self.bits_ns(to_end.into()),
            idle: t + self.bits_ns(total.into()),
            eof_bits: bits.to_eof_end(),
            outcome,
            aborted: false,
        });
    }

    fn fault_for(&mut self, raw_id: u32, sender: usize) -> Option<FaultAction> {
        let mut hit = None;
        for i in 0..self.faults.len() {
            let rule = self.faults[i];
            if rule.matches(raw_id, sender) && self.rng.chance(rule.probability_ppm) {
                hit = Some(i);
                break;
            }
        }
        let i = hit?;
        let action = self.faults[i].action;
        if let Some(r) = &mut self.faults[i].remaining {
            *r -= 1;
            if *r == 0 {
                self.faults.remove(i);
            }
        }
        Some(action)
    }

    fn end(&mut self, seg: usize) {
        let Some(f) = self.segments[seg].busy.take() else { return };
        self.nodes[f.sender].sending = false;
        let alive = self.nodes[f.sender].powered && self.nodes[f.sender].epoch == f.epoch;
        let outcome = if alive { f.outcome } else { Outcome::Error(ErrorCause::SenderLost) };
        let receivers: Vec<usize> = (0..self.nodes.len())
            .filter(|&p| p != f.sender && self.nodes[p].segment == seg && self.nodes[p].active())
            .collect();
        match outcome {
            Outcome::Ok(missed_by) => {
                let at = f.end / 1000;
                for &p in &receivers {
                    let missed = match missed_by {
                        Some(None) => true,
                        Some(Some(q)) => q == p,
                        None => false,
                    };
                    if missed {
                        continue;
                    }
                    let depth = self.config.rx_depth;
                    let n = &mut self.nodes[p];
                    n.rec = if n.rec > 127 { 119 } else { n.rec.saturating_sub(1) };
                    if n.filters.iter().any(|flt| flt.accepts(f.frame.id().to_raw())) {
                        if n.fifo.len() < depth {
                            n.fifo.push_back((Received { frame: f.frame, at }, f.eof_bits));
                            n.received += 1;
                        } else {
                            n.overflows += 1;
                        }
                    }
                }
                let n = &mut self.nodes[f.sender];
                n.tec = n.tec.saturating_sub(1);
                if let Source::Mailbox(i, seq) = f.source {
                    n.finish(i, seq, TxOutcome::Sent, Some(f.start));
                }
                self.log(
                    f.end,
                    f.sender,
                    EventKind::Sent { start_ns: f.start, frame: f.frame, missed_by },
                );
            }
            Outcome::Error(cause) => {
                for &p in &receivers {
                    let n = &mut self.nodes[p];
                    n.rec = (n.rec + 1).min(255);
                }
                if alive {
                    let n = &mut self.nodes[f.sender];
                    // ISO 11898-1 exception: an error-passive transmitter that sees no ACK
                    // and no dominant bit in its passive error flag keeps its TEC.
                    let passive = n.tec >= 128 || n.rec >= 128;
                    if !(cause == ErrorCause::NoAck && passive) {
                        n.tec += 8;
                    }
                    if f.aborted || n.tx_mode == TxMode::OneShot {
                        if let Source::Mailbox(i, seq) = f.source {
                            n.finish(i, seq, TxOutcome::Error, None);
                        }
                    }
                }
                self.log(
                    f.end,
                    f.sender,
                    EventKind::Error { start_ns: f.start, frame: f.frame, cause },
                );
                if alive && self.nodes[f.sender].tec > 255 {
                    self.nodes[f.sender].bus_off = Some(0);
                    self.log(f.end, f.sender, EventKind::BusOff);
                }
            }
        }
        let run = self.bits_ns(RECOVERY_RUN_BITS.into());
        let s = &mut self.segments[seg];
        s.idle_at = f.idle;
        s.recessive_since = f.idle - run;
    }
}

fn lock(inner: &Mutex<Inner>) -> MutexGuard<'_, Inner> {
    inner.lock().unwrap_or_else(|e| e.into_inner())
}

/// A virtual CAN 2.0B bus with a fixed number of ports. See the crate documentation.
#[derive(Clone)]
pub struct Bus {
    inner: Arc<Mutex<Inner>>,
}

impl Bus {
    /// A bus with `ports` ports, all powered and on one segment, at virtual time 0.
    pub fn new(ports: usize, config: Config) -> Self {
        assert!(ports > 0, "a bus needs a port");
        assert!(
            config.bit_rate > 0 && config.bit_rate <= rtcan::cycle::MAX_BIT_RATE,
            "bit rate out of range"
        );
        let inner = Inner {
            config,
            now: 0,
            seq: 0,
            nodes: (0..ports).map(|_| Node::new()).collect(),
            segments: vec![Segment::default(); ports],
            faults: Vec::new(),
            rng: SplitMix64::new(config.seed),
            trace: Vec::new(),
            withdrawals: Vec::new(),
        };
        Self { inner: Arc::new(Mutex::new(inner)) }
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        lock(&self.inner)
    }

    /// Number of ports.
    pub fn ports(&self) -> usize {
        self.lock().nodes.len()
    }

    /// The CAN controller of port `index` (panics if out of range).
    pub fn port(&self, index: usize) -> Port {
        assert!(index < self.ports(), "no port {index}");
        Port { inner: self.inner.clone(), index }
    }

    /// The bus configuration.
    pub fn config(&self) -> Config {
        self.lock().config
    }

    /// Current virtual time in ns.
    pub fn now(&self) -> u64 {
        self.lock().now
    }

    /// Duration in ns of `frame` on the wire, intermission included.
    pub fn frame_ns(&self, frame: &Frame) -> u64 {
        let g = self.lock();
        g.bits_ns(FrameBits::of(frame).total().into())
    }

    /// When the next bus event (a start of frame, an end of frame, a bus-off recovery) is due,
    /// given the requests pending now.
    pub fn next_event(&self) -> Option<u64> {
        self.lock().next_due().map(|(t, _)| t)
    }

    /// Runs every event due at or before `t_ns` and sets the time to `t_ns` (no effect if
    /// `t_ns` is in the past).
    pub fn advance_to(&self, t_ns: u64) {
        self.lock().run(t_ns);
    }

    /// [`Self::advance_to`] `now + dt_ns`.
    pub fn advance_by(&self, dt_ns: u64) {
        let mut g = self.lock();
        let t = g.now + dt_ns;
        g.run(t);
    }

    /// Advances to the next event and runs it (and any others due at the same time); returns
    /// its time, or `None` (time unchanged) if nothing is pending.
    pub fn step(&self) -> Option<u64> {
        let mut g = self.lock();
        let (t, _) = g.next_due()?;
        let t = t.max(g.now);
        g.run(t);
        Some(t)
    }

    /// Steps until nothing is pending or the time would pass `limit_ns`; returns the time.
    pub fn run_until_idle(&self, limit_ns: u64) -> u64 {
        while let Some(t) = self.next_event() {
            if t > limit_ns {
                break;
            }
            self.step();
        }
        self.now()
    }

    /// Powers port `port` on or off. Off: it neither sends, receives nor acknowledges, and a
    /// frame it is sending is cut short. Both transitions clear its mailboxes, receive FIFO,
    /// filters (back to accept-all) and error counters, like a controller reset.
    pub fn power(&self, port: usize, on: bool) {
        let mut g = self.lock();
        let now = g.now;
        let n = &mut g.nodes[port];
        if n.powered == on {
            return;
        }
        n.powered = on;
        n.reset();
        g.log(now, port, if on { EventKind::PowerOn } else { EventKind::PowerOff });
    }

    /// True if `port` is powered.
    pub fn is_powered(&self, port: usize) -> bool {
        self.lock().nodes[port].powered
    }

    /// Puts `port` on segment `segment` (0 ..ports); ports on different segments do not hear
    /// each other. A frame already on the wire finishes on its own segment.
    pub fn set_segment(&self, port: usize, segment: usize) {
        let mut g = self.lock();
        assert!(segment < g.segments.len(), "no segment {segment}");
        g.nodes[port].segment = segment;
    }

    /// Splits the bus: `ports` on segment 1, every other port on segment 0.
    pub fn partition(&self, ports: &[usize]) {
        let n = self.ports();
        for p in 0..n {
            self.set_segment(p, usize::from(ports.contains(&p)));
        }
    }

    /// Joins every port onto segment 0 again.
    pub fn heal(&self) {
        self.partition(&[]);
    }

    /// Makes `port` a babbling idiot sending `frame` back to back (besides its mailboxes), or
    /// stops it (`None`).
    pub fn babble(&self, port: usize, frame: Option<Frame>) {
        let mut g = self.lock();
        let now = g.now;
        g.nodes[port].babble = frame.map(|f| (f, now));
    }

    /// Adds a fault rule; rules are tried in the order added and the first that hits applies.
    pub fn inject(&self, rule: FaultRule) {
        self.lock().faults.push(rule);
    }

    /// Removes every fault rule.
    pub fn clear_faults(&self) {
        self.lock().faults.clear();
    }

    /// Fault rules still active.
    pub fn faults(&self) -> Vec<FaultRule> {
        self.lock().faults.clone()
    }

    /// Frames lost at `port` because its receive FIFO was full.
    pub fn overflows(&self, port: usize) -> u64 {
        self.lock().nodes[port].overflows
    }

    /// Frames `port` has put in its receive FIFO.
    pub fn received(&self, port: usize) -> u64 {
        self.lock().nodes[port].received
    }

    /// The event log so far, oldest first.
    pub fn trace(&self) -> Vec<Event> {
        self.lock().trace.clone()
    }

    /// The frames that went out (the sender's transmit confirmation), as (end of frame in ns,
    /// sender, frame), oldest first: what a candump of the bus would list.
    pub fn frames(&self) -> impl Iterator<Item = (u64, usize, Frame)> {
        self.trace().into_iter().filter_map(|e| match e.kind {
            EventKind::Sent { frame, .. } => Some((e.time_ns, e.port, frame)),
            _ => None,
        })
    }

    /// A hash of the event log (same seed and inputs → same hash).
    pub fn trace_hash(&self) -> u64 {
        let mut h = DefaultHasher::new();
        self.lock().trace.hash(&mut h);
        h.finish()
    }
}

/// One port's CAN controller on a [`Bus`]: three transmit mailboxes, a bounded receive FIFO,
/// acceptance filters and fault confinement. Timestamps are the end of EOF in µs.
#[derive(Clone)]
pub struct Port {
    inner: Arc<Mutex<Inner>>,
    index: usize,
}

impl Port {
    /// This port's index on its bus.
    pub fn index(&self) -> usize {
        self.index
    }

    /// Frames waiting in transmit mailboxes (including one on the wire).
    pub fn pending(&self) -> usize {
        lock(&self.inner).nodes[self.index].mailboxes.iter().flatten().count()
    }

    /// The outcomes of finished frames whose results the driver has not taken, oldest first:
    /// what bxCAN's `CAN_TSR` still shows (`RQCP` set, `TXOK`), one per mailbox. A mailbox
    /// with its result waiting is empty but loading it would clear that result.
    pub fn results_waiting(&self) -> Vec<TxOutcome> {
        lock(&self.inner).nodes[self.index].results.iter().map(|f| f.result.outcome).collect()
    }

    /// Per mailbox, what a bxCAN-like controller's status register shows: whether it holds a
    /// frame, and the outcome of the last frame that left it if its result was not taken
    /// (bxCAN's `TME`, and `RQCP` with `TXOK`/`ALST`/`TERR`).
    pub fn mailboxes(&self) -> [(bool, Option<TxOutcome>); MAILBOXES] {
        let g = lock(&self.inner);
        let n = &g.nodes[self.index];
        core::array::from_fn(|i| {
            let last = n.results.iter().rev().find(|f| f.mailbox == i);
            (n.mailboxes[i].is_some(), last.map(|f| f.result.outcome))
        })
    }

    /// The mailbox of the newest frame loaded whose result was not taken: the last of them to
    /// leave in load order (what a driver's bookkeeping knows).
    pub fn newest_held(&self) -> Option<usize> {
        let g = lock(&self.inner);
        let n = &g.nodes[self.index];
        let held = n.mailboxes.iter().enumerate().filter_map(|(i, m)| m.map(|m| (m.seq, i)));
        held.chain(n.results.iter().map(|f| (f.seq, f.mailbox))).max().map(|(_, i)| i)
    }

    /// Writes `frame` into mailbox `i`, requesting the bus `delay_ns` from now, as firmware
    /// writing the mailbox's registers does: nothing if the mailbox holds a frame (bxCAN
    /// write-protects a pending mailbox), and the result of the frame that last left it is
    /// gone (setting `TXRQ` clears `RQCP`, RM0008 §24.9.2). Returns whether it loaded.
    pub fn load_mailbox(&self, i: usize, frame: &Frame, delay_ns: u64) -> bool {
        let mut g = lock(&self.inner);
        let (now, seq) = (g.now, g.seq);
        let n = &mut g.nodes[self.index];
        if n.mailboxes[i].is_some() {
            return false;
        }
        n.results.retain(|f| f.mailbox != i);
        n.mailboxes[i] = Some(Mailbox { frame: *frame, loaded_at: now + delay_ns, seq });
        g.seq += 1;
        true
    }

    /// The bus's virtual time, ns (what this board's clock reads).
    pub fn now_ns(&self) -> u64 {
        lock(&self.inner).now
    }

    /// [`CanController::try_receive`] with the frame's bits from SOF to the end of EOF (what a
    /// controller that stamps the start of frame counts back from the end).
    pub fn try_receive_with_bits(&mut self) -> Option<(Received, u32)> {
        lock(&self.inner).nodes[self.index].fifo.pop_front()
    }

    /// Frames waiting in the receive FIFO.
    pub fn rx_len(&self) -> usize {
        lock(&self.inner).nodes[self.index].fifo.len()
    }

    /// [`CanController::try_transmit`] for a driver that takes `delay_ns` from the caller's
    /// clock read to the mailbox request: the frame competes for the bus from then on.
    pub fn transmit_after(&mut self, frame: &Frame, delay_ns: u64) -> Result<(), TxError> {
        let mut g = lock(&self.inner);
        let (now, seq) = (g.now, g.seq);
        let n = &mut g.nodes[self.index];
        if !n.active() {
            return Err(TxError::BusOff);
        }
        let slot = n.mailboxes.iter_mut().find(|m| m.is_none()).ok_or(TxError::MailboxesFull)?;
        *slot = Some(Mailbox { frame: *frame, loaded_at: now + delay_ns, seq });
        g.seq += 1;
        Ok(())
    }

    /// The oldest finished frame's result with, if it was sent, its start of frame on the bus
    /// (ns): what a controller that timestamps transmissions captures.
    pub fn take_tx_result_with_start(&mut self) -> Option<(TxResult, Option<u64>)> {
        lock(&self.inner).nodes[self.index].results.pop_front().map(|f| (f.result, f.sof_ns))
    }

    /// Sets the order in which the port's mailboxes go out (kept across power cycles, like
    /// the driver setting it at every start).
    pub fn set_tx_order(&mut self, order: TxOrder) {
        lock(&self.inner).nodes[self.index].tx_order = order;
    }
}

impl CanController for Port {
    /// Loads `frame` at the current virtual time. A powered-off port reports
    /// [`TxError::BusOff`]. Mailboxes take part in arbitration in the port's [`TxOrder`].
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        self.transmit_after(frame, 0)
    }

    /// One setting for the port's mailboxes, read when a frame loses arbitration or fails;
    /// back to [`TxMode::Retransmit`] at power-on.
    fn set_tx_mode(&mut self, mode: TxMode) {
        lock(&self.inner).nodes[self.index].tx_mode = mode;
    }

    /// A one-shot loser's result is there from the end of the bit where it lost; a sent frame's
    /// from its end of EOF; a failed one's from the end of its error delimiter.
    ///
    /// A plain port is a controller without transmit timestamps (`start_of_frame: None`);
    /// [`crate::BxCanPort`] adds bxCAN's.
    fn take_tx_result(&mut self) -> Option<TxResult> {
        self.take_tx_result_with_start().map(|(r, _)| r)
    }

    fn try_receive(&mut self) -> Option<Received> {
        lock(&self.inner).nodes[self.index].fifo.pop_front().map(|(r, _)| r)
    }

    /// An empty list accepts nothing; the default (and after power-on) accepts everything.
    fn set_filters(&mut self, filters: &[Filter]) {
        lock(&self.inner).nodes[self.index].filters = filters.to_vec();
    }

    /// Frees the mailboxes not on the wire (results [`TxOutcome::Aborted`], oldest first). A
    /// frame on the wire is left to finish and not counted; if it fails it is not retried (its
    /// result: [`TxOutcome::Error`]), as bxCAN's abort request behaves. So is a frame still in
    /// the arbitration it is losing: it is withdrawn at the bit where it loses
    /// ([`TxOutcome::LostArbitration`]).
    fn abort_pending(&mut self) -> usize {
        let mut g = lock(&self.inner);
        let me = self.index;
        let mut on_wire = Vec::new();
        for s in g.segments.iter_mut() {
            if let Some(f) = &mut s.busy {
                if let (true, Source::Mailbox(i, seq)) = (f.sender == me, f.source) {
                    f.aborted = true;
                    on_wire.push((i, seq));
                }
            }
        }
        for w in g.withdrawals.iter_mut().filter(|w| w.port == me) {
            w.withdraw = true;
            on_wire.push((w.mailbox, w.seq));
        }
        let n = &mut g.nodes[me];
        let mut waiting: Vec<(u64, usize)> = (0..MAILBOXES)
            .filter_map(|i| n.mailboxes[i].map(|m| (m.seq, i)))
            .filter(|&(seq, i)| !on_wire.contains(&(i, seq)))
            .collect();
        waiting.sort_unstable();
        for &(seq, i) in &waiting {
            n.finish(i, seq, TxOutcome::Aborted, None);
        }
        waiting.len()
    }

    /// [`BusState::BusOff`] while bus-off or powered off.
    fn bus_state(&self) -> BusState {
        lock(&self.inner).nodes[self.index].state()
    }

    /// Counters saturate at 255 (the TEC passes 255 only to go bus-off).
    fn error_counters(&self) -> ErrorCounters {
        let g = lock(&self.inner);
        let n = &g.nodes[self.index];
        ErrorCounters { tx: n.tec.min(255) as u8, rx: n.rec.min(255) as u8 }
    }
}
