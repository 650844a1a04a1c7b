//! Frame-sized reservations: where the master places each calendar slot in the cycle when a
//! reservation lasts its own frame instead of a whole grid slot (issue 22, docs/rtcan.md
//! "Capacity").
//!
//! A reservation lasts its frame's worst case for the stream's identifier and length
//! ([`crate::cycle::frame_bits_of`]) plus [`RESERVATION_GUARD_BITS`], rounded up to whole µs.
//! Reservations lie back to back in `blocks` blocks, block b starting at b·cycle/blocks (the
//! sync opens block 0), so the time between blocks is one free window each — every window's end
//! costs what no frame can fill, so few windows carry the most (`r2p-loadbench`, rtcan_framed:
//! one block carries the most but keeps a 2 ms-deadline message out of a 1.4 ms block; two are
//! the count that meets both issue 22's capacity and SRT-miss goals).
//!
//! **A placed slot never moves** while the calendar lives: every node sends at its slots'
//! offsets, so moving one would need every node to switch in the same cycle. A new slot takes
//! the first gap of its block that holds it (a released slot's hole, or the block's end), in the
//! block where it ends earliest; a released slot's time is free at once (the sync's mask no
//! longer reserves it) and its gap is reused by the next slot that fits it. The master is the
//! one place that computes positions; grants carry them to the nodes.

use crate::cycle::{frame_bits_of, CycleConfig, MAX_SLOTS, SYNC_PAYLOAD_LEN, SYNC_SLOT};
use crate::id::{FrameId, MessageId, MAX_SYNC_SENDER};
use crate::schedule::{Reject, Scheduler, StreamSlots};

/// Bit times a reservation adds to its frame's worst case: the nodes' clocks agree within a
/// few µs of the master's sync (docs/rtcan.md, "Slave clock"), so the next reservation's owner
/// must not start earlier than that after this one's worst-case end.
pub const RESERVATION_GUARD_BITS: u32 = 3;

/// Most blocks a cycle may be cut into.
pub const MAX_BLOCKS: u8 = 4;

/// Worst-case bit times of a sync frame, intermission included: the longest over every cycle
/// counter and sender rank (the identifier carries both, so their stuff bits vary).
pub const SYNC_FRAME_BITS: u32 = {
    let (mut worst, mut cycle) = (0, 0);
    while cycle < 256 {
        let mut sender = 0;
        while sender <= MAX_SYNC_SENDER {
            let raw = FrameId::sync_from(cycle, sender).to_raw();
            let bits = frame_bits_of(raw, SYNC_PAYLOAD_LEN);
            if bits > worst {
                worst = bits;
            }
            sender += 1;
        }
        cycle += 1;
    }
    worst
};

/// Where one slot's reservation lies: µs from the cycle's start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Span {
    /// Its frame starts here.
    pub start_us: u16,
    /// Its frame (worst case, guard included) has ended this long after the start.
    pub len_us: u16,
}

impl Span {
    /// The first µs after the reservation: the next one may start here.
    pub const fn end_us(self) -> u32 {
        self.start_us as u32 + self.len_us as u32
    }

    /// True if the two reservations share a µs.
    pub const fn overlaps(self, other: Span) -> bool {
        (self.start_us as u32) < other.end_us() && (other.start_us as u32) < self.end_us()
    }
}

/// Why a slot cannot be placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayoutError {
    /// The sync slot is placed by the layout itself; slots beyond [`MAX_SLOTS`] do not exist.
    NotHrtSlot(u8),
    /// The slot is placed already and shorter than the frame: it cannot grow without moving
    /// the slots after it.
    TooShort {
        /// The slot.
        slot: u8,
        /// Its reservation, µs.
        has_us: u16,
        /// What the frame needs, µs.
        needs_us: u16,
    },
    /// No block has a gap that long left within its share of the cycle.
    NoRoom {
        /// What the frame needs, µs.
        needs_us: u16,
    },
}

