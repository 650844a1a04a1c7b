//! What an HRT stream's owner relies on beyond the slot it gets (host tests on the slotted
//! loopback bus): a frame goes only in its own stream's occurrences of a shared slot, a newer
//! message supersedes an older one as a counted deadline miss, and only a grant that answers
//! the request and names a slot of the cycle is taken.

use r2p_management::message::{HrtResult, Message, ENCODED_MAX};
use r2p_management::NodeId;
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use rtcan::{fragments, FrameId, Laxity, Phase};

use crate::node::{HrtState, NodeConfig};
use crate::tdma_tests::{tdma, CYCLE, CYCLE_US};
use crate::testbus::{run_slots, Bus, TestNode};
use crate::{NoParams, RemotePublisher, RemoteSubscriber};

/// 8 ms: every second cycle.
const EVERY_2: Class = Class::SyncRealTime { period_us: 8_000 };

fn granted(n: &TestNode<'_>, export: usize) -> Phase {
    match n.hrt_state(export) {
        Some(HrtState::Granted { slots }) => slots.first(),
        other => panic!("export {export} not granted: {other:?}"),
    }
}

/// Puts management message `msg` on node `from`'s management stream.
pub(crate) fn inject<const P: usize>(bus: &Bus<P>, from: u8, msg: &Message) {
    let mut buf = [0u8; ENCODED_MAX];
    let n = msg.encode(&mut buf).unwrap();
    let stream = NodeId::new(from).unwrap().management();
    let template = FrameId { laxity: Laxity::NRT, message: stream, fragment: 0 };
    for f in fragments(template, &buf[..n]).unwrap() {
        bus.inject(f);
    }
}

#[test]
fn two_streams_sharing_a_slot_each_send_only_in_their_own_cycles() {
    // One HRT slot on the master; A offers two streams of period 2: they share the slot, one in
    // even cycles, one in odd ones. Both always have a message waiting.
    static T1: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("left", 0);
    static P1: Publisher<'static, u8> = Publisher::new(&T1, EVERY_2);
    static O1: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P1);
    static T2: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("right", 0);
    static P2: Publisher<'static, u8> = Publisher::new(&T2, EVERY_2);
    static O2: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P2);
    static L1: Topic<'static, u8, { pool_size(&[8], 1) }, 1> = Topic::new("left", 0);
    static LP1: Publisher<'static, u8> = Publisher::new(&L1, Class::NonRealTime);
    static I1: RemotePublisher<'static, u8> = RemotePublisher::new(&LP1, &L1);
    static S1: Subscriber<'static, u8, 8> = Subscriber::new();
    static L2: Topic<'static, u8, { pool_size(&[8], 1) }, 1> = Topic::new("right", 0);
    static LP2: Publisher<'static, u8> = Publisher::new(&L2, Class::NonRealTime);
    static I2: RemotePublisher<'static, u8> = RemotePublisher::new(&LP2, &L2);
    static S2: Subscriber<'static, u8, 8> = Subscriber::new();
    T1.subscribe(&O1).unwrap();
    T2.subscribe(&O2).unwrap();
    L1.subscribe(&S1).unwrap();
    L2.subscribe(&S2).unwrap();

    let bus = Bus::<3>::slotted(CYCLE);
    let mut m =
        TestNode::new(NodeConfig { hrt_slots: 1, ..tdma(1, "psu", Some(0)) }, &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "a", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "b", None), &NoParams).unwrap();
    a.export(&O1).unwrap();
    a.export(&O2).unwrap();
    b.import(&I1).unwrap();
    b.import(&I2).unwrap();
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], 200_000);
    let (p1, p2) = (granted(&a, 0), granted(&a, 1));
    assert_eq!(p1.slot, p2.slot, "one HRT slot: the streams share it");
    assert_ne!(p1.offset, p2.offset);
    let (m1, m2) = (a.node_id().message_id(1), a.node_id().message_id(2));

    bus.clear_hrt_log();
    for k in 0..6u8 {
        // Both streams have a message in every one of their periods.
        P1.publish_with(|v| *v = k).unwrap();
        P2.publish_with(|v| *v = 100 + k).unwrap();
        let until = bus.now.get() + 2 * CYCLE_US;
        run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
    }
    let log = bus.hrt_log();
    assert!(log.len() >= 10, "both streams sent: {log:?}");
    for seen in &log {
        let offset = if seen.message == m1 {
            p1.offset
        } else {
            assert_eq!(seen.message, m2, "only A's two streams are HRT");
            p2.offset
        };
        assert_eq!(seen.slot, p1.slot);
        assert_eq!(seen.cycle % 2, u32::from(offset), "{seen:?} in another stream's cycle");
    }
    let got1: heapless::Vec<u8, 8> = core::iter::from_fn(|| S1.try_recv()).map(|v| *v).collect();
    let got2: heapless::Vec<u8, 8> = core::iter::from_fn(|| S2.try_recv()).map(|v| *v).collect();
    assert_eq!(
        (got1.as_slice(), got2.as_slice()),
        (&[0, 1, 2, 3, 4, 5][..], &[100, 101, 102, 103, 104, 105][..])
    );
    assert_eq!((a.stats().hrt_sent, a.stats().hrt_missed), (12, 0));
    assert_eq!(bus.violations(), 0);
}

