//! Frame-sized reservations, a what-if of docs/rtcan.md "Capacity": where a cycle's sync and
//! HRT frames would lie if each reservation lasted its own frame's worst case
//! ([`rtcan::cycle::frame_bits_of`] the stream's identifier and payload length, plus
//! [`RESERVATION_GUARD_BITS`])
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

use rtcan::cycle::{SYNC_PAYLOAD_LEN, SYNC_SLOT};
use rtcan::{CycleConfig, FrameId, Laxity, SyncFrame};

use crate::traffic::{Kind, Traffic};
use crate::RESERVATION_GUARD_BITS;

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

/// Where each slot of the calendar lies when reservations are as long as their frames.
#[derive(Clone, Debug)]
pub struct Timeline {
    /// The slots the calendar uses, in time order: slot, offset in the cycle and length, µs.
    slots: Vec<(u8, u32, u32)>,
}

impl Timeline {
    /// The layout of `traffic`'s calendar on `cycle`'s bus: the sync, then every slot the
    /// calendar uses, back to back in slot order, each as long as the longest worst-case frame
    /// of the streams that share it (streams of period 2 alternate in one slot). A slot's
    /// offset is the same in every cycle, so each stream stays strictly periodic; in a cycle
    /// where a slot's streams do not send, its time is free.
    pub fn new(traffic: &Traffic, cycle: CycleConfig, blocks: u8) -> Self {
        let us = |bits: u32| {
            let bits = u64::from(bits + RESERVATION_GUARD_BITS);
            (bits * 1_000_000).div_ceil(u64::from(cycle.bit_rate)) as u32
        };
        let n = usize::from(cycle.slots);
        let mut len = vec![0u32; n];
        // Per slot, the share of cycles its streams send in, in 256ths.
        let mut used = vec![0u32; n];
        // The sync's identifier carries the cycle counter and the sender's rank: the longest.
        let sync_bits = (0..=u8::MAX)
            .flat_map(|c| {
                (0..4).map(move |rank| SyncFrame {
                    sender: rank,
                    ..SyncFrame::new(u32::from(c), 0, false)
                })
            })
            .map(|s| rtcan::cycle::frame_bits_of(s.to_frame().id().to_raw(), SYNC_PAYLOAD_LEN))
            .max()
            .expect("256 counters");
        len[usize::from(SYNC_SLOT)] = us(sync_bits);
        used[usize::from(SYNC_SLOT)] = 256;
        for (&bytes, stream) in traffic.hrt_len.iter().zip(&traffic.streams) {
            if let Kind::Hrt { period, phase } = stream.kind {
                let slot = usize::from(phase.slot);
                let id = FrameId { laxity: Laxity::HRT, message: stream.message, fragment: 0 };
                len[slot] = len[slot].max(us(rtcan::cycle::frame_bits_of(id.to_raw(), bytes)));
                used[slot] += 256 / period.cycles();
            }
        }
        // Slots used in every cycle first: a slot left unused in some cycles then lies at the
        // block's end, where its time joins the free window instead of opening a window of its
        // own inside the block.
        let mut order: Vec<usize> = (0..n).filter(|&s| len[s] > 0).collect();
        order.sort_by_key(|&s| (std::cmp::Reverse(used[s]), s));
        let (k, total) = (usize::from(blocks), order.len());
        let mut at = 0;
        let slots = order
            .into_iter()
            .enumerate()
            .map(|(i, s)| {
                let b = (i * k / total) as u32;
                at = at.max(b * cycle.cycle_us / k as u32);
                at += len[s];
                (s as u8, at - len[s], len[s])
            })
            .collect();
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
