//! The master's cycle keeps its grid (docs/rtcan.md, "The slot timer on a module"): a sync
//! sent late — the slot timer's interrupt held off by a higher-priority one — delays that sync
//! only; the next ones go out at whole cycles from the first, so the slaves' cycle length and
//! the HRT streams' periods stay exact.

use rtcan::controller::CanController;
use rtcan::failover::Role;
use rtcan::{Micros, SyncFrame};

use crate::tdma_tests::{tdma, CYCLE, CYCLE_US};
use crate::testbus::{Bus, TestNode};
use crate::NoParams;

/// The times a lone master's syncs went out over 120 ms, its slot timer driven as
/// `next_slot_at` asks except that the tick of its fourth sync as master fires `late_us` late.
fn sync_times_with_fourth_sync_late_by(late_us: Micros) -> std::vec::Vec<Micros> {
    let bus = Bus::<2>::slotted(CYCLE); // port 1 listens
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut syncs: std::vec::Vec<Micros> = std::vec::Vec::new();
    let (mut t, mut late_done) = (0, false);
    while t < 120_000 {
        if m.role() == Role::Master && !late_done && syncs.len() == 3 && t == syncs[2] + CYCLE_US {
            t += late_us;
            late_done = true;
        }
        bus.now.set(t);
        m.slot_tick(t, &mut bus.port(0));
        bus.arbitrate();
        while let Some(rx) = bus.port(1).try_receive() {
            if SyncFrame::from_frame(&rx.frame).is_ok() {
                syncs.push(rx.at);
            }
        }
        t = m.next_slot_at(t).max(t + 1);
    }
    assert!(late_done && syncs.len() > 10, "{} syncs", syncs.len());
    syncs
}

#[test]
fn a_late_sync_delays_itself_not_the_cycles_after_it() {
    let syncs = sync_times_with_fourth_sync_late_by(40);
    let first = syncs[0];
    for (k, &at) in syncs.iter().enumerate() {
        let on_grid = first + k as Micros * CYCLE_US;
        let expected = if k == 3 { on_grid + 40 } else { on_grid };
        assert_eq!(at, expected, "sync {k}");
    }
}

#[test]
fn a_sync_more_than_a_cycle_late_restarts_the_grid_from_itself() {
    // The master's timer held off for 1.5 cycles (a debugger halt, a flash erase stalling the
    // CPU): that sync goes out late and the cycle restarts from it — no burst of catch-up
    // syncs, no gap.
    let syncs = sync_times_with_fourth_sync_late_by(CYCLE_US + CYCLE_US / 2);
    let gaps: std::vec::Vec<Micros> = syncs.windows(2).map(|w| w[1] - w[0]).collect();
    assert_eq!(gaps[2], 2 * CYCLE_US + CYCLE_US / 2, "the late one");
    assert!(gaps[3..].iter().all(|&g| g == CYCLE_US), "then whole cycles from it: {gaps:?}");
}
