//! The offered traffic of one load point: the streams and every message they release, drawn
//! from the seed once and offered unchanged to every protocol of the run.
//!
//! - **HRT**: periodic control streams of 4–8 bytes at 200 Hz or 100 Hz (1 or 2 cycles of
//!   5 ms), admitted and phased by RTCAN's [`Scheduler`]; a message is released at the start of
//!   its reserved slot (the control loop runs in phase with its slot).
//! - **SRT**: `srt_streams_per_node` streams per node, each with a relative deadline drawn from
//!   `srt_deadline_us`, messages of 1–24 bytes (1–3 frames); half periodic (random phase), half
//!   Poisson. Rates are drawn so that SRT gets its share of the load.
//! - **NRT**: one log stream per node, 8–64 bytes (1–8 frames), at uniformly random instants;
//!   messages are added until the offered bits reach the requested load (within one message).
//!
//! The offered load counts every frame's bits on the wire as the virtual bus computes them
//! ([`FrameBits::total`]: stuffing and intermission included) with the fixed-priority
//! baseline's identifiers; RTCAN's identifiers differ in the laxity field only, so its frames
//! differ by a few stuff bits.

use r2p_vbus::FrameBits;
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use rtcan::id::SYNC_MESSAGE_IDS;
use rtcan::layout::Layout;
use rtcan::schedule::{next_reserved, Period, Phase, Scheduler};
use rtcan::{fragments, Frame, FrameId, Laxity, MessageId};

use crate::setup::{Setup, SetupError};

/// Capacity of the master's calendar: more than `hrt_slots` × 2 streams of 2 cycles.
const MAX_HRT_STREAMS: usize = 64;
/// HRT payload length range, bytes.
const HRT_BYTES: (usize, usize) = (4, 8);
/// SRT payload length range, bytes.
const SRT_BYTES: (usize, usize) = (1, 24);
/// NRT payload length range, bytes.
const NRT_BYTES: (usize, usize) = (8, 64);

/// A stream's traffic class and timing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// Periodic, in a reserved slot.
    Hrt {
        /// Period in cycles.
        period: Period,
        /// The master's phase for it.
        phase: Phase,
        /// Its phase in the frame-sized calendar ([`Traffic::framed`]).
        framed: Phase,
    },
    /// Deadline-driven.
    Srt {
        /// Relative deadline, µs.
        deadline_us: u32,
        /// Periodic arrivals (else Poisson).
        periodic: bool,
    },
    /// Best effort.
    Nrt,
}

/// One topic from one publisher.
#[derive(Clone, Debug, PartialEq)]
pub struct Stream {
    /// The node that publishes it.
    pub node: usize,
    /// Class and timing.
    pub kind: Kind,
    /// Its RTCAN message ID.
    pub message: MessageId,
    /// Mean messages per second (what rate-monotonic priority ranks).
    pub rate_hz: f64,
    /// Static priority in the fixed-priority baseline, 0 highest: rate-monotonic over HRT and
    /// SRT streams, NRT streams after them all.
    pub rank: u8,
}

impl Stream {
    /// The identifier the fixed-priority baseline gives fragment `fragment`: the RTCAN layout
    /// with the laxity field holding the static rank, so frames stay comparable bit for bit.
    pub fn static_id(&self, fragment: u8) -> FrameId {
        FrameId { laxity: Laxity::from_code(self.rank), message: self.message, fragment }
    }

    /// Relative deadline, µs: SRT's own, HRT's period (the next occurrence replaces it), none
    /// for NRT.
    pub fn deadline_us(&self, cycle_us: u32) -> Option<u64> {
        match self.kind {
            Kind::Hrt { period, .. } => Some(u64::from(period.cycles() * cycle_us)),
            Kind::Srt { deadline_us, .. } => Some(u64::from(deadline_us)),
            Kind::Nrt => None,
        }
    }
}

/// One message released by a stream.
#[derive(Clone, Debug, PartialEq)]
pub struct Message {
    /// Index of its stream in [`Traffic::streams`].
    pub stream: u16,
    /// Release time, µs.
    pub release_us: u64,
    /// HRT: the cycle whose reserved slot carries it (0 otherwise).
    pub cycle: u32,
    /// Its payload (1–64 bytes).
    pub payload: Vec<u8>,
    /// Frames it takes.
    pub frames: u8,
    /// Its bits on the wire with the baseline's identifiers.
    pub bits: u32,
}

