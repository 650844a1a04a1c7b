//! The master's reservations follow their nodes' lives (node/liveness.rs): a node that goes
//! silent loses its slots and another node gets them; a node that reboots registers again,
//! even with another period.

use heapless::Vec;
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use rtcan::Micros;

use crate::node::{Event, HrtState, NodeConfig, PEER_TIMEOUT_HEARTBEATS};
use crate::remote::Export;
use crate::tdma_tests::{tdma, CYCLE, CYCLE_US};
use crate::testbus::{run_slots, Bus, TestNode};
use crate::{NoParams, RemotePublisher, RemoteSubscriber};

/// Every cycle: a stream of this period fills one HRT slot.
const EVERY_CYCLE: Class = Class::SyncRealTime { period_us: CYCLE_US as u32 };
/// The test nodes' heartbeat period (tdma_tests::tdma).
const HEARTBEAT_US: Micros = 20_000;

fn granted(n: &TestNode<'_>, export: usize) -> bool {
    matches!(n.hrt_state(export), Some(HrtState::Granted { .. }))
}

#[test]
fn a_silent_nodes_slot_is_released_after_the_timeout_and_granted_to_another() {
    static TA: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("left", 0);
    static PA: Publisher<'static, u8> = Publisher::new(&TA, EVERY_CYCLE);
    static OA: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&PA);
    static TC: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("right", 0);
    static PC: Publisher<'static, u8> = Publisher::new(&TC, EVERY_CYCLE);
    static OC: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&PC);
    static L1: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("left", 0);
    static LP1: Publisher<'static, u8> = Publisher::new(&L1, Class::NonRealTime);
    static I1: RemotePublisher<'static, u8> = RemotePublisher::new(&LP1, &L1);
    static S1: Subscriber<'static, u8, 4> = Subscriber::new();
    static L2: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("right", 0);
    static LP2: Publisher<'static, u8> = Publisher::new(&L2, Class::NonRealTime);
    static I2: RemotePublisher<'static, u8> = RemotePublisher::new(&LP2, &L2);
    static S2: Subscriber<'static, u8, 4> = Subscriber::new();
    TA.subscribe(&OA).unwrap();
    TC.subscribe(&OC).unwrap();
    L1.subscribe(&S1).unwrap();
    L2.subscribe(&S2).unwrap();

    // The master's calendar has one HRT slot: A's every-cycle stream fills it.
    let bus = Bus::<4>::slotted(CYCLE);
    let mut m =
        TestNode::new(NodeConfig { hrt_slots: 1, ..tdma(1, "psu", Some(0)) }, &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "a", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "b", None), &NoParams).unwrap();
    let mut c = TestNode::new(tdma(4, "c", None), &NoParams).unwrap();
    a.export(&OA).unwrap();
    c.export(&OC).unwrap();
    b.import(&I1).unwrap();
    b.import(&I2).unwrap();
    bus.power(3, false); // C comes later
    run_slots(&bus, &mut [&mut m, &mut a, &mut b, &mut c], 200_000);
    assert!(granted(&a, 0));

    // A goes silent (cable pulled). Within the timeout its slot stays reserved.
    bus.power(1, false);
    let off = bus.now.get();
    let timeout = PEER_TIMEOUT_HEARTBEATS * HEARTBEAT_US;
    run_slots(&bus, &mut [&mut m, &mut a, &mut b, &mut c], off + timeout - HEARTBEAT_US);
    assert_eq!(m.stats().hrt_released, 0, "a live node's slot is kept through lost heartbeats");
    run_slots(&bus, &mut [&mut m, &mut a, &mut b, &mut c], off + timeout + 2 * HEARTBEAT_US);
    assert_eq!(m.stats().hrt_released, 1, "released once A was silent for the timeout");

    // C arrives: B subscribes to its stream, and the master grants it the freed slot.
    bus.power(3, true);
    let until = bus.now.get() + 300_000;
    run_slots(&bus, &mut [&mut m, &mut a, &mut b, &mut c], until);
    assert!(granted(&c, 0), "{:?}", c.hrt_state(0));
    PC.publish_with(|v| *v = 7).unwrap();
    let until = bus.now.get() + 3 * CYCLE_US;
    run_slots(&bus, &mut [&mut m, &mut a, &mut b, &mut c], until);
    assert_eq!(S2.try_recv().map(|v| *v), Some(7));
    assert_eq!(bus.violations(), 0);
}

