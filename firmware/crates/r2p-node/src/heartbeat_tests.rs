//! The heartbeat as a tool on the bus reads it (host tests): the uptime counts whole seconds
//! since the node booted, not since the clock's epoch (a module's clock may start anywhere,
//! e.g. an emulated bus's virtual time).

use r2p_management::message::Message;
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