#[test]
fn a_message_superseded_before_its_slot_is_a_reported_deadline_miss() {
    // A's stream has room for two waiting messages; two published in one period: only the
    // newer goes out (the implicit deadline is the period), the older is a miss its publisher
    // hears of.
    static T: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("setpoint", 0);
    static P: Publisher<'static, u32> = Publisher::new(&T, EVERY_2);
    static OUT: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&P);
    static L: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("setpoint", 0);
    static LP: Publisher<'static, u32> = Publisher::new(&L, Class::NonRealTime);
    static IN: RemotePublisher<'static, u32> = RemotePublisher::new(&LP, &L);
    static SUB: Subscriber<'static, u32, 4> = Subscriber::new();
    T.advertise(&P).unwrap();
    T.subscribe(&OUT).unwrap();
    L.subscribe(&SUB).unwrap();

    let bus = Bus::<3>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "motor", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "control", None), &NoParams).unwrap();
    a.export(&OUT).unwrap();
    b.import(&IN).unwrap();
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], 150_000);
    granted(&a, 0);
    assert_eq!(P.stats().deadline_misses, 0);

    P.publish_with(|v| *v = 1).unwrap();
    P.publish_with(|v| *v = 2).unwrap();
    let until = bus.now.get() + 2 * CYCLE_US;
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
    assert_eq!(SUB.try_recv().map(|v| *v), Some(2), "the newer message went out");
    assert!(SUB.try_recv().is_none(), "the older one did not");
    assert_eq!(P.stats().deadline_misses, 1, "the publisher heard of the superseded one");
    assert_eq!(a.stats().deadline_misses, 1);
    assert_eq!((a.stats().hrt_sent, a.stats().hrt_missed), (1, 0), "a miss, not a lost slot");
}

#[test]
fn only_a_grant_that_answers_the_request_with_a_slot_of_the_cycle_is_taken() {
    static T: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("setpoint", 0);
    static P: Publisher<'static, u32> = Publisher::new(&T, EVERY_2);
    static OUT: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&P);
    static L: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("setpoint", 0);
    static LP: Publisher<'static, u32> = Publisher::new(&L, Class::NonRealTime);
    static IN: RemotePublisher<'static, u32> = RemotePublisher::new(&LP, &L);
    T.subscribe(&OUT).unwrap();

    let bus = Bus::<3>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "motor", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "control", None), &NoParams).unwrap();
    a.export(&OUT).unwrap();
    b.import(&IN).unwrap();
    // Slot by slot until A has asked the master for a slot: the answer is not in yet.
    let step = u64::from(CYCLE.slot_us());
    while !matches!(a.hrt_state(0), Some(HrtState::Requested { .. })) {
        assert!(bus.now.get() < 200_000, "A never asked for a slot: {:?}", a.hrt_state(0));
        let until = bus.now.get() + step;
        run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
    }
    let message_id = a.node_id().message_id(1).0;
    // A grant of the slot grid (no reservation of its own), or one placing it at `start`.
    let grant_at = |period_cycles, offset, slot, start_us| Message::HrtGrant {
        message_id,
        period_cycles,
        offset,
        slot,
        result: HrtResult::Ok,
        start_us,
        len_us: if start_us == 0 { 0 } else { 115 },
    };
    let grant = |period_cycles, offset, slot| grant_at(period_cycles, offset, slot, 0);
    let bogus = [
        grant(2, 2, 1),           // offset not less than the period
        grant(2, 0, 0),           // slot 0 is the sync's
        grant(2, 1, CYCLE.slots), // beyond the cycle
        grant(4, 1, 1),           // not the period asked for
        grant_at(2, 1, 1, 167),   // a frame-sized reservation: a bus of another layout
    ];
    let master = m.node_id().get();
    for g in &bogus {
        inject(&bus, master, g);
    }
    let unexpected = a.stats().unexpected;
    let until = bus.now.get() + step;
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
    assert_eq!(a.stats().unexpected - unexpected, bogus.len() as u32, "each bogus grant counted");
    assert!(
        matches!(a.hrt_state(0), Some(HrtState::Requested { .. })),
        "no bogus grant was taken: {:?}",
        a.hrt_state(0)
    );
    // The master's own answer is then taken.
    let until = bus.now.get() + 4 * CYCLE_US;
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
    let phase = granted(&a, 0);
    assert!(phase.offset < 2 && (1..CYCLE.slots).contains(&phase.slot), "{phase:?}");
    // Granted: the beacon repeating its grant is taken silently; a grant of a slot it does not
    // hold is counted, and the reservation stays.
    let other = if phase.slot == 1 { 2 } else { 1 };
    let unexpected = a.stats().unexpected;
    inject(&bus, master, &grant(2, phase.offset, phase.slot));
    inject(&bus, master, &grant(2, phase.offset, other));
    let until = bus.now.get() + step;
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
    assert_eq!(a.stats().unexpected - unexpected, 1, "only the slot it does not hold");
    assert_eq!(granted(&a, 0), phase);
}

