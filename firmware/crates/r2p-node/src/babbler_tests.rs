//! A babbler — a node sending syncs out of turn (a wrong clock, a bug) — while the master lives
//! (issue 22; docs/rtcan.md, "Babblers"): a sync off the followed cycle's grid or out of its
//! sequence is counted and not followed (by a master, unless its rank is better), so the
//! master keeps the bus, the slaves keep its phase and HRT streams lose nothing. A master
//! steps down for an out-of-turn sync of a better rank: that is how a start-up race ends. The
//! rule is `rtcan`'s (`Failover::on_sync`), whose unit tests and proptests time the edges.

use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use rtcan::failover::Role;
use rtcan::{Micros, SyncFrame};

use crate::node::HrtState;
use crate::tdma_tests::{tdma, CYCLE, CYCLE_US};
use crate::testbus::{run_slots, Bus, TestNode};
use crate::{NoParams, RemotePublisher, RemoteSubscriber};

/// Every cycle: a stream of this period fills one HRT slot.
const EVERY_CYCLE: Class = Class::SyncRealTime { period_us: CYCLE_US as u32 };

fn granted(n: &TestNode<'_>) -> Option<rtcan::Phase> {
    match n.hrt_state(0) {
        Some(HrtState::Granted { slots }) => Some(slots.first()),
        _ => None,
    }
}

/// A sync a babbler of rank `rank` sends: any counter, the other epoch, every slot reserved.
fn babble(k: u32, rank: u8) -> rtcan::Frame {
    SyncFrame::new(k.wrapping_mul(37), u64::MAX, k.is_multiple_of(2)).from_rank(rank).to_frame()
}

#[test]
fn a_babbler_ranked_below_the_master_changes_nothing() {
    static T: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("setpoint", 0);
    static P: Publisher<'static, u8> = Publisher::new(&T, EVERY_CYCLE);
    static O: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P);
    static L: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("setpoint", 0);
    static LP: Publisher<'static, u8> = Publisher::new(&L, Class::NonRealTime);
    static I: RemotePublisher<'static, u8> = RemotePublisher::new(&LP, &L);
    static S: Subscriber<'static, u8, 4> = Subscriber::new();
    T.subscribe(&O).unwrap();
    L.subscribe(&S).unwrap();

    let bus = Bus::<3>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "motor", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "gateway", Some(1)), &NoParams).unwrap();
    a.export(&O).unwrap();
    b.import(&I).unwrap();
    let nodes = &mut [&mut m, &mut a, &mut b];
    run_slots(&bus, nodes, 300_000);
    let phase = granted(nodes[1]);
    assert!(phase.is_some());

    // 100 cycles, two babbled syncs in each (a third and two thirds in), from rank 3.
    let mut received = 0;
    for k in 0..100u32 {
        P.publish_with(|v| *v = k as u8).unwrap();
        let start = bus.now.get();
        for third in 1..3 {
            run_slots(&bus, nodes, start + third * CYCLE_US / 3);
            bus.inject(babble(2 * k + third as u32, 3));
        }
        run_slots(&bus, nodes, start + CYCLE_US);
        while S.try_recv().is_some() {
            received += 1;
        }
        assert_eq!(granted(nodes[1]), phase, "the stream never registers again");
    }
    assert_eq!(received, 100, "no HRT message lost");
    assert_eq!((nodes[0].role(), nodes[2].role()), (Role::Master, Role::Slave));
    for n in nodes.iter() {
        assert_eq!(n.stats().syncs_out_of_turn, 200, "every babbled sync counted, none followed");
    }
    assert_eq!(bus.violations(), 0);
}

#[test]
fn an_out_of_turn_sync_of_a_better_rank_is_followed() {
    // A master of rank 1 (the rank-0 module not there yet) and a slave: a rank-0 sync out of
    // turn is what a start-up race looks like to the worse master, which steps down for it.
    let bus = Bus::<2>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "gateway", Some(1)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "motor", None), &NoParams).unwrap();
    let nodes = &mut [&mut m, &mut a];
    run_slots(&bus, nodes, 300_000);
    assert_eq!(nodes[0].role(), Role::Master);
    let at: Micros = bus.now.get() + CYCLE_US / 2;
    run_slots(&bus, nodes, at);
    bus.inject(babble(1, 0));
    run_slots(&bus, nodes, at + 100);
    assert_eq!(nodes[0].role(), Role::Slave, "the worse master steps down");
    assert_eq!(nodes[0].stats().syncs_out_of_turn, 0);
    // Its slave waits for the syncs it follows to stop (the sync timeout) before it follows
    // another.
    assert_eq!(nodes[1].stats().syncs_out_of_turn, 1);
}

#[test]
fn an_out_of_turn_sync_of_the_masters_own_rank_changes_nothing() {
    // Ranks are unique on a bus: a second sender of the master's rank is misconfigured or
    // babbling, and the master keeps the bus.
    let bus = Bus::<2>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "gateway", Some(1)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "motor", None), &NoParams).unwrap();
    let nodes = &mut [&mut m, &mut a];
    run_slots(&bus, nodes, 300_000);
    let at: Micros = bus.now.get() + CYCLE_US / 2;
    run_slots(&bus, nodes, at);
    bus.inject(babble(1, 1));
    run_slots(&bus, nodes, at + 3 * CYCLE_US);
    assert_eq!(nodes[0].role(), Role::Master);
    assert_eq!((nodes[0].stats().syncs_out_of_turn, nodes[1].stats().syncs_out_of_turn), (1, 1));
}
