//! HRT scheduling: admission control, phase assignment and the master's reservation calendar.
//!
//! An HRT stream sends one message every `P` cycles. The master admits it, gives it a cycle
//! offset `o` (0 ≤ o < P) and one slot per frame of its message — a [`Phase`] (o, s) each — and
//! from then on reserves those slots in every cycle `c` with `c mod P = o`; the message's frames
//! go out first to last in its slots' cycle order ([`StreamSlots`]). Each node computes its own
//! occurrences from (period, phase) with [`next_reserved`]; only the master keeps the whole
//! calendar ([`Scheduler`]) to build each sync's reservation mask.
//!
//! # Admission rule
//! Periods are powers of two from 1 to [`MAX_PERIOD_CYCLES`] = 256 cycles. Any two such periods
//! divide each other (a harmonic set), so two streams in the same slot collide iff their offsets
//! agree modulo the smaller period; and 256 is the cycle counter's modulus, so every node can
//! compute every occurrence from the sync's 8-bit counter alone (a chain like 3, 6, 12 would be
//! harmonic too but would break at the counter's wrap). The paper's weaker rule ("not relatively
//! prime") is not enough: periods 4 and 6 share a factor, yet offsets 0 and 2 collide in cycle 12.
//!
//! Capacity: a stream of period P uses 256/P of a slot's 256-cycle hyperperiod. A stream is
//! admitted iff `Σ 256/Pᵢ + 256/P ≤ 256 · hrt_slots` (and the table has room), and a collision-free
//! phase exists. With registrations only (no removals) the placement below guarantees that a phase
//! exists whenever the capacity test passes, so admission is exactly the utilization test.
//!
//! A message of k frames (at most [`MAX_HRT_FRAMES`]) takes k reservations with one period
//! and one offset, in k slots: it uses k · 256/P, and is admitted iff that fits and k slots are
//! free at one offset. Best fit (below) gives the offset, then each frame the best-fit slot
//! left at that offset; if too few are free there, the first offset where enough are. Its frames share the message ID, so a
//! receiver reassembles them as any multi-frame message (docs/rtcan.md, "Fragmentation").
//!
//! # Placement (best-fit buddy)
//! Bit-reversing the 8-bit cycle number maps the occurrences of (P = 2^k, o) onto one aligned
//! block of 256/P consecutive positions, block number `rev_k(o)`; two streams collide iff their
//! blocks overlap. Each HRT slot is thus a buddy allocator over 256 positions. The scheduler
//! takes, over all slots, the free aligned block whose largest free enclosing aligned block is
//! smallest (best fit); ties go to the lower slot, then the lower block number. The phase is
//! `offset = rev_k(block)`, `slot = s`.
//!
//! # Where the HRT slots lie ([`hrt_slot`])
//! The scheduler's HRT slots 1…h are laid out in runs of at most `run` slots, each run followed
//! by one free slot (`run` ≥ 2, the shortest that fits the cycle; `run` ≥ h is one block
//! 1…h). The longest time in which no SRT or NRT frame can start is thus the sync slot and
//! `run` reserved slots (3 slots, 500 µs with the defaults) instead of every reservation of the
//! cycle in one block after the sync, which made short-deadline SRT messages released late in a
//! cycle miss (docs/rtcan.md, "Under load"); the cycle's free tail stays one long window in which
//! frames go back to back.
//!
//! # Which HRT slots open first ([`placement_slot`])
//! Placement prefers slots in this order (best fit ties go to the earlier one):
//! 1. the first slot of every run but the last two, in cycle order — a light calendar
//!    alternates one reserved slot with two free ones, so every free window carries two frames;
//! 2. the other slots of those runs, latest run first — runs of reservations form late in the
//!    cycle first and the slots right after the sync, where SRT messages released at the end
//!    of the previous cycle wait, stay spread longest;
//! 3. the last two runs, in cycle order — they border the cycle's free tail, so slots a full
//!    calendar leaves idle in some cycles lengthen that window instead of cutting new ones
//!    (each window ends with a guard: fewer windows carry more frames).
//!
//! Measured on the load benchmark (15 of 30 slots, seeds 1–16) against filling in cycle order:
//! SRT misses at 60–90 % load fell from 353 to 202 of 1.73 million messages; at 95 % they
//! stayed (3 871 and 3 926); spreading the second-to-last run too multiplied them by 2.4 at
//! 95 % (seeds 1–8; docs/rtcan.md, "Under load").

use crate::cycle::{EPOCH_BIT, MAX_SLOTS, SYNC_SLOT};
use crate::id::MessageId;

/// Longest period in cycles: the cycle counter's modulus and the calendar's hyperperiod.
pub const MAX_PERIOD_CYCLES: u32 = 256;
/// log₂ of [`MAX_PERIOD_CYCLES`].
pub const MAX_PERIOD_LOG2: u8 = 8;
/// Highest slot index the scheduler can reserve.
pub const MAX_HRT_SLOT: u8 = MAX_SLOTS - 1;
/// Most frames an HRT message may take, one slot each: 62 bytes with the transfer CRC, the
/// longest message a node's reassembly buffer holds by default.
pub const MAX_HRT_FRAMES: u8 = 8;

/// An admissible HRT period: 2^k cycles, 0 ≤ k ≤ 8.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Period(u8);

impl Period {
    /// The period of `cycles` cycles, if it is a power of two ≤ [`MAX_PERIOD_CYCLES`].
    pub const fn from_cycles(cycles: u32) -> Result<Self, Reject> {
        if cycles == 0 || !cycles.is_power_of_two() || cycles > MAX_PERIOD_CYCLES {
            return Err(Reject::NotHarmonic);
        }
        Ok(Period(cycles.trailing_zeros() as u8))
    }

    /// Length in cycles.
    pub const fn cycles(self) -> u32 {
        1 << self.0
    }

    /// log₂ of the length.
    pub const fn log2(self) -> u8 {
        self.0
    }
}

/// Where a stream's occurrences are: cycles `c` with `c mod period = offset`, in slot `slot`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Phase {
    /// Cycle offset, less than the period.
    pub offset: u8,
    /// Slot index, at least 1 (slot 0 is the sync slot).
    pub slot: u8,
}

