//! A passive observer of an R2P bus: decodes every frame's RTCAN identifier, reassembles
//! management messages and advertised topics, and keeps what heartbeats and advertisements
//! say about the nodes and topics on the bus. It sends nothing; `monitor`, `nodes` and
//! `topics` are built on it, live or over a trace.

use std::collections::BTreeMap;
use std::time::Duration;

use r2p_canlink::{CanFrame, Stamped};
use r2p_management::message::{BusClass, Message, ModuleState, UID_LEN};
use r2p_management::{DecodeError, NodeId, MANAGEMENT_INDEX};
use rtcan::cycle::SyncError;
use rtcan::{Expect, Frame, FrameId, Reassembler, SyncFrame};

use crate::types::MsgType;

/// Streams reassembled at once (management streams and topics).
const STREAMS: usize = 64;
/// A half-received message with no frame for this long is given up, µs. Longer than the
/// modules' own (20 ms): frames reach a tool over TCP in bursts.
const REASSEMBLY_TIMEOUT_US: u64 = 200_000;

/// What the latest heartbeat of a node said.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NodeInfo {
    /// Node ID.
    pub id: u8,
    /// Module name.
    pub name: String,
    /// The MCU's unique ID.
    pub uid: [u8; UID_LEN],
    /// Its state.
    pub state: ModuleState,
    /// Seconds since boot.
    pub uptime_s: u32,
    /// CAN transmit error counter.
    pub tx_errors: u8,
    /// CAN receive error counter.
    pub rx_errors: u8,
    /// Frames it dropped as malformed.
    pub dropped: u16,
    /// When its last heartbeat came.
    pub last_seen: Duration,
    /// Heartbeats heard.
    pub heartbeats: u64,
    /// The panic its last reset followed, as its PANIC_REPORT says (none heard since it booted:
    /// `None`).
    pub panic: Option<String>,
    /// The image it runs, as its FIRMWARE message says (none heard since it booted: `None`).
    pub firmware: Option<Firmware>,
}

/// What a node's FIRMWARE message says about the image it runs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Firmware {
    /// major << 24 | minor << 16 | patch (0: an image flashed without a trailer).
    pub version: u32,
    /// The first 8 bytes of SHA-512 of the image.
    pub digest: [u8; 8],
    /// The module kind the image is for.
    pub kind: String,
    /// Not yet confirmed after its swap.
    pub on_trial: bool,
}

impl Firmware {
    /// `1.4.2`, or `unsigned` for an image without a trailer.
    pub fn version_text(&self) -> String {
        if self.version == 0 && self.digest == [0; 8] {
            return "unsigned".into();
        }
        let v = self.version;
        format!("{}.{}.{}", v >> 24, (v >> 16) & 0xFF, v & 0xFFFF)
    }

    /// The digest in hex, as `r2p sign` prints it.
    pub fn digest_hex(&self) -> String {
        self.digest.iter().map(|b| format!("{b:02x}")).collect()
    }
}

/// A topic some node advertised.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TopicInfo {
    /// Topic name.
    pub topic: String,
    /// Publisher's node ID.
    pub node: u8,
    /// Stream index (the message ID's low byte).
    pub index: u8,
    /// Type hash.
    pub type_hash: u32,
    /// Message size in bytes.
    pub size: u16,
    /// Bus class.
    pub class: BusClass,
}

impl TopicInfo {
    /// The stream's message ID.
    pub fn message(&self) -> u16 {
        u16::from(self.node) << 8 | u16::from(self.index)
    }

    /// The message type, if the CLI knows it.
    pub fn msg_type(&self) -> Option<MsgType> {
        MsgType::by_hash(self.type_hash, usize::from(self.size))
    }

    /// The type's name, or its hash.
    pub fn type_name(&self) -> String {
        self.msg_type().map_or_else(|| format!("0x{:08X}", self.type_hash), |t| t.name)
    }
}

/// What a frame is.
#[derive(Clone, Debug, PartialEq)]
pub enum What {
    /// An 11-bit frame: not RTCAN.
    Standard,
    /// A sync frame (or a frame with a sync identifier and another length).
    Sync(Result<SyncFrame, usize>),
    /// A frame of a node's management stream; `done` is the message it completes.
    Management {
        /// Sender.
        node: u8,
        /// The message completed by this frame, decoded.
        done: Option<Result<Message, DecodeError>>,
    },
    /// A frame of a topic stream; `topic` if it was advertised, `done` the payload it
    /// completes.
    Topic {
        /// Publisher.
        node: u8,
        /// Stream index.
        index: u8,
        /// The advertisement, if seen.
        topic: Option<TopicInfo>,
        /// The message completed by this frame.
        done: Option<Vec<u8>>,
    },
    /// A message ID no node or sync may use (node 0 with a fragment or laxity, node 255).
    Reserved,
}

