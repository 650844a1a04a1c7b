//! Management requests are addressed (docs/middleware.md, "The management protocol"): on a
//! bus of several modules of the same kind, a parameter write, a subscription request or its
//! answer meant for one module must change nothing on the others, and answers a node did not
//! ask for are bus traffic, not events of its application.

use r2p_management::message::{BusClass, Message, ModuleState, SubscribeResult, Value};
use r2p_management::NodeId;
use r2p_middleware::{pool_size, Class, Publisher, Topic};
use rtcan::controller::CanController;
use rtcan::{Expect, Reassembler};

use crate::hrt_stream_tests::inject;
use crate::node::{Event, ImportState, NodeConfig};
use crate::remote::Export;
use crate::testbus::{run, uid, Bus, TestNode};
use crate::{NoParams, Param, ParamStore, RamParams, RemotePublisher, RemoteSubscriber, Wire};

fn config(n: u32, name: &'static str) -> NodeConfig {
    NodeConfig { heartbeat_period_us: 10_000, ..NodeConfig::new(uid(n), name) }
}

fn events(node: &mut TestNode<'_>) -> std::vec::Vec<Event> {
    core::iter::from_fn(|| node.next_event()).collect()
}

/// The management messages other than heartbeats and advertisements that `port` saw from
/// node `by`.
fn answers<const P: usize>(bus: &Bus<P>, port: usize, by: NodeId) -> std::vec::Vec<Message> {
    let mut r: Reassembler<4, 64> = Reassembler::new(1_000_000);
    let mut port = bus.port(port);
    let mut out = std::vec::Vec::new();
    while let Some(rx) = port.try_receive() {
        let Some(m) = r.accept(&rx.frame, rx.at, Expect::Any) else { continue };
        if NodeId::of(rx.frame.id().message).map(|(from, _)| from) != Some(by) {
            continue;
        }
        match Message::decode(m.data) {
            Ok(Message::Heartbeat { .. } | Message::Advertise { .. }) | Err(_) => {}
            Ok(msg) => out.push(msg),
        }
    }
    out
}

#[test]
fn requests_for_another_module_change_nothing_here() {
    static PARAMS: RamParams<1> = RamParams::new([Param::u32("rate_hz", 100, 1, 1_000)]);
    static T: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("speed", 0);
    static P: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
    static OUT: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&P);
    T.subscribe(&OUT).unwrap();
    // Port 0: the module; port 1 listens.
    let bus = Bus::<2>::new();
    let mut module = TestNode::new(config(1, "motor"), &PARAMS).unwrap();
    module.export(&OUT).unwrap();
    run(&bus, &mut [&mut module], 20_000);
    let _ = events(&mut module);
    let me = module.node_id();
    let _ = answers(&bus, 1, me);
    let other = if me.get() == 0x41 { 0x42 } else { 0x41 };

    // A tool (0x40) talks to another motor module (`other`) on the same bus.
    let type_hash = <u32 as Wire>::TYPE_HASH;
    let topic = || heapless::String::try_from("speed").unwrap();
    inject(&bus, 0x40, &Message::ParamSet { target: other, index: 0, value: Value::U32(7) });
    inject(&bus, 0x40, &Message::ParamGet { target: other, index: 0 });
    inject(
        &bus,
        0x40,
        &Message::SubscribeRequest { target: other, topic: topic(), type_hash, queue_len: 2 },
    );
    run(&bus, &mut [&mut module], 40_000);
    assert_eq!(answers(&bus, 1, me), [], "nothing answered for {other:#x}");
    assert_eq!(events(&mut module), [], "no event for another module's requests");
    assert_eq!(PARAMS.get(0), Ok(Value::U32(100)), "another module's parameter write not applied");
    assert_eq!(OUT.active_len(), 0, "another module's subscriber not added");

    // The same requests addressed to it are answered (what the checks above rely on).
    inject(&bus, 0x40, &Message::ParamSet { target: me.get(), index: 0, value: Value::U32(7) });
    inject(&bus, 0x40, &Message::ParamGet { target: me.get(), index: 0 });
    inject(
        &bus,
        0x40,
        &Message::SubscribeRequest { target: me.get(), topic: topic(), type_hash, queue_len: 2 },
    );
    run(&bus, &mut [&mut module], 60_000);
    let value = Value::U32(7);
    let answered = answers(&bus, 1, me);
    assert_eq!(
        answered[..2],
        [Message::ParamValue { index: 0, value }, Message::ParamValue { index: 0, value }]
    );
    assert!(matches!(
        answered[2],
        Message::SubscribeResponse { target: 0x40, result: SubscribeResult::Ok, .. }
    ));
    assert_eq!(PARAMS.get(0), Ok(value));
    assert_eq!(OUT.active_len(), 2);
}