#[test]
fn an_occurrence_that_cannot_go_out_is_a_missed_deadline_its_publisher_hears_of() {
    // A's controller refuses frames for four periods (its mailboxes stay full: e.g. a bus it
    // cannot win, or a stuck transceiver): each of those occurrences is an HRT miss.
    static T: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("setpoint", 0);
    static P: Publisher<'static, u32> = Publisher::new(&T, EVERY_2);
    static OUT: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&P);
    static L: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("setpoint", 0);
    static LP: Publisher<'static, u32> = Publisher::new(&L, Class::NonRealTime);
    static IN: RemotePublisher<'static, u32> = RemotePublisher::new(&LP, &L);
    static SUB: Subscriber<'static, u32, 4> = Subscriber::new();
    T.advertise(&P).unwrap();
    T.subscribe(&OUT).unwrap();
    L.subscribe(&SUB).unwrap();
    let bus = Bus::<3>::slotted(CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "motor", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(3, "control", None), &NoParams).unwrap();
    a.export(&OUT).unwrap();
    b.import(&IN).unwrap();
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], 150_000);
    granted(&a, 0);

    bus.unplug(1, true);
    for v in 0..4 {
        P.publish_with(|m| *m = v).unwrap();
        let until = bus.now.get() + 2 * CYCLE_US; // one period
        run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
    }
    assert_eq!((a.stats().hrt_sent, a.stats().hrt_missed), (0, 4));
    assert_eq!(a.stats().deadline_misses, 4);
    assert_eq!(P.stats().deadline_misses, 4, "the publisher heard of each");
    assert!(SUB.try_recv().is_none());
    bus.unplug(1, false);
    P.publish_with(|m| *m = 9).unwrap();
    let until = bus.now.get() + 2 * CYCLE_US;
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
    assert_eq!(SUB.try_recv().map(|v| *v), Some(9), "its slot is still its own");
}

#[test]
fn an_unanswered_hrt_request_is_asked_again_after_the_request_timeout() {
    // A master that syncs but never answers (its HRT_GRANTs are lost): A asks again every
    // `request_timeout_us` (30 ms here), not at every slot and not never.
    use rtcan::controller::CanController;
    use rtcan::{Expect, Reassembler, SyncFrame};

    use crate::Wire;

    static T: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("setpoint", 0);
    static P: Publisher<'static, u32> = Publisher::new(&T, EVERY_2);
    static OUT: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&P);
    T.subscribe(&OUT).unwrap();
    let bus = Bus::<2>::slotted(CYCLE);
    let mut a = TestNode::new(tdma(2, "motor", None), &NoParams).unwrap();
    a.export(&OUT).unwrap();
    let slot_us = rtcan::Micros::from(CYCLE.slot_us());
    let mut r: Reassembler<4, 64> = Reassembler::new(1_000_000);
    let mut requests = std::vec::Vec::new();
    let mut t = 0;
    while t < 130_000 {
        bus.now.set(t);
        if t % CYCLE_US == 0 {
            bus.inject(SyncFrame::new((t / CYCLE_US) as u32, 0, false).to_frame());
        }
        if t == 20_000 {
            // A module subscribes: A needs its slot.
            let topic = heapless::String::try_from("setpoint").unwrap();
            let type_hash = <u32 as Wire>::TYPE_HASH;
            inject(
                &bus,
                0x40,
                &Message::SubscribeRequest {
                    target: a.node_id().get(),
                    topic,
                    type_hash,
                    queue_len: 1,
                },
            );
        }
        a.slot_tick(t, &mut bus.port(0));
        bus.arbitrate();
        let mut port = bus.port(1);
        while let Some(rx) = port.try_receive() {
            if let Some(m) = r.accept(&rx.frame, rx.at, Expect::Any) {
                if let Ok(Message::HrtRequest { .. }) = Message::decode(m.data) {
                    requests.push(rx.at);
                }
            }
        }
        t += slot_us;
    }
    assert_eq!(requests.len(), 4, "at {requests:?}");
    // Queued every 30 ms; each goes out in a free slot within a cycle of being queued.
    let spacing = 30_000 - CYCLE_US..30_000 + CYCLE_US;
    assert!(requests.windows(2).all(|w| spacing.contains(&(w[1] - w[0]))), "{requests:?}");
}