/// Where a stream's message goes: in the cycles `c` with `c mod P = offset`, frame `j` (from 0)
/// in the `j`-th lowest slot of `slots` (bit `s` for slot `s`), so that frames go out in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StreamSlots {
    /// Cycle offset, less than the period.
    pub offset: u8,
    /// One bit per slot the stream holds; never bit 0 (the sync slot).
    pub slots: u64,
}

/// The slots whose bits `mask` sets, lowest first: a few steps for a few slots, not one per
/// slot of the cycle (the frame-sized slot path walks them).
pub const fn slots_in(mask: u64) -> SlotBits {
    SlotBits(mask)
}

/// The iterator [`slots_in`] returns.
#[derive(Clone, Copy, Debug)]
pub struct SlotBits(u64);

impl Iterator for SlotBits {
    type Item = u8;

    fn next(&mut self) -> Option<u8> {
        if self.0 == 0 {
            return None;
        }
        let slot = self.0.trailing_zeros() as u8;
        self.0 &= self.0 - 1;
        Some(slot)
    }
}

impl StreamSlots {
    /// The slots the stream holds, lowest first.
    pub const fn iter(self) -> SlotBits {
        slots_in(self.slots)
    }

    /// The first frame's phase (offset and lowest slot).
    pub const fn first(self) -> Phase {
        Phase { offset: self.offset, slot: self.slots.trailing_zeros() as u8 }
    }

    /// The number of frames (slots).
    pub const fn frames(self) -> u8 {
        self.slots.count_ones() as u8
    }

    /// Which frame (from 0) goes in `slot`, if the stream holds it.
    pub const fn frame_in(self, slot: u8) -> Option<u8> {
        if slot >= 64 || self.slots & 1 << slot == 0 {
            return None;
        }
        // The first frame without counting bits: the usual one-frame stream's slot path.
        let below = self.slots & ((1 << slot) - 1);
        Some(if below == 0 { 0 } else { below.count_ones() as u8 })
    }
}

/// An admitted stream's reservation of one slot (a k-frame stream has k of them, with one
/// period and one offset).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Reservation {
    /// The stream's message ID (its HRT frames carry it).
    pub stream: MessageId,
    /// Its period.
    pub period: Period,
    /// Its phase.
    pub phase: Phase,
}

/// Why a registration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reject {
    /// The period is not a power of two from 1 to [`MAX_PERIOD_CYCLES`] cycles.
    NotHarmonic,
    /// The capacity test passes, but every phase collides with an admitted stream (slots are
    /// fragmented by earlier removals).
    NoFreePhase,
    /// The HRT slots' capacity (or the scheduler's table) would be exceeded.
    Full,
    /// The message ID is reserved for sync frames.
    ReservedId,
    /// The stream is already admitted with another period or number of frames (remove it
    /// first).
    Conflict,
    /// No frames, or more than [`MAX_HRT_FRAMES`].
    TooManyFrames,
}

/// True if a stream with `period` and `phase` sends in cycle `cycle` (only `cycle mod 256`
/// matters, so the sync's 8-bit counter is enough).
pub const fn occurs(period: Period, phase: Phase, cycle: u32) -> bool {
    cycle & (period.cycles() - 1) == phase.offset as u32
}

/// The stream's first reserved (cycle, slot) at or after cycle `from`.
pub const fn next_reserved(period: Period, phase: Phase, from: u32) -> (u32, u8) {
    let p = period.cycles();
    let wait = (phase.offset as u32).wrapping_sub(from) & (p - 1);
    (from.wrapping_add(wait), phase.slot)
}

/// True if `a` and `b` reserve the same slot of some cycle: with power-of-two periods, when
/// their offsets agree modulo the shorter period.
fn collide(a: &Reservation, b: &Reservation) -> bool {
    let p = a.period.cycles().min(b.period.cycles());
    a.phase.slot == b.phase.slot
        && (u32::from(a.phase.offset) ^ u32::from(b.phase.offset)) & (p - 1) == 0
}

/// `k`-bit reversal of `j`.
const fn rev(j: u32, k: u8) -> u32 {
    if k == 0 {
        0
    } else {
        (j as u8).reverse_bits() as u32 >> (8 - k)
    }
}

/// 256 positions of one slot's hyperperiod, in bit-reversed cycle order.
#[derive(Clone, Copy)]
struct Occupancy([u64; 4]);

impl Occupancy {
    fn range_mask(word: usize, start: u32, len: u32) -> u64 {
        let lo = (word as u32) * 64;
        let s = start.max(lo);
        let e = (start + len).min(lo + 64);
        if s >= e {
            0
        } else if e - s == 64 {
            u64::MAX
        } else {
            ((1u64 << (e - s)) - 1) << (s - lo)
        }
    }

    fn is_free(&self, start: u32, len: u32) -> bool {
        (0..4).all(|w| self.0[w] & Self::range_mask(w, start, len) == 0)
    }

    fn fill(&mut self, start: u32, len: u32) {
        for w in 0..4 {
            self.0[w] |= Self::range_mask(w, start, len);
        }
    }
}

/// The cycle slot of the scheduler's HRT slot `k` (1…) when HRT slots come in runs of `run`,
/// each run followed by one free slot.
pub const fn hrt_slot(k: u8, run: u8) -> u8 {
    1 + (run + 1) * ((k - 1) / run) + (k - 1) % run
}

/// The cycle slot placement tries `i`-th (0…h−1) of `h` HRT slots laid out in runs of `run`
/// (module documentation, "Which HRT slots open first").
pub const fn placement_slot(i: u8, h: u8, run: u8) -> u8 {
    let runs = h.div_ceil(run);
    // Runs whose slots are spread (all full: only the last run can be short).
    let spread = runs.saturating_sub(2);
    let k = if i < spread {
        i * run + 1
    } else if i < spread * run {
        let j = i - spread;
        let (position, from_last) = (1 + j / spread, j % spread);
        (spread - 1 - from_last) * run + position + 1
    } else {
        i + 1
    };
    hrt_slot(k, run)
}

/// The shortest run (≥ 2) that places `hrt_slots` HRT slots in a cycle of `cycle_slots`.
const fn run_for(hrt_slots: u8, cycle_slots: u8) -> u8 {
    let mut run = 2;
    while run < hrt_slots && hrt_slot(hrt_slots, run) >= cycle_slots {
        run += 1;
    }
    run
}

