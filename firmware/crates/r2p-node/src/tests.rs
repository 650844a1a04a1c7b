//! Behaviour suite of the node runtime: modules on a loopback bus (host and QEMU).

use core::sync::atomic::{AtomicU32, Ordering::Relaxed};

use r2p_management::message::{Message, ParamFault, SubscribeResult, Value, ENCODED_MAX};
use r2p_management::NodeId;
use r2p_middleware::{pool_size, Callback, Class, Publisher, Subscriber, Topic, TopicInfo};
use rtcan::{fragments, FrameId, Laxity, MessageId};

use crate::node::{Event, ImportState, NodeConfig, NodeError};
use crate::remote::Export;
use crate::testbus::{run, uid, Bus, TestNode};
use crate::{NoParams, Param, ParamStore, RamParams, RemotePublisher, RemoteSubscriber};

const SRT_5MS: Class = Class::AsyncRealTime { deadline_us: 5_000 };

/// Fast protocol timers so the suite runs in little virtual time.
fn config(n: u32, name: &'static str) -> NodeConfig {
    NodeConfig {
        heartbeat_period_us: 10_000,
        request_timeout_us: 30_000,
        ..NodeConfig::new(uid(n), name)
    }
}

fn events(node: &mut TestNode<'_>) -> heapless::Vec<Event, 16> {
    core::iter::from_fn(|| node.next_event()).take(16).collect()
}

/// Puts management message `msg` on node `from`'s management stream.
fn inject<const P: usize>(bus: &Bus<P>, from: u8, msg: &Message) {
    let mut buf = [0u8; ENCODED_MAX];
    let n = msg.encode(&mut buf).unwrap();
    let stream = NodeId::new(from).unwrap().management();
    let template = FrameId { laxity: Laxity::NRT, message: stream, fragment: 0 };
    for f in fragments(template, &buf[..n]).unwrap() {
        bus.inject(f);
    }
}

/// A node ID none of `taken` uses.
fn other_than(taken: &[NodeId]) -> u8 {
    (0x30..).find(|n| taken.iter().all(|t| t.get() != *n)).unwrap()
}

