//! Frame-sized reservations, a what-if of docs/rtcan.md "Capacity": where a cycle's sync and
//! HRT frames would lie if each reservation lasted its own frame's worst case
//! ([`worst_case_frame_bits`] of the stream's payload length, plus [`RESERVATION_GUARD_BITS`])
//! instead of a whole 166 µs slot, and the calendar's slots were laid out back to back after
//! the sync as one block.
//!
//! One block because every free window costs what its end cannot use: a frame may not start
//! unless it ends before the next reservation, so a window closes with up to a frame's time
//! idle (fitted windows: up to the shortest frame's). Runs of two reservations spread over the
//! cycle, as the grid's scheduler lays them out, carried 83 % at 95 % offered load; one block
//! 92–93 %. Every node could compute this layout from the calendar and each stream's length;
//! the grants and the calendar beacon would have to carry the length, which the protocol does
//! not do yet.

use rtcan::cycle::SYNC_SLOT;
use rtcan::CycleConfig;

use crate::traffic::{Kind, Traffic};
use crate::{worst_case_frame_bits, RESERVATION_GUARD_BITS};

/// One reservation of a cycle, µs from the cycle's start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reservation {
    /// The calendar's slot (0: the sync).
    pub slot: u8,
    /// Its frame starts here.
    pub start_us: u32,
    /// Its frame has ended (worst case, guard included) by here: the next may start.
    pub end_us: u32,
}

/// Where each slot of the calendar lies when reservations are as long as their frames.
#[derive(Clone, Debug)]
pub struct Timeline {
    /// Per slot: its offset in the cycle and its length, µs (length 0: no stream uses it).
    slots: Vec<(u32, u32)>,
}

impl Timeline {
    /// The layout of `traffic`'s calendar on `cycle`'s bus: the sync, then every slot the
    /// calendar uses, back to back in slot order, each as long as the longest worst-case frame
    /// of the streams that share it (streams of period 2 alternate in one slot). A slot's
    /// offset is the same in every cycle, so each stream stays strictly periodic; in a cycle
    /// where a slot's streams do not send, its time is free.
    pub fn new(traffic: &Traffic, cycle: CycleConfig) -> Self {
        let us = |len: usize| {
            let bits = u64::from(worst_case_frame_bits(len) + RESERVATION_GUARD_BITS);
            (bits * 1_000_000).div_ceil(u64::from(cycle.bit_rate)) as u32
        };
        let n = usize::from(cycle.slots);
        let mut len = vec![0u32; n];
        // Per slot, the share of cycles its streams send in, in 256ths.
        let mut used = vec![0u32; n];
        len[usize::from(SYNC_SLOT)] =
            us(rtcan::SyncFrame::new(0, 0, false).to_frame().payload().len());
        used[usize::from(SYNC_SLOT)] = 256;
        for (&bytes, stream) in traffic.hrt_len.iter().zip(&traffic.streams) {
            if let Kind::Hrt { period, phase } = stream.kind {
                let slot = usize::from(phase.slot);
                len[slot] = len[slot].max(us(bytes));
                used[slot] += 256 / period.cycles();
            }
        }
        // Slots used in every cycle first: a slot left unused in some cycles then lies at the
        // block's end, where its time joins the free window instead of opening a window of its
        // own inside the block.
        let mut order: Vec<usize> = (0..n).filter(|&s| len[s] > 0).collect();
        order.sort_by_key(|&s| (std::cmp::Reverse(used[s]), s));
        let mut slots = vec![(0u32, 0u32); n];
        let mut at = 0;
        for s in order {
            slots[s] = (at, len[s]);
            at += len[s];
        }
        Self { slots }
    }

    /// The reservations of cycle `cycle` whose sync announced `mask`, in time order (slots
    /// the calendar does not use are never reserved).
    pub fn of(&self, mask: u64) -> Vec<Reservation> {
        let mut out: Vec<Reservation> = (0..self.slots.len() as u8)
            .filter(|&slot| slot == SYNC_SLOT || mask & (1 << slot) != 0)
            .filter_map(|slot| {
                let (start_us, len) = self.slots[usize::from(slot)];
                (len > 0).then_some(Reservation { slot, start_us, end_us: start_us + len })
            })
            .collect();
        out.sort_by_key(|r| r.start_us);
        out
    }
}
