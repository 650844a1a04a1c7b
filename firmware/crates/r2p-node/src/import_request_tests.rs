//! An import's subscription as the bus drives it (docs/middleware.md, "Remote topics"): it asks
//! a publisher once per advertisement it acts on (advertisements repeat for late joiners; only
//! the request timeout, another publisher or a moved stream asks again), takes in the asked
//! stream from the request on, and takes only the asked publisher's answer for the asked topic.

use r2p_management::message::{BusClass, Message, SubscribeResult};
use r2p_management::NodeId;
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use rtcan::controller::CanController;
use rtcan::{fragments, Expect, FrameId, Laxity, MessageId, Reassembler};

use crate::hrt_stream_tests::inject;
use crate::node::{ImportState, NodeConfig};
use crate::testbus::{run, uid, Bus, TestNode};
use crate::{NoParams, RemotePublisher, Wire};

#[test]
fn a_repeated_advertisement_does_not_repeat_a_pending_subscription_request() {
    static L: Topic<'static, u32, { pool_size(&[1], 1) }, 1> = Topic::new("speed", 0);
    static LP: Publisher<'static, u32> = Publisher::new(&L, Class::NonRealTime);
    static IN: RemotePublisher<'static, u32> = RemotePublisher::new(&LP, &L);
    let bus = Bus::<2>::new();
    let config = NodeConfig {
        heartbeat_period_us: 10_000,
        request_timeout_us: 30_000,
        ..NodeConfig::new(uid(1), "control")
    };
    let mut b = TestNode::new(config, &NoParams).unwrap();
    b.import(&IN).unwrap();
    run(&bus, &mut [&mut b], 5_000);
    // A publisher (node 0x40, not on the bus otherwise) advertises `speed` three times within
    // the request timeout; it never answers.
    let ad = Message::Advertise {
        topic: heapless::String::try_from("speed").unwrap(),
        type_hash: <u32 as Wire>::TYPE_HASH,
        size: <u32 as Wire>::SIZE as u16,
        index: 1,
        class: BusClass::Nrt,
    };
    let mut requests = 0;
    let mut r: Reassembler<4, 64> = Reassembler::new(1_000_000);
    for _ in 0..3 {
        inject(&bus, 0x40, &ad);
        let until = bus.now.get() + 5_000;
        run(&bus, &mut [&mut b], until);
        let mut port = bus.port(1);
        while let Some(rx) = port.try_receive() {
            if let Some(m) = r.accept(&rx.frame, rx.at, Expect::Any) {
                if matches!(Message::decode(m.data), Ok(Message::SubscribeRequest { .. })) {
                    requests += 1;
                }
            }
        }
    }
    assert_eq!(requests, 1, "one request for one publisher's advertisement");
}

#[test]
fn the_first_message_right_behind_the_publishers_answer_is_taken_in() {
    // The filters admit the asked-for stream from the request on: a publisher whose stream
    // already runs for other subscribers sends its next frame right behind its answer, before
    // the subscriber has read the answer (and reprogrammed its filters).
    static L: Topic<'static, u32, { pool_size(&[1], 1) }, 1> = Topic::new("speed", 0);
    static LP: Publisher<'static, u32> = Publisher::new(&L, Class::NonRealTime);
    static IN: RemotePublisher<'static, u32> = RemotePublisher::new(&LP, &L);
    static S: Subscriber<'static, u32, 1> = Subscriber::new();
    L.subscribe(&S).unwrap();
    let bus = Bus::<1>::new();
    let config = NodeConfig { heartbeat_period_us: 10_000, ..NodeConfig::new(uid(1), "control") };
    let mut b = TestNode::new(config, &NoParams).unwrap();
    b.import(&IN).unwrap();
    run(&bus, &mut [&mut b], 5_000);
    let publisher = NodeId::new(0x40).unwrap();
    let topic = || heapless::String::try_from("speed").unwrap();
    let type_hash = <u32 as Wire>::TYPE_HASH;
    let class = BusClass::Nrt;
    inject(
        &bus,
        publisher.get(),
        &Message::Advertise { topic: topic(), type_hash, size: 4, index: 1, class },
    );
    run(&bus, &mut [&mut b], 10_000);
    assert!(matches!(b.import_state(0), Some(ImportState::Requested { .. })));

    let stream = publisher.message_id(1);
    let (target, result) = (b.node_id().get(), SubscribeResult::Ok);
    inject(
        &bus,
        publisher.get(),
        &Message::SubscribeResponse { target, topic: topic(), result, message_id: stream.0 },
    );
    let mut data = [0u8; 4];
    42u32.encode(&mut data).unwrap();
    let template = FrameId { laxity: Laxity::NRT, message: stream, fragment: 0 };
    for f in fragments(template, &data).unwrap() {
        bus.inject(f);
    }
    run(&bus, &mut [&mut b], 15_000);
    assert_eq!(
        b.import_state(0),
        Some(ImportState::Subscribed { from: publisher, message: stream })
    );
    assert_eq!(S.try_recv().as_deref(), Some(&42), "the first message is not lost");
    assert_eq!(b.stats().unknown_frames, 0);
}