/// The master's calendar: up to `N` admitted streams in `hrt_slots` slots of the cycle.
#[derive(Clone, Debug)]
pub struct Scheduler<const N: usize> {
    table: [Option<Reservation>; N],
    hrt_slots: u8,
    run: u8,
}

impl<const N: usize> Scheduler<N> {
    /// An empty calendar with `hrt_slots` HRT slots in a cycle of `cycle_slots` slots, laid out
    /// as the module documentation says. `hrt_slots` is capped at `cycle_slots − 1` (the sync
    /// slot) and [`MAX_HRT_SLOT`]; keep it well below so that SRT and NRT traffic — including the
    /// registrations themselves — has room.
    pub const fn new(hrt_slots: u8, cycle_slots: u8) -> Self {
        let cap =
            if cycle_slots > MAX_SLOTS { MAX_HRT_SLOT } else { cycle_slots.saturating_sub(1) };
        let hrt_slots = if hrt_slots > cap { cap } else { hrt_slots };
        Self { table: [None; N], hrt_slots, run: run_for(hrt_slots, cycle_slots) }
    }

    /// Number of slots the scheduler may reserve.
    pub const fn hrt_slots(&self) -> u8 {
        self.hrt_slots
    }

    /// The cycle slots the scheduler may reserve, in cycle order.
    pub fn layout(&self) -> impl Iterator<Item = u8> + '_ {
        (1..=self.hrt_slots).map(|k| hrt_slot(k, self.run))
    }

    /// The cycle slots the scheduler may reserve, in the order placement tries them.
    pub fn slots(&self) -> impl Iterator<Item = u8> + '_ {
        (0..self.hrt_slots).map(|i| placement_slot(i, self.hrt_slots, self.run))
    }

    /// Admitted streams.
    pub fn iter(&self) -> impl Iterator<Item = &Reservation> {
        self.table.iter().flatten()
    }

    /// The reservation in the table's entry `k` (modulo its size), if any: for walking the
    /// calendar one entry at a time.
    pub fn entry(&self, k: usize) -> Option<Reservation> {
        self.table.get(k % N).copied().flatten()
    }

    /// Number of admitted streams.
    pub fn len(&self) -> usize {
        self.iter().count()
    }

    /// True if no stream is admitted.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The (first) reservation of `stream`, if admitted.
    pub fn get(&self, stream: MessageId) -> Option<&Reservation> {
        self.iter().find(|r| r.stream == stream)
    }

    /// The period and slots of `stream`, if admitted.
    pub fn slots_of(&self, stream: MessageId) -> Option<(Period, StreamSlots)> {
        let first = self.get(stream)?;
        let slots =
            self.iter().filter(|r| r.stream == stream).fold(0, |m, r| m | 1 << r.phase.slot);
        Some((first.period, StreamSlots { offset: first.phase.offset, slots }))
    }

    /// Used capacity in 1/256 of a slot: Σ 256 / Pᵢ.
    pub fn utilization(&self) -> u32 {
        self.iter().map(|r| MAX_PERIOD_CYCLES >> r.period.log2()).sum()
    }

    /// Admits one-frame `stream` with a period of `period_cycles` cycles and returns its phase.
    /// Registering an admitted stream again with the same period returns its phase unchanged.
    pub fn register(&mut self, stream: MessageId, period_cycles: u32) -> Result<Phase, Reject> {
        self.register_frames(stream, period_cycles, 1).map(StreamSlots::first)
    }

    /// Admits `stream`, whose messages take `frames` frames, with a period of `period_cycles`
    /// cycles: one offset and `frames` slots. Registering it again with the same period and
    /// frames returns its slots unchanged.
    pub fn register_frames(
        &mut self,
        stream: MessageId,
        period_cycles: u32,
        frames: u8,
    ) -> Result<StreamSlots, Reject> {
        self.register_in(stream, period_cycles, frames, |_| true)
    }

    /// [`Self::register_frames`] in the slots for which `usable` is true only (frame-sized
    /// reservations: a slot placed already and too short for the stream's frames,
    /// [`crate::layout::Layout::admit`]).
    pub fn register_in(
        &mut self,
        stream: MessageId,
        period_cycles: u32,
        frames: u8,
        usable: impl Fn(u8) -> bool,
    ) -> Result<StreamSlots, Reject> {
        if stream.is_reserved_for_sync() {
            return Err(Reject::ReservedId);
        }
        let period = Period::from_cycles(period_cycles)?;
        if frames == 0 || frames > MAX_HRT_FRAMES {
            return Err(Reject::TooManyFrames);
        }
        if let Some((held, slots)) = self.slots_of(stream) {
            let same = held == period && slots.frames() == frames;
            return if same { Ok(slots) } else { Err(Reject::Conflict) };
        }
        let need = u32::from(frames) * (MAX_PERIOD_CYCLES >> period.log2());
        let room = self.table.iter().filter(|e| e.is_none()).count();
        if room < usize::from(frames)
            || self.utilization() + need > MAX_PERIOD_CYCLES * self.hrt_slots as u32
        {
            return Err(Reject::Full);
        }
        let got = self.place(period, frames, &usable).ok_or(Reject::NoFreePhase)?;
        let mut slots = got.slots;
        for e in self.table.iter_mut().filter(|e| e.is_none()) {
            if slots == 0 {
                break;
            }
            let phase = Phase { offset: got.offset, slot: slots.trailing_zeros() as u8 };
            *e = Some(Reservation { stream, period, phase });
            slots &= slots - 1;
        }
        Ok(got)
    }

    /// Placement (module documentation): the offset best fit gives the first frame, each frame
    /// in the best-fit slot left at that offset; if too few are free there, the first offset at
    /// which enough are. One frame: best fit itself.
    fn place(
        &self,
        period: Period,
        frames: u8,
        usable: &impl Fn(u8) -> bool,
    ) -> Option<StreamSlots> {
        let (first, _) = self.best_fit(period, None, 0, usable)?;
        core::iter::once(first).chain(0..1u32 << period.log2()).find_map(|block| {
            let mut slots = 0u64;
            for _ in 0..frames {
                slots |= 1 << self.best_fit(period, Some(block), slots, usable)?.1;
            }
            Some(StreamSlots { offset: rev(block, period.log2()) as u8, slots })
        })
    }

    /// Best fit (module documentation): over the slots not in `taken`, the aligned block of
    /// 256/P positions (block `only`, if given) whose largest free enclosing aligned block is
    /// smallest; ties: the slot placement tries first, then the lower block. (block, slot).
    fn best_fit(
        &self,
        period: Period,
        only: Option<u32>,
        taken: u64,
        usable: &impl Fn(u8) -> bool,
    ) -> Option<(u32, u8)> {
        let k = period.log2();
        let size = MAX_PERIOD_CYCLES >> k;
        let mut best: Option<(u32, u32, u8)> = None;
        for slot in self.slots().filter(|&s| taken & 1 << s == 0 && usable(s)) {
            let occ = self.occupancy(slot);
            for block in 0..(1u32 << k) {
                if only.is_some_and(|b| b != block) || !occ.is_free(block * size, size) {
                    continue;
                }
                // Largest free aligned block containing this one.
                let (mut idx, mut len) = (block, size);
                while len < MAX_PERIOD_CYCLES && occ.is_free((idx >> 1) * len * 2, len * 2) {
                    idx >>= 1;
                    len *= 2;
                }
                if best.is_none_or(|(b, ..)| len < b) {
                    best = Some((len, block, slot));
                    if len == size {
                        break;
                    }
                }
            }
            if best.is_some_and(|(len, ..)| len == size) {
                break;
            }
        }
        best.map(|(_, block, slot)| (block, slot))
    }

    fn occupancy(&self, slot: u8) -> Occupancy {
        let mut occ = Occupancy([0; 4]);
        for r in self.iter().filter(|r| r.phase.slot == slot) {
            let k = r.period.log2();
            let size = MAX_PERIOD_CYCLES >> k;
            occ.fill(rev(r.phase.offset as u32, k) * size, size);
        }
        occ
    }

    /// Takes in a reservation the master's calendar made (a standby following the grants it
    /// hears, docs/rtcan.md "Master failover"): it replaces the stream's entries of another
    /// period or offset (an older grant; its other frames stay) and every entry it shares a
    /// (cycle, slot) with, which the master's calendar can no longer hold.
    /// `Err(Full)` if the table has no room, `Err(ReservedId)` for a sync ID, `Err(Conflict)`
    /// for a phase the calendar could not have made (offset beyond the period, the sync slot).
    pub fn admit(&mut self, r: Reservation) -> Result<(), Reject> {
        if r.stream.is_reserved_for_sync() {
            return Err(Reject::ReservedId);
        }
        if u32::from(r.phase.offset) >= r.period.cycles() || r.phase.slot == SYNC_SLOT {
            return Err(Reject::Conflict);
        }
        // The stream's other frames stay (same period and offset); an older grant of it goes.
        let older = |x: &Reservation| {
            x.stream == r.stream && (x.period != r.period || x.phase.offset != r.phase.offset)
        };
        self.retain(|x| !older(x) && !collide(x, &r));
        let free = self.table.iter_mut().find(|e| e.is_none()).ok_or(Reject::Full)?;
        *free = Some(r);
        Ok(())
    }

    /// Keeps only the reservations for which `keep` is true.
    pub fn retain(&mut self, mut keep: impl FnMut(&Reservation) -> bool) {
        for e in self.table.iter_mut() {
            if e.is_some_and(|r| !keep(&r)) {
                *e = None;
            }
        }
    }

    /// Removes `stream` (every frame's slot); returns its first reservation if it was admitted.
    pub fn remove(&mut self, stream: MessageId) -> Option<Reservation> {
        let first = self.get(stream).copied();
        self.retain(|r| r.stream != stream);
        first
    }

    /// Removes every stream (a new master starts with an empty calendar).
    pub fn clear(&mut self) {
        self.table = [None; N];
    }

    /// The reservation mask of cycle `cycle`: bit 0 (the sync slot) and the slot of every
    /// stream occurring in it. The sync of cycle c carries `mask(c + 1)`.
    pub fn mask(&self, cycle: u32) -> u64 {
        self.iter()
            .filter(|r| occurs(r.period, r.phase, cycle))
            .fold(EPOCH_BIT, |m, r| m | 1 << r.phase.slot)
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    fn p(cycles: u32) -> Period {
        Period::from_cycles(cycles).unwrap()
    }

    fn check_no_collision<const N: usize>(s: &Scheduler<N>) {
        for c in 0..MAX_PERIOD_CYCLES {
            let mut m = 1u64;
            for r in s.iter() {
                if occurs(r.period, r.phase, c) {
                    assert_eq!(m & (1 << r.phase.slot), 0, "collision in cycle {}", c);
                    m |= 1 << r.phase.slot;
                }
            }
            assert_eq!(s.mask(c), m);
        }
    }

    r2p_testkit::suite! {
        fn a_standby_admitting_the_grants_holds_the_masters_calendar() {
            let mut master: Scheduler<16> = Scheduler::new(8, 60);
            let mut standby: Scheduler<16> = Scheduler::new(8, 60);
            for (k, period) in [1u32, 2, 4, 2, 8, 1, 16, 4].into_iter().enumerate() {
                let stream = MessageId(0x4201 + k as u16);
                let phase = master.register(stream, period).unwrap();
                standby.admit(Reservation { stream, period: p(period), phase }).unwrap();
            }
            // A 3-frame stream: one grant per frame, the same offset.
            let three = master.register_frames(MessageId(0x4209), 4, 3).unwrap();
            for slot in (1..64).filter(|&x| three.slots & 1 << x != 0) {
                let phase = Phase { offset: three.offset, slot };
                standby.admit(Reservation { stream: MessageId(0x4209), period: p(4), phase }).unwrap();
            }
            assert_eq!(standby.slots_of(MessageId(0x4209)), Some((p(4), three)));
            master.remove(MessageId(0x4202));
            standby.remove(MessageId(0x4202));
            for c in 0..MAX_PERIOD_CYCLES {
                assert_eq!(standby.mask(c), master.mask(c), "cycle {c}");
            }
            // Placement continues from the same table: the next grant is the same on both.
            let next = master.register(MessageId(0x4301), 2).unwrap();
            assert_eq!(standby.register(MessageId(0x4301), 2), Ok(next));
        }

        fn admitting_evicts_what_the_master_can_no_longer_hold() {
            let mut s: Scheduler<4> = Scheduler::new(8, 60);
            let a = Reservation { stream: MessageId(0x4201), period: p(2), phase: Phase { offset: 1, slot: 3 } };
            s.admit(a).unwrap();
            // Period 4 at offset 3 meets period 2 at offset 1 (cycle 3): the old one goes.
            let b = Reservation { stream: MessageId(0x4301), period: p(4), phase: Phase { offset: 3, slot: 3 } };
            s.admit(b).unwrap();
            assert_eq!((s.get(a.stream), s.get(b.stream)), (None, Some(&b)));
            // Offset 1 of period 4 does not meet offset 3: both stay. The same stream moves to
            // another offset (a new grant): its old slot goes.
            let c = Reservation { stream: MessageId(0x4401), period: p(4), phase: Phase { offset: 1, slot: 3 } };
            s.admit(c).unwrap();
            assert_eq!(s.len(), 2);
            let c2 = Reservation { phase: Phase { offset: 2, slot: 4 }, ..c };
            s.admit(c2).unwrap();
            assert_eq!((s.len(), s.get(c.stream)), (2, Some(&c2)));
            // At the same offset in another slot: the stream's next frame, kept beside it.
            let c3 = Reservation { phase: Phase { offset: 2, slot: 5 }, ..c };
            s.admit(c3).unwrap();
            assert_eq!(s.slots_of(c.stream), Some((p(4), StreamSlots { offset: 2, slots: 0b11_0000 })));
            s.remove(c.stream);
            assert_eq!(s.len(), 1);
            // A phase the calendar cannot make, a sync ID, a full table.
            let bad = Reservation { phase: Phase { offset: 4, slot: 3 }, ..c };
            assert_eq!(s.admit(bad), Err(Reject::Conflict));
            assert_eq!(s.admit(Reservation { phase: Phase { offset: 0, slot: 0 }, ..c }), Err(Reject::Conflict));
            assert_eq!(s.admit(Reservation { stream: MessageId(0x45), ..c }), Err(Reject::ReservedId));
            for k in 0..3u16 {
                let r = Reservation { stream: MessageId(0x4501 + k), period: p(1), phase: Phase { offset: 0, slot: 10 + k as u8 } };
                s.admit(r).unwrap();
            }
            let r = Reservation { stream: MessageId(0x4601), period: p(1), phase: Phase { offset: 0, slot: 20 } };
            assert_eq!(s.admit(r), Err(Reject::Full));
        }

        fn a_multi_frame_stream_takes_one_offset_and_a_slot_per_frame() {
            let mut s: Scheduler<8> = Scheduler::new(15, 30);
            let a = s.register_frames(MessageId(0x4201), 4, 3).unwrap();
            // The first three slots placement opens, in one offset; frames in cycle order.
            assert_eq!(a, StreamSlots { offset: 0, slots: 1 << 1 | 1 << 4 | 1 << 7 });
            assert_eq!((a.frames(), a.first(), a.frame_in(4), a.frame_in(7)), (3, Phase { offset: 0, slot: 1 }, Some(1), Some(2)));
            assert_eq!((a.frame_in(2), a.frame_in(64)), (None, None));
            assert_eq!((s.len(), s.utilization()), (3, 3 * 64));
            assert_eq!(s.mask(4), 1 | 1 << 1 | 1 << 4 | 1 << 7);
            assert_eq!(s.mask(5), 1);
            // Again with the same period and frames: the same slots; otherwise a conflict.
            assert_eq!(s.register_frames(MessageId(0x4201), 4, 3), Ok(a));
            assert_eq!(s.register_frames(MessageId(0x4201), 4, 2), Err(Reject::Conflict));
            assert_eq!(s.register(MessageId(0x4201), 4), Err(Reject::Conflict));
            assert_eq!(s.slots_of(MessageId(0x4201)), Some((p(4), a)));
            for bad in [0, MAX_HRT_FRAMES + 1] {
                assert_eq!(s.register_frames(MessageId(0x4301), 4, bad), Err(Reject::TooManyFrames));
            }
            // The longest message: eight frames, eight slots.
            let mut eight: Scheduler<8> = Scheduler::new(15, 30);
            let got = eight.register_frames(MessageId(0x4501), 1, MAX_HRT_FRAMES).unwrap();
            assert_eq!((got.frames(), eight.len()), (MAX_HRT_FRAMES, 8));
            // A one-frame stream of the same period takes the best fit beside it.
            assert_eq!(s.register(MessageId(0x4301), 4), Ok(Phase { offset: 2, slot: 1 }));
            check_no_collision(&s);
            // The table holds 8 reservations: four left, so a 5-frame stream is refused.
            assert_eq!(s.register_frames(MessageId(0x4401), 4, 5), Err(Reject::Full));
            assert_eq!(s.register_frames(MessageId(0x4401), 4, 4).map(|x| x.frames()), Ok(4));
            assert!(s.remove(MessageId(0x4201)).is_some());
            assert_eq!((s.len(), s.slots_of(MessageId(0x4201))), (5, None));
        }

        fn a_multi_frame_stream_needs_every_frame_at_one_offset() {
            let r = |stream, period, offset, slot| Reservation { stream: MessageId(stream), period: p(period), phase: Phase { offset, slot } };
            // Slot 1 is free at offset 1 only, slot 2 at offset 0 only (period 2): room for two
            // frames, but not at one offset.
            let mut s: Scheduler<8> = Scheduler::new(2, 4);
            s.admit(r(0x4201, 2, 0, 1)).unwrap();
            s.admit(r(0x4202, 2, 1, 2)).unwrap();
            assert_eq!(s.register_frames(MessageId(0x4301), 2, 2), Err(Reject::NoFreePhase));
            assert_eq!(s.register(MessageId(0x4301), 2), Ok(Phase { offset: 1, slot: 1 }));
            // Slots 1, 2, 4 (period 4): slot 1 is free at offset 3 only, the best fit of a first
            // frame, but slots 2 and 4 are taken there; offset 0 has both.
            let mut s: Scheduler<8> = Scheduler::new(3, 5);
            for (stream, offset, slot) in [(0x4201, 0, 1), (0x4202, 1, 1), (0x4203, 2, 1), (0x4204, 3, 2), (0x4205, 3, 4)] {
                s.admit(r(stream, 4, offset, slot)).unwrap();
            }
            assert_eq!(s.register(MessageId(0x4301), 4), Ok(Phase { offset: 3, slot: 1 }));
            s.remove(MessageId(0x4301));
            let got = s.register_frames(MessageId(0x4301), 4, 2).unwrap();
            assert_eq!(got, StreamSlots { offset: 0, slots: 1 << 2 | 1 << 4 });
            check_no_collision(&s);
        }

        fn periods_are_powers_of_two_up_to_256() {
            for k in 0..=8 {
                assert_eq!(p(1 << k).cycles(), 1 << k);
            }
            for bad in [0, 3, 5, 6, 12, 100, 512, 1024] {
                assert_eq!(Period::from_cycles(bad), Err(Reject::NotHarmonic));
            }
        }

        fn next_reserved_adds_the_period() {
            let ph = Phase { offset: 3, slot: 7 };
            assert_eq!(next_reserved(p(4), ph, 0), (3, 7));
            assert_eq!(next_reserved(p(4), ph, 3), (3, 7));
            assert_eq!(next_reserved(p(4), ph, 4), (7, 7));
            assert_eq!(next_reserved(p(8), Phase { offset: 0, slot: 1 }, 255), (256, 1));
            // Extended counters that differ above the low byte agree on the slot.
            assert!(occurs(p(16), Phase { offset: 5, slot: 1 }, 0x1_0015));
            assert!(!occurs(p(16), Phase { offset: 5, slot: 1 }, 0x1_0016));
            assert_eq!(next_reserved(p(1), Phase { offset: 0, slot: 2 }, 41), (41, 2));
        }

        fn phases_spread_like_a_buddy_allocator() {
            let mut s = Scheduler::<8>::new(1, 2);
            assert_eq!(s.register(MessageId(0x100), 4), Ok(Phase { offset: 0, slot: 1 }));
            assert_eq!(s.register(MessageId(0x101), 4), Ok(Phase { offset: 2, slot: 1 }));
            // Period 2 still fits: offsets 1 and 3 are both free.
            assert_eq!(s.register(MessageId(0x102), 2), Ok(Phase { offset: 1, slot: 1 }));
            assert_eq!(s.register(MessageId(0x103), 2), Err(Reject::Full));
            assert_eq!(s.utilization(), 256);
            assert_eq!(s.mask(0), 0b11);
            assert_eq!(s.mask(1), 0b11);
            assert_eq!(s.mask(2), 0b11);
        }

        fn best_fit_fills_holes_first() {
            let mut s = Scheduler::<8>::new(2, 3);
            assert_eq!(s.register(MessageId(0x100), 2), Ok(Phase { offset: 0, slot: 1 }));
            assert_eq!(s.register(MessageId(0x101), 1), Ok(Phase { offset: 0, slot: 2 }));
            // The half-slot hole in slot 1 is the best fit for period 4.
            assert_eq!(s.register(MessageId(0x102), 4), Ok(Phase { offset: 1, slot: 1 }));
            assert_eq!(s.register(MessageId(0x103), 4), Ok(Phase { offset: 3, slot: 1 }));
            assert_eq!(s.register(MessageId(0x104), 256), Err(Reject::Full));
        }

        fn removal_frees_and_fragmentation_is_reported() {
            let mut s = Scheduler::<8>::new(1, 2);
            for (id, o) in [(0x100, 0), (0x101, 2), (0x102, 1), (0x103, 3)] {
                assert_eq!(s.register(MessageId(id), 4), Ok(Phase { offset: o, slot: 1 }));
            }
            assert!(s.remove(MessageId(0x100)).is_some());
            assert!(s.remove(MessageId(0x103)).is_some());
            assert_eq!(s.remove(MessageId(0x103)), None);
            // Half the slot is free, but offsets 0 and 3 are not congruent mod 2.
            assert_eq!(s.register(MessageId(0x104), 2), Err(Reject::NoFreePhase));
            assert_eq!(s.register(MessageId(0x104), 4), Ok(Phase { offset: 0, slot: 1 }));
            assert_eq!(s.mask(3), 0b1);
            assert_eq!(s.mask(2), 0b11);
        }

        fn best_fit_keeps_large_holes_after_removals() {
            let mut s = Scheduler::<8>::new(1, 2);
            for id in 0x100..0x104 {
                s.register(MessageId(id), 4).unwrap();
            }
            // Free offsets 0 and 2 (one 128-block) and offset 3 (a 64-block).
            for id in [0x100, 0x101, 0x103] {
                s.remove(MessageId(id)).unwrap();
            }
            // Period 4 goes to the small hole (first fit would split the large one) ...
            assert_eq!(s.register(MessageId(0x104), 4), Ok(Phase { offset: 3, slot: 1 }));
            // ... so period 2 still fits.
            assert_eq!(s.register(MessageId(0x105), 2), Ok(Phase { offset: 0, slot: 1 }));
            check_no_collision(&s);
        }

        fn reregistration_is_idempotent() {
            let mut s = Scheduler::<2>::new(4, 5);
            let ph = s.register(MessageId(0x200), 8).unwrap();
            assert_eq!(s.register(MessageId(0x200), 8), Ok(ph));
            assert_eq!(s.register(MessageId(0x200), 16), Err(Reject::Conflict));
            assert_eq!(s.register(MessageId(0x0FF), 8), Err(Reject::ReservedId));
            assert_eq!(s.register(MessageId(0x201), 6), Err(Reject::NotHarmonic));
            s.register(MessageId(0x201), 8).unwrap();
            assert_eq!(s.register(MessageId(0x202), 8), Err(Reject::Full));
            assert_eq!(s.len(), 2);
            s.clear();
            assert!(s.is_empty());
            assert_eq!(s.mask(0), 1);
        }

        fn hrt_slots_come_in_short_runs() {
            let slots = |h, c| {
                let s = Scheduler::<1>::new(h, c);
                let mut out = [0u8; 64];
                let mut n = 0;
                for x in s.layout() {
                    out[n] = x;
                    n += 1;
                }
                (out, n)
            };
            // The load benchmark's cycle: 15 of 30 slots, runs of two, a free tail of 7 slots.
            let (s15, n) = slots(15, 30);
            assert_eq!(&s15[..n], &[1, 2, 4, 5, 7, 8, 10, 11, 13, 14, 16, 17, 19, 20, 22]);
            // Longer runs where the cycle is short; one block where it must be.
            let (s20, n) = slots(20, 25);
            assert_eq!(&s20[..n], &[1, 2, 3, 4, 6, 7, 8, 9, 11, 12, 13, 14, 16, 17, 18, 19, 21, 22, 23, 24]);
            let (s3, n) = slots(3, 4);
            assert_eq!(&s3[..n], &[1, 2, 3]);
            // Capped: the sync slot and the sync payload's 64 bits.
            assert_eq!(Scheduler::<1>::new(9, 5).hrt_slots(), 4);
            assert_eq!(Scheduler::<1>::new(70, 64).hrt_slots(), MAX_HRT_SLOT);
            for c in 2..=MAX_SLOTS {
                for h in 1..c {
                    let s = Scheduler::<1>::new(h, c);
                    let (v, n) = slots(h, c);
                    assert_eq!(n, h as usize);
                    // Distinct, increasing, inside the cycle, never more than the run in a row.
                    assert!(v[..n].windows(2).all(|w| w[0] < w[1]) && v[n - 1] < c);
                    let mut longest = 0;
                    let mut run = 0;
                    for x in 1..c {
                        run = if v[..n].contains(&x) { run + 1 } else { 0 };
                        longest = longest.max(run);
                    }
                    assert!(longest <= s.run.max(2), "h {h} c {c}");
                }
            }
        }

        fn placement_spreads_first_and_opens_the_tail_runs_last() {
            let order = |h, c| {
                let s = Scheduler::<1>::new(h, c);
                let mut out = [0u8; 64];
                let mut n = 0;
                for x in s.slots() {
                    out[n] = x;
                    n += 1;
                }
                (out, n)
            };
            // The load benchmark's cycle: one slot of each of the first six runs, the second
            // slots from the latest run back, the two runs before the free tail last.
            let (o, n) = order(15, 30);
            assert_eq!(&o[..n], &[1, 4, 7, 10, 13, 16, 17, 14, 11, 8, 5, 2, 19, 20, 22]);
            let (o, n) = order(20, 25);
            assert_eq!(
                &o[..n],
                &[1, 6, 11, 12, 7, 2, 13, 8, 3, 14, 9, 4, 16, 17, 18, 19, 21, 22, 23, 24]
            );
            // One block, or too few runs to spread: cycle order.
            assert_eq!(&order(3, 4).0[..3], &[1, 2, 3]);
            assert_eq!(&order(4, 30).0[..4], &[1, 2, 4, 5]);
            for c in 2..=MAX_SLOTS {
                for h in 1..c {
                    let s = Scheduler::<1>::new(h, c);
                    let (o, n) = order(h, c);
                    // The same slots as the layout, each once.
                    let mut sorted = o;
                    sorted[..n].sort_unstable();
                    assert!(s.layout().eq(sorted[..n].iter().copied()), "h {h} c {c}");
                    // Until the spread runs' first slots are taken, no two reservations touch.
                    let spread = usize::from(h.div_ceil(s.run).saturating_sub(2));
                    assert!(o[..spread].windows(2).all(|w| w[1] > w[0] + 1), "h {h} c {c}");
                }
            }
            // What a light calendar looks like: eight 1-cycle streams leave every free window
            // between reservations two slots long until the second slots open.
            let mut s = Scheduler::<8>::new(15, 30);
            let slots: [u8; 8] =
                core::array::from_fn(|i| s.register(MessageId(0x300 + i as u16), 1).unwrap().slot);
            assert_eq!(slots, [1, 4, 7, 10, 13, 16, 17, 14]);
        }

        fn mask_is_the_union_of_occurrences() {
            let mut s = Scheduler::<16>::new(6, 7);
            let periods = [1, 2, 4, 8, 16, 32, 64, 128, 256, 2, 4, 8];
            for (i, &per) in periods.iter().enumerate() {
                s.register(MessageId(0x300 + i as u16), per).unwrap();
            }
            check_no_collision(&s);
            for c in 0..MAX_PERIOD_CYCLES {
                assert_eq!(s.mask(c + 256), s.mask(c));
            }
        }
    }
}