#[test]
fn answers_a_node_did_not_ask_for_are_not_its_events() {
    static T: Topic<'static, u32, { pool_size(&[1], 1) }, 1> = Topic::new("speed", 0);
    static LP: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
    static IN: RemotePublisher<'static, u32> = RemotePublisher::new(&LP, &T);
    let bus = Bus::<1>::new();
    let mut tool = TestNode::new(config(1, "tool"), &NoParams).unwrap();
    tool.import(&IN).unwrap();
    run(&bus, &mut [&mut tool], 20_000);
    let _ = events(&mut tool);
    let me = tool.node_id().get();
    let (asked, stranger) = (NodeId::new(0x50).unwrap(), NodeId::new(0x51).unwrap());
    let value = Value::U32(3);
    let fault = r2p_management::message::ParamFault::UnknownIndex;
    tool.get_param(asked, 0).unwrap();

    // The stranger advertises `speed`: the tool asks it for a subscription.
    let type_hash = <u32 as Wire>::TYPE_HASH;
    let topic = || heapless::String::try_from("speed").unwrap();
    let ad =
        Message::Advertise { topic: topic(), type_hash, size: 4, index: 1, class: BusClass::Nrt };
    inject(&bus, stranger.get(), &ad);
    run(&bus, &mut [&mut tool], 30_000);
    assert!(
        matches!(tool.import_state(0), Some(ImportState::Requested { from, .. }) if from == stranger)
    );

    // Answers this tool did not ask for: parameters of a module it never asked (another
    // tool's), and the stranger's subscription answer to another node.
    inject(&bus, stranger.get(), &Message::ParamValue { index: 0, value });
    inject(&bus, stranger.get(), &Message::ParamError { index: 1, fault });
    let message_id = stranger.message_id(1).0;
    let result = SubscribeResult::Ok;
    inject(
        &bus,
        stranger.get(),
        &Message::SubscribeResponse { target: me ^ 1, topic: topic(), result, message_id },
    );
    run(&bus, &mut [&mut tool], 40_000);
    assert_eq!(events(&mut tool), []);
    assert!(matches!(tool.import_state(0), Some(ImportState::Requested { .. })));
    inject(
        &bus,
        stranger.get(),
        &Message::SubscribeResponse { target: me, topic: topic(), result, message_id },
    );
    run(&bus, &mut [&mut tool], 45_000);
    let message = stranger.message_id(1);
    assert_eq!(tool.import_state(0), Some(ImportState::Subscribed { from: stranger, message }));
    let _ = events(&mut tool);

    // The module it asked answers: both kinds are events.
    inject(&bus, asked.get(), &Message::ParamValue { index: 0, value });
    inject(&bus, asked.get(), &Message::ParamError { index: 1, fault });
    run(&bus, &mut [&mut tool], 60_000);
    assert_eq!(
        events(&mut tool),
        [
            Event::ParamValue { from: asked, index: 0, value },
            Event::ParamError { from: asked, index: 1, fault },
        ]
    );
}

