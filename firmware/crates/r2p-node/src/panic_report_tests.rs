//! The panic report as a tool on the bus hears it (host tests): after the first heartbeat and
//! every `PANIC_REPORT_EVERY` heartbeats after, from a node told of a panic before this boot;
//! never from one that was not; its text made fit for the wire.

use r2p_management::message::{Message, PANIC_TEXT_MAX};
use rtcan::controller::CanController;
use rtcan::{Expect, Reassembler};

use crate::node::{NodeConfig, PANIC_REPORT_EVERY};
use crate::testbus::{run, uid, Bus, TestNode};
use crate::NoParams;

/// The management messages that reached port 1, in order: `H` for a heartbeat, the text of a
/// panic report.
fn heard(bus: &Bus<2>, r: &mut Reassembler<4, 64>, out: &mut std::vec::Vec<std::string::String>) {
    let mut port = bus.port(1);
    while let Some(rx) = port.try_receive() {
        if let Some(m) = r.accept(&rx.frame, rx.at, Expect::Any) {
            match Message::decode(m.data) {
                Ok(Message::Heartbeat { .. }) => out.push("H".into()),
                Ok(Message::PanicReport { text }) => out.push(text.as_str().into()),
                _ => {}
            }
        }
    }
}

fn listen(report: Option<&[u8]>, heartbeats: u64) -> std::vec::Vec<std::string::String> {
    let bus = Bus::<2>::new();
    let config = NodeConfig { heartbeat_period_us: 10_000, ..NodeConfig::new(uid(1), "motor") };
    let mut node = TestNode::new(config, &NoParams).unwrap();
    if let Some(text) = report {
        node.set_panic_report(text);
    }
    let mut r = Reassembler::new(1_000_000);
    let mut seen = std::vec::Vec::new();
    while bus.now.get() < heartbeats * 10_000 - 5_000 {
        let until = bus.now.get() + 5_000;
        run(&bus, &mut [&mut node], until);
        heard(&bus, &mut r, &mut seen);
    }
    seen
}

#[test]
fn a_panic_is_reported_after_the_first_heartbeat_and_every_few_after() {
    let text = "panic, calls: 08002a1e 0800b3c2 08004f16 08000d5a 08000120";
    let seen = listen(Some(text.as_bytes()), 2 * u64::from(PANIC_REPORT_EVERY) + 1);
    let every = PANIC_REPORT_EVERY as usize;
    let mut expected = std::vec::Vec::new();
    for i in 0..=2 * every {
        expected.push(std::string::String::from("H"));
        if i % every == 0 {
            expected.push(std::string::String::from(text));
        }
    }
    assert_eq!(seen, expected);
}

#[test]
fn no_panic_no_report() {
    let seen = listen(None, u64::from(PANIC_REPORT_EVERY) + 1);
    assert!(seen.len() > PANIC_REPORT_EVERY as usize && seen.iter().all(|m| m == "H"), "{seen:?}");
}

#[test]
fn the_text_is_made_printable_and_cut_to_fit() {
    // Whatever a module kept: line breaks and non-ASCII cannot travel.
    let seen = listen(Some("a.rs:1:2:\nbad \u{e9}tat \u{1F600}".as_bytes()), 1);
    assert_eq!(seen, ["H", "a.rs:1:2: bad ?tat ?"]);
    let long: std::string::String = "x".repeat(PANIC_TEXT_MAX + 10);
    let seen = listen(Some(long.as_bytes()), 1);
    assert_eq!(seen[1], "x".repeat(PANIC_TEXT_MAX));
}
