//! Advertisements reach every module that may subscribe (docs/middleware.md, "Remote
//! topics"): a node advertises its exports at boot, and again when it first hears a module
//! (one that was unplugged while it booted) or a module that is starting (again) — not at
//! every heartbeat of a module it knows.

use r2p_management::message::{Message, ModuleState};
use r2p_middleware::{pool_size, Class, Publisher, Topic};
use rtcan::controller::CanController;
use rtcan::{Expect, Reassembler};

use crate::hrt_stream_tests::inject;
use crate::node::NodeConfig;
use crate::testbus::{run, uid, Bus, TestNode};
use crate::{NoParams, RemoteSubscriber};
use std::borrow::ToOwned;

/// Advertisements of `speed` that reached port `port` since the last call.
fn advertisements<const P: usize>(bus: &Bus<P>, port: usize) -> usize {
    let mut r: Reassembler<4, 64> = Reassembler::new(1_000_000);
    let mut port = bus.port(port);
    let mut n = 0;
    while let Some(rx) = port.try_receive() {
        if let Some(m) = r.accept(&rx.frame, rx.at, Expect::Any) {
            if let Ok(Message::Advertise { topic, .. }) = Message::decode(m.data) {
                n += usize::from(topic == "speed");
            }
        }
    }
    n
}

fn heartbeat(n: u8, state: ModuleState) -> Message {
    let name = heapless::String::try_from("tool").unwrap();
    let uid = uid(0x100 + u32::from(n));
    Message::Heartbeat { uid, name, state, uptime_s: 9, tx_errors: 0, rx_errors: 0, dropped: 0 }
}

#[test]
fn a_node_advertises_again_to_a_new_or_starting_module_only() {
    static T: Topic<'static, u32, { pool_size(&[1], 1) }, 1> = Topic::new("speed", 0);
    static P: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
    static OUT: RemoteSubscriber<'static, u32, 1> = RemoteSubscriber::new(&P);
    T.subscribe(&OUT).unwrap();
    let bus = Bus::<2>::new();
    let config = NodeConfig { heartbeat_period_us: 10_000, ..NodeConfig::new(uid(1), "motor") };
    let mut a = TestNode::new(config, &NoParams).unwrap();
    a.export(&OUT).unwrap();
    let step = |bus: &Bus<2>, a: &mut TestNode<'_>| {
        let until = bus.now.get() + 5_000;
        run(bus, &mut [a], until);
        advertisements(bus, 1)
    };
    assert_eq!(step(&bus, &mut a), 1, "at boot");
    for _ in 0..10 {
        assert_eq!(step(&bus, &mut a), 0, "running, nobody new: no advertisement");
    }

    // A module heard for the first time, already running (it was unplugged while A booted).
    inject(&bus, 0x40, &heartbeat(0x40, ModuleState::Running));
    assert_eq!(step(&bus, &mut a), 1, "to a new module");
    inject(&bus, 0x40, &heartbeat(0x40, ModuleState::Running));
    assert_eq!(step(&bus, &mut a), 0, "not at a known module's heartbeat");
    // A second new module, then the first one rebooting.
    inject(&bus, 0x41, &heartbeat(0x41, ModuleState::Running));
    assert_eq!(step(&bus, &mut a), 1, "to another new module");
    inject(&bus, 0x40, &heartbeat(0x40, ModuleState::Starting));
    assert_eq!(step(&bus, &mut a), 1, "to a module starting again");
    inject(&bus, 0x41, &heartbeat(0x41, ModuleState::Stopped));
    assert_eq!(step(&bus, &mut a), 0, "not to a known module that stopped");
}

#[test]
fn an_advertisement_names_the_class_the_publisher_asked_for() {
    use r2p_management::message::BusClass;

    use crate::tdma_tests::{tdma, CYCLE_US};
    use crate::testbus::run_slots;

    static HRT_T: Topic<'static, u32, { pool_size(&[1], 1) }, 1> = Topic::new("hrt", 0);
    static HRT_P: Publisher<'static, u32> =
        Publisher::new(&HRT_T, Class::SyncRealTime { period_us: 2 * CYCLE_US as u32 });
    static HRT_OUT: RemoteSubscriber<'static, u32, 1> = RemoteSubscriber::new(&HRT_P);
    static SRT_T: Topic<'static, u32, { pool_size(&[1], 1) }, 1> = Topic::new("srt", 0);
    static SRT_P: Publisher<'static, u32> =
        Publisher::new(&SRT_T, Class::AsyncRealTime { deadline_us: 3_000 });
    static SRT_OUT: RemoteSubscriber<'static, u32, 1> = RemoteSubscriber::new(&SRT_P);
    HRT_T.subscribe(&HRT_OUT).unwrap();
    SRT_T.subscribe(&SRT_OUT).unwrap();
    let bus = Bus::<2>::slotted(crate::tdma_tests::CYCLE);
    let mut a = TestNode::new(tdma(1, "imu", Some(0)), &NoParams).unwrap();
    a.export(&HRT_OUT).unwrap();
    a.export(&SRT_OUT).unwrap();
    run_slots(&bus, &mut [&mut a], 40_000);
    let mut r: Reassembler<4, 64> = Reassembler::new(1_000_000);
    let mut classes = std::vec::Vec::new();
    let mut port = bus.port(1);
    while let Some(rx) = port.try_receive() {
        if let Some(m) = r.accept(&rx.frame, rx.at, Expect::Any) {
            if let Ok(Message::Advertise { topic, class, .. }) = Message::decode(m.data) {
                classes.push((topic.as_str().to_owned(), class));
            }
        }
    }
    assert_eq!(
        classes,
        [
            ("hrt".to_owned(), BusClass::Hrt { period_cycles: 2 }),
            ("srt".to_owned(), BusClass::Srt { deadline_us: 3_000 }),
        ]
    );
}
