//! One cycle of frame-sized reservations as a node sends in it (issue 22, docs/rtcan.md
//! "Frame-sized reservations"): which reservation an instant lies in, where the free window
//! around it ends, and when the node must act next.
//!
//! The cycle's reservations are the sync's and those of the slots its sync announced (the
//! mask), where the [`Layout`] places them. Between them the bus is free: a free window ends
//! where the next reservation starts. A window opens at a reservation's worst-case end, or —
//! after the last reservation before a gap — [`FOLLOW_US`] after its start: its owner's frame
//! is on the wire by then, so free frames queue behind it and go at its actual end instead of
//! its worst case's.
//!
//! A slot the sync announced whose position the node does not know (a grant it missed, or
//! [`crate::cycle::UNKNOWN_MASK`] after a missed sync) could lie anywhere in the blocks' shares:
//! then each block's whole share counts as reserved, and free frames go only outside them.

use crate::cycle::SYNC_SLOT;
use crate::layout::Layout;
use crate::schedule::slots_in;

/// How long after the start of a reservation followed by a gap free frames may be loaded:
/// its owner's one-shot frame has started by then (the nodes' clocks agree within a few µs of
/// the sync), so they wait for it to end; if it was not sent, they use the idle reservation.
pub const FOLLOW_US: u32 = 10;

/// Where an instant of the cycle lies, µs from the cycle's start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Moment {
    /// Inside a reservation, before free frames may follow it: only its owner loads, at
    /// `start_us`.
    Reserved {
        /// The calendar's slot (the sync's: [`SYNC_SLOT`]); `None` for a block's share held
        /// for a slot whose position is not known.
        slot: Option<u8>,
        /// Where it starts.
        start_us: u32,
    },
    /// In a free window, which ends where the next reservation starts (or the cycle ends).
    Free {
        /// The window's end.
        end_us: u32,
    },
}

/// A reservation of the cycle: slot (`None`: a block's share), start and end, µs.
#[derive(Clone, Copy)]
struct Held {
    slot: Option<u8>,
    start_us: u32,
    end_us: u32,
}

/// The reservations of one cycle: `layout`'s placed slots that `mask` announces.
#[derive(Clone, Copy)]
pub struct FramedCycle<'l> {
    layout: &'l Layout,
    /// The slots reserved this cycle whose position is known: announced and placed, and the
    /// sync's.
    mask: u64,
    /// A slot `mask` announces has no known position: every block's share is held.
    unknown: bool,
}

impl<'l> FramedCycle<'l> {
    /// The cycle whose sync announced `mask`, as `layout` places its slots.
    pub fn new(layout: &'l Layout, mask: u64) -> Self {
        let slots = u64::MAX.checked_shr(64 - u32::from(layout.slots())).unwrap_or(0);
        let unknown = mask & slots & !layout.placed() != 0;
        Self { layout, mask: (mask | 1 << SYNC_SLOT) & layout.placed(), unknown }
    }

    /// True if a slot the sync announced has no known position (module documentation).
    pub fn positions_unknown(&self) -> bool {
        self.unknown
    }

