//! The frame-sized what-if's cycle as the nodes see it: the master's [`Layout`] of its
//! calendar's slots (each reservation as long as its frame's worst case, back to back in
//! blocks, never moved once placed; `rtcan::layout`), cut into the reservations of one cycle.
//! The grants carry these positions to every node (r2p-node's `framed-reservations`); the
//! nodes' slot path does not use them yet, which is what this what-if's nodes stand in for
//! (docs/rtcan.md "Frame-sized reservations").

use rtcan::cycle::SYNC_SLOT;
use rtcan::layout::Layout;

/// One reservation of a cycle, µs from the cycle's start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reservation {
    /// The calendar's slot (0: the sync).
    pub slot: u8,
    /// Its frame starts here.
    pub start_us: u32,
    /// Its frame has ended (worst case, guard included) by here: the next may start.
    pub end_us: u32,
    /// Free frames may be loaded from here: the end, or — the last reservation of a block —
    /// [`FOLLOW_US`] after the start, when its frame is on the wire and they go right after it.
    pub free_at_us: u32,
}

/// How long after the start of a block's last reservation free frames are loaded: its owner's
/// one-shot frame has started by then (the clocks agree within a few µs), so they queue behind
/// it and go out at its actual end instead of its worst case's; if it was not sent, they use
/// the idle reservation.
pub const FOLLOW_US: u32 = 10;

/// The placed slots of a calendar, in time order.
#[derive(Clone, Debug)]
pub struct Timeline {
    /// Slot, offset in the cycle and length, µs.
    slots: Vec<(u8, u32, u32)>,
}

impl Timeline {
    /// The slots `layout` places, in time order.
    pub fn new(layout: &Layout) -> Self {
        let mut slots: Vec<(u8, u32, u32)> = layout
            .iter()
            .map(|(slot, span)| (slot, u32::from(span.start_us), u32::from(span.len_us)))
            .collect();
        slots.sort_by_key(|&(_, start, _)| start);
        Self { slots }
    }

    /// The reservations of cycle `cycle` whose sync announced `mask`, in time order (slots
    /// the calendar does not use are never reserved).
    pub fn of(&self, mask: u64) -> Vec<Reservation> {
        let mut out: Vec<Reservation> = self
            .slots
            .iter()
            .filter(|&&(slot, ..)| slot == SYNC_SLOT || mask & (1 << slot) != 0)
            .map(|&(slot, start_us, len)| {
                let end_us = start_us + len;
                Reservation { slot, start_us, end_us, free_at_us: end_us }
            })
            .collect();
        for i in 0..out.len() {
            if out.get(i + 1).is_none_or(|next| next.start_us > out[i].end_us) {
                out[i].free_at_us = out[i].end_us.min(out[i].start_us + FOLLOW_US);
            }
        }
        out
    }
}
