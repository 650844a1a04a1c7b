//! A standby's rank is the number its configuration gives (docs/rtcan.md, "Master failover"):
//! 0 to 15, read back unchanged (tools print it, the takeover delay is computed from it).

use rtcan::failover::{takeover_delay_us, Rank, MAX_RANK, RANK_STEP_CYCLES, TAKEOVER_BASE_CYCLES};

#[test]
fn every_rank_reads_back_as_given_and_sixteen_is_refused() {
    for r in 0..=MAX_RANK {
        assert_eq!(Rank::new(r).map(Rank::get), Some(r));
    }
    assert_eq!(Rank::new(MAX_RANK + 1), None);
    assert_eq!(Rank::new(u8::MAX), None);
}

#[test]
fn each_rank_waits_its_steps_longer() {
    let cycle_us = 5_000;
    let delay = |r| takeover_delay_us(Rank::new(r).unwrap(), cycle_us);
    assert_eq!(delay(0), u64::from(TAKEOVER_BASE_CYCLES * cycle_us));
    for r in 1..=MAX_RANK {
        assert_eq!(delay(r) - delay(r - 1), u64::from(RANK_STEP_CYCLES * cycle_us));
    }
}