/// One frame, decoded.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// When it was on the bus.
    pub time: Duration,
    /// The frame.
    pub frame: CanFrame,
    /// Its RTCAN identifier (extended frames only).
    pub id: Option<FrameId>,
    /// What it is.
    pub what: What,
}

/// The observer. See the module documentation.
pub struct Watcher {
    rx: Box<Reassembler<STREAMS, { r2p_msgs::MAX_SIZE }>>,
    nodes: BTreeMap<u8, NodeInfo>,
    topics: BTreeMap<u16, TopicInfo>,
    /// Each topic name's latest advertisement (its message ID).
    latest: BTreeMap<String, u16>,
    frames: u64,
}

impl Default for Watcher {
    fn default() -> Self {
        Self::new()
    }
}

impl Watcher {
    /// An observer that has seen nothing yet.
    pub fn new() -> Self {
        Self {
            rx: Box::new(Reassembler::new(REASSEMBLY_TIMEOUT_US)),
            nodes: BTreeMap::new(),
            topics: BTreeMap::new(),
            latest: BTreeMap::new(),
            frames: 0,
        }
    }

    /// Nodes heard, by node ID.
    pub fn nodes(&self) -> impl Iterator<Item = &NodeInfo> {
        self.nodes.values()
    }

    /// Node `id`, if heard.
    pub fn node(&self, id: u8) -> Option<&NodeInfo> {
        self.nodes.get(&id)
    }

    /// Topics advertised, by message ID.
    pub fn topics(&self) -> impl Iterator<Item = &TopicInfo> {
        self.topics.values()
    }

    /// The latest advertisement of `topic` (the one imports follow).
    pub fn topic(&self, topic: &str) -> Option<&TopicInfo> {
        self.latest.get(topic).and_then(|m| self.topics.get(m))
    }

    /// Frames seen.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// A node's name for messages: `2 (motor)`, or `2` if not heard.
    pub fn node_label(&self, id: u8) -> String {
        match self.nodes.get(&id) {
            Some(n) => format!("{id} ({})", n.name),
            None => id.to_string(),
        }
    }

    /// Takes one frame and says what it is.
    pub fn feed(&mut self, s: &Stamped) -> Report {
        self.frames += 1;
        let mut report = Report { time: s.time, frame: s.frame, id: None, what: What::Standard };
        if !s.frame.is_extended() {
            return report;
        }
        let Ok(frame) = Frame::from_raw(s.frame.id(), s.frame.data()) else { return report };
        let id = frame.id();
        report.id = Some(id);
        let at = s.time.as_micros() as u64;
        report.what = if id.message.is_reserved_for_sync() {
            match SyncFrame::from_frame(&frame) {
                Ok(sync) => What::Sync(Ok(sync)),
                Err(SyncError::Length(n)) => What::Sync(Err(n)),
                Err(_) => What::Reserved,
            }
        } else {
            match NodeId::of(id.message) {
                None => What::Reserved,
                Some((node, MANAGEMENT_INDEX)) => {
                    let done =
                        self.rx.accept(&frame, at, Expect::Any).map(|m| Message::decode(m.data));
                    if let Some(Ok(msg)) = &done {
                        self.learn(node.get(), msg, s.time);
                    }
                    What::Management { node: node.get(), done }
                }
                Some((node, index)) => {
                    let topic = self.topics.get(&id.message.0).cloned();
                    let done = topic.as_ref().and_then(|t| {
                        self.rx
                            .accept(&frame, at, Expect::Exactly(usize::from(t.size)))
                            .map(|m| m.data.to_vec())
                    });
                    What::Topic { node: node.get(), index, topic, done }
                }
            }
        };
        report
    }