#[cfg(test)]
mod proptests {
    extern crate std;
    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    const PERIODS: [u32; 13] = [0, 1, 2, 3, 4, 6, 8, 16, 32, 64, 128, 256, 512];

    /// Brute force: is there any (slot, offset) free for `period`?
    fn some_phase_free<const N: usize>(s: &Scheduler<N>, period: Period) -> bool {
        some_offset_free(s, period, 1)
    }

    /// Brute force: is there an offset at which `frames` slots are free for `period`?
    fn some_offset_free<const N: usize>(s: &Scheduler<N>, period: Period, frames: u8) -> bool {
        (0..period.cycles()).any(|o| {
            let free = s.slots().filter(|&slot| {
                s.iter().filter(|r| r.phase.slot == slot).all(|r| {
                    let m = period.cycles().min(r.period.cycles()) - 1;
                    o & m != r.phase.offset as u32 & m
                })
            });
            free.count() >= usize::from(frames)
        })
    }

    fn check_calendar<const N: usize>(s: &Scheduler<N>) {
        for c in 0..MAX_PERIOD_CYCLES {
            let mut union = 1u64;
            for r in s.iter() {
                if occurs(r.period, r.phase, c) {
                    assert_eq!(union & (1 << r.phase.slot), 0, "two streams in cycle {c}");
                    union |= 1 << r.phase.slot;
                }
            }
            assert_eq!(s.mask(c), union);
        }
    }

