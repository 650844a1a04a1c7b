//! Master failover that continues the cycle (issue 22; docs/rtcan.md, "Master failover"): a
//! standby that keeps the master's calendar takes over at the next cycle's start when a sync is
//! missing, so HRT streams keep their slots and nobody registers again; the master coming back
//! does not take the bus back; of two standbys the better rank wins; a standby that does not
//! know the calendar yet starts a new one, as before.

use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use rtcan::failover::Role;
use rtcan::Micros;

use crate::node::HrtState;
use crate::tdma_tests::{tdma, CYCLE, CYCLE_US};
use crate::testbus::{run_slots, Bus, TestNode};
use crate::{NoParams, RemotePublisher, RemoteSubscriber};

/// Every cycle: a stream of this period fills one HRT slot.
const EVERY_CYCLE: Class = Class::SyncRealTime { period_us: CYCLE_US as u32 };
/// Long enough for a standby to trust its copy: 256 syncs of 4 ms after the grant.
const TRUSTED_AT: Micros = 1_400_000;

fn granted(n: &TestNode<'_>) -> Option<rtcan::Phase> {
    match n.hrt_state(0) {
        Some(HrtState::Granted { slots }) => Some(slots.first()),
        _ => None,
    }
}

/// Runs `cycles` cycles, the publisher publishing `*k` (then `k + 1`) at each cycle's start;
/// returns how many the subscriber received and checks that the stream never left its phase.
fn publish_cycles(
    bus: &Bus<4>,
    nodes: &mut [&mut TestNode<'_>],
    publisher: &'static Publisher<'static, u8>,
    subscriber: &'static Subscriber<'static, u8, 4>,
    k: &mut u8,
    cycles: u32,
) -> u32 {
    let phase = granted(nodes[1]);
    let mut received = 0;
    for _ in 0..cycles {
        publisher.publish_with(|v| *v = *k).unwrap();
        *k = k.wrapping_add(1);
        let until = bus.now.get() + CYCLE_US;
        run_slots(bus, nodes, until);
        while subscriber.try_recv().is_some() {
            received += 1;
        }
        assert_eq!(granted(nodes[1]), phase, "the stream never registers again");
    }
    received
}

#[test]
fn a_standby_that_knows_the_calendar_continues_the_cycle_and_no_hrt_cycle_is_lost() {
    static T: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("setpoint", 0);
    static P: Publisher<'static, u8> = Publisher::new(&T, EVERY_CYCLE);
    static O: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P);
    static L: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("setpoint", 0);
    static LP: Publisher<'static, u8> = Publisher::new(&L, Class::NonRealTime);
    static I: RemotePublisher<'static, u8> = RemotePublisher::new(&LP, &L);
    static S: Subscriber<'static, u8, 4> = Subscriber::new();
    T.subscribe(&O).unwrap();
    L.subscribe(&S).unwrap();

    let bus = Bus::<4>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "motor", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "gateway", Some(1)), &NoParams).unwrap();
    let mut c = TestNode::new(tdma(4, "imu", Some(2)), &NoParams).unwrap();
    a.export(&O).unwrap();
    b.import(&I).unwrap();
    run_slots(&bus, &mut [&mut m, &mut a, &mut b, &mut c], 300_000);
    assert!(granted(&a).is_some());
    assert!(!b.knows_calendar(), "a hyperperiod of syncs is not over yet");
    run_slots(&bus, &mut [&mut m, &mut a, &mut b, &mut c], TRUSTED_AT);
    assert!(b.knows_calendar() && c.knows_calendar());
    let mut k = 0;
    let nodes = &mut [&mut m, &mut a, &mut b, &mut c];
    assert_eq!(publish_cycles(&bus, nodes, &P, &S, &mut k, 10), 10);

    // The master dies a third into a cycle, after its sync: the next sync is missing.
    let death = bus.now.get() + CYCLE_US / 3;
    run_slots(&bus, nodes, death);
    bus.power(0, false);
    let got = publish_cycles(&bus, nodes, &P, &S, &mut k, 30);
    assert_eq!(got, 30, "no HRT message lost over the takeover");
    assert_eq!(nodes[2].role(), Role::Master, "the rank-1 standby took over");
    assert_eq!(nodes[3].role(), Role::Slave, "rank 2 lost the arbitration and follows");
    assert!(nodes[2].stats().syncs_sent >= 29);
    assert_eq!(nodes[3].stats().syncs_sent, 0);
    assert_eq!(bus.violations(), 0);

    // The master comes back (rebooted): it follows, it does not take the bus back.
    bus.power(0, true);
    *nodes[0] = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    // It learns the calendar from the new master's beacon (one table entry per heartbeat: 16
    // heartbeats of 20 ms) and trusts it after a hyperperiod of syncs (256 of 4 ms).
    let got = publish_cycles(&bus, nodes, &P, &S, &mut k, 400);
    assert_eq!(got, 400);
    assert_eq!((nodes[0].role(), nodes[2].role()), (Role::Slave, Role::Master));
    assert!(nodes[0].knows_calendar(), "it could stand by again");
    assert_eq!(bus.violations(), 0);
}

#[test]
fn a_standby_that_does_not_know_the_calendar_yet_starts_a_new_one() {
    static T: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("setpoint", 0);
    static P: Publisher<'static, u8> = Publisher::new(&T, EVERY_CYCLE);
    static O: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P);
    static L: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("setpoint", 0);
    static LP: Publisher<'static, u8> = Publisher::new(&L, Class::NonRealTime);
    static I: RemotePublisher<'static, u8> = RemotePublisher::new(&LP, &L);
    T.subscribe(&O).unwrap();
    L.subscribe(&S).unwrap();
    static S: Subscriber<'static, u8, 4> = Subscriber::new();

    let bus = Bus::<4>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "motor", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "gateway", Some(1)), &NoParams).unwrap();
    let mut c = TestNode::new(tdma(4, "imu", None), &NoParams).unwrap();
    a.export(&O).unwrap();
    b.import(&I).unwrap();
    run_slots(&bus, &mut [&mut m, &mut a, &mut b, &mut c], 300_000);
    let before = granted(&a);
    assert!(before.is_some() && !b.knows_calendar());
    bus.power(0, false);
    let until = bus.now.get() + 20 * CYCLE_US;
    run_slots(&bus, &mut [&mut m, &mut a, &mut b, &mut c], until);
    assert_eq!(b.role(), Role::Master, "taken over after the rank-ordered delay");
    assert!(b.knows_calendar(), "its own, new calendar");
    assert!(granted(&a).is_some(), "the publisher registered again: {:?}", a.hrt_state(0));
    assert_eq!(bus.violations(), 0);
}