/// Why a layout cannot be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayoutConfigError {
    /// Blocks must be 1 … [`MAX_BLOCKS`].
    Blocks(u8),
    /// The reservable time per block must hold the sync and leave the block's share free.
    Reservable {
        /// Asked per block, µs.
        per_block_us: u32,
        /// Block length, µs.
        block_us: u32,
    },
}

/// The master's placement of its calendar's slots in the cycle (module documentation).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    config: CycleConfig,
    blocks: u8,
    /// Reservations may lie within this long from each block's start (block 0: after the sync).
    per_block_us: u32,
    /// Per slot; `len_us == 0`: not placed.
    spans: [Span; MAX_SLOTS as usize],
    /// One bit per placed slot (`spans` with a length).
    placed: u64,
}

impl Layout {
    /// An empty layout of a validated `config` in `blocks` blocks, each of which may hold
    /// `reservable_us` / `blocks` µs of reservations (block 0 the sync besides).
    pub fn new(
        config: CycleConfig,
        blocks: u8,
        reservable_us: u32,
    ) -> Result<Self, LayoutConfigError> {
        if blocks == 0 || blocks > MAX_BLOCKS {
            return Err(LayoutConfigError::Blocks(blocks));
        }
        let block_us = config.cycle_us / u32::from(blocks);
        let per_block_us = reservable_us / u32::from(blocks);
        let sync_us = Self::us(&config, SYNC_FRAME_BITS);
        if per_block_us == 0 || sync_us + per_block_us >= block_us {
            return Err(LayoutConfigError::Reservable { per_block_us, block_us });
        }
        let mut spans = [Span::default(); MAX_SLOTS as usize];
        spans[usize::from(SYNC_SLOT)] = Span { start_us: 0, len_us: sync_us as u16 };
        Ok(Self { config, blocks, per_block_us, spans, placed: 1 << SYNC_SLOT })
    }

    /// An empty layout whose `blocks` blocks together may hold as much time as `hrt_slots`
    /// slots of the grid `config` cuts the cycle into: what a bus configured for the grid
    /// reserves at most, laid out frame-sized.
    pub fn for_hrt_slots(
        config: CycleConfig,
        blocks: u8,
        hrt_slots: u8,
    ) -> Result<Self, LayoutConfigError> {
        Self::new(config, blocks, u32::from(hrt_slots) * config.slot_us())
    }

    /// µs a reservation for a frame of `bits` worst-case bit times lasts: with the guard,
    /// rounded up.
    fn us(config: &CycleConfig, bits: u32) -> u32 {
        let bits = u64::from(bits + RESERVATION_GUARD_BITS);
        (bits * 1_000_000).div_ceil(u64::from(config.bit_rate)) as u32
    }

    /// The reservation a frame with identifier `raw_id` and `len` data bytes needs, µs.
    pub fn reservation_us(&self, raw_id: u32, len: usize) -> u16 {
        self.reservation_us_of_bits(frame_bits_of(raw_id, len))
    }

    /// The reservation a frame of `bits` bit times (intermission included) needs, µs: with the
    /// guard, rounded up ([`Self::reservation_us`] gives it a frame's worst case).
    pub fn reservation_us_of_bits(&self, bits: u32) -> u16 {
        Self::us(&self.config, bits) as u16
    }

    /// Where `slot`'s reservation lies, if it is placed (the sync slot always is).
    pub fn span(&self, slot: u8) -> Option<Span> {
        self.spans.get(usize::from(slot)).copied().filter(|s| s.len_us > 0)
    }

