//! A babbler — a node sending syncs out of turn (a wrong clock, a bug) — while the master lives
//! (issue 22; docs/rtcan.md, "Babblers"): a sync off the followed cycle's grid or out of its
//! sequence is counted and not followed (by a master, unless its rank is better), so the
//! master keeps the bus, the slaves keep its phase and HRT streams lose nothing. A master
//! steps down for an out-of-turn sync of a better rank: that is how a start-up race ends. After
//! the master died and every node timed out, a node follows only two syncs in sequence, so a
//! babbler's lone syncs are never followed and the new master's are. The rules are `rtcan`'s
//! (`Failover::on_sync`), whose unit tests and proptests time the edges.

use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use rtcan::cycle::ClockState;
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

/// True if `n` follows a cycle (a sync fed its clock within the last two cycles).
fn follows_a_cycle(n: &TestNode<'_>, now: Micros) -> bool {
    matches!(n.clock().state(now), ClockState::Running(_))
}

#[test]
fn lone_syncs_after_the_master_died_are_never_followed() {
    static T: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("setpoint", 0);
    static P: Publisher<'static, u8> = Publisher::new(&T, EVERY_CYCLE);
    static O: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P);
    static L: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("setpoint", 0);
    static LP: Publisher<'static, u8> = Publisher::new(&L, Class::NonRealTime);
    static I: RemotePublisher<'static, u8> = RemotePublisher::new(&LP, &L);
    static S: Subscriber<'static, u8, 4> = Subscriber::new();
    T.subscribe(&O).unwrap();
    L.subscribe(&S).unwrap();

    // The master (rank 0), a publisher of an every-cycle HRT stream, a rank-1 standby that
    // subscribes to it and does not trust its copy of the calendar yet (a new calendar, then),
    // and a plain node.
    let bus = Bus::<4>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "motor", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "gateway", Some(1)), &NoParams).unwrap();
    let mut c = TestNode::new(tdma(4, "imu", None), &NoParams).unwrap();
    a.export(&O).unwrap();
    b.import(&I).unwrap();
    let nodes = &mut [&mut m, &mut a, &mut b, &mut c];
    run_slots(&bus, nodes, 300_000);
    assert!(granted(nodes[1]).is_some() && !nodes[2].knows_calendar());
    bus.power(0, false);
    let death = bus.now.get();

    // Every node times out (3.5 cycles); lone syncs at odd instants, of other ranks, counters
    // and epochs, each held and none followed. Each restarts the standby's delay (rank 1: 9
    // cycles), as a followed sync would.
    let lone = [(5, 750, 3, 200, false), (7, 1_250, 0, 17, true), (13, 3_500, 9, 201, true)];
    let mut last = 0;
    for (k, &(cycles, us, rank, cycle, epoch)) in lone.iter().enumerate() {
        run_slots(&bus, nodes, death + cycles * CYCLE_US + us);
        last = bus.now.get();
        bus.inject(SyncFrame::new(cycle, u64::MAX, epoch).from_rank(rank).to_frame());
        run_slots(&bus, nodes, last + CYCLE_US);
        for (i, n) in nodes.iter().enumerate().skip(1) {
            assert!(!follows_a_cycle(n, bus.now.get()), "node {i} followed lone sync {k}");
        }
        assert_eq!(nodes[2].role(), Role::Candidate);
    }
    run_slots(&bus, nodes, last + 8 * CYCLE_US);
    assert_eq!(nodes[2].role(), Role::Candidate, "its delay counts from the last lone sync");
    while nodes[2].role() != Role::Master {
        assert!(bus.now.get() < last + 10 * CYCLE_US, "the standby took over");
        run_slots(&bus, nodes, bus.now.get() + 1);
    }

    // The new master's first sync goes out now; a lone sync half a cycle on is held in its
    // place, so the plain nodes follow the master at its third sync, two cycles on.
    let first = bus.now.get();
    run_slots(&bus, nodes, first + CYCLE_US / 2);
    bus.inject(SyncFrame::new(99, u64::MAX, false).from_rank(5).to_frame());
    run_slots(&bus, nodes, first + 2 * CYCLE_US);
    assert!(!follows_a_cycle(nodes[1], bus.now.get()) && !follows_a_cycle(nodes[3], bus.now.get()));
    run_slots(&bus, nodes, first + 3 * CYCLE_US);
    assert!(follows_a_cycle(nodes[1], bus.now.get()) && follows_a_cycle(nodes[3], bus.now.get()));

    // The publisher registers with the new master, and its messages arrive every cycle.
    run_slots(&bus, nodes, first + 40 * CYCLE_US);
    assert!(granted(nodes[1]).is_some(), "registered again: {:?}", nodes[1].hrt_state(0));
    while S.try_recv().is_some() {}
    let mut received = 0;
    for k in 0..20u8 {
        P.publish_with(|v| *v = k).unwrap();
        run_slots(&bus, nodes, bus.now.get() + CYCLE_US);
        while S.try_recv().is_some() {
            received += 1;
        }
    }
    assert_eq!(received, 20);
    assert_eq!(nodes[2].role(), Role::Master);
    // Counted: every sync not followed — the four lone ones and the master's first, which a
    // lone sync displaced — on the plain nodes; on the master, the first two lone ones (each
    // displaced by the next) and the one it heard as master (out of turn).
    let counts = [1, 2, 3].map(|i| nodes[i].stats().syncs_out_of_turn);
    assert_eq!(counts, [5, 3, 5]);
    assert_eq!(bus.violations(), 0);
}
