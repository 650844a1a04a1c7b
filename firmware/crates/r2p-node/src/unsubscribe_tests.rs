//! A subscriber that stays up but no longer wants a topic (`Node::unsubscribe`, issue 22): its
//! publisher drops it at once, the last one leaving stops the stream (an HRT stream gives its
//! slot back), an unsubscription sent while the publisher is out of reach arrives when it is
//! back, and `resubscribe` gets the stream again.

use heapless::Vec;
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use rtcan::Micros;

use crate::node::{HrtState, ImportState};
use crate::remote::Export;
use crate::subscriber_liveness_tests::departures;
use crate::tdma_tests::{tdma, CYCLE, CYCLE_US};
use crate::testbus::{run_slots, Bus, TestNode};
use crate::{NoParams, NodeConfig, NodeError, RemotePublisher, RemoteSubscriber};

/// The test nodes' heartbeat period (tdma_tests::tdma): the publisher checks its subscribers
/// once a period, so the last one unsubscribing stops its export within two.
const HEARTBEAT_US: Micros = 20_000;

#[test]
fn the_last_subscriber_unsubscribing_stops_the_stream_and_resubscribing_starts_it() {
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
    assert_eq!(b.unsubscribe(1), Err(NodeError::NoImport), "b has one import");
    let nodes = &mut [&mut m, &mut a, &mut b, &mut c];
    run_slots(&bus, nodes, 300_000);
    let a_id = nodes[1].node_id();
    assert!(matches!(nodes[2].import_state(0), Some(ImportState::Subscribed { .. })));

    // B unsubscribes: told at its next tick, answered, B's frames stop; C still receives.
    nodes[2].unsubscribe(0).unwrap();
    let until = bus.now.get() + 20_000;
    run_slots(&bus, nodes, until);
    assert_eq!(
        nodes[2].import_state(0),
        Some(ImportState::Unsubscribed { publisher: Some((a_id, 1)) })
    );
    assert_eq!(departures(nodes[1]), Vec::<usize, 8>::new(), "C is still subscribed");
    P.publish_with(|v| *v = 1).unwrap();
    let until = bus.now.get() + 20_000;
    run_slots(&bus, nodes, until);
    assert_eq!((SB.try_recv().map(|v| *v), SC.try_recv().map(|v| *v)), (None, Some(1)));

    // C unsubscribes too: A's export stops within two heartbeat periods (no peer timeout to
    // wait for), and what it publishes no longer takes the bus.
    nodes[3].unsubscribe(0).unwrap();
    let until = bus.now.get() + 2 * HEARTBEAT_US;
    run_slots(&bus, nodes, until);
    assert_eq!(departures(nodes[1]), [0]);
    assert_eq!(O.active_len(), 0);
    let queued = nodes[1].stats().queued;
    for k in 0..5 {
        P.publish_with(|v| *v = 10 + k).unwrap();
        let until = bus.now.get() + CYCLE_US;
        run_slots(&bus, nodes, until);
    }
    assert_eq!(nodes[1].stats().queued, queued, "nothing published went to the bus");
    assert_eq!(SC.try_recv().map(|v| *v), None);

    // B wants the topic again: asked at the next tick, the stream runs again for it alone.
    nodes[2].resubscribe(0).unwrap();
    let until = bus.now.get() + 40_000;
    run_slots(&bus, nodes, until);
    assert!(matches!(nodes[2].import_state(0), Some(ImportState::Subscribed { .. })));
    P.publish_with(|v| *v = 3).unwrap();
    let until = bus.now.get() + 20_000;
    run_slots(&bus, nodes, until);
    assert_eq!((SB.try_recv().map(|v| *v), SC.try_recv().map(|v| *v)), (Some(3), None));
    assert_eq!(nodes[1].stats().unexpected, 0);
    assert_eq!(bus.violations(), 0);
}