    proptest! {
        #[test]
        fn any_sequence_keeps_streams_apart(
            hrt_slots in 1u8..=4,
            extra in 1u8..8,
            ops in proptest::collection::vec(
                (any::<bool>(), 0u16..12, 0usize..PERIODS.len(), 0u8..=4),
                1..60,
            ),
        ) {
            let mut s = Scheduler::<10>::new(hrt_slots, hrt_slots + extra);
            for (reg, id, pi, frames) in ops {
                let stream = MessageId(0x100 + id);
                if !reg {
                    let before = s.get(stream).copied();
                    prop_assert_eq!(s.remove(stream), before);
                    prop_assert!(s.get(stream).is_none());
                    check_calendar(&s);
                    continue;
                }
                // Mostly one frame, as most streams are.
                let frames = if frames == 4 { MAX_HRT_FRAMES + 1 } else { frames.max(1) };
                let cycles = PERIODS[pi];
                let existing = s.slots_of(stream);
                let util = s.utilization();
                let cap = MAX_PERIOD_CYCLES * hrt_slots as u32;
                let len = s.len();
                let res = s.register_frames(stream, cycles, frames);
                let need = |per: Period| u32::from(frames) * (256 >> per.log2());
                match (Period::from_cycles(cycles), res) {
                    (Err(_), r) => prop_assert_eq!(r, Err(Reject::NotHarmonic)),
                    (Ok(_), Err(Reject::TooManyFrames)) => prop_assert!(frames > MAX_HRT_FRAMES),
                    (Ok(per), Ok(got)) => {
                        prop_assert!((got.offset as u32) < per.cycles());
                        prop_assert_eq!(got.frames(), frames);
                        for slot in (0..64).filter(|&x| got.slots & 1 << x != 0) {
                            prop_assert!(s.slots().any(|x| x == slot));
                        }
                        match existing {
                            Some(e) => prop_assert_eq!(e, (per, got)),
                            None => prop_assert!(util + need(per) <= cap),
                        }
                        prop_assert_eq!(s.slots_of(stream), Some((per, got)));
                    }
                    (Ok(per), Err(Reject::Conflict)) => {
                        prop_assert!(existing.is_some_and(|(p, sl)| p != per || sl.frames() != frames));
                    }
                    (Ok(per), Err(Reject::Full)) => {
                        prop_assert!(existing.is_none());
                        prop_assert!(len + usize::from(frames) > 10 || util + need(per) > cap);
                    }
                    (Ok(per), Err(Reject::NoFreePhase)) => {
                        prop_assert!(existing.is_none() && frames <= MAX_HRT_FRAMES);
                        prop_assert!(util + need(per) <= cap);
                        prop_assert!(!some_offset_free(&s, per, frames));
                        if frames == 1 {
                            prop_assert!(!some_phase_free(&s, per));
                        }
                    }
                    (_, Err(e)) => prop_assert!(false, "unexpected {:?}", e),
                }
                check_calendar(&s);
            }
        }

        #[test]
        fn without_removals_admission_is_the_utilization_test(
            hrt_slots in 1u8..=3,
            extra in 1u8..8,
            periods in proptest::collection::vec(0u32..=8, 1..40),
        ) {
            let mut s = Scheduler::<64>::new(hrt_slots, hrt_slots + extra);
            let mut admitted: Vec<u32> = Vec::new();
            for (i, k) in periods.into_iter().enumerate() {
                let need = 256 >> k;
                let fits = admitted.iter().sum::<u32>() + need <= 256 * hrt_slots as u32;
                let r = s.register(MessageId(0x400 + i as u16), 1 << k);
                prop_assert_eq!(r.is_ok(), fits, "{:?}", r);
                if r.is_ok() {
                    admitted.push(need);
                } else {
                    prop_assert_eq!(r, Err(Reject::Full));
                }
            }
            check_calendar(&s);
        }
    }
}

