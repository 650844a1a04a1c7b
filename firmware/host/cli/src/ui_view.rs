//! What `r2p ui` shows, built from the frames on the bus: the [`Watcher`]'s nodes and topics
//! plus what the page needs over time — which modules went silent (lost), who subscribed to
//! what, each topic's rate and latest decoded value, the RTCAN cycle's reservation mask, the
//! bus load by class and a histogram of SRT latencies. Kept apart from the HTTP server and the bus thread so it is tested with
//! frames alone, and sends nothing.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::time::Duration;

use r2p_management::message::BusClass;
use r2p_management::message::Message;
use rtcan::{FrameClass, LaxityEncoding};
use serde_json::{json, Value as Json};

use crate::describe::{class_json, state_name};
use crate::host::NODE_NAME;
use crate::watch::{Report, Watcher, What};

/// The window rates and loads are measured over.
pub const WINDOW: Duration = Duration::from_secs(2);
/// The bus's bit rate (every R2P bus runs at 1 Mbit/s: docs/rtcan.md), for the load.
pub const BITRATE: f64 = 1_000_000.0;

/// Bits an extended data frame with `len` data bytes takes on the wire, without stuff bits
/// (SOF, 29-bit identifier with SRR/IDE/RTR, control, data, CRC, delimiters, ACK, EOF and the
/// 3-bit intermission): 67 + 8·len. Stuffing adds up to ~20 %, so the load shown is a floor.
pub fn frame_bits(len: usize) -> u64 {
    67 + 8 * len as u64
}

/// Upper edges (µs) of the SRT latency histogram's buckets; the last bucket takes the rest.
pub const LATENCY_EDGES_US: [u32; 8] = [250, 500, 1_000, 2_000, 3_000, 5_000, 10_000, 20_000];

/// The latency, at most, of an SRT message from its publication to its last frame on the bus:
/// the topic's deadline less the least time to the deadline that frame's laxity code says was
/// left (the code is computed when the frame is sent; it encodes a lower bound).
pub fn srt_latency_us(deadline_us: u32, laxity: LaxityEncoding, code: rtcan::Laxity) -> u32 {
    deadline_us.saturating_sub(laxity.lower_bound_us(code))
}

/// The histogram bucket of a latency.
pub fn latency_bucket(us: u32) -> usize {
    LATENCY_EDGES_US.iter().position(|e| us < *e).unwrap_or(LATENCY_EDGES_US.len())
}

/// A topic's traffic as seen since the view started.
#[derive(Default)]
struct TopicSeen {
    /// When each recent message completed (within [`WINDOW`]).
    times: VecDeque<Duration>,
    /// Messages completed in all.
    count: u64,
    /// The latest message, decoded (or why it did not decode).
    latest: Option<Json>,
    /// Nodes that asked the publisher for the topic (SUBSCRIBE_REQUEST) and it accepted.
    subscribers: BTreeSet<u8>,
}

/// The page's view of the bus. See the module documentation.
pub struct BusView {
    /// Silence after which a module is shown as lost.
    lost_after: Duration,
    /// Per node: when (view time) its latest heartbeat came.
    heard: BTreeMap<u8, Duration>,
    /// Per (publisher node, topic).
    topics: BTreeMap<(u8, String), TopicSeen>,
    /// Per class (HRT, SRT, NRT): (view time, bits) of recent frames.
    bits: [VecDeque<(Duration, u64)>; 3],
    /// The latest sync: cycle counter, reservation mask, epoch bit.
    sync: Option<(u8, u64, bool)>,
    /// Syncs seen in all.
    syncs: u64,
    /// How the bus encodes SRT laxity.
    laxity: LaxityEncoding,
    /// SRT messages per latency bucket ([`LATENCY_EDGES_US`]).
    latency: [u64; LATENCY_EDGES_US.len() + 1],
}

