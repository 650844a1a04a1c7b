//! What a node's failover state machine reports as the bus sees it (docs/rtcan.md, "Master
//! failover"): a master has no takeover pending, and a slave hearing syncs that come a little
//! early or late (the master's jitter, the bus's arbitration) keeps its streams registered.

use rtcan::failover::{Actions, Rank, Role};
use rtcan::{Failover, SyncFrame};

const CYCLE_US: u32 = 10_000;
const T: u64 = CYCLE_US as u64;

#[test]
fn a_master_has_no_takeover_pending_and_a_standby_has_one() {
    let mut f = Failover::new(Rank::new(1), CYCLE_US, 0);
    assert_eq!(f.takeover_at(), Some(9 * T), "rank 1: L + 2 + (2L + 1) cycles");
    let a = f.poll(9 * T);
    assert!(!a.is_empty() && a.start_syncing.is_some());
    assert_eq!(f.role(), Role::Master);
    assert_eq!(f.takeover_at(), None, "a master takes over from nobody");
    assert!(Actions::default().is_empty());
}

#[test]
fn syncs_a_little_early_or_late_continue_the_cycle() {
    let mut f = Failover::new(None, CYCLE_US, 0);
    let a = f.on_sync(0, &SyncFrame::new(0, 0, false));
    assert!(a.re_register, "the first sync heard registers the streams");
    let mut at = 0;
    for (cycle, offset) in [(1, -40i64), (2, 35), (3, -2_000), (4, 2_000), (6, 0)] {
        let now = (cycle * T as i64 + offset) as u64;
        let a = f.on_sync(now, &SyncFrame::new(cycle as u32, 0, false));
        assert!(!a.re_register, "sync of cycle {cycle} {offset} µs off: the same master's cycle");
        at = now;
    }
    // A sync whose counter does not match the elapsed cycles is another master's.
    let a = f.on_sync(at + T, &SyncFrame::new(9, 0, false));
    assert!(a.re_register);
}