#[test]
fn a_rebooted_node_registers_again_even_with_another_period() {
    static T1: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("left", 0);
    static P1: Publisher<'static, u8> = Publisher::new(&T1, EVERY_CYCLE);
    static O1: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P1);
    // The same topic after a firmware update: every other cycle.
    static T2: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("left", 0);
    static P2: Publisher<'static, u8> =
        Publisher::new(&T2, Class::SyncRealTime { period_us: 2 * CYCLE_US as u32 });
    static O2: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P2);
    static L: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("left", 0);
    static LP: Publisher<'static, u8> = Publisher::new(&L, Class::NonRealTime);
    static I: RemotePublisher<'static, u8> = RemotePublisher::new(&LP, &L);
    static S: Subscriber<'static, u8, 4> = Subscriber::new();
    T1.subscribe(&O1).unwrap();
    T2.subscribe(&O2).unwrap();
    L.subscribe(&S).unwrap();

    let bus = Bus::<3>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "a", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "b", None), &NoParams).unwrap();
    a.export(&O1).unwrap();
    b.import(&I).unwrap();
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], 300_000);
    assert!(granted(&a, 0));

    // A reboots into its new image (same unique ID, same node ID and stream), and so does its
    // subscriber B (one that stays up: the next tests): A's old reservation (every cycle)
    // would make its new request (every other cycle) a conflict.
    bus.power(1, false);
    bus.power(2, false);
    let mut a = TestNode::new(tdma(2, "a", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "b", None), &NoParams).unwrap();
    a.export(&O2).unwrap();
    b.import(&I).unwrap();
    bus.power(1, true);
    bus.power(2, true);
    let until = bus.now.get() + 400_000;
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
    assert_eq!(m.stats().hrt_released, 1, "the reboot released the old reservation");
    assert!(granted(&a, 0), "{:?}", a.hrt_state(0));
    assert_eq!(bus.violations(), 0);
}

#[test]
fn a_live_node_keeps_its_slot_as_its_uptime_grows() {
    // Heartbeats every 20 ms for 3.5 s: the uptime they carry goes 0, 1, 2, 3 — a node that
    // keeps running is never taken for one that rebooted.
    static T: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("left", 0);
    static P: Publisher<'static, u8> = Publisher::new(&T, EVERY_CYCLE);
    static O: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P);
    static L: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("left", 0);
    static LP: Publisher<'static, u8> = Publisher::new(&L, Class::NonRealTime);
    static I: RemotePublisher<'static, u8> = RemotePublisher::new(&LP, &L);
    static S: Subscriber<'static, u8, 4> = Subscriber::new();
    T.subscribe(&O).unwrap();
    L.subscribe(&S).unwrap();
    let bus = Bus::<3>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "a", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "b", None), &NoParams).unwrap();
    a.export(&O).unwrap();
    b.import(&I).unwrap();
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], 3_500_000);
    assert!(granted(&a, 0));
    assert_eq!(m.stats().hrt_released, 0);
}

#[test]
fn a_subscriber_that_stays_up_gets_a_rebooted_publishers_messages_again() {
    // The publisher's export before and after its reboot: a fresh one has no subscribers.
    static T: Topic<'static, u8, { pool_size(&[2, 2], 1) }, 2> = Topic::new("state", 0);
    static P: Publisher<'static, u8> = Publisher::new(&T, Class::NonRealTime);
    static O1: RemoteSubscriber<'static, u8, 2> = RemoteSubscriber::new(&P);
    static O2: RemoteSubscriber<'static, u8, 2> = RemoteSubscriber::new(&P);
    static L: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("state", 0);
    static LP: Publisher<'static, u8> = Publisher::new(&L, Class::NonRealTime);
    static I: RemotePublisher<'static, u8> = RemotePublisher::new(&LP, &L);
    static S: Subscriber<'static, u8, 4> = Subscriber::new();
    T.subscribe(&O1).unwrap();
    T.subscribe(&O2).unwrap();
    L.subscribe(&S).unwrap();

    let bus = Bus::<3>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "a", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "b", None), &NoParams).unwrap();
    a.export(&O1).unwrap();
    b.import(&I).unwrap();
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], 300_000);
    P.publish_with(|v| *v = 1).unwrap();
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], 320_000);
    assert_eq!(S.try_recv().map(|v| *v), Some(1));

    // A reboots (same image, same node ID); B stays up, subscribed as far as it knows.
    bus.power(1, false);
    let mut a = TestNode::new(tdma(2, "a", None), &NoParams).unwrap();
    a.export(&O2).unwrap();
    bus.power(1, true);
    let until = bus.now.get() + 200_000;
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
    assert!(O2.active_len() > 0, "B subscribed again when A advertised while starting");
    P.publish_with(|v| *v = 2).unwrap();
    let until = bus.now.get() + 20_000;
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
    assert_eq!(S.try_recv().map(|v| *v), Some(2));
    assert_eq!(bus.violations(), 0);
}