#[test]
fn an_hrt_stream_gives_its_slot_back_when_its_subscriber_unsubscribes() {
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

    // B stays up but unsubscribes: A releases the slot within two heartbeat periods, not a
    // peer timeout.
    nodes[2].unsubscribe(0).unwrap();
    let until = bus.now.get() + 2 * HEARTBEAT_US;
    run_slots(&bus, nodes, until);
    assert_eq!(departures(nodes[1]), [0]);
    assert_eq!(nodes[1].hrt_state(0), Some(HrtState::Idle));
    assert_eq!(nodes[0].stats().hrt_released, 1);
    bus.clear_hrt_log();
    let until = bus.now.get() + 4 * CYCLE_US;
    run_slots(&bus, nodes, until);
    assert!(bus.hrt_log().is_empty(), "no HRT frame after the release");

    // B resubscribes: A asks for a slot again, gets it, and B receives.
    nodes[2].resubscribe(0).unwrap();
    let until = bus.now.get() + 200_000;
    run_slots(&bus, nodes, until);
    assert!(matches!(nodes[1].hrt_state(0), Some(HrtState::Granted { .. })));
    while S.try_recv().is_some() {}
    P.publish_with(|v| *v = 5).unwrap();
    let until = bus.now.get() + 3 * CYCLE_US;
    run_slots(&bus, nodes, until);
    assert_eq!(S.try_recv().map(|v| *v), Some(5));
    assert_eq!(bus.violations(), 0);
}

#[test]
fn an_unsubscription_sent_while_the_publisher_is_away_arrives_when_it_is_back() {
    static T: Topic<'static, u8, { pool_size(&[2], 1) }, 1> = Topic::new("status", 0);
    static P: Publisher<'static, u8> = Publisher::new(&T, Class::NonRealTime);
    static O: RemoteSubscriber<'static, u8, 2> = RemoteSubscriber::new(&P);
    static L: Topic<'static, u8, { pool_size(&[4], 1) }, 1> = Topic::new("status", 0);
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
    let nodes = &mut [&mut m, &mut a, &mut b];
    run_slots(&bus, nodes, 300_000);
    let a_id = nodes[1].node_id();

    // A is cut off for 100 ms (half the peer timeout: it does not drop B on its own) while B
    // unsubscribes: B keeps telling it, every request timeout.
    bus.power(1, false);
    nodes[2].unsubscribe(0).unwrap();
    let until = bus.now.get() + 100_000;
    run_slots(&bus, nodes, until);
    assert!(matches!(nodes[2].import_state(0), Some(ImportState::Leaving { .. })));
    assert_eq!(O.active_len(), 2, "A never heard it");

    bus.power(1, true);
    let until = bus.now.get() + 60_000;
    run_slots(&bus, nodes, until);
    assert_eq!(departures(nodes[1]), [0]);
    assert_eq!(O.active_len(), 0);
    assert_eq!(
        nodes[2].import_state(0),
        Some(ImportState::Unsubscribed { publisher: Some((a_id, 1)) })
    );
    assert_eq!(bus.violations(), 0);
}

#[test]
fn a_subscriber_that_leaves_before_the_master_answered_gets_no_stream() {
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
    // No master yet: B's request waits at A for a slot A cannot ask for.
    bus.power(0, false);
    let nodes = &mut [&mut m, &mut a, &mut b];
    run_slots(&bus, nodes, 300_000);
    assert_eq!(nodes[1].hrt_state(0), Some(HrtState::Wanted));
    assert!(matches!(nodes[2].import_state(0), Some(ImportState::Requested { .. })));

    // B gives up before any master answered: A stops wanting the slot.
    nodes[2].unsubscribe(0).unwrap();
    let until = bus.now.get() + 3 * HEARTBEAT_US;
    run_slots(&bus, nodes, until);
    assert!(matches!(nodes[2].import_state(0), Some(ImportState::Unsubscribed { .. })));
    assert_eq!(nodes[1].hrt_state(0), Some(HrtState::Idle));

    // The master arrives: nothing is asked of it, nothing runs.
    bus.power(0, true);
    let until = bus.now.get() + 300_000;
    run_slots(&bus, nodes, until);
    assert_eq!(nodes[1].hrt_state(0), Some(HrtState::Idle));
    assert_eq!(O.active_len(), 0);
    assert!(bus.hrt_log().is_empty(), "no HRT frame on the bus");
    assert_eq!(bus.violations(), 0);
}