#[test]
fn a_node_that_never_asked_leaves_the_replies_to_the_tools() {
    // A module never asks for a parameter: it reads the bus's replies (another tool's answers,
    // modules' firmware and panic reports) as traffic for the tools, not as malformed messages;
    // once it asks, the answers of the node it asked are events.
    let bus = Bus::<1>::new();
    let mut module = TestNode::new(config(1, "motor"), &NoParams).unwrap();
    run(&bus, &mut [&mut module], 20_000);
    let _ = events(&mut module);
    let other = NodeId::new(0x52).unwrap();
    let value = Value::U32(7);
    let replies = [
        Message::ParamValue { index: 0, value },
        Message::ParamError { index: 1, fault: r2p_management::message::ParamFault::ReadOnly },
        Message::Firmware {
            version: 3,
            digest: [1; r2p_management::message::DIGEST_LEN],
            kind: "psu".try_into().unwrap(),
            on_trial: false,
        },
        Message::PanicReport { text: "src/main.rs:3:5: boom".try_into().unwrap() },
    ];
    for m in &replies {
        inject(&bus, other.get(), m);
    }
    run(&bus, &mut [&mut module], 40_000);
    assert_eq!(events(&mut module), []);
    assert_eq!(module.stats().malformed, 0, "replies are not malformed");

    module.get_param(other, 0).unwrap();
    inject(&bus, other.get(), &replies[0]);
    run(&bus, &mut [&mut module], 60_000);
    assert_eq!(events(&mut module), [Event::ParamValue { from: other, index: 0, value }]);
    assert_eq!(module.stats().malformed, 0);
}

#[test]
fn frames_queued_under_a_node_id_the_module_gave_up_are_dropped_and_counted() {
    static T: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("speed", 0);
    static P: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
    static OUT: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&P);
    T.subscribe(&OUT).unwrap();
    // Port 0: the module, cut off for 35 ms (its controller refuses every frame, so its
    // heartbeats and advertisement wait in its queue); port 1 listens.
    let bus = Bus::<2>::new();
    let mine = uid(0x0700);
    let mut module = TestNode::new(config(0x0700, "motor"), &NoParams).unwrap();
    module.export(&OUT).unwrap();
    bus.unplug(0, true);
    run(&bus, &mut [&mut module], 35_000);
    let held = module.tx_pending();
    assert!(held >= 4, "heartbeats and the advertisement wait: {held}");
    let contested = module.node_id();

    // A module with a smaller unique ID claims the same node ID; the cable is back.
    let other = uid(0x0001);
    let state = ModuleState::Running;
    let name = heapless::String::try_from("motor").unwrap();
    let hb = Message::Heartbeat {
        uid: other,
        name,
        state,
        uptime_s: 9,
        tx_errors: 0,
        rx_errors: 0,
        dropped: 0,
    };
    inject(&bus, contested.get(), &hb);
    bus.unplug(0, false);
    run(&bus, &mut [&mut module], 60_000);
    assert_ne!(module.node_id(), contested, "the smaller unique ID keeps it");
    assert!(events(&mut module).contains(&Event::NodeIdChanged(module.node_id())));
    assert_eq!(module.stats().dropped_on_move, held as u32);

    // Nothing of this module went out on the streams of the node ID it gave up; its heartbeat
    // and advertisement did on the new ones.
    let mut r: Reassembler<4, 64> = Reassembler::new(1_000_000);
    let mut port = bus.port(1);
    let (mut on_contested, mut on_new) = (0, 0);
    while let Some(rx) = port.try_receive() {
        let Some(m) = r.accept(&rx.frame, rx.at, Expect::Any) else { continue };
        let Some((from, _)) = NodeId::of(rx.frame.id().message) else { continue };
        match Message::decode(m.data) {
            Ok(Message::Heartbeat { uid, .. }) if from == contested => assert_eq!(uid, other),
            Ok(_) if from == contested => on_contested += 1,
            Ok(Message::Heartbeat { uid, .. }) if from == module.node_id() => {
                assert_eq!(uid, mine);
                on_new += 1;
            }
            Ok(Message::Advertise { .. }) if from == module.node_id() => on_new += 1,
            _ => {}
        }
    }
    assert_eq!(on_contested, 0, "nothing but the other module's heartbeat on {contested:?}");
    assert!(on_new >= 2, "heartbeat and advertisement on the new node ID: {on_new}");
}