    /// Every reservation of the cycle, in slot order then the blocks' shares (not in time
    /// order; they never overlap each other, but a share overlaps the slots it holds).
    fn held(&self) -> impl Iterator<Item = Held> + '_ {
        let slots = slots_in(self.mask).filter_map(|slot| {
            let s = self.layout.span(slot)?;
            Some(Held { slot: Some(slot), start_us: s.start_us.into(), end_us: s.end_us() })
        });
        let shares = (0..if self.unknown { self.layout.blocks() } else { 0 }).map(|b| {
            let (start_us, end_us) = self.layout.share(b);
            Held { slot: None, start_us, end_us }
        });
        slots.chain(shares)
    }

    /// When free frames may be loaded after `r`: its end if another reservation holds that
    /// instant (no window opens there), else [`FOLLOW_US`] after its start at the latest; a
    /// block's share has no frame to follow.
    fn free_at(&self, r: Held) -> u32 {
        let followed = self.held().any(|o| o.start_us <= r.end_us && r.end_us < o.end_us);
        match r.slot {
            Some(_) if !followed => r.end_us.min(r.start_us + FOLLOW_US),
            _ => r.end_us,
        }
    }

    /// Where `t_us` lies.
    pub fn at(&self, t_us: u32) -> Moment {
        // `free_at` only for the (at most two) reservations holding `t_us`: it walks them all.
        let holds = |r: &Held| r.start_us <= t_us && t_us < r.end_us;
        let inside = self.held().filter(holds).find(|&r| t_us < self.free_at(r));
        match inside {
            Some(r) => Moment::Reserved { slot: r.slot, start_us: r.start_us },
            None => Moment::Free { end_us: self.next_start(t_us) },
        }
    }

    /// The first reservation start after `t_us`, or the cycle's end.
    fn next_start(&self, t_us: u32) -> u32 {
        let starts = self.held().map(|r| r.start_us).filter(|&s| s > t_us);
        starts.min().unwrap_or(self.layout.cycle_us()).min(self.layout.cycle_us())
    }

    /// The next instant after `t_us` at which what a node may load changes: a reservation
    /// starts, a window opens, or the cycle ends.
    pub fn next_edge(&self, t_us: u32) -> u32 {
        let opens = self
            .held()
            .filter(|&r| r.start_us <= t_us && t_us < r.end_us)
            .map(|r| self.free_at(r))
            .filter(|&f| f > t_us)
            .min();
        let start = self.next_start(t_us);
        opens.map_or(start, |o| o.min(start))
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;
    use crate::cycle::{CycleConfig, UNKNOWN_MASK};
    use crate::layout::Span;

    const CYCLE: CycleConfig = CycleConfig { bit_rate: 1_000_000, cycle_us: 5_000, slots: 30 };

    /// Two blocks of 1.2 ms: slots 1 and 2 back to back after the sync, slot 3 opens block 1.
    fn layout() -> Layout {
        let mut l = Layout::new(CYCLE, 2, 2_400).unwrap();
        l.take(1, Span { start_us: 160, len_us: 100 }).unwrap();
        l.take(2, Span { start_us: 260, len_us: 100 }).unwrap();
        l.take(3, Span { start_us: 2_500, len_us: 100 }).unwrap();
        l
    }

    fn reserved(slot: u8, start_us: u32) -> Moment {
        Moment::Reserved { slot: Some(slot), start_us }
    }

    r2p_testkit::suite! {
        fn back_to_back_reservations_open_no_window_and_the_last_is_followed() {
            let l = layout();
            let c = FramedCycle::new(&l, 0b1110);
            assert!(!c.positions_unknown());
            // The sync, then slots 1 and 2 back to back: no window between them.
            assert_eq!(c.at(0), reserved(SYNC_SLOT, 0));
            assert_eq!(c.at(159), reserved(SYNC_SLOT, 0));
            assert_eq!(c.at(160), reserved(1, 160));
            assert_eq!(c.at(260), reserved(2, 260));
            // Slot 2 is followed by a gap: free frames queue behind its frame 10 µs in.
            assert_eq!(c.at(269), reserved(2, 260));
            assert_eq!(c.at(270), Moment::Free { end_us: 2_500 });
            assert_eq!(c.at(2_499), Moment::Free { end_us: 2_500 });
            assert_eq!(c.at(2_500), reserved(3, 2_500));
            assert_eq!(c.at(2_510), Moment::Free { end_us: 5_000 });
            assert_eq!(c.at(4_999), Moment::Free { end_us: 5_000 });
            let edges: [u32; 6] = [0, 160, 260, 270, 2_500, 2_510].map(|t| c.next_edge(t));
            assert_eq!(edges, [160, 260, 270, 2_500, 2_510, 5_000]);
            assert_eq!(c.next_edge(1_000), 2_500);
        }

        fn slots_the_sync_does_not_announce_are_free() {
            let l = layout();
            // Only slot 2 this cycle: the sync is followed by a gap, slot 1's time is free.
            let c = FramedCycle::new(&l, 0b100);
            assert_eq!(c.at(9), reserved(SYNC_SLOT, 0));
            assert_eq!(c.at(10), Moment::Free { end_us: 260 });
            assert_eq!(c.at(200), Moment::Free { end_us: 260 });
            assert_eq!(c.next_edge(0), 10);
            assert_eq!(c.next_edge(10), 260);
            assert_eq!(c.at(2_500), Moment::Free { end_us: 5_000 });
        }

        fn a_slot_of_unknown_position_holds_every_blocks_share() {
            let l = layout();
            for mask in [0b1_1110, UNKNOWN_MASK] {
                let c = FramedCycle::new(&l, mask);
                assert!(c.positions_unknown());
                // Block 0's share: the sync and 1.2 ms; block 1's from 2.5 ms.
                // Slot 2 holds its worst case: the share follows it.
                assert_eq!(c.at(270), reserved(2, 260));
                assert_eq!(c.at(360), Moment::Reserved { slot: None, start_us: 0 });
                assert_eq!(c.at(1_359), Moment::Reserved { slot: None, start_us: 0 });
                assert_eq!(c.at(1_360), Moment::Free { end_us: 2_500 });
                // The owners of known slots still send at their starts.
                assert_eq!(c.at(160), reserved(1, 160));
                assert_eq!(c.at(2_500), reserved(3, 2_500));
                // Nothing follows slot 3 at 10 µs: the share holds the time after it.
                assert_eq!(c.at(2_510), reserved(3, 2_500));
                assert_eq!(c.at(2_600), Moment::Reserved { slot: None, start_us: 2_500 });
                assert_eq!(c.at(3_700), Moment::Free { end_us: 5_000 });
                assert_eq!(c.next_edge(1_000), 1_360);
                assert_eq!(c.next_edge(2_600), 3_700);
            }
        }
    }
}