#[cfg(test)]
mod vectors {
    extern crate std;
    use super::*;
    use serde::Deserialize;
    use std::{string::String, vec::Vec};

    #[derive(Deserialize)]
    struct File {
        #[allow(dead_code)]
        description: String,
        cases: Vec<Case>,
    }

    #[derive(Deserialize)]
    struct Case {
        name: String,
        hrt_slots: u8,
        cycle_slots: u8,
        steps: Vec<Step>,
    }

    #[derive(Deserialize)]
    struct Accept {
        offset: u8,
        slot: Option<u8>,
        slots: Option<Vec<u8>>,
    }

    #[derive(Deserialize)]
    struct Step {
        op: String,
        stream: Option<u16>,
        period: Option<u32>,
        frames: Option<u8>,
        accept: Option<Accept>,
        reject: Option<String>,
        removed: Option<bool>,
        first_cycle: Option<u32>,
        masks: Option<Vec<String>>,
    }

    #[test]
    fn schedule_vectors() {
        let f: File =
            serde_json::from_str(include_str!("../../../../tests/vectors/rtcan/schedule.json"))
                .unwrap();
        let mut checked = 0;
        for case in &f.cases {
            let mut s = Scheduler::<8>::new(case.hrt_slots, case.cycle_slots);
            for (i, st) in case.steps.iter().enumerate() {
                let at = (case.name.as_str(), i);
                match st.op.as_str() {
                    "register" => {
                        let (stream, period) = (MessageId(st.stream.unwrap()), st.period.unwrap());
                        let r = s.register_frames(stream, period, st.frames.unwrap_or(1));
                        match (&st.accept, &st.reject) {
                            (Some(a), None) => {
                                let slots = match (a.slot, &a.slots) {
                                    (Some(x), None) => 1u64 << x,
                                    (None, Some(v)) => v.iter().fold(0, |m, x| m | 1 << x),
                                    _ => panic!("bad accept {at:?}"),
                                };
                                assert_eq!(r, Ok(StreamSlots { offset: a.offset, slots }), "{at:?}")
                            }
                            (None, Some(why)) => {
                                let want = match why.as_str() {
                                    "not_harmonic" => Reject::NotHarmonic,
                                    "no_free_phase" => Reject::NoFreePhase,
                                    "full" => Reject::Full,
                                    "reserved_id" => Reject::ReservedId,
                                    "conflict" => Reject::Conflict,
                                    "too_many_frames" => Reject::TooManyFrames,
                                    other => panic!("unknown reason {other}"),
                                };
                                assert_eq!(r, Err(want), "{at:?}");
                            }
                            _ => panic!("bad step {at:?}"),
                        }
                    }
                    "remove" => assert_eq!(
                        s.remove(MessageId(st.stream.unwrap())).is_some(),
                        st.removed.unwrap(),
                        "{at:?}"
                    ),
                    "masks" => {
                        let first = st.first_cycle.unwrap();
                        for (j, m) in st.masks.as_ref().unwrap().iter().enumerate() {
                            let want = u64::from_str_radix(m.trim_start_matches("0x"), 16).unwrap();
                            assert_eq!(
                                s.mask(first + j as u32),
                                want,
                                "{at:?} cycle {}",
                                first + j as u32
                            );
                        }
                    }
                    other => panic!("unknown op {other}"),
                }
                checked += 1;
            }
        }
        assert!(checked > 40);
    }
}