/// Every `PublisherSilent` event `n` had queued.
fn silences(n: &mut TestNode<'_>) -> Vec<usize, 8> {
    let mut v = Vec::new();
    while let Some(e) = n.next_event() {
        if let Event::PublisherSilent { import, .. } = e {
            let _ = v.push(import);
        }
    }
    v
}

#[test]
fn a_subscriber_learns_that_its_publisher_went_silent() {
    // An HRT stream every cycle, and a plain (NRT) one from another module.
    static TH: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("setpoint", 0);
    static PH: Publisher<'static, u8> = Publisher::new(&TH, EVERY_CYCLE);
    static OH: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&PH);
    static TN: Topic<'static, u8, { pool_size(&[2], 1) }, 1> = Topic::new("status", 0);
    static PN: Publisher<'static, u8> = Publisher::new(&TN, Class::NonRealTime);
    static ON: RemoteSubscriber<'static, u8, 2> = RemoteSubscriber::new(&PN);
    static LH: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("setpoint", 0);
    static LPH: Publisher<'static, u8> = Publisher::new(&LH, Class::NonRealTime);
    static IH: RemotePublisher<'static, u8> = RemotePublisher::new(&LPH, &LH);
    static SH: Subscriber<'static, u8, 4> = Subscriber::new();
    static LN: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("status", 0);
    static LPN: Publisher<'static, u8> = Publisher::new(&LN, Class::NonRealTime);
    static IN: RemotePublisher<'static, u8> = RemotePublisher::new(&LPN, &LN);
    static SN: Subscriber<'static, u8, 4> = Subscriber::new();
    TH.subscribe(&OH).unwrap();
    TN.subscribe(&ON).unwrap();
    LH.subscribe(&SH).unwrap();
    LN.subscribe(&SN).unwrap();

    let bus = Bus::<4>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "a", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "b", None), &NoParams).unwrap();
    let mut c = TestNode::new(tdma(4, "c", None), &NoParams).unwrap();
    a.export(&OH).unwrap();
    c.export(&ON).unwrap();
    b.import(&IH).unwrap();
    b.import(&IN).unwrap();
    let nodes = &mut [&mut m, &mut a, &mut b, &mut c];
    // A publishes every cycle for a while: no silence.
    for _ in 0..100 {
        PH.publish_with(|v| *v = 1).unwrap();
        let until = bus.now.get() + CYCLE_US;
        run_slots(&bus, nodes, until);
    }
    assert!(SH.try_recv().is_some());
    assert_eq!(silences(nodes[2]), Vec::<usize, 8>::new());
    // A stops publishing (alive, heartbeats go on): two periods plus a heartbeat period later
    // B knows, once.
    let until = bus.now.get() + 2 * CYCLE_US + 2 * HEARTBEAT_US;
    run_slots(&bus, nodes, until);
    assert_eq!(silences(nodes[2]), [0]);
    let until = bus.now.get() + 5 * HEARTBEAT_US;
    run_slots(&bus, nodes, until);
    assert_eq!(silences(nodes[2]), Vec::<usize, 8>::new(), "raised once");
    // C's module leaves (its cable pulled): after the peer timeout B knows.
    bus.power(3, false);
    let until = bus.now.get() + (PEER_TIMEOUT_HEARTBEATS + 2) * HEARTBEAT_US;
    run_slots(&bus, nodes, until);
    assert_eq!(silences(nodes[2]), [1]);
    // C comes back: B hears it, asks again, and C's messages arrive.
    bus.power(3, true);
    let until = bus.now.get() + 200_000;
    run_slots(&bus, nodes, until);
    PN.publish_with(|v| *v = 9).unwrap();
    let until = bus.now.get() + 20_000;
    run_slots(&bus, nodes, until);
    assert_eq!(SN.try_recv().map(|v| *v), Some(9));
    assert_eq!(bus.violations(), 0);
}