/// Every stream and message of one load point.
#[derive(Clone, Debug)]
pub struct Traffic {
    /// The streams; stream `i` has message ID `SYNC_MESSAGE_IDS + i`.
    pub streams: Vec<Stream>,
    /// The messages, by release time (ties by stream).
    pub messages: Vec<Message>,
    /// The master's calendar with every HRT stream admitted.
    pub scheduler: Scheduler<MAX_HRT_STREAMS>,
    /// HRT streams' payload length, bytes (streams `0..hrt_len.len()` are the HRT ones).
    pub hrt_len: Vec<usize>,
    /// The frame-sized what-if's calendar: the same streams admitted in the same order by
    /// [`Layout::admit`] (their cycle offsets may differ from [`Self::scheduler`]'s).
    pub framed: Scheduler<MAX_HRT_STREAMS>,
    /// Where the frame-sized calendar's slots lie in the cycle.
    pub layout: Layout,
    /// Bits offered in the window.
    pub offered_bits: u64,
}

/// An HRT payload of `len` bytes with no run of equal bits (`Setup::hrt_exact`).
fn hrt_payload(len: usize) -> Vec<u8> {
    vec![0x55; len]
}

/// Bits on the wire of `payload` sent as `stream`'s message with the baseline's identifiers.
fn wire_bits(stream: &Stream, payload: &[u8]) -> u32 {
    fragments(stream.static_id(0), payload)
        .map(|f| f.map(|fr: Frame| FrameBits::of(&fr).total()).sum())
        .unwrap_or(0)
}

/// The generator's state: the seeded numbers, the streams so far and their messages.
struct Builder<'s> {
    setup: &'s Setup,
    rng: Xoshiro256PlusPlus,
    streams: Vec<Stream>,
    scheduler: Scheduler<MAX_HRT_STREAMS>,
    messages: Vec<Message>,
    /// HRT streams' payload length (streams `0..hrt_len.len()` are the HRT ones).
    hrt_len: Vec<usize>,
    framed: Scheduler<MAX_HRT_STREAMS>,
    layout: Layout,
}