    /// The placed slots and their reservations, in slot order (the sync first).
    pub fn iter(&self) -> impl Iterator<Item = (u8, Span)> + '_ {
        (0..MAX_SLOTS).filter_map(|slot| self.span(slot).map(|s| (slot, s)))
    }

    /// One bit per placed slot (the sync's, bit 0, always): what a node's slot path looks up
    /// instead of walking every slot.
    pub const fn placed(&self) -> u64 {
        self.placed
    }

    /// Places `slot` for frames needing `needs_us` (from [`Self::reservation_us`]), or checks
    /// that its reservation holds them if it is placed already (streams sharing a slot in
    /// alternate cycles). Never moves a placed slot.
    pub fn place(&mut self, slot: u8, needs_us: u16) -> Result<Span, LayoutError> {
        if slot == SYNC_SLOT || slot >= MAX_SLOTS {
            return Err(LayoutError::NotHrtSlot(slot));
        }
        if let Some(has) = self.span(slot) {
            if has.len_us >= needs_us {
                return Ok(has);
            }
            let grown = Span { len_us: needs_us, ..has };
            if !self.room_for(grown, slot) {
                return Err(LayoutError::TooShort { slot, has_us: has.len_us, needs_us });
            }
            self.spans[usize::from(slot)] = grown;
            return Ok(grown);
        }
        let mut best: Option<(u32, Span)> = None;
        for b in 0..u32::from(self.blocks) {
            if let Some(span) = self.first_gap(b, needs_us) {
                let from_block_start = span.end_us() - b * self.block_us();
                if best.is_none_or(|(e, _)| from_block_start < e) {
                    best = Some((from_block_start, span));
                }
            }
        }
        let (_, span) = best.ok_or(LayoutError::NoRoom { needs_us })?;
        self.spans[usize::from(slot)] = span;
        self.placed |= 1 << slot;
        Ok(span)
    }

    /// Admits `stream` into `calendar` ([`Scheduler::register_in`]) in slots whose reservation
    /// holds its frames of `needs_us` ([`Self::reservation_us`]), and places the slots it
    /// opens. If a slot it opens finds no room, the registration is undone: `Err(Full)`.
    /// A stream registered already whose slots are shorter than `needs_us`: `Err(Conflict)`.
    pub fn admit<const N: usize>(
        &mut self,
        calendar: &mut Scheduler<N>,
        stream: MessageId,
        period_cycles: u32,
        frames: u8,
        needs_us: u16,
    ) -> Result<StreamSlots, Reject> {
        let usable = |slot: u8| match self.span(slot) {
            None => true,
            Some(has) => {
                has.len_us >= needs_us || self.room_for(Span { len_us: needs_us, ..has }, slot)
            }
        };
        let known = calendar.slots_of(stream);
        if let Some((_, held)) = known {
            // Registered again (a node repeating its request): its slots must hold the frames.
            if held.iter().any(|s| self.span(s).is_none_or(|s| s.len_us < needs_us)) {
                return Err(Reject::Conflict);
            }
        }
        let got = calendar.register_in(stream, period_cycles, frames, usable)?;
        let before = self.clone();
        for slot in got.iter() {
            if self.place(slot, needs_us).is_err() {
                if known.is_none() {
                    calendar.remove(stream);
                }
                *self = before;
                return Err(Reject::Full);
            }
        }
        Ok(got)
    }

    /// Frees the time of every slot `calendar` no longer uses (after streams left it).
    pub fn release_unused<const N: usize>(&mut self, calendar: &Scheduler<N>) {
        for slot in 1..MAX_SLOTS {
            if !calendar.iter().any(|r| r.phase.slot == slot) {
                self.release(slot);
            }
        }
    }

    /// Takes in where the master placed `slot` (a node learning the layout from the grants it
    /// hears): the master's newest word wins, so a reservation of another slot it overlaps is
    /// forgotten (that slot was released and its time reused). `Err` for a position the master
    /// cannot have given: the sync slot, a slot beyond [`MAX_SLOTS`], no length, past the
    /// cycle's end or into the sync's reservation.
    pub fn take(&mut self, slot: u8, span: Span) -> Result<(), LayoutError> {
        let sync = self.spans[usize::from(SYNC_SLOT)];
        if slot == SYNC_SLOT || slot >= MAX_SLOTS {
            return Err(LayoutError::NotHrtSlot(slot));
        }
        if span.len_us == 0 || span.end_us() > self.config.cycle_us || span.overlaps(sync) {
            return Err(LayoutError::NoRoom { needs_us: span.len_us });
        }
        for (s, other) in self.spans.iter_mut().enumerate().skip(1) {
            if s != usize::from(slot) && other.overlaps(span) {
                *other = Span::default();
                self.placed &= !(1 << s);
            }
        }
        self.spans[usize::from(slot)] = span;
        self.placed |= 1 << slot;
        Ok(())
    }

    /// Frees `slot`'s time (its last stream left); its gap is reused by the next slot that fits.
    pub fn release(&mut self, slot: u8) {
        if slot != SYNC_SLOT {
            if let Some(s) = self.spans.get_mut(usize::from(slot)) {
                *s = Span::default();
                self.placed &= !(1 << slot);
            }
        }
    }

    /// Forgets every HRT slot (a new master starts with an empty calendar).
    pub fn clear(&mut self) {
        let sync = self.spans[usize::from(SYNC_SLOT)];
        self.spans = [Span::default(); MAX_SLOTS as usize];
        self.spans[usize::from(SYNC_SLOT)] = sync;
        self.placed = 1 << SYNC_SLOT;
    }

    fn block_us(&self) -> u32 {
        self.config.cycle_us / u32::from(self.blocks)
    }

    /// The cycle's length, µs.
    pub const fn cycle_us(&self) -> u32 {
        self.config.cycle_us
    }

    /// The calendar's slots (the sync's included): the grid's count.
    pub const fn slots(&self) -> u8 {
        self.config.slots
    }

    /// How many blocks the cycle is cut into.
    pub const fn blocks(&self) -> u8 {
        self.blocks
    }

    /// Where block `b`'s share of the cycle lies (start, end), µs: its reservations lie
    /// there (block 0's after the sync), wherever the master placed them.
    pub fn share(&self, b: u8) -> (u32, u32) {
        let b = u32::from(b);
        (b * self.block_us(), self.limit(b))
    }

    /// True if `span` overlaps no placed reservation but `slot`'s own and ends within its
    /// block's share: a slot nothing follows in its block may grow without moving another.
    fn room_for(&self, span: Span, slot: u8) -> bool {
        let b = u32::from(span.start_us) / self.block_us();
        let free = (0..MAX_SLOTS)
            .filter(|&s| s != slot)
            .filter_map(|s| self.span(s))
            .all(|other| !other.overlaps(span));
        free && span.end_us() <= self.limit(b)
    }

    /// The end of block `b`'s share: its reservations must end by then.
    fn limit(&self, b: u32) -> u32 {
        b * self.block_us() + self.per_block_us + if b == 0 { self.spans[0].end_us() } else { 0 }
    }

    /// The earliest `len_us` long gap of block `b` between its placed reservations, within its
    /// share.
    fn first_gap(&self, b: u32, len_us: u16) -> Option<Span> {
        let (start, limit) = (b * self.block_us(), self.limit(b));
        let mut at = start;
        loop {
            let candidate = Span { start_us: at as u16, len_us };
            if candidate.end_us() > limit {
                return None;
            }
            // The placed reservation that ends last among those the candidate overlaps.
            match self.spans.iter().filter(|s| s.overlaps(candidate)).map(|s| s.end_us()).max() {
                None => return Some(candidate),
                Some(end) => at = end,
            }
        }
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    const CYCLE: CycleConfig = CycleConfig { bit_rate: 1_000_000, cycle_us: 5_000, slots: 30 };

    r2p_testkit::suite! {
        fn the_sync_reservation_holds_every_sync_and_no_more() {
            // The longest sync: 8 data bytes, its identifier's stuff bits at their worst over
            // counters and ranks; never more than an 8-byte frame's bound, and met by one sync.
            assert!(SYNC_FRAME_BITS <= crate::cycle::frame_bits(8));
            let met = (0..256).any(|c| {
                (0..=MAX_SYNC_SENDER).any(|s| {
                    frame_bits_of(FrameId::sync_from(c, s).to_raw(), 8) == SYNC_FRAME_BITS
                })
            });
            assert!(met);
            let held = (0..256).all(|c| {
                (0..=MAX_SYNC_SENDER).all(|s| {
                    frame_bits_of(FrameId::sync_from(c, s).to_raw(), 8) <= SYNC_FRAME_BITS
                })
            });
            assert!(held);
            let l = Layout::new(CYCLE, 2, 2_400).unwrap();
            assert_eq!(l.span(SYNC_SLOT), Some(Span { start_us: 0, len_us: (SYNC_FRAME_BITS + 3) as u16 }));
        }

        fn a_reservation_lasts_its_frames_worst_case_and_the_guard_in_whole_us() {
            let l = Layout::new(CYCLE, 2, 2_400).unwrap();
            // Identifier 0, 8 bytes: 157 bits (cycle.rs), 3 guard bits: 160 µs at 1 Mbit/s.
            assert_eq!(frame_bits_of(0, 8), 157);
            assert_eq!(l.reservation_us(0, 8), 160);
            // At 250 kbit/s a bit is 4 µs; at 300 kbit/s 160 bits take 533.3 µs: rounded up.
            let slow = |bit_rate| CycleConfig { bit_rate, cycle_us: 40_000, ..CYCLE };
            assert_eq!(Layout::new(slow(250_000), 2, 9_000).unwrap().reservation_us(0, 8), 640);
            assert_eq!(Layout::new(slow(300_000), 2, 9_000).unwrap().reservation_us(0, 8), 534);
        }

        fn slots_lie_back_to_back_after_the_sync_in_the_emptier_block() {
            let mut l = Layout::new(CYCLE, 2, 2_400).unwrap();
            let sync_end = l.span(SYNC_SLOT).unwrap().end_us();
            // Block 1 (at 2 500 µs) is emptier than block 0, which holds the sync.
            assert_eq!(sync_end, 160, "157 bits and the guard");
            let a = l.place(5, 115).unwrap();
            assert_eq!(a, Span { start_us: 2_500, len_us: 115 });
            // Block 1 would end 270 µs from its start, block 0 315: block 1 again.
            let b = l.place(3, 155).unwrap();
            assert_eq!(b, Span { start_us: 2_615, len_us: 155 });
            // Now block 0 ends earlier (260 against 370).
            let c = l.place(9, 100).unwrap();
            assert_eq!(c, Span { start_us: 160, len_us: 100 });
            // A slot placed already: its reservation holds a frame as long or shorter; a longer
            // one only if nothing follows it in its block (slot 3 follows slot 5).
            assert_eq!(l.place(5, 115), Ok(a));
            assert_eq!(l.place(5, 116), Err(LayoutError::TooShort { slot: 5, has_us: 115, needs_us: 116 }));
            assert_eq!(l.place(3, 170), Ok(Span { start_us: 2_615, len_us: 170 }));
        }

        fn of_two_blocks_that_would_end_it_as_early_the_first_takes_a_slot() {
            let mut l = Layout::new(CYCLE, 2, 2_400).unwrap();
            // Block 1 holds as much as block 0's sync: a slot would end as far into either.
            assert_eq!(l.place(1, 160).unwrap().start_us, 2_500);
            assert_eq!(l.place(2, 100).unwrap().start_us, 160);
        }

        fn a_released_slot_leaves_a_hole_the_next_slot_that_fits_takes_and_nothing_moves() {
            let mut l = Layout::new(CYCLE, 1, 2_400).unwrap();
            let spans: [Span; 3] = [l.place(1, 120).unwrap(), l.place(2, 120).unwrap(), l.place(3, 120).unwrap()];
            l.release(2);
            assert_eq!(l.span(2), None);
            assert_eq!(l.span(1), Some(spans[0]));
            assert_eq!(l.span(3), Some(spans[2]));
            // Too long for the hole: after the block's last reservation.
            assert_eq!(l.place(4, 121).unwrap().start_us as u32, spans[2].end_us());
            // Fits the hole: there.
            assert_eq!(l.place(6, 100).unwrap().start_us, spans[1].start_us);
        }

        fn a_block_holds_no_more_than_its_share() {
            let mut l = Layout::new(CYCLE, 2, 400).unwrap();
            // 200 µs per block: one 150 µs slot each, then nothing.
            assert!(l.place(1, 150).is_ok());
            assert!(l.place(2, 150).is_ok());
            assert_eq!(l.place(3, 150), Err(LayoutError::NoRoom { needs_us: 150 }));
            assert!(l.place(3, 50).is_ok(), "a shorter one still fits a block's share");
        }

        fn a_stream_goes_into_a_slot_long_enough_or_opens_its_own() {
            let mut l = Layout::new(CYCLE, 1, 2_400).unwrap();
            let mut cal: Scheduler<8> = Scheduler::new(15, 30);
            // Two streams of period 2 could share one slot in alternate cycles.
            let long = l.admit(&mut cal, MessageId(0x101), 2, 1, 155).unwrap();
            let short = l.admit(&mut cal, MessageId(0x102), 2, 1, 115).unwrap();
            assert_eq!(short.slots, long.slots, "a shorter frame shares the longer one's slot");
            assert_ne!(short.offset, long.offset);
            // The other way round, the longer one shares the shorter one's slot only if that
            // slot can grow without moving another: when nothing follows it in its block.
            let a = l.admit(&mut cal, MessageId(0x103), 2, 1, 115).unwrap();
            let after_a = l.admit(&mut cal, MessageId(0x105), 1, 1, 100).unwrap();
            let b = l.admit(&mut cal, MessageId(0x104), 2, 1, 155).unwrap();
            assert_ne!(a.slots, b.slots, "slot {} is followed by {}", a.slots, after_a.slots);
            let c = l.admit(&mut cal, MessageId(0x106), 2, 1, 160).unwrap();
            assert_eq!(c.slots, b.slots, "the block's last slot grows to 160 µs");
            let grown = l.span(c.slots.trailing_zeros() as u8).unwrap();
            assert_eq!(grown.len_us, 160);
            for got in [long, a, b] {
                let slot = got.slots.trailing_zeros() as u8;
                assert!(l.span(slot).is_some(), "slot {slot} placed");
            }
            // Every placed reservation holds its streams' frames and none overlap.
            let spans: [Option<Span>; 64] = core::array::from_fn(|s| l.span(s as u8));
            for (i, x) in spans.iter().enumerate().filter_map(|(i, x)| x.map(|x| (i, x))) {
                for y in spans[i + 1..].iter().flatten() {
                    assert!(!x.overlaps(*y), "{x:?} {y:?}");
                }
            }
        }

        fn a_stream_registered_again_with_longer_frames_is_a_conflict() {
            // Its message changed (another type, another size): its slot is not made to fit,
            // even where it could grow.
            let mut l = Layout::new(CYCLE, 1, 2_400).unwrap();
            let mut cal: Scheduler<8> = Scheduler::new(15, 30);
            let a = l.admit(&mut cal, MessageId(0x101), 1, 1, 115).unwrap();
            assert_eq!(l.admit(&mut cal, MessageId(0x101), 1, 1, 115), Ok(a), "the same again");
            assert_eq!(l.admit(&mut cal, MessageId(0x101), 1, 1, 100), Ok(a), "shorter: it fits");
            let before = l.clone();
            assert_eq!(l.admit(&mut cal, MessageId(0x101), 1, 1, 116), Err(Reject::Conflict));
            l.admit(&mut cal, MessageId(0x102), 1, 1, 100).unwrap();
            assert_eq!(l.admit(&mut cal, MessageId(0x101), 1, 1, 150), Err(Reject::Conflict));
            assert_eq!(l.span(a.slots.trailing_zeros() as u8), before.span(a.slots.trailing_zeros() as u8));
        }

        fn a_stream_the_layout_has_no_room_for_is_refused_and_leaves_nothing_behind() {
            let mut l = Layout::new(CYCLE, 1, 300).unwrap();
            let mut cal: Scheduler<8> = Scheduler::new(15, 30);
            l.admit(&mut cal, MessageId(0x101), 1, 1, 150).unwrap();
            l.admit(&mut cal, MessageId(0x102), 1, 1, 150).unwrap();
            let before = (l.clone(), cal.len());
            assert_eq!(l.admit(&mut cal, MessageId(0x103), 1, 1, 150), Err(Reject::Full));
            assert_eq!(cal.get(MessageId(0x103)), None, "the registration is undone");
            assert_eq!((l.clone(), cal.len()), before);
            // A two-frame message whose second slot finds no room: its first goes too.
            let (mut l, mut cal) = (Layout::new(CYCLE, 1, 300).unwrap(), Scheduler::<8>::new(15, 30));
            l.admit(&mut cal, MessageId(0x104), 1, 1, 100).unwrap();
            let before = l.clone();
            assert_eq!(l.admit(&mut cal, MessageId(0x105), 1, 2, 150), Err(Reject::Full));
            assert_eq!(l, before, "the first frame's slot is released again");
            assert_eq!(cal.len(), 1);
            // A stream leaving frees its slot's time for the next.
            cal.remove(MessageId(0x104));
            l.release_unused(&cal);
            assert!(l.admit(&mut cal, MessageId(0x105), 1, 2, 150).is_ok());
        }

        fn a_node_takes_the_masters_positions_and_forgets_what_they_overlap() {
            let mut master = Layout::new(CYCLE, 2, 2_400).unwrap();
            let mut node = Layout::new(CYCLE, 2, 2_400).unwrap();
            for (slot, us) in [(4, 120), (2, 155), (9, 100)] {
                let span = master.place(slot, us).unwrap();
                node.take(slot, span).unwrap();
            }
            assert_eq!(node, master);
            // Slot 4 released and its time given to slot 6: a node that hears slot 6's grant
            // forgets slot 4's old place.
            let old = master.span(4).unwrap();
            master.release(4);
            let six = master.place(6, 100).unwrap();
            assert_eq!(six.start_us, old.start_us);
            node.take(6, six).unwrap();
            assert_eq!(node.span(4), None);
            assert_eq!(node, master);
            // Positions the master cannot have given.
            let at = |start_us, len_us| Span { start_us, len_us };
            assert_eq!(node.take(0, at(200, 100)), Err(LayoutError::NotHrtSlot(0)));
            assert_eq!(node.take(64, at(200, 100)), Err(LayoutError::NotHrtSlot(64)));
            assert!(node.take(7, at(200, 0)).is_err(), "no length");
            assert!(node.take(7, at(4_950, 51)).is_err(), "past the cycle's end");
            assert!(node.take(7, at(159, 100)).is_err(), "into the sync's reservation");
            assert!(node.take(7, at(4_900, 100)).is_ok(), "ends with the cycle");
            assert!(node.take(7, at(160, 100)).is_ok(), "right after the sync");
            // Slot 7 right after the sync took slot 9's time: the bitmask follows the spans.
            assert_eq!(node.placed(), 1 << 2 | 1 << 6 | 1 << 7 | 1);
            assert_eq!(node.span(9), None);
            node.clear();
            assert_eq!((node.placed(), node.iter().count()), (1, 1), "the sync's only");
        }

        fn blocks_for_hrt_slots_hold_as_much_time_as_those_grid_slots() {
            // 30 slots of 166 µs in 5 ms: two HRT slots' time is 332 µs, in one block.
            let l = Layout::for_hrt_slots(CYCLE, 1, 2).unwrap();
            assert_eq!(l, Layout::new(CYCLE, 1, 332).unwrap());
        }

        fn bad_slots_and_configurations_are_refused() {
            let mut l = Layout::new(CYCLE, 2, 2_400).unwrap();
            assert_eq!(l.place(SYNC_SLOT, 10), Err(LayoutError::NotHrtSlot(0)));
            assert_eq!(l.place(MAX_SLOTS, 10), Err(LayoutError::NotHrtSlot(64)));
            assert_eq!(Layout::new(CYCLE, 0, 2_400), Err(LayoutConfigError::Blocks(0)));
            assert_eq!(Layout::new(CYCLE, 5, 2_400), Err(LayoutConfigError::Blocks(5)));
            // Two blocks of 2 500 µs cannot each reserve 2 500 µs and the sync.
            assert_eq!(
                Layout::new(CYCLE, 2, 5_000),
                Err(LayoutConfigError::Reservable { per_block_us: 2_500, block_us: 2_500 })
            );
            l.place(7, 150).unwrap();
            l.clear();
            assert_eq!(l.iter().count(), 1, "only the sync is left");
        }
    }
}
