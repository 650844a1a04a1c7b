//! A master steps down after more than L sync failures *in a row* (docs/rtcan.md, "Master
//! failover"): failures separated by a sync that went out do not add up, so a master on a
//! noisy bus that loses one sync now and then keeps the bus.

use rtcan::cycle::MAX_SYNC_LOSS;
use rtcan::failover::Role;
use rtcan::{Failover, SyncFrame};

const CYCLE_US: u32 = 10_000;

/// A rank-0 node that took over and sent its first sync; returns it and that sync.
fn master() -> (Failover, SyncFrame, u64) {
    let mut f = Failover::new(rtcan::failover::Rank::new(0), CYCLE_US, 0);
    let s = f.poll(40_000).start_syncing.expect("rank 0 takes over after L + 2 silent cycles");
    let sync = SyncFrame::new(s.cycle, 0, s.epoch);
    assert!(f.on_sync_sent(40_000, &sync, true).is_empty());
    (f, sync, 40_000)
}

#[test]
fn failures_separated_by_a_good_sync_never_make_the_master_step_down() {
    let (mut f, sync, mut now) = master();
    // L failures, one sync out, L failures, ...: never more than L in a row.
    for round in 0..4 {
        for _ in 0..MAX_SYNC_LOSS {
            now += u64::from(CYCLE_US);
            let a = f.on_sync_sent(now, &sync, false);
            assert!(a.is_empty(), "round {round}: stepped down after at most L failures in a row");
        }
        now += u64::from(CYCLE_US);
        assert!(f.on_sync_sent(now, &sync, true).is_empty());
        assert_eq!(f.role(), Role::Master, "round {round}");
    }
}

#[test]
fn the_count_restarts_at_the_good_sync_then_l_plus_one_in_a_row_step_down() {
    let (mut f, sync, mut now) = master();
    for _ in 0..MAX_SYNC_LOSS {
        now += u64::from(CYCLE_US);
        f.on_sync_sent(now, &sync, false);
    }
    now += u64::from(CYCLE_US);
    f.on_sync_sent(now, &sync, true);
    let good = now;
    for k in 1..=MAX_SYNC_LOSS {
        now += u64::from(CYCLE_US);
        assert!(f.on_sync_sent(now, &sync, false).is_empty(), "failure {k} after the good sync");
    }
    now += u64::from(CYCLE_US);
    let a = f.on_sync_sent(now, &sync, false);
    assert!(a.stop_syncing && a.re_register, "L + 1 failures in a row: step down");
    assert_eq!(f.role(), Role::Slave);
    // It competes again from its last sync that went out, like every standby that heard it.
    let expected =
        good + rtcan::failover::takeover_delay_us(rtcan::failover::Rank::new(0).unwrap(), CYCLE_US);
    assert_eq!(f.takeover_at(), Some(expected));
}

#[test]
fn the_epoch_is_the_current_masters_and_a_takeover_flips_it() {
    let mut f = Failover::new(rtcan::failover::Rank::new(1), CYCLE_US, 0);
    assert_eq!(f.epoch(), None, "no master heard yet");
    // Not synced: the first sync is held, the second in sequence followed.
    f.on_sync(10_000, &SyncFrame::new(4, 0, true));
    assert_eq!(f.epoch(), None, "a sync held is not followed");
    f.on_sync(20_000, &SyncFrame::new(5, 0, true));
    assert_eq!(f.epoch(), Some(true), "the epoch of the master followed");
    // The master goes silent: this standby takes over with the other epoch.
    let at = f.takeover_at().unwrap();
    let s = f.poll(at).start_syncing.expect("takes over at its time");
    assert_eq!((s.epoch, f.epoch()), (false, Some(false)));
}