impl Builder<'_> {
    fn payload(&mut self, (lo, hi): (usize, usize)) -> Vec<u8> {
        let n = self.rng.random_range(lo..=hi);
        (0..n).map(|_| self.rng.random()).collect()
    }

    /// An exponentially distributed interval with mean `mean_us`.
    fn exponential(&mut self, mean_us: f64) -> f64 {
        let u: f64 = self.rng.random();
        -(1.0 - u).ln() * mean_us
    }

    fn window_s(&self) -> f64 {
        self.setup.duration_us as f64 / 1e6
    }

    fn add_stream(&mut self, node: usize, kind: Kind, rate_hz: f64) {
        let message = MessageId(SYNC_MESSAGE_IDS + self.streams.len() as u16);
        self.streams.push(Stream { node, kind, message, rate_hz, rank: 0 });
    }

    /// A stream not added yet, to measure frame lengths with.
    fn probe(&self) -> Stream {
        let message = MessageId(SYNC_MESSAGE_IDS + self.streams.len() as u16);
        Stream { node: 0, kind: Kind::Nrt, message, rate_hz: 0.0, rank: 0 }
    }

    /// HRT streams at 200 or 100 Hz, added while that brings their bits closer to `target`
    /// and the master admits them; returns the bits they will offer (estimated).
    fn add_hrt_streams(&mut self, target: f64) -> f64 {
        let cycle_us = f64::from(self.setup.cycle.cycle_us);
        let mut offered = 0.0;
        loop {
            let cycles = if self.rng.random_bool(0.5) { 1 } else { 2 };
            let len = self.rng.random_range(HRT_BYTES.0..=HRT_BYTES.1);
            let rate_hz = 1e6 / (f64::from(cycles) * cycle_us);
            let probe = self.probe();
            let bits = rate_hz * self.window_s() * f64::from(wire_bits(&probe, &hrt_payload(len)));
            if offered + bits / 2.0 > target {
                return offered;
            }
            let Ok(phase) = self.scheduler.register(probe.message, cycles) else {
                return offered;
            };
            let id = FrameId { laxity: Laxity::HRT, message: probe.message, fragment: 0 };
            let needs_us = if self.setup.hrt_exact {
                let exact = FrameBits::of(&Frame::new(id, &hrt_payload(len)).expect("≤ 8 bytes"));
                self.layout.reservation_us_of_bits(exact.total())
            } else {
                self.layout.reservation_us(id.to_raw(), len)
            };
            let framed = self.layout.admit(&mut self.framed, probe.message, cycles, 1, needs_us);
            let Ok(framed) = framed.map(|s| s.first()) else {
                self.scheduler.remove(probe.message);
                return offered;
            };
            let period = Period::from_cycles(cycles).expect("1 and 2 cycles are harmonic");
            let node = self.streams.len() % self.setup.nodes;
            self.add_stream(node, Kind::Hrt { period, phase, framed }, rate_hz);
            self.hrt_len.push(len);
            offered += bits;
        }
    }

    /// SRT streams, round robin over the nodes, sharing `target` bits with random weights.
    fn add_srt_streams(&mut self, target: f64) {
        let n = self.setup.nodes * self.setup.srt_streams_per_node;
        let weights: Vec<f64> = (0..n).map(|_| self.rng.random_range(0.25..1.0)).collect();
        let total: f64 = weights.iter().sum();
        for (k, w) in weights.iter().enumerate() {
            let (lo, hi) = self.setup.srt_deadline_us;
            let deadline_us = self.rng.random_range(lo..=hi);
            let periodic = self.rng.random_bool(0.5);
            let probe = self.probe();
            let samples = 16;
            let mean_bits = (0..samples)
                .map(|_| f64::from(wire_bits(&probe, &self.payload(SRT_BYTES))))
                .sum::<f64>()
                / f64::from(samples);
            let rate_hz = target * w / total / mean_bits / self.window_s();
            self.add_stream(k % self.setup.nodes, Kind::Srt { deadline_us, periodic }, rate_hz);
        }
    }

    /// The baseline's rate-monotonic ranks: HRT and SRT by falling rate, then NRT by node.
    fn rank(&mut self) {
        let mut order: Vec<usize> = (0..self.streams.len()).collect();
        let key = |s: &Stream| (matches!(s.kind, Kind::Nrt), -s.rate_hz);
        order.sort_by(|&a, &b| {
            let (ka, kb) = (key(&self.streams[a]), key(&self.streams[b]));
            ka.0.cmp(&kb.0).then(ka.1.total_cmp(&kb.1)).then(a.cmp(&b))
        });
        for (rank, &i) in order.iter().enumerate() {
            self.streams[i].rank = rank.min(usize::from(Laxity::NRT.code())) as u8;
        }
    }

    fn push(&mut self, stream: usize, release_us: u64, cycle: u32, payload: Vec<u8>) -> u32 {
        let bits = wire_bits(&self.streams[stream], &payload);
        let frames = rtcan::fragment::frame_count(payload.len()).unwrap_or(1) as u8;
        self.messages.push(Message {
            stream: stream as u16,
            release_us,
            cycle,
            payload,
            frames,
            bits,
        });
        bits
    }

    /// Every HRT occurrence in the window, released at its reserved slot's start.
    fn hrt_releases(&mut self) {
        let (start, end) = (self.setup.start_us(), self.setup.end_us());
        let cycle_us = u64::from(self.setup.cycle.cycle_us);
        for s in 0..self.hrt_len.len() {
            let Kind::Hrt { period, phase, .. } = self.streams[s].kind else { continue };
            let slot_us = u64::from(self.setup.cycle.slot_offset_us(phase.slot));
            let p = u64::from(period.cycles());
            let mut c = start.div_ceil(cycle_us);
            c += (u64::from(phase.offset) + p - c % p) % p;
            while c * cycle_us + slot_us < end {
                let random = (0..self.hrt_len[s]).map(|_| self.rng.random()).collect();
                // Drawn either way: the rest of the traffic stays the same.
                let data = if self.setup.hrt_exact { hrt_payload(self.hrt_len[s]) } else { random };
                self.push(s, c * cycle_us + slot_us, c as u32, data);
                c += p;
            }
        }
    }

    /// Every SRT release in the window: periodic streams from a random phase, the others
    /// Poisson.
    fn srt_releases(&mut self) {
        let end = self.setup.end_us() as f64;
        for s in 0..self.streams.len() {
            let Kind::Srt { periodic, .. } = self.streams[s].kind else { continue };
            let mean_us = 1e6 / self.streams[s].rate_hz;
            let gap = |b: &mut Self| if periodic { mean_us } else { b.exponential(mean_us) };
            let first = if periodic { self.rng.random_range(0.0..mean_us) } else { gap(self) };
            let mut t = self.setup.start_us() as f64 + first;
            while t.round() < end {
                let data = self.payload(SRT_BYTES);
                self.push(s, t.round() as u64, 0, data);
                t += gap(self);
            }
        }
    }

    /// NRT messages at uniformly random instants until the offered bits reach `target`
    /// (stopping where one more message would overshoot more than it helps); returns the
    /// offered bits.
    fn nrt_fill(&mut self, target: f64) -> u64 {
        let first_nrt = self.streams.len() - self.setup.nodes;
        let mut offered: u64 = self.messages.iter().map(|m| u64::from(m.bits)).sum();
        loop {
            let s = first_nrt + self.rng.random_range(0..self.setup.nodes);
            let data = self.payload(NRT_BYTES);
            let bits = u64::from(wire_bits(&self.streams[s], &data));
            if (offered + bits / 2) as f64 > target {
                break;
            }
            let t = self.rng.random_range(self.setup.start_us()..self.setup.end_us());
            self.push(s, t, 0, data);
            offered += bits;
        }
        for s in first_nrt..self.streams.len() {
            let n = self.messages.iter().filter(|m| usize::from(m.stream) == s).count();
            self.streams[s].rate_hz = n as f64 / self.window_s();
        }
        offered
    }
}

