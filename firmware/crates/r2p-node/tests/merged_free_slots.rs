//! With merged free slots (docs/rtcan.md, "Free slots"), a free slot's window runs to the next
//! reserved slot (or the end of the cycle), so a run of free slots carries frames longer than
//! one slot; a single-slot policy ends it at the next slot.

use r2p_node::{FreeSlots, SlotTx};
use rtcan::cycle::{ClockState, CycleConfig, SlotClock};
use rtcan::SyncFrame;

/// 4 ms cycles of 16 slots of 250 µs.
const CYCLE: CycleConfig = CycleConfig { bit_rate: 1_000_000, cycle_us: 4_000, slots: 16 };

#[test]
fn a_merged_window_ends_at_the_next_reserved_slot_or_the_cycles_end() {
    let mut clock = SlotClock::new(CYCLE);
    // The sync of cycle 1 announces the reservations of cycle 2: slots 5 and 9.
    clock.on_sync(0, &SyncFrame::new(0, 0, false));
    clock.on_sync(4_000, &SyncFrame::new(1, (1 << 5) | (1 << 9), false));
    let at = |us| match clock.state(us) {
        ClockState::Running(p) => p,
        other => panic!("{other:?}"),
    };
    let merged: SlotTx<()> = SlotTx::new(&CYCLE, FreeSlots::Merged);
    let single: SlotTx<()> = SlotTx::new(&CYCLE, FreeSlots::Single);
    let slot_start = |slot: u64| 8_000 + slot * 250;
    let p = at(slot_start(1));
    assert_eq!((p.cycle, p.slot), (2, 1));
    assert_eq!(merged.window_end(&clock, p), Some(slot_start(5)), "up to reserved slot 5");
    assert_eq!(single.window_end(&clock, p), Some(slot_start(2)));
    assert_eq!(merged.window_end(&clock, at(slot_start(6))), Some(slot_start(9)));
    assert_eq!(merged.window_end(&clock, at(slot_start(10))), Some(slot_start(16)), "cycle's end");
}
