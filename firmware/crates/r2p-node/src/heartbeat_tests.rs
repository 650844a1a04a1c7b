//! The heartbeat as a tool on the bus reads it (host tests): the uptime counts whole seconds
//! since the node booted, not since the clock's epoch (a module's clock may start anywhere,
//! e.g. an emulated bus's virtual time); it reports the state the application set once the
//! starting ones are sent.

use r2p_management::message::{Message, ModuleState};
use rtcan::controller::CanController;
use rtcan::{Expect, Micros, Reassembler};

use crate::node::NodeConfig;
use crate::testbus::{run, uid, Bus, TestNode};
use crate::NoParams;

/// Every heartbeat that reached port `port` since the last call: (time sent, uptime_s).
fn heartbeats<const P: usize>(
    bus: &Bus<P>,
    port: usize,
    r: &mut Reassembler<4, 64>,
) -> std::vec::Vec<(Micros, u32)> {
    let mut out = std::vec::Vec::new();
    let mut port = bus.port(port);
    while let Some(rx) = port.try_receive() {
        if let Some(m) = r.accept(&rx.frame, rx.at, Expect::Any) {
            if let Ok(Message::Heartbeat { uptime_s, .. }) = Message::decode(m.data) {
                out.push((rx.at, uptime_s));
            }
        }
    }
    out
}

#[test]
fn uptime_counts_whole_seconds_from_boot_not_from_the_clocks_zero() {
    const BOOT: Micros = 7_300_000;
    let bus = Bus::<2>::new();
    bus.now.set(BOOT);
    let config = NodeConfig { heartbeat_period_us: 100_000, ..NodeConfig::new(uid(1), "imu") };
    let mut node = TestNode::new(config, &NoParams).unwrap();
    let mut r = Reassembler::new(1_000_000);
    let mut seen = std::vec::Vec::new();
    while bus.now.get() < BOOT + 3_450_000 {
        // A 50 ms step at a time: the port's queue holds a few heartbeats' frames only.
        let until = bus.now.get() + 50_000;
        run(&bus, &mut [&mut node], until);
        seen.extend(heartbeats(&bus, 1, &mut r));
    }
    assert!(seen.len() >= 30, "a heartbeat every 100 ms: {}", seen.len());
    assert_eq!(seen[0].1, 0, "the first heartbeat, at boot");
    for &(at, uptime_s) in &seen {
        let expected = ((at - BOOT) / 1_000_000) as u32;
        assert_eq!(uptime_s, expected, "heartbeat sent {} µs after boot", at - BOOT);
    }
    assert_eq!(seen.last().unwrap().1, 3);
}

#[test]
fn heartbeats_say_starting_then_the_state_the_application_set() {
    let bus = Bus::<2>::new();
    let config = NodeConfig { heartbeat_period_us: 10_000, ..NodeConfig::new(uid(1), "motor") };
    let mut node = TestNode::new(config, &NoParams).unwrap();
    let mut r: Reassembler<4, 64> = Reassembler::new(1_000_000);
    let mut states = |bus: &Bus<2>, node: &mut TestNode<'_>| {
        let until = bus.now.get() + 10_000;
        run(bus, &mut [node], until);
        let mut out = std::vec::Vec::new();
        let mut port = bus.port(1);
        while let Some(rx) = port.try_receive() {
            if let Some(m) = r.accept(&rx.frame, rx.at, Expect::Any) {
                if let Ok(Message::Heartbeat { state, .. }) = Message::decode(m.data) {
                    out.push(state);
                }
            }
        }
        out
    };
    let mut seen = std::vec::Vec::new();
    for _ in 0..3 {
        seen.extend(states(&bus, &mut node));
    }
    assert_eq!(seen, [ModuleState::Starting, ModuleState::Starting, ModuleState::Running]);
    // A latched fault stops the application; the bus sees it at the next heartbeat.
    node.set_state(ModuleState::Stopped);
    assert_eq!(states(&bus, &mut node), [ModuleState::Stopped]);
}

#[test]
fn tx_pending_counts_the_frames_waiting_for_the_controller() {
    use r2p_middleware::{pool_size, Class, Publisher, Topic};

    use crate::remote::Export;
    use crate::RemoteSubscriber;

    static T: Topic<'static, [u8; 20], { pool_size(&[1], 1) }, 1> = Topic::new("scan", [0; 20]);
    static P: Publisher<'static, [u8; 20]> = Publisher::new(&T, Class::NonRealTime);
    static OUT: RemoteSubscriber<'static, [u8; 20], 1> = RemoteSubscriber::new(&P);
    T.subscribe(&OUT).unwrap();
    OUT.activate(1); // a remote module subscribed
    let bus = Bus::<2>::new();
    let mut node = TestNode::new(NodeConfig::new(uid(1), "lidar"), &NoParams).unwrap();
    node.export(&OUT).unwrap();
    run(&bus, &mut [&mut node], 1_000);
    assert_eq!(node.tx_pending(), 0, "heartbeat and advertisement sent");
    P.publish_with(|m| *m = [7; 20]).unwrap();
    node.tick(2_000);
    // 20 bytes + the 2-byte transfer CRC in frames of 8 bytes: 3 frames.
    assert_eq!(node.tx_pending(), 3, "encoded, not yet handed to the controller");
    let sent_before = node.stats().frames_sent;
    assert_eq!(node.transmit(2_000, &mut bus.port(0)), 3, "frames handed over");
    assert_eq!(node.tx_pending(), 0);
    assert_eq!(node.stats().frames_sent, sent_before + 3);
}