r2p_testkit::suite! {
    fn a_topic_published_on_one_node_reaches_a_subscriber_on_another() {
        // Module A publishes `speed` (SRT, 5 ms) and offers it on the bus.
        static A_SPEED: Topic<'static, u32, { pool_size(&[3], 1) }, 1> = Topic::new("speed", 0);
        static A_PUB: Publisher<'static, u32> = Publisher::new(&A_SPEED, SRT_5MS);
        static A_OUT: RemoteSubscriber<'static, u32, 3> = RemoteSubscriber::new(&A_PUB);
        // Module B has a local `speed` topic with an ordinary subscriber and a callback.
        static B_SPEED: Topic<'static, u32, { pool_size(&[2], 1) }, 2> = Topic::new("speed", 0);
        static B_IN_PUB: Publisher<'static, u32> = Publisher::new(&B_SPEED, Class::NonRealTime);
        static B_IN: RemotePublisher<'static, u32> = RemotePublisher::new(&B_IN_PUB, &B_SPEED);
        static B_SUB: Subscriber<'static, u32, 2> = Subscriber::new();
        static SUM: AtomicU32 = AtomicU32::new(0);
        fn add(v: &u32) {
            SUM.fetch_add(*v, Relaxed);
        }
        static B_CB: Callback<fn(&u32)> = Callback::new(add);
        A_SPEED.advertise(&A_PUB).unwrap();
        A_SPEED.subscribe(&A_OUT).unwrap();
        B_SPEED.advertise(&B_IN_PUB).unwrap();
        B_SPEED.subscribe(&B_SUB).unwrap();
        B_SPEED.subscribe(&B_CB).unwrap();

        let bus = Bus::<2>::new();
        let mut a = TestNode::new(config(1, "proximity"), &NoParams).unwrap();
        let mut b = TestNode::new(config(2, "motor"), &NoParams).unwrap();
        assert_ne!(a.node_id(), b.node_id());
        assert_eq!(a.export(&A_OUT), Ok(1));
        assert_eq!(b.import(&B_IN), Ok(0));
        run(&bus, &mut [&mut a, &mut b], 40_000);

        let message = a.node_id().message_id(1);
        assert_eq!(b.import_state(0), Some(ImportState::Subscribed { from: a.node_id(), message }));
        assert_eq!(A_OUT.active_len(), 2, "B's longest local queue sizes A's remote queue");
        assert!(events(&mut a).contains(&Event::RemoteSubscriber { export: 0, from: b.node_id(), queue_len: 2 }));
        assert!(events(&mut b).contains(&Event::Subscribed { import: 0, from: a.node_id(), message }));

        A_PUB.publish_with(|m| *m = 10).unwrap();
        A_PUB.publish_with(|m| *m = 20).unwrap();
        run(&bus, &mut [&mut a, &mut b], 45_000);
        // The same API as a local subscription: B cannot tell.
        assert_eq!(*B_SUB.try_recv().unwrap(), 10);
        assert_eq!(*B_SUB.try_recv().unwrap(), 20);
        assert!(B_SUB.try_recv().is_none());
        assert_eq!(SUM.load(Relaxed), 30);
        assert_eq!((a.stats().queued, b.stats().published), (2, 2));
        assert_eq!(A_SPEED.free_slots(), A_SPEED.capacity(), "A's slots are back once encoded");
        assert_eq!(B_SPEED.free_slots(), B_SPEED.capacity());
        assert_eq!(b.dropped(), 0);
    }

    fn a_type_mismatch_is_refused_on_both_sides() {
        static A_T: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("speed", 0);
        static A_PUB: Publisher<'static, u32> = Publisher::new(&A_T, SRT_5MS);
        static A_OUT: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&A_PUB);
        // B thinks `speed` is an i32: same size, another type.
        static B_T: Topic<'static, i32, { pool_size(&[2], 1) }, 1> = Topic::new("speed", 0);
        static B_PUB: Publisher<'static, i32> = Publisher::new(&B_T, Class::NonRealTime);
        static B_IN: RemotePublisher<'static, i32> = RemotePublisher::new(&B_PUB, &B_T);
        A_T.subscribe(&A_OUT).unwrap();
        A_T.advertise(&A_PUB).unwrap();
        B_T.advertise(&B_PUB).unwrap();

        let bus = Bus::<2>::new();
        let mut a = TestNode::new(config(1, "a"), &NoParams).unwrap();
        let mut b = TestNode::new(config(2, "b"), &NoParams).unwrap();
        a.export(&A_OUT).unwrap();
        b.import(&B_IN).unwrap();
        run(&bus, &mut [&mut a, &mut b], 40_000);
        let result = SubscribeResult::TypeMismatch;
        assert_eq!(b.import_state(0), Some(ImportState::Refused { from: a.node_id(), result }));
        assert!(b.stats().type_mismatches >= 1);
        assert!(events(&mut b).contains(&Event::SubscriptionRefused { import: 0, from: a.node_id(), result }));
        assert_eq!(A_OUT.active_len(), 0, "no subscription was made");
        A_PUB.publish_with(|m| *m = 1).unwrap();
        run(&bus, &mut [&mut a, &mut b], 45_000);
        assert_eq!(a.stats().queued, 0, "nothing goes on the bus");

        // A subscriber that asks anyway, with its own hash, is refused by the publisher.
        let asker = other_than(&[a.node_id(), b.node_id()]);
        inject(&bus, asker, &Message::SubscribeRequest {
            target: a.node_id().get(),
            topic: "speed".try_into().unwrap(),
            type_hash: 0xBAD,
            queue_len: 1,
        });
        let before = a.stats().type_mismatches;
        run(&bus, &mut [&mut a, &mut b], 50_000);
        assert_eq!(a.stats().type_mismatches, before + 1);
        assert_eq!(A_OUT.active_len(), 0);
    }

    fn param_set_out_of_range_is_refused_and_the_value_unchanged() {
        static PARAMS: RamParams<2> =
            RamParams::new([Param::u32("rate_hz", 100, 1, 1_000), Param::f32("gain", 0.5, 0.0, 2.0)]);
        let bus = Bus::<2>::new();
        let mut module = TestNode::new(config(1, "motor"), &PARAMS).unwrap();
        let mut tool = TestNode::new(config(2, "tool"), &NoParams).unwrap();
        run(&bus, &mut [&mut module, &mut tool], 20_000);
        let target = module.node_id();
        let from = target;

        tool.set_param(target, 0, Value::U32(5_000)).unwrap();
        run(&bus, &mut [&mut module, &mut tool], 25_000);
        assert_eq!(events(&mut tool).as_slice(), &[Event::ParamError { from, index: 0, fault: ParamFault::OutOfRange }]);
        assert_eq!(PARAMS.get(0), Ok(Value::U32(100)), "refused: not applied");
        assert!(events(&mut module).is_empty());

        tool.set_param(target, 0, Value::F32(5.0)).unwrap();
        tool.get_param(target, 9).unwrap();
        tool.set_param(target, 1, Value::F32(1.25)).unwrap();
        tool.get_param(target, 0).unwrap();
        run(&bus, &mut [&mut module, &mut tool], 30_000);
        assert_eq!(events(&mut tool).as_slice(), &[
            Event::ParamError { from, index: 0, fault: ParamFault::WrongType },
            Event::ParamError { from, index: 9, fault: ParamFault::UnknownIndex },
            Event::ParamValue { from, index: 1, value: Value::F32(1.25) },
            Event::ParamValue { from, index: 0, value: Value::U32(100) },
        ]);
        assert_eq!(events(&mut module).as_slice(), &[Event::ParamChanged { index: 1, value: Value::F32(1.25) }]);
        assert_eq!(PARAMS.get(1), Ok(Value::F32(1.25)));
    }

    fn a_reboot_request_reaches_the_right_node() {
        let bus = Bus::<3>::new();
        let mut a = TestNode::new(config(1, "a"), &NoParams).unwrap();
        let mut b = TestNode::new(config(2, "b"), &NoParams).unwrap();
        let mut c = TestNode::new(config(3, "c"), &NoParams).unwrap();
        run(&bus, &mut [&mut a, &mut b, &mut c], 20_000);
        assert_eq!((a.peer_count(), b.peer_count(), c.peer_count()), (2, 2, 2));
        c.request_reboot(b.node_id().get()).unwrap();
        run(&bus, &mut [&mut a, &mut b, &mut c], 25_000);
        assert!(b.take_reboot_request());
        assert!(!b.take_reboot_request(), "taken once");
        assert!(!a.take_reboot_request());
        assert!(events(&mut b).contains(&Event::RebootRequested { from: c.node_id() }));
        c.request_reboot(NodeId::BROADCAST).unwrap();
        run(&bus, &mut [&mut a, &mut b, &mut c], 30_000);
        assert!(a.take_reboot_request() && b.take_reboot_request());
        assert!(!c.take_reboot_request(), "the sender does not hear itself");
    }

    fn garbage_and_unexpected_messages_are_counted_and_dropped() {
        static T: Topic<'static, u32, { pool_size(&[1], 1) }, 1> = Topic::new("cmd", 0);
        static P: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
        static IN: RemotePublisher<'static, u32> = RemotePublisher::new(&P, &T);
        static O: Topic<'static, u16, { pool_size(&[1], 1) }, 1> = Topic::new("state", 0);
        static OP: Publisher<'static, u16> = Publisher::new(&O, Class::NonRealTime);
        static OUT: RemoteSubscriber<'static, u16, 1> = RemoteSubscriber::new(&OP);
        O.subscribe(&OUT).unwrap();
        let bus = Bus::<1>::new();
        let mut a = TestNode::new(config(1, "a"), &NoParams).unwrap();
        a.import(&IN).unwrap();
        a.export(&OUT).unwrap();
        run(&bus, &mut [&mut a], 5_000);
        // The software's own sorting: what the hardware filters would keep out reaches it.
        bus.accept_everything();
        let me = a.node_id();
        let x = other_than(&[me]);
        let nrt = |message: u16, fragment: u8, data: &[u8]| {
            rtcan::Frame::new(FrameId { laxity: Laxity::NRT, message: MessageId(message), fragment }, data).unwrap()
        };
        bus.inject(rtcan::Frame::new(FrameId::sync(5), &[]).unwrap());
        bus.inject(nrt(0xFF05, 0, &[1, 2])); // node 255: not a node
        bus.inject(nrt(0x0042, 3, &[1])); // sync range, not a sync frame
        bus.inject(nrt(u16::from(x) << 8 | 2, 0, &[1, 2, 3, 4])); // a topic nobody subscribed
        inject_raw(&bus, x, &[0x99]); // unknown type
        inject_raw(&bus, x, &[0x11, 1, 2]); // truncated heartbeat
        inject_raw(&bus, x, &[]); // empty
        bus.inject(nrt(u16::from(x) << 8, 2, &[0x11; 5])); // bad fragment length
        let topic = |s: &str| s.try_into().unwrap();
        // A response nobody asked for, and an advertisement of our import with another type.
        inject(&bus, x, &Message::SubscribeResponse {
            target: me.get(), topic: topic("cmd"), result: SubscribeResult::Ok, message_id: 0x1234,
        });
        inject(&bus, x, &Message::Advertise {
            topic: topic("cmd"), type_hash: 1, size: 4, index: 1, class: r2p_management::message::BusClass::Nrt,
        });
        run(&bus, &mut [&mut a], 10_000);
        let s = a.stats();
        assert_eq!((s.sync_frames, s.bad_syncs), (1, 1), "an empty sync is counted, not fatal");
        assert_eq!(s.unknown_frames, 3);
        assert_eq!(s.malformed, 3);
        assert_eq!(s.unexpected, 1);
        assert_eq!(s.type_mismatches, 1);
        assert_eq!(a.reassembly_stats().bad_length, 1);
        assert!(a.dropped() >= 5);
        // Still answering: a subscription to its export works.
        inject(&bus, x, &Message::SubscribeRequest {
            target: me.get(), topic: topic("state"), type_hash: <u16 as crate::Wire>::TYPE_HASH, queue_len: 1,
        });
        run(&bus, &mut [&mut a], 15_000);
        assert_eq!(OUT.active_len(), 1);
    }

    fn hrt_and_invalid_exports_are_refused_explicitly() {
        static T: Topic<'static, u32, 8, 4> = Topic::new("setpoint", 0);
        // Not a power of two of the default 10 ms cycle.
        static HRT: Publisher<'static, u32> = Publisher::new(&T, Class::SyncRealTime { period_us: 5_000 });
        static HRT_OUT: RemoteSubscriber<'static, u32, 1> = RemoteSubscriber::new(&HRT);
        static HRT3: Publisher<'static, u32> = Publisher::new(&T, Class::SyncRealTime { period_us: 30_000 });
        static HRT3_OUT: RemoteSubscriber<'static, u32, 1> = RemoteSubscriber::new(&HRT3);
        static LONG: Topic<'static, [u8; 63], 2, 1> = Topic::new("long", [0; 63]);
        static LONG_PUB: Publisher<'static, [u8; 63]> = Publisher::new(&LONG, Class::SyncRealTime { period_us: 20_000 });
        static LONG_OUT: RemoteSubscriber<'static, [u8; 63], 1> = RemoteSubscriber::new(&LONG_PUB);
        static EIGHT: Topic<'static, [u8; 62], 2, 1> = Topic::new("eight", [0; 62]);
        static EIGHT_PUB: Publisher<'static, [u8; 62]> = Publisher::new(&EIGHT, Class::SyncRealTime { period_us: 20_000 });
        static EIGHT_OUT: RemoteSubscriber<'static, [u8; 62], 1> = RemoteSubscriber::new(&EIGHT_PUB);
        static NRT: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
        static NRT_OUT: RemoteSubscriber<'static, u32, 1> = RemoteSubscriber::new(&NRT);
        static BIG: Topic<'static, [u8; 65], 2, 1> = Topic::new("big", [0; 65]);
        static BIG_PUB: Publisher<'static, [u8; 65]> = Publisher::new(&BIG, Class::NonRealTime);
        static BIG_OUT: RemoteSubscriber<'static, [u8; 65], 1> = RemoteSubscriber::new(&BIG_PUB);
        static BAD: Topic<'static, u8, 2, 1> = Topic::new("no spaces", 0);
        static BAD_PUB: Publisher<'static, u8> = Publisher::new(&BAD, Class::NonRealTime);
        static BAD_OUT: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&BAD_PUB);
        let mut a = TestNode::new(config(1, "a"), &NoParams).unwrap();
        assert_eq!(a.export(&HRT_OUT), Err(NodeError::HrtPeriod { period_us: 5_000, cycle_us: 10_000 }));
        assert_eq!(a.export(&HRT3_OUT), Err(NodeError::HrtPeriod { period_us: 30_000, cycle_us: 10_000 }));
        // HRT: at most eight frames (62 bytes and the transfer CRC), one slot each.
        assert_eq!(a.export(&LONG_OUT), Err(NodeError::TooLarge { size: 63, max: 62 }));
        assert!(matches!(TestNode::new(NodeConfig { rank: Some(16), ..config(1, "a") }, &NoParams), Err(NodeError::BadRank)));
        let short = rtcan::CycleConfig { slots: 64, ..rtcan::CycleConfig::DEFAULT };
        assert!(matches!(TestNode::new(NodeConfig { cycle: short, ..config(1, "a") }, &NoParams), Err(NodeError::BadCycle(_))));
        assert_eq!(a.export(&BIG_OUT), Err(NodeError::TooLarge { size: 65, max: 64 }));
        assert_eq!(a.export(&BAD_OUT), Err(NodeError::BadTopicName));
        assert_eq!(a.export(&NRT_OUT), Ok(1));
        assert_eq!(a.export(&NRT_OUT), Err(NodeError::DuplicateTopic));
        assert_eq!(a.export(&EIGHT_OUT), Ok(2));
        assert_eq!(NRT_OUT.topic(), "setpoint");
        assert!(matches!(TestNode::new(config(1, "a name longer than 16"), &NoParams), Err(NodeError::BadName)));
        assert!(matches!(TestNode::new(config(1, "tab\t"), &NoParams), Err(NodeError::BadName)));
    }

    fn with_a_clock_the_deadline_counts_from_publication() {
        static CLOCK: AtomicU32 = AtomicU32::new(0);
        fn clock() -> rtcan::Micros {
            rtcan::Micros::from(CLOCK.load(Relaxed))
        }
        static T: Topic<'static, u8, { pool_size(&[2], 1) }, 1> = Topic::new("bump", 0);
        static P: Publisher<'static, u8> = Publisher::new(&T, Class::AsyncRealTime { deadline_us: 3_000 });
        static OUT: RemoteSubscriber<'static, u8, 2> = RemoteSubscriber::with_clock(&P, clock);
        T.subscribe(&OUT).unwrap();
        OUT.activate(2);
        let bus = Bus::<1>::new();
        let mut a = TestNode::new(config(1, "a"), &NoParams).unwrap();
        a.export(&OUT).unwrap();
        run(&bus, &mut [&mut a], 10_000);
        CLOCK.store(10_000, Relaxed);
        P.publish_with(|m| *m = 1).unwrap(); // published at 10 ms, due at 13 ms
        CLOCK.store(11_000, Relaxed);
        P.publish_with(|m| *m = 2).unwrap(); // due at 14 ms
        a.tick(13_500); // the node only looks at 13.5 ms: the first is late, the second goes
        assert_eq!((a.stats().deadline_misses, a.stats().queued), (1, 1));
        assert_eq!(P.stats().deadline_misses, 1);
    }

    fn a_missed_deadline_is_reported_to_the_publisher() {
        static A_T: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("alarm", 0);
        static A_PUB: Publisher<'static, u32> =
            Publisher::new(&A_T, Class::AsyncRealTime { deadline_us: 2_000 });
        static A_OUT: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&A_PUB);
        static B_T: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("alarm", 0);
        static B_PUB: Publisher<'static, u32> = Publisher::new(&B_T, Class::NonRealTime);
        static B_IN: RemotePublisher<'static, u32> = RemotePublisher::new(&B_PUB, &B_T);
        static B_SUB: Subscriber<'static, u32, 2> = Subscriber::new();
        A_T.subscribe(&A_OUT).unwrap();
        B_T.subscribe(&B_SUB).unwrap();
        let bus = Bus::<2>::new();
        let mut a = TestNode::new(config(1, "a"), &NoParams).unwrap();
        let mut b = TestNode::new(config(2, "b"), &NoParams).unwrap();
        a.export(&A_OUT).unwrap();
        b.import(&B_IN).unwrap();
        run(&bus, &mut [&mut a, &mut b], 40_000);
        assert!(matches!(b.import_state(0), Some(ImportState::Subscribed { .. })));

        bus.unplug(0, true); // A's mailboxes stay full
        A_PUB.publish_with(|m| *m = 7).unwrap();
        run(&bus, &mut [&mut a, &mut b], 45_000);
        assert_eq!(A_PUB.stats().deadline_misses, 1);
        assert_eq!(a.stats().deadline_misses, 1);
        assert_eq!(A_PUB.take_fault(), Some(r2p_middleware::Fault::DeadlineMiss));

        bus.unplug(0, false);
        A_PUB.publish_with(|m| *m = 8).unwrap();
        run(&bus, &mut [&mut a, &mut b], 50_000);
        assert_eq!(*B_SUB.try_recv().unwrap(), 8, "the expired message never went out");
        assert!(B_SUB.try_recv().is_none());
    }
}

fn inject_raw<const P: usize>(bus: &Bus<P>, from: u8, bytes: &[u8]) {
    let stream = NodeId::new(from).unwrap().management();
    let template = FrameId { laxity: Laxity::NRT, message: stream, fragment: 0 };
    for f in fragments(template, bytes).unwrap() {
        bus.inject(f);
    }
}
