//! A publisher follows its remote subscribers (node/subscribers.rs): the export stops when
//! none of them has been heard for the peer timeout (no more frames on the bus; an HRT stream
//! gives its slot back), not while one stays, and a subscriber that returns gets the stream
//! again.

use heapless::Vec;
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use rtcan::Micros;

use crate::node::{Event, HrtState, PEER_TIMEOUT_HEARTBEATS};
use crate::remote::Export;
use crate::tdma_tests::{tdma, CYCLE, CYCLE_US};
use crate::testbus::{run_slots, Bus, TestNode};
use crate::{NoParams, NodeConfig, RemotePublisher, RemoteSubscriber};

/// The test nodes' heartbeat period (tdma_tests::tdma).
const HEARTBEAT_US: Micros = 20_000;
/// From a subscriber's last heartbeat to its publisher's check that drops it, at most.
const LEAVE_US: Micros = (PEER_TIMEOUT_HEARTBEATS + 2) * HEARTBEAT_US;

/// The exports of every `SubscribersLeft` event `n` had queued (also `unsubscribe_tests.rs`).
pub(crate) fn departures(n: &mut TestNode<'_>) -> Vec<usize, 8> {
    let mut v = Vec::new();
    while let Some(e) = n.next_event() {
        if let Event::SubscribersLeft { export } = e {
            let _ = v.push(export);
        }
    }
    v
}

#[test]
fn a_publisher_stops_sending_when_its_last_subscriber_left() {
    static T: Topic<'static, u8, { pool_size(&[2], 1) }, 1> = Topic::new("status", 0);
    static P: Publisher<'static, u8> = Publisher::new(&T, Class::NonRealTime);
    static O: RemoteSubscriber<'static, u8, 2> = RemoteSubscriber::new(&P);
    static LB: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("status", 0);
    static LPB: Publisher<'static, u8> = Publisher::new(&LB, Class::NonRealTime);
    static IB: RemotePublisher<'static, u8> = RemotePublisher::new(&LPB, &LB);
    static SB: Subscriber<'static, u8, 4> = Subscriber::new();
    static LC: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("status", 0);
    static LPC: Publisher<'static, u8> = Publisher::new(&LC, Class::NonRealTime);
    static IC: RemotePublisher<'static, u8> = RemotePublisher::new(&LPC, &LC);
    static SC: Subscriber<'static, u8, 4> = Subscriber::new();
    T.subscribe(&O).unwrap();
    LB.subscribe(&SB).unwrap();
    LC.subscribe(&SC).unwrap();

    let bus = Bus::<4>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "a", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "b", None), &NoParams).unwrap();
    let mut c = TestNode::new(tdma(4, "c", None), &NoParams).unwrap();
    a.export(&O).unwrap();
    b.import(&IB).unwrap();
    c.import(&IC).unwrap();
    let nodes = &mut [&mut m, &mut a, &mut b, &mut c];
    run_slots(&bus, nodes, 300_000);
    P.publish_with(|v| *v = 1).unwrap();
    let until = bus.now.get() + 20_000;
    run_slots(&bus, nodes, until);
    assert_eq!((SB.try_recv().map(|v| *v), SC.try_recv().map(|v| *v)), (Some(1), Some(1)));
    assert_eq!(departures(nodes[1]), Vec::<usize, 8>::new());

    // B's module leaves: A keeps sending for C, which stays, however long.
    bus.power(2, false);
    let until = bus.now.get() + 2 * LEAVE_US;
    run_slots(&bus, nodes, until);
    assert_eq!(departures(nodes[1]), Vec::<usize, 8>::new());
    assert!(O.active_len() > 0, "C is still subscribed");
    let queued = nodes[1].stats().queued;
    P.publish_with(|v| *v = 2).unwrap();
    let until = bus.now.get() + 20_000;
    run_slots(&bus, nodes, until);
    assert_eq!(SC.try_recv().map(|v| *v), Some(2));
    assert_eq!(nodes[1].stats().queued, queued + 1);

    // C leaves too: A's export stops, and what it publishes no longer takes the bus.
    bus.power(3, false);
    let until = bus.now.get() + LEAVE_US;
    run_slots(&bus, nodes, until);
    assert_eq!(departures(nodes[1]), [0]);
    assert_eq!(O.active_len(), 0);
    let queued = nodes[1].stats().queued;
    for k in 0..12 {
        P.publish_with(|v| *v = 10 + k).unwrap();
        let until = bus.now.get() + CYCLE_US;
        run_slots(&bus, nodes, until);
    }
    assert_eq!(nodes[1].stats().queued, queued, "nothing published went to the bus");

    // B comes back: it hears A, asks again, and the stream runs again.
    bus.power(2, true);
    let until = bus.now.get() + 200_000;
    run_slots(&bus, nodes, until);
    while SB.try_recv().is_some() {}
    P.publish_with(|v| *v = 3).unwrap();
    let until = bus.now.get() + 20_000;
    run_slots(&bus, nodes, until);
    assert_eq!(SB.try_recv().map(|v| *v), Some(3));
    assert_eq!(bus.violations(), 0);
}

#[test]
fn an_hrt_publisher_gives_its_slot_back_when_its_subscriber_left() {
    static T: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("setpoint", 0);
    static P: Publisher<'static, u8> =
        Publisher::new(&T, Class::SyncRealTime { period_us: CYCLE_US as u32 });
    static O: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P);
    static L: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("setpoint", 0);
    static LP: Publisher<'static, u8> = Publisher::new(&L, Class::NonRealTime);
    static I: RemotePublisher<'static, u8> = RemotePublisher::new(&LP, &L);
    static S: Subscriber<'static, u8, 4> = Subscriber::new();
    T.subscribe(&O).unwrap();
    L.subscribe(&S).unwrap();

    let bus = Bus::<3>::slotted(CYCLE);
    let mut m =
        TestNode::new(NodeConfig { hrt_slots: 1, ..tdma(1, "psu", Some(0)) }, &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "a", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "b", None), &NoParams).unwrap();
    a.export(&O).unwrap();
    b.import(&I).unwrap();
    let nodes = &mut [&mut m, &mut a, &mut b];
    run_slots(&bus, nodes, 300_000);
    assert!(matches!(nodes[1].hrt_state(0), Some(HrtState::Granted { .. })));

    // B leaves: A releases its slot, the master's calendar is empty again.
    bus.power(2, false);
    let until = bus.now.get() + LEAVE_US;
    run_slots(&bus, nodes, until);
    assert_eq!(departures(nodes[1]), [0]);
    assert_eq!(nodes[1].hrt_state(0), Some(HrtState::Idle));
    assert_eq!(nodes[0].stats().hrt_released, 1);
    assert_eq!(O.active_len(), 0);

    // B comes back: A asks for the slot again, gets it, and B receives.
    bus.power(2, true);
    let until = bus.now.get() + 300_000;
    run_slots(&bus, nodes, until);
    assert!(matches!(nodes[1].hrt_state(0), Some(HrtState::Granted { .. })));
    while S.try_recv().is_some() {}
    P.publish_with(|v| *v = 5).unwrap();
    let until = bus.now.get() + 3 * CYCLE_US;
    run_slots(&bus, nodes, until);
    assert_eq!(S.try_recv().map(|v| *v), Some(5));
    assert_eq!(bus.violations(), 0);
}