impl Traffic {
    /// Draws the traffic of `setup`.
    pub fn generate(setup: &Setup) -> Result<Self, SetupError> {
        setup.validate()?;
        // One independent sequence of numbers per (seed, load).
        let point = (setup.load * 1e6).round() as u64;
        let seed = setup.seed ^ point.wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let mut b = Builder {
            setup,
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            streams: Vec::new(),
            scheduler: Scheduler::new(setup.hrt_slots, setup.cycle.slots),
            messages: Vec::new(),
            hrt_len: Vec::new(),
            framed: Scheduler::new(setup.hrt_slots, setup.cycle.slots),
            layout: setup.layout()?,
        };
        let target = setup.load * setup.capacity_bits();
        let hrt = b.add_hrt_streams(setup.mix.hrt * target);
        let rest = (target - hrt).max(0.0);
        b.add_srt_streams(rest * setup.mix.srt / (1.0 - setup.mix.hrt).max(f64::EPSILON));
        for node in 0..setup.nodes {
            b.add_stream(node, Kind::Nrt, 0.0);
        }
        b.rank(); // NRT streams rank last whatever their rate turns out to be
        b.hrt_releases();
        b.srt_releases();
        let offered_bits = b.nrt_fill(target);
        let mut messages = b.messages;
        messages.sort_by_key(|m| (m.release_us, m.stream));
        Ok(Self {
            streams: b.streams,
            messages,
            scheduler: b.scheduler,
            hrt_len: b.hrt_len,
            framed: b.framed,
            layout: b.layout,
            offered_bits,
        })
    }

    /// The reservations the master announces for cycle `cycle` (sync slot included).
    pub fn mask(&self, cycle: u32) -> u64 {
        self.scheduler.mask(cycle)
    }

    /// The reservations the frame-sized calendar announces for cycle `cycle`.
    pub fn framed_mask(&self, cycle: u32) -> u64 {
        self.framed.mask(cycle)
    }

    /// The cycle whose frame-sized reservation carries HRT message `m`: its stream's first
    /// occurrence in the frame-sized calendar from the cycle of its release on.
    pub fn framed_cycle(&self, m: &Message) -> Option<u32> {
        match self.streams[usize::from(m.stream)].kind {
            Kind::Hrt { period, framed, .. } => Some(next_reserved(period, framed, m.cycle).0),
            _ => None,
        }
    }

    /// Offered load: offered bits over the window's bit times.
    pub fn offered_load(&self, setup: &Setup) -> f64 {
        self.offered_bits as f64 / setup.capacity_bits()
    }

    /// Offered bits of one class (`Kind` discriminant compared), for the report.
    pub fn offered_bits_of(&self, class: fn(&Kind) -> bool) -> u64 {
        self.messages
            .iter()
            .filter(|m| class(&self.streams[usize::from(m.stream)].kind))
            .map(|m| u64::from(m.bits))
            .sum()
    }

    /// The absolute deadline of message `m`, µs (none for NRT).
    pub fn deadline_us(&self, m: &Message, cycle_us: u32) -> Option<u64> {
        self.streams[usize::from(m.stream)].deadline_us(cycle_us).map(|d| m.release_us + d)
    }
}