/// A node importing `speed`, run past its boot; the SUBSCRIBE_REQUESTs it sent since the last
/// call are counted by [`requests_to`].
fn importer(bus: &Bus<2>, import: &'static RemotePublisher<'static, u32>) -> TestNode<'static> {
    let config = NodeConfig {
        heartbeat_period_us: 10_000,
        request_timeout_us: 100_000,
        ..NodeConfig::new(uid(1), "control")
    };
    let mut b = TestNode::new(config, &NoParams).unwrap();
    b.import(import).unwrap();
    run(bus, &mut [&mut b], 5_000);
    b
}

/// SUBSCRIBE_REQUESTs that reached port 1 since the last call, by target.
fn requests_to(bus: &Bus<2>) -> std::vec::Vec<u8> {
    let mut r: Reassembler<4, 64> = Reassembler::new(1_000_000);
    let mut port = bus.port(1);
    let mut out = std::vec::Vec::new();
    while let Some(rx) = port.try_receive() {
        if let Some(m) = r.accept(&rx.frame, rx.at, Expect::Any) {
            if let Ok(Message::SubscribeRequest { target, .. }) = Message::decode(m.data) {
                out.push(target);
            }
        }
    }
    out
}

fn advertise(index: u8) -> Message {
    let topic = heapless::String::try_from("speed").unwrap();
    Message::Advertise {
        topic,
        type_hash: <u32 as Wire>::TYPE_HASH,
        size: 4,
        index,
        class: BusClass::Nrt,
    }
}

fn respond(target: u8, topic: &str, result: SubscribeResult, message: MessageId) -> Message {
    let topic = heapless::String::try_from(topic).unwrap();
    Message::SubscribeResponse { target, topic, result, message_id: message.0 }
}

#[test]
fn a_subscribed_import_ignores_its_publishers_repeated_advertisements() {
    static L: Topic<'static, u32, { pool_size(&[1], 1) }, 1> = Topic::new("speed", 0);
    static LP: Publisher<'static, u32> = Publisher::new(&L, Class::NonRealTime);
    static IN: RemotePublisher<'static, u32> = RemotePublisher::new(&LP, &L);
    let bus = Bus::<2>::new();
    let mut b = importer(&bus, &IN);
    let a = NodeId::new(0x40).unwrap();
    inject(&bus, a.get(), &advertise(1));
    run(&bus, &mut [&mut b], 10_000);
    assert_eq!(requests_to(&bus), [0x40]);
    inject(
        &bus,
        a.get(),
        &respond(b.node_id().get(), "speed", SubscribeResult::Ok, a.message_id(1)),
    );
    run(&bus, &mut [&mut b], 15_000);
    let subscribed = Some(ImportState::Subscribed { from: a, message: a.message_id(1) });
    assert_eq!(b.import_state(0), subscribed);
    // The publisher repeats its advertisement for late joiners.
    for k in 0..3 {
        inject(&bus, a.get(), &advertise(1));
        run(&bus, &mut [&mut b], 20_000 + k * 5_000);
    }
    assert_eq!(requests_to(&bus), [], "no new request");
    assert_eq!(b.import_state(0), subscribed);
    // The same publisher moves the topic to another stream (it restarted): asked again.
    inject(&bus, a.get(), &advertise(2));
    run(&bus, &mut [&mut b], 40_000);
    assert_eq!(requests_to(&bus), [0x40]);
}