    fn learn(&mut self, node: u8, msg: &Message, time: Duration) {
        match msg {
            Message::Heartbeat { uid, name, state, uptime_s, tx_errors, rx_errors, dropped } => {
                let old = self.nodes.get(&node);
                let heartbeats = old.map_or(0, |n| n.heartbeats) + 1;
                // A report stands until the node boots again (its uptime goes back); the
                // reports that follow a new panic's first heartbeat set it again.
                let same_boot = old.filter(|n| n.uptime_s <= *uptime_s);
                let panic = same_boot.and_then(|n| n.panic.clone());
                let firmware = same_boot.and_then(|n| n.firmware.clone());
                self.nodes.insert(
                    node,
                    NodeInfo {
                        id: node,
                        name: name.to_string(),
                        uid: *uid,
                        state: *state,
                        uptime_s: *uptime_s,
                        tx_errors: *tx_errors,
                        rx_errors: *rx_errors,
                        dropped: *dropped,
                        last_seen: time,
                        heartbeats,
                        panic,
                        firmware,
                    },
                );
            }
            Message::PanicReport { text } => {
                if let Some(n) = self.nodes.get_mut(&node) {
                    n.panic = Some(text.to_string());
                }
            }
            Message::Firmware { version, digest, kind, on_trial } => {
                if let Some(n) = self.nodes.get_mut(&node) {
                    n.firmware = Some(Firmware {
                        version: *version,
                        digest: *digest,
                        kind: kind.to_string(),
                        on_trial: *on_trial,
                    });
                }
            }
            Message::Advertise { topic, type_hash, size, index, class } if *index != 0 => {
                let info = TopicInfo {
                    topic: topic.to_string(),
                    node,
                    index: *index,
                    type_hash: *type_hash,
                    size: *size,
                    class: *class,
                };
                self.latest.insert(info.topic.clone(), info.message());
                self.topics.insert(info.message(), info);
            }
            _ => {}
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use r2p_management::message::ENCODED_MAX;
    use rtcan::{fragments, Laxity};

    /// The frames of management message `msg` sent by `node` (NRT), stamped from `t_us`.
    pub fn management(node: u8, msg: &Message, t_us: u64) -> Vec<Stamped> {
        let mut buf = [0u8; ENCODED_MAX];
        let n = msg.encode(&mut buf).unwrap();
        let id = FrameId::new(Laxity::NRT, NodeId::new(node).unwrap().management(), 0).unwrap();
        stamp(fragments(id, &buf[..n]).unwrap(), t_us)
    }

    /// The frames of a topic message on `node`'s stream `index`.
    pub fn topic(node: u8, index: u8, laxity: Laxity, payload: &[u8], t_us: u64) -> Vec<Stamped> {
        let id = FrameId::new(laxity, NodeId::new(node).unwrap().message_id(index), 0).unwrap();
        stamp(fragments(id, payload).unwrap(), t_us)
    }

    fn stamp(frames: impl Iterator<Item = Frame>, t_us: u64) -> Vec<Stamped> {
        frames
            .enumerate()
            .map(|(i, f)| Stamped {
                time: Duration::from_micros(t_us + 200 * i as u64),
                frame: CanFrame::extended(f.id().to_raw(), f.payload()).unwrap(),
            })
            .collect()
    }

    pub fn heartbeat(name: &str, n: u8) -> Message {
        let mut uid = [0u8; 12];
        uid[11] = n;
        Message::Heartbeat {
            uid,
            name: name.try_into().unwrap(),
            state: ModuleState::Running,
            uptime_s: 7,
            tx_errors: 1,
            rx_errors: 2,
            dropped: 3,
        }
    }

    pub fn advertise(topic: &str, t: &MsgType, index: u8, class: BusClass) -> Message {
        Message::Advertise {
            topic: topic.try_into().unwrap(),
            type_hash: t.hash,
            size: t.size as u16,
            index,
            class,
        }
    }

    #[test]
    fn heartbeats_and_advertisements_fill_the_tables() {
        let mut w = Watcher::new();
        let frames = management(2, &heartbeat("motor", 2), 1_000);
        assert_eq!(frames.len(), 4, "a 5-character name's heartbeat is 4 frames");
        let reports: Vec<_> = frames.iter().map(|f| w.feed(f)).collect();
        assert!(reports[..3]
            .iter()
            .all(|r| matches!(r.what, What::Management { node: 2, done: None })));
        assert!(matches!(&reports[3].what, What::Management { node: 2, done: Some(Ok(_)) }));
        let n = w.node(2).unwrap();
        assert_eq!((n.name.as_str(), n.uptime_s, n.dropped, n.heartbeats), ("motor", 7, 3, 1));
        assert_eq!(w.node_label(2), "2 (motor)");
        assert_eq!(w.node_label(9), "9");

        let scan = MsgType::by_name("uint32[4]").unwrap();
        let adv = advertise("scan", &scan, 2, BusClass::Srt { deadline_us: 20_000 });
        for f in management(2, &adv, 5_000) {
            w.feed(&f);
        }
        let t = w.topic("scan").unwrap();
        assert_eq!((t.message(), t.type_name().as_str()), (0x0202, "uint32[4]"));
        // A later advertiser of the name is the one imports follow, whatever its node ID.
        for f in management(1, &adv, 6_000).into_iter().chain(management(2, &adv, 7_000)) {
            w.feed(&f);
        }
        assert_eq!(w.topic("scan").unwrap().node, 2);
        for f in management(1, &adv, 8_000) {
            w.feed(&f);
        }
        assert_eq!(w.topic("scan").unwrap().node, 1);
        assert_eq!(w.topics().count(), 2);

        // The topic's frames are now reassembled and named.
        let payload: Vec<u8> = (1..=16).collect();
        let frames = topic(2, 2, Laxity::from_code(9), &payload, 9_000);
        let reports: Vec<_> = frames.iter().map(|f| w.feed(f)).collect();
        assert_eq!(reports.len(), 3, "16 bytes and the transfer CRC");
        match &reports[2].what {
            What::Topic { node: 2, index: 2, topic: Some(t), done: Some(d) } => {
                assert_eq!(t.topic, "scan");
                assert_eq!(d, &payload);
            }
            other => panic!("{other:?}"),
        }
        // A stream nobody advertised is named by its node and index only.
        let r = w.feed(&topic(3, 1, Laxity::NRT, &[1], 10_000)[0]);
        assert!(matches!(r.what, What::Topic { node: 3, index: 1, topic: None, done: None }));
    }

    #[test]
    fn syncs_standard_frames_and_reserved_ids_are_told_apart() {
        let mut w = Watcher::new();
        let sync = SyncFrame::new(0x45, 0b110, true).to_frame();
        let s = |f: CanFrame| Stamped { time: Duration::ZERO, frame: f };
        let r = w.feed(&s(CanFrame::extended(sync.id().to_raw(), sync.payload()).unwrap()));
        assert_eq!(r.id.unwrap().to_raw(), 0x2280);
        assert!(matches!(r.what, What::Sync(Ok(SyncFrame { cycle: 0x45, epoch: true, .. }))));
        let r = w.feed(&s(CanFrame::extended(0x2280, &[1, 2]).unwrap()));
        assert_eq!(r.what, What::Sync(Err(2)));
        let r = w.feed(&s(CanFrame::standard(0x123, &[]).unwrap()));
        assert_eq!((r.id, r.what), (None, What::Standard));
        // The sender's rank in the fragment field (a standby continuing the cycle)...
        let from_1 = SyncFrame::new(0x46, 0, true).from_rank(1).to_frame();
        let r = w.feed(&s(CanFrame::extended(0x2301, from_1.payload()).unwrap()));
        assert!(matches!(r.what, What::Sync(Ok(SyncFrame { cycle: 0x46, sender: 1, .. }))));
        // ...up to rank 15; message 0x0045 with a larger fragment field: not a sync, not a node.
        assert_eq!(w.feed(&s(CanFrame::extended(0x2290, &[]).unwrap())).what, What::Reserved);
        // Node 255 is "every node", never a sender.
        assert_eq!(w.feed(&s(CanFrame::extended(0xFF00 << 7, &[]).unwrap())).what, What::Reserved);
        assert_eq!(w.frames(), 6);
    }

    #[test]
    fn malformed_management_messages_are_reported_as_such() {
        let mut w = Watcher::new();
        let id = FrameId::new(Laxity::NRT, NodeId::new(5).unwrap().management(), 0).unwrap();
        let f = CanFrame::extended(id.to_raw(), &[0x7F, 1]).unwrap();
        let r = w.feed(&Stamped { time: Duration::ZERO, frame: f });
        assert_eq!(
            r.what,
            What::Management { node: 5, done: Some(Err(DecodeError::UnknownType(0x7F))) }
        );
        assert_eq!(w.nodes().count(), 0);
    }
}