fn class_index(c: FrameClass) -> usize {
    match c {
        FrameClass::Hrt => 0,
        FrameClass::Srt => 1,
        FrameClass::Nrt => 2,
    }
}

/// Drops entries older than [`WINDOW`] before `now`.
fn trim<T>(q: &mut VecDeque<T>, now: Duration, at: impl Fn(&T) -> Duration) {
    while q.front().is_some_and(|x| now.saturating_sub(at(x)) > WINDOW) {
        q.pop_front();
    }
}

impl BusView {
    /// A view that shows a module as lost after `lost_after` without a heartbeat, on a bus
    /// that encodes SRT laxity as `laxity`.
    pub fn new(lost_after: Duration, laxity: LaxityEncoding) -> Self {
        Self {
            lost_after,
            heard: BTreeMap::new(),
            topics: BTreeMap::new(),
            bits: Default::default(),
            sync: None,
            syncs: 0,
            laxity,
            latency: [0; LATENCY_EDGES_US.len() + 1],
        }
    }

    /// Takes the frames `reports` the watcher decoded, received at view time `now`.
    pub fn feed(&mut self, reports: &[Report], now: Duration) {
        for r in reports {
            if let Some(id) = r.id {
                let q = &mut self.bits[class_index(id.class())];
                q.push_back((now, frame_bits(r.frame.data().len())));
            }
            match &r.what {
                What::Sync(Ok(s)) => {
                    self.sync = Some((s.cycle, s.reservations, s.epoch));
                    self.syncs += 1;
                }
                What::Topic { topic: Some(t), done: Some(bytes), .. } => {
                    if let (BusClass::Srt { deadline_us }, Some(id)) = (t.class, r.id) {
                        if id.class() == FrameClass::Srt {
                            let us = srt_latency_us(deadline_us, self.laxity, id.laxity);
                            self.latency[latency_bucket(us)] += 1;
                        }
                    }
                    let seen = self.topics.entry((t.node, t.topic.clone())).or_default();
                    seen.times.push_back(now);
                    seen.count += 1;
                    seen.latest = Some(match t.msg_type().map(|ty| ty.decode(bytes)) {
                        Some(Ok(v)) => v.to_json(),
                        Some(Err(e)) => json!({ "error": e }),
                        None => json!({ "payload": crate::describe::hex(bytes) }),
                    });
                }
                What::Management { node, done: Some(Ok(Message::Heartbeat { .. })) } => {
                    self.heard.insert(*node, now);
                }
                What::Management {
                    node,
                    done: Some(Ok(Message::SubscribeResponse { target, topic, result, .. })),
                } if *result == r2p_management::message::SubscribeResult::Ok => {
                    let seen = self.topics.entry((*node, topic.to_string())).or_default();
                    seen.subscribers.insert(*target);
                }
                _ => {}
            }
        }
        for seen in self.topics.values_mut() {
            trim(&mut seen.times, now, |t| *t);
        }
        for q in &mut self.bits {
            trim(q, now, |x| x.0);
        }
    }

    /// True if node `id` has sent no heartbeat for longer than the lost time at `now`.
    pub fn is_lost(&self, id: u8, now: Duration) -> bool {
        self.heard.get(&id).is_some_and(|at| now.saturating_sub(*at) > self.lost_after)
    }