#[test]
fn a_pending_request_gives_way_to_another_publishers_advertisement() {
    // Publisher 0x40 advertised and went silent; 0x41 (same stream index) advertises: the
    // import asks 0x41 at once rather than waiting out the request timeout.
    static L: Topic<'static, u32, { pool_size(&[1], 1) }, 1> = Topic::new("speed", 0);
    static LP: Publisher<'static, u32> = Publisher::new(&L, Class::NonRealTime);
    static IN: RemotePublisher<'static, u32> = RemotePublisher::new(&LP, &L);
    let bus = Bus::<2>::new();
    let mut b = importer(&bus, &IN);
    inject(&bus, 0x40, &advertise(1));
    run(&bus, &mut [&mut b], 10_000);
    inject(&bus, 0x41, &advertise(1));
    run(&bus, &mut [&mut b], 15_000);
    assert_eq!(requests_to(&bus), [0x40, 0x41]);
    let from = NodeId::new(0x41).unwrap();
    assert!(matches!(b.import_state(0), Some(ImportState::Requested { from: f, .. }) if f == from));
}

#[test]
fn only_the_asked_publishers_answer_for_the_asked_topic_is_taken() {
    static L: Topic<'static, u32, { pool_size(&[1], 1) }, 1> = Topic::new("speed", 0);
    static LP: Publisher<'static, u32> = Publisher::new(&L, Class::NonRealTime);
    static IN: RemotePublisher<'static, u32> = RemotePublisher::new(&LP, &L);
    let bus = Bus::<2>::new();
    let mut b = importer(&bus, &IN);
    let (a, other) = (NodeId::new(0x40).unwrap(), NodeId::new(0x41).unwrap());
    let me = b.node_id().get();
    inject(&bus, a.get(), &advertise(1));
    run(&bus, &mut [&mut b], 10_000);
    let unexpected = b.stats().unexpected;
    // Another node answers for `speed`, and the asked one for another topic: neither counts.
    inject(&bus, other.get(), &respond(me, "speed", SubscribeResult::Ok, other.message_id(1)));
    inject(&bus, a.get(), &respond(me, "heading", SubscribeResult::Ok, a.message_id(1)));
    run(&bus, &mut [&mut b], 15_000);
    assert_eq!(b.stats().unexpected, unexpected + 2);
    assert!(matches!(b.import_state(0), Some(ImportState::Requested { from, .. }) if from == a));
    // The asked one names a stream that is not its own, or its management stream.
    inject(&bus, a.get(), &respond(me, "speed", SubscribeResult::Ok, other.message_id(1)));
    inject(&bus, a.get(), &respond(me, "speed", SubscribeResult::Ok, a.management()));
    run(&bus, &mut [&mut b], 20_000);
    assert_eq!(b.stats().unexpected, unexpected + 4);
    assert!(matches!(b.import_state(0), Some(ImportState::Requested { from, .. }) if from == a));
    inject(&bus, a.get(), &respond(me, "speed", SubscribeResult::Ok, a.message_id(1)));
    run(&bus, &mut [&mut b], 25_000);
    assert_eq!(
        b.import_state(0),
        Some(ImportState::Subscribed { from: a, message: a.message_id(1) })
    );
}

#[test]
fn a_refusal_counts_as_a_type_mismatch_only_when_it_is_one() {
    static L: Topic<'static, u32, { pool_size(&[1], 1) }, 1> = Topic::new("speed", 0);
    static LP: Publisher<'static, u32> = Publisher::new(&L, Class::NonRealTime);
    static IN: RemotePublisher<'static, u32> = RemotePublisher::new(&LP, &L);
    let bus = Bus::<2>::new();
    let mut b = importer(&bus, &IN);
    let me = b.node_id().get();
    for (publisher, result, mismatches) in [
        (0x40, SubscribeResult::NoSlot, 0),
        (0x41, SubscribeResult::UnknownTopic, 0),
        (0x42, SubscribeResult::TypeMismatch, 1),
    ] {
        let before = b.stats().type_mismatches;
        inject(&bus, publisher, &advertise(1));
        let until = bus.now.get() + 5_000;
        run(&bus, &mut [&mut b], until);
        let from = NodeId::new(publisher).unwrap();
        inject(&bus, publisher, &respond(me, "speed", result, from.message_id(1)));
        let until = bus.now.get() + 5_000;
        run(&bus, &mut [&mut b], until);
        assert_eq!(b.import_state(0), Some(ImportState::Refused { from, result }));
        assert_eq!(b.stats().type_mismatches - before, mismatches, "{result:?}");
    }
}
