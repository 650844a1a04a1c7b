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
    assert!(a.ignored && !a.re_register, "the first sync heard is held");
    let a = f.on_sync(T - 20, &SyncFrame::new(1, 0, false));
    assert!(a.re_register, "the first sync followed registers the streams");
    let mut at = T - 20;
    // Within the sync tolerance (0.5 % of the cycles since the last sync: 50 µs per cycle).
    for (cycle, offset) in [(2, 15i64), (3, -20), (4, 20), (6, 0)] {
        let now = (cycle * T as i64 + offset) as u64;
        let a = f.on_sync(now, &SyncFrame::new(cycle as u32, 0, false));
        assert!(!a.re_register, "sync of cycle {cycle} {offset} µs off: the same master's cycle");
        assert!(!a.out_of_turn, "sync of cycle {cycle} {offset} µs off is on the grid");
        at = now;
    }
    // 2 ms early is off the grid (docs/rtcan.md, "Babblers"): skipped, the cycle goes on.
    let a = f.on_sync(at + T - 2_000, &SyncFrame::new(7, 0, false));
    assert!(a.out_of_turn && !a.re_register, "a sync 2 ms early is out of turn");
    let a = f.on_sync(at + T, &SyncFrame::new(7, 0, false));
    assert!(!a.out_of_turn && !a.re_register, "the master's own sync of cycle 7 continues");
    let at = at + T;
    // A sync whose counter does not match the elapsed cycles is another master's: while the
    // node is synced it is out of sequence, skipped; once the sync timeout has passed without a
    // sync it follows, the node follows it and registers its streams again.
    let mut outcomes = Vec::new();
    for k in 1..=4u64 {
        let now = at + k * T;
        f.poll(now);
        let a = f.on_sync(now, &SyncFrame::new(8 + k as u32, 0, false));
        outcomes.push((a.out_of_turn, a.re_register));
    }
    assert_eq!(outcomes, [(true, false), (true, false), (true, false), (false, true)]);
}
