//! How far from where a slave's clock expects it a sync may arrive and still continue the cycle
//! (docs/rtcan.md, `SYNC_TOLERANCE_PPM` = 0.5 % of the elapsed cycles): a master whose crystal
//! drifts or whose sync was delayed within that keeps its slaves' slot grids; beyond it the
//! clock re-phases as for a new master. And the mask of a cycle's slots has one bit per slot.

use rtcan::cycle::{CycleConfig, SlotClock, SYNC_TOLERANCE_PPM};
use rtcan::SyncFrame;

/// A clock that heard syncs 0 and 1 of 10 ms cycles; then sync 2 comes `late_us` late.
fn third_sync_late_by(late_us: u64) -> bool {
    let mut clk = SlotClock::new(CycleConfig::DEFAULT);
    clk.on_sync(0, &SyncFrame::new(0, 0, false));
    clk.on_sync(10_000, &SyncFrame::new(1, 0, false));
    clk.on_sync(20_000 + late_us, &SyncFrame::new(2, 0, false)).continuous
}

#[test]
fn a_sync_within_half_a_percent_of_a_cycle_continues_it_and_beyond_does_not() {
    assert_eq!(SYNC_TOLERANCE_PPM, 5_000);
    // 0.5 % of 10 ms = 50 µs.
    for late in [0, 10, 30, 45, 49, 50] {
        assert!(third_sync_late_by(late), "{late} µs late is within 0.5 %");
    }
    for late in [51, 55, 100, 1_000] {
        assert!(!third_sync_late_by(late), "{late} µs late is beyond 0.5 %");
    }
}

#[test]
fn the_tolerance_grows_with_the_cycles_elapsed_since_the_last_sync() {
    // Sync 2 lost: sync 3 comes two cycles after sync 1, with twice the tolerance (100 µs).
    let late3 = |late_us: u64| {
        let mut clk = SlotClock::new(CycleConfig::DEFAULT);
        clk.on_sync(0, &SyncFrame::new(0, 0, false));
        clk.on_sync(10_000, &SyncFrame::new(1, 0, false));
        clk.on_sync(30_000 + late_us, &SyncFrame::new(3, 0, false))
    };
    let info = late3(90);
    assert!(info.continuous && info.missed == 1, "{info:?}");
    assert!(!late3(110).continuous);
}

#[test]
fn the_mask_of_all_slots_has_one_bit_per_slot() {
    let mask = |slots| CycleConfig { slots, ..CycleConfig::DEFAULT }.all_slots();
    assert_eq!(mask(2), 0b11);
    assert_eq!(mask(16), 0xFFFF);
    assert_eq!(mask(60), (1 << 60) - 1);
    assert_eq!(mask(63), u64::MAX >> 1);
    assert_eq!(mask(64), u64::MAX);
}

#[test]
fn a_cycle_whose_sync_came_off_time_has_its_reservations_unknown() {
    use rtcan::cycle::UNKNOWN_MASK;
    // Sync 1 announces slots 3 and 5 for cycle 2. Sync 2 comes on time: the announcement holds.
    // If it comes 1 ms off (beyond the tolerance: another master, or a re-phased one), its
    // cycle's reservations are not known: every slot counts as reserved (no frame risks an
    // HRT slot) until the next sync announces them.
    let announced = 1 << 3 | 1 << 5;
    let run = |at2: u64| {
        let mut clk = SlotClock::new(CycleConfig::DEFAULT);
        clk.on_sync(0, &SyncFrame::new(0, 0, false));
        clk.on_sync(10_000, &SyncFrame::new(1, announced, false));
        clk.on_sync(at2, &SyncFrame::new(2, 0, false));
        clk.mask(2)
    };
    assert_eq!(run(20_000) & !1, announced, "on time");
    assert_eq!(run(21_000), UNKNOWN_MASK, "off time");
}

#[test]
fn the_period_is_measured_over_the_whole_window_of_syncs() {
    // A master whose crystal runs 0.05 % fast (9 995 µs cycles), its syncs jittering by ±15 µs:
    // over the window of the last 8 syncs (7 cycles) the jitter of the two ends is divided by
    // 7, so the estimate stays within 5 µs of the true period however the window slides.
    let mut clk = SlotClock::new(CycleConfig::DEFAULT);
    let jitter = [0i64, 15, -15, 10, -10, 15, -5, 12, -15, 5, 0, -12, 15, -15, 8, 3];
    for (k, j) in jitter.iter().enumerate() {
        let at = (k as i64 * 9_995 + j) as u64 + 100_000;
        let info = clk.on_sync(at, &SyncFrame::new(k as u32, 0, false));
        assert!(k == 0 || info.continuous, "sync {k}");
        if k >= 7 {
            let period = clk.period_q8() as f64 / 256.0;
            assert!((period - 9_995.0).abs() <= 5.0, "after sync {k}: {period} µs");
        }
    }
}

#[test]
fn every_slot_the_clock_runs_in_has_a_start_time() {
    // Free-running after its last sync (cycle 5 at 50 ms) for FREE_RUN_CYCLES cycles: in each
    // of those cycles the clock's slot has a start (the slot timer is set from it), until the
    // clock is lost.
    use rtcan::cycle::{ClockState, FREE_RUN_CYCLES};
    let mut clk = SlotClock::new(CycleConfig::DEFAULT);
    for k in 0..=5u32 {
        clk.on_sync(u64::from(k) * 10_000, &SyncFrame::new(k, 0, false));
    }
    for k in 0..=FREE_RUN_CYCLES {
        let now = 50_000 + u64::from(k) * 10_000 + 3_300;
        let ClockState::Running(p) = clk.state(now) else { panic!("running {k} cycles on") };
        let start = clk.slot_start(p.cycle, p.slot).expect("a start for the slot it runs in");
        assert!(start <= now && now - start <= 10_000 / 60 + 1, "{start} for {now}");
    }
    assert_eq!(clk.state(50_000 + u64::from(FREE_RUN_CYCLES + 1) * 10_000 + 1), ClockState::Lost);
}