    /// The view as the page's JSON at view time `now`. Tools (nodes named `r2p-cli`, such as
    /// the UI's own parameter sessions) are left out once they leave, and the UI's own node
    /// (`own`) always.
    pub fn snapshot(&self, w: &Watcher, now: Duration, own: Option<u8>) -> Json {
        let nodes: Vec<Json> = w
            .nodes()
            .filter(|n| Some(n.id) != own)
            .filter(|n| !(n.name == NODE_NAME && self.is_lost(n.id, now)))
            .map(|n| {
                let lost = self.is_lost(n.id, now);
                json!({
                    "node": n.id, "name": n.name,
                    "kind": n.firmware.as_ref().map_or_else(|| n.name.clone(), |f| f.kind.clone()),
                    "state": if lost { "LOST" } else { state_name(n.state) },
                    "lost": lost,
                    "silent_s": self.heard.get(&n.id).map(|at| now.saturating_sub(*at).as_secs_f64()),
                    "uptime_s": n.uptime_s, "tx_errors": n.tx_errors, "rx_errors": n.rx_errors,
                    "dropped": n.dropped, "panic": n.panic,
                    "firmware": n.firmware.as_ref().map(|f| {
                        let trial = if f.on_trial { " (on trial)" } else { "" };
                        format!("{}{trial}", f.version_text())
                    }),
                })
            })
            .collect();
        let topics: Vec<Json> = crate::listing::sorted_topics(w, own)
            .iter()
            .map(|t| {
                let seen = self.topics.get(&(t.node, t.topic.clone()));
                let rate = seen.map_or(0.0, |s| s.times.len() as f64 / WINDOW.as_secs_f64());
                json!({
                    "topic": t.topic, "type": t.type_name(), "size": t.size,
                    "publisher": t.node, "publisher_name": w.node(t.node).map(|n| n.name.clone()),
                    "subscribers": seen.map(|s| s.subscribers.iter().copied().collect::<Vec<_>>()),
                    "class": class_json(t.class), "rate_hz": rate,
                    "messages": seen.map_or(0, |s| s.count),
                    "latest": seen.and_then(|s| s.latest.clone()),
                })
            })
            .collect();
        let load: Vec<f64> = self
            .bits
            .iter()
            .map(|q| q.iter().map(|x| x.1).sum::<u64>() as f64 / WINDOW.as_secs_f64() / BITRATE)
            .collect();
        json!({
            "nodes": nodes,
            "topics": topics,
            "cycle": {
                "syncs": self.syncs,
                "cycle": self.sync.map(|s| s.0),
                "reserved_slots": self.sync.map(|s| (1..64).filter(|i| s.1 & (1u64 << i) != 0).collect::<Vec<u32>>()),
                "epoch": self.sync.map(|s| s.2),
                "load": {"HRT": load[0], "SRT": load[1], "NRT": load[2]},
            },
            "srt_latency": {"edges_us": LATENCY_EDGES_US, "counts": self.latency},
            "frames": w.frames(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::MsgType;
    use crate::watch::tests::{advertise, heartbeat, management, topic};
    use r2p_management::message::{BusClass, SubscribeResult};
    use rtcan::{Laxity, SyncFrame};

    const S: Duration = Duration::from_secs(1);
    const LOG: LaxityEncoding = LaxityEncoding::Logarithmic { tick_us: 100 };

    fn feed(v: &mut BusView, w: &mut Watcher, frames: Vec<r2p_canlink::Stamped>, now: Duration) {
        let reports: Vec<Report> = frames.iter().map(|f| w.feed(f)).collect();
        v.feed(&reports, now);
    }

    #[test]
    fn a_module_silent_longer_than_the_lost_time_is_lost_until_it_heartbeats_again() {
        let (mut v, mut w) = (BusView::new(S, LOG), Watcher::new());
        feed(&mut v, &mut w, management(2, &heartbeat("motor", 2), 1_000), Duration::ZERO);
        feed(&mut v, &mut w, management(3, &heartbeat("imu", 3), 2_000), Duration::ZERO);
        let at = |ms| Duration::from_millis(ms);
        feed(&mut v, &mut w, management(3, &heartbeat("imu", 3), 3_000), at(900));
        assert!(!v.is_lost(2, S), "exactly the lost time: not yet");
        feed(&mut v, &mut w, Vec::new(), at(1_001));
        assert!(v.is_lost(2, at(1_001)) && !v.is_lost(3, at(1_001)));
        let j = v.snapshot(&w, at(1_001), None);
        assert_eq!(j["nodes"][0]["state"], "LOST");
        assert_eq!(j["nodes"][0]["lost"], true);
        assert_eq!(j["nodes"][1]["state"], "running");
        assert_eq!(j["nodes"][1]["uptime_s"], 7);
        feed(&mut v, &mut w, management(2, &heartbeat("motor", 2), 4_000), at(1_500));
        assert!(!v.is_lost(2, at(1_500)), "back");
        assert!(!v.is_lost(9, at(9_000)), "never heard: not lost");
    }

    #[test]
    fn tools_that_left_and_the_ui_itself_are_left_out() {
        let (mut v, mut w) = (BusView::new(S, LOG), Watcher::new());
        feed(&mut v, &mut w, management(4, &heartbeat(NODE_NAME, 4), 0), Duration::ZERO);
        feed(&mut v, &mut w, management(5, &heartbeat(NODE_NAME, 5), 0), Duration::ZERO);
        feed(&mut v, &mut w, management(6, &heartbeat("psu", 6), 0), Duration::ZERO);
        let names = |j: &Json| {
            j["nodes"]
                .as_array()
                .unwrap()
                .iter()
                .map(|n| n["node"].as_u64().unwrap())
                .collect::<Vec<_>>()
        };
        assert_eq!(names(&v.snapshot(&w, Duration::ZERO, Some(5))), [4, 6]);
        let later = Duration::from_secs(5);
        assert_eq!(
            names(&v.snapshot(&w, later, Some(5))),
            [6],
            "the tool left; the psu is shown lost"
        );
    }

    #[test]
    fn topics_carry_their_class_subscribers_rate_and_latest_value() {
        let (mut v, mut w) = (BusView::new(S, LOG), Watcher::new());
        let ty = MsgType::by_name("uint32").unwrap();
        let srt = BusClass::Srt { deadline_us: 20_000 };
        feed(&mut v, &mut w, management(2, &heartbeat("motor", 2), 0), Duration::ZERO);
        feed(
            &mut v,
            &mut w,
            management(2, &advertise("speed", &ty, 1, srt), 1_000),
            Duration::ZERO,
        );
        let ok = Message::SubscribeResponse {
            target: 7,
            topic: "speed".try_into().unwrap(),
            result: SubscribeResult::Ok,
            message_id: 0x0201,
        };
        feed(&mut v, &mut w, management(2, &ok, 2_000), Duration::ZERO);
        let mut refused = ok.clone();
        if let Message::SubscribeResponse { target, result, .. } = &mut refused {
            (*target, *result) = (8, SubscribeResult::UnknownTopic);
        }
        feed(&mut v, &mut w, management(2, &refused, 2_500), Duration::ZERO);
        for i in 0..10u32 {
            let at = Duration::from_millis(100 * u64::from(i));
            feed(
                &mut v,
                &mut w,
                topic(2, 1, Laxity::from_code(21), &i.to_le_bytes(), 3_000 + 1_000 * u64::from(i)),
                at,
            );
        }
        let j = v.snapshot(&w, Duration::from_millis(900), None);
        // Laxity code 21 leaves at least LOG_THRESHOLDS[21] ticks of the 20 ms deadline.
        let us = srt_latency_us(20_000, LOG, Laxity::from_code(21));
        assert_eq!(us, 20_000 - LOG.lower_bound_us(Laxity::from_code(21)));
        let mut counts = [0u64; 9];
        counts[latency_bucket(us)] = 10;
        assert_eq!(j["srt_latency"]["counts"], json!(counts));
        let t = &j["topics"][0];
        assert_eq!(t["topic"], "speed");
        assert_eq!(t["class"]["class"], "SRT");
        assert_eq!(t["subscribers"], json!([7]), "the refused one is not a subscriber");
        assert_eq!(t["messages"], 10);
        assert_eq!(t["latest"], json!(9));
        assert_eq!(t["rate_hz"], 5.0, "10 messages in the 2 s window");
        // Three seconds later the window is empty but the count and value stay.
        feed(&mut v, &mut w, Vec::new(), Duration::from_secs(4));
        let j = v.snapshot(&w, Duration::from_secs(4), None);
        assert_eq!(
            (j["topics"][0]["rate_hz"].clone(), j["topics"][0]["messages"].clone()),
            (json!(0.0), json!(10))
        );
    }

    #[test]
    fn srt_latencies_fall_in_their_buckets() {
        assert_eq!(latency_bucket(0), 0);
        assert_eq!(latency_bucket(249), 0);
        assert_eq!(latency_bucket(250), 1);
        assert_eq!(latency_bucket(19_999), 7);
        assert_eq!(latency_bucket(20_000), 8);
        assert_eq!(latency_bucket(u32::MAX), 8);
        let lin = LaxityEncoding::Linear { tick_us: 100 };
        assert_eq!(
            srt_latency_us(5_000, lin, Laxity::from_code(11)),
            4_000,
            "code 11: ≥ 1 ms left"
        );
        assert_eq!(srt_latency_us(500, lin, Laxity::from_code(11)), 0, "never below zero");
        // An HRT frame of an SRT-advertised stream (a mismatch) is not counted.
        let (mut v, mut w) = (BusView::new(S, lin), Watcher::new());
        let ty = MsgType::by_name("uint32").unwrap();
        let srt = BusClass::Srt { deadline_us: 5_000 };
        feed(&mut v, &mut w, management(2, &advertise("speed", &ty, 1, srt), 0), Duration::ZERO);
        feed(&mut v, &mut w, topic(2, 1, Laxity::HRT, &[1, 0, 0, 0], 1_000), Duration::ZERO);
        feed(
            &mut v,
            &mut w,
            topic(2, 1, Laxity::from_code(11), &[1, 0, 0, 0], 2_000),
            Duration::ZERO,
        );
        let j = v.snapshot(&w, Duration::ZERO, None);
        assert_eq!(j["srt_latency"]["counts"], json!([0, 0, 0, 0, 0, 1, 0, 0, 0]));
        assert_eq!(j["topics"][0]["messages"], 2);
    }

    #[test]
    fn the_cycle_shows_the_latest_reservations_and_the_load_by_class() {
        let (mut v, mut w) = (BusView::new(S, LOG), Watcher::new());
        let sync = SyncFrame::new(0x1234, 0b1010_0110, true).to_frame();
        let f = r2p_canlink::CanFrame::extended(sync.id().to_raw(), sync.payload()).unwrap();
        let stamped = r2p_canlink::Stamped { time: Duration::ZERO, frame: f };
        feed(&mut v, &mut w, vec![stamped], Duration::ZERO);
        let j = v.snapshot(&w, Duration::ZERO, None);
        assert_eq!(j["cycle"]["cycle"], 0x34);
        assert_eq!(j["cycle"]["reserved_slots"], json!([1, 2, 5, 7]));
        assert_eq!(j["cycle"]["syncs"], 1);
        // A sync is an HRT frame of 8 bytes: 131 bits in the 2 s window.
        let hrt = j["cycle"]["load"]["HRT"].as_f64().unwrap();
        assert!((hrt - 131.0 / 2.0 / BITRATE).abs() < 1e-12, "{hrt}");
        assert_eq!(j["cycle"]["load"]["NRT"], 0.0);
        feed(&mut v, &mut w, management(2, &heartbeat("motor", 2), 0), Duration::ZERO);
        let nrt = v.snapshot(&w, Duration::ZERO, None)["cycle"]["load"]["NRT"].as_f64().unwrap();
        assert!(nrt > 0.0 && nrt < 1.0);
        assert_eq!(frame_bits(0), 67);
        assert_eq!(frame_bits(8), 131);
    }
}
