//! Firmware updates carried by the node (host tests): UPDATE messages reach the addressed
//! module's sink with their sender, its answer goes back to the sender's sink, other nodes
//! and nodes without a sink ignore them; FIRMWARE follows the first heartbeat and every few.

use std::sync::Mutex;
use std::vec::Vec;

use r2p_management::message::{Message, UPDATE_MAX};
use r2p_management::NodeId;
use rtcan::controller::CanController;
use rtcan::{Expect, Reassembler};

use crate::node::{NodeConfig, PANIC_REPORT_EVERY};
use crate::testbus::{run, uid, Bus, TestNode};
use crate::{FirmwareId, NoParams, NodeError, UpdateSink};

/// Records what reaches it; answers `reply` followed by the message's first byte.
struct Recorder {
    seen: Mutex<Vec<(u8, Vec<u8>)>>,
    reply: &'static [u8],
}

impl Recorder {
    const fn new(reply: &'static [u8]) -> Self {
        Self { seen: Mutex::new(Vec::new()), reply }
    }
    fn seen(&self) -> Vec<(u8, Vec<u8>)> {
        self.seen.lock().unwrap().clone()
    }
}

impl UpdateSink for Recorder {
    fn handle(&self, from: u8, msg: &[u8], answer: &mut [u8; 64]) -> usize {
        self.seen.lock().unwrap().push((from, msg.to_vec()));
        if self.reply.is_empty() {
            return 0;
        }
        answer[..self.reply.len()].copy_from_slice(self.reply);
        answer[self.reply.len()] = msg[0];
        self.reply.len() + 1
    }
}

fn config(n: u32, name: &'static str) -> NodeConfig {
    NodeConfig { heartbeat_period_us: 10_000, ..NodeConfig::new(uid(n), name) }
}

#[test]
fn updates_reach_the_addressed_sink_and_its_answer_the_sender() {
    let module_sink = Recorder::new(b"ok");
    let other_sink = Recorder::new(b"no");
    let tool_sink = Recorder::new(b"");
    let bus = Bus::<4>::new();
    let mut module = TestNode::new(config(1, "motor"), &NoParams).unwrap();
    let mut other = TestNode::new(config(2, "psu"), &NoParams).unwrap();
    let mut bare = TestNode::new(config(3, "imu"), &NoParams).unwrap();
    let mut tool = TestNode::new(config(4, "r2p"), &NoParams).unwrap();
    module.set_update_sink(&module_sink);
    other.set_update_sink(&other_sink);
    tool.set_update_sink(&tool_sink);
    run(&bus, &mut [&mut module, &mut other, &mut bare, &mut tool], 30_000);
    let block: Vec<u8> = (0..UPDATE_MAX as u8).collect();
    tool.send_update(module.node_id(), &block).unwrap();
    tool.send_update(bare.node_id(), &[0x51, 1]).unwrap();
    run(&bus, &mut [&mut module, &mut other, &mut bare, &mut tool], 60_000);
    let t = tool.node_id().get();
    assert_eq!(module_sink.seen(), [(t, block.clone())], "the whole message, with its sender");
    assert!(other_sink.seen().is_empty(), "addressed to another node");
    assert_eq!(tool_sink.seen(), [(module.node_id().get(), b"ok\x00".to_vec())]);
    assert!(
        module_sink.seen().iter().all(|(from, _)| *from == t),
        "its own answer never comes back"
    );
}

#[test]
fn an_update_longer_than_a_message_is_refused_whole() {
    let mut tool = TestNode::new(config(4, "r2p"), &NoParams).unwrap();
    let e = tool.send_update(NodeId::new(1).unwrap(), &[0; UPDATE_MAX + 1]);
    assert_eq!(e, Err(NodeError::TooLarge { size: UPDATE_MAX + 1, max: UPDATE_MAX }));
}

/// Management messages port 1 heard: `H` for a heartbeat, `F<version>` for a firmware message.
fn heard(firmware: Option<FirmwareId>, heartbeats: u64) -> Vec<std::string::String> {
    let bus = Bus::<2>::new();
    let mut node = TestNode::new(config(1, "motor"), &NoParams).unwrap();
    if let Some(f) = firmware {
        node.set_firmware(f);
    }
    let mut r: Reassembler<4, 64> = Reassembler::new(1_000_000);
    let mut seen = Vec::new();
    while bus.now.get() < heartbeats * 10_000 - 5_000 {
        let until = bus.now.get() + 5_000;
        run(&bus, &mut [&mut node], until);
        let mut port = bus.port(1);
        while let Some(rx) = port.try_receive() {
            if let Some(m) = r.accept(&rx.frame, rx.at, Expect::Any) {
                match Message::decode(m.data) {
                    Ok(Message::Heartbeat { .. }) => seen.push("H".into()),
                    Ok(Message::Firmware { version, digest, kind, .. }) => {
                        assert_eq!((digest, kind.as_str()), ([9, 8, 7, 6, 5, 4, 3, 2], "motor"));
                        seen.push(std::format!("F{version:x}"));
                    }
                    _ => {}
                }
            }
        }
    }
    seen
}

#[test]
fn the_firmware_is_said_after_the_first_heartbeat_and_every_few_after() {
    let kind = "motor".try_into().unwrap();
    let f = FirmwareId {
        version: 0x0104_0002,
        digest: [9, 8, 7, 6, 5, 4, 3, 2],
        kind,
        on_trial: false,
    };
    let seen = heard(Some(f), u64::from(PANIC_REPORT_EVERY) + 1);
    let mut expected: Vec<std::string::String> = Vec::new();
    for i in 0..=PANIC_REPORT_EVERY {
        expected.push("H".into());
        if i % PANIC_REPORT_EVERY == 0 {
            expected.push("F1040002".into());
        }
    }
    assert_eq!(seen, expected);
    assert!(heard(None, 3).iter().all(|m| m == "H"), "nothing said without a firmware set");
}
