//! How frames and management messages are shown: one line of text per frame for people,
//! one JSON object per frame for programs (`--json`).

use std::fmt::Write as _;

use r2p_management::message::{BusClass, Message, ModuleState, ParamFault, SubscribeResult, Value};
use r2p_management::NodeId;
use rtcan::{FrameClass, FrameId, LaxityEncoding, SyncFrame};
use serde_json::{json, Map, Value as Json};

use crate::types::MsgType;
use crate::watch::{Report, Watcher, What};

/// A module state as heartbeats report it.
pub fn state_name(s: ModuleState) -> &'static str {
    match s {
        ModuleState::Starting => "starting",
        ModuleState::Running => "running",
        ModuleState::Stopped => "stopped",
        ModuleState::Bootloader => "bootloader",
    }
}

/// A parameter fault in words.
pub fn fault_name(f: ParamFault) -> &'static str {
    match f {
        ParamFault::UnknownIndex => "unknown parameter index",
        ParamFault::OutOfRange => "value out of range",
        ParamFault::ReadOnly => "read-only parameter",
        ParamFault::WrongType => "wrong value type",
        ParamFault::StorageFailed => "storing the value failed",
    }
}

/// A subscription result in words.
pub fn result_name(r: SubscribeResult) -> &'static str {
    match r {
        SubscribeResult::Ok => "ok",
        SubscribeResult::UnknownTopic => "unknown topic",
        SubscribeResult::TypeMismatch => "type mismatch",
        SubscribeResult::NoSlot => "no HRT slot",
    }
}

/// A parameter value as `type:value` (`u32:5`, `f32:1.5`, `bool:true`).
pub fn value_text(v: Value) -> String {
    match v {
        Value::Bool(b) => format!("bool:{b}"),
        Value::U32(x) => format!("u32:{x}"),
        Value::I32(x) => format!("i32:{x}"),
        Value::F32(x) => format!("f32:{x:?}"),
    }
}

/// A parameter value as JSON: `{"type": "u32", "value": 5}`.
pub fn value_json(v: Value) -> Json {
    let (t, value) = match v {
        Value::Bool(b) => ("bool", json!(b)),
        Value::U32(x) => ("u32", json!(x)),
        Value::I32(x) => ("i32", json!(x)),
        Value::F32(x) => ("f32", crate::types::Scalar::F32(x).to_json()),
    };
    json!({"type": t, "value": value})
}

/// A bus class in words.
pub fn class_text(c: BusClass) -> String {
    match c {
        BusClass::Hrt { period_cycles } => format!("HRT every {period_cycles} cycles"),
        BusClass::Srt { deadline_us } => format!("SRT deadline {deadline_us} us"),
        BusClass::Nrt => "NRT".into(),
    }
}

/// A bus class as JSON: `{"class": "SRT", "deadline_us": 20000}`.
pub fn class_json(c: BusClass) -> Json {
    match c {
        BusClass::Hrt { period_cycles } => json!({"class": "HRT", "period_cycles": period_cycles}),
        BusClass::Srt { deadline_us } => json!({"class": "SRT", "deadline_us": deadline_us}),
        BusClass::Nrt => json!({"class": "NRT"}),
    }
}

fn type_text(hash: u32, size: u16) -> String {
    match MsgType::by_hash(hash, usize::from(size)) {
        Some(t) => format!("{} (0x{hash:08X})", t.name),
        None => format!("0x{hash:08X}"),
    }
}

fn target_text(t: u8) -> String {
    if t == NodeId::BROADCAST {
        "all".into()
    } else {
        t.to_string()
    }
}

/// A trailer's version word as `major.minor.patch`.
pub fn version_text(v: u32) -> String {
    format!("{}.{}.{}", v >> 24, (v >> 16) & 0xFF, v & 0xFFFF)
}

/// A firmware-update transfer message (r2p-boot's `transfer`) in a few words.
fn transfer_text(data: &[u8]) -> String {
    use r2p_boot::transfer::{Msg, State};
    match Msg::decode(data) {
        Ok(Msg::Begin { id, len }) => format!("BEGIN id={id} len={len}"),
        Ok(Msg::Block { id, offset, data }) => {
            format!("BLOCK id={id} offset={offset} len={}", data.len())
        }
        Ok(Msg::End { id }) => format!("END id={id}"),
        Ok(Msg::Status(s)) => {
            let state = match s.state {
                State::Idle => "idle".to_string(),
                State::Receiving => "receiving".to_string(),
                State::Verified => "verified".to_string(),
                State::Refused(r) => format!("refused ({})", r.message()),
            };
            format!("STATUS id={} state={state} received={}", s.id, s.received)
        }
        Err(e) => format!("malformed ({e:?}, {} bytes)", data.len()),
    }
}

/// A management message in one line: `HEARTBEAT name=psu state=running …`.
pub fn message_text(m: &Message) -> String {
    match m {
        Message::Heartbeat { uid, name, state, uptime_s, tx_errors, rx_errors, dropped } => format!(
            "HEARTBEAT name={name} uid={} state={} uptime={uptime_s}s tx_errors={tx_errors} \
             rx_errors={rx_errors} dropped={dropped}",
            hex(uid),
            state_name(*state)
        ),
        Message::Reboot { target } => format!("REBOOT target={}", target_text(*target)),
        Message::PanicReport { text } => format!("PANIC_REPORT text={text:?}"),
        Message::Firmware { version, digest, kind, on_trial } => format!(
            "FIRMWARE kind={kind} version={} digest={} on_trial={on_trial}",
            version_text(*version),
            hex(digest)
        ),
        Message::Update { target, data } => {
            format!("UPDATE target={} {}", target_text(*target), transfer_text(data))
        }
        Message::Advertise { topic, type_hash, size, index, class } => format!(
            "ADVERTISE topic={topic} type={} size={size} stream={index} class={}",
            type_text(*type_hash, *size),
            class_text(*class)
        ),
        Message::SubscribeRequest { target, topic, type_hash, queue_len } => format!(
            "SUBSCRIBE_REQUEST target={target} topic={topic} type=0x{type_hash:08X} queue={queue_len}"
        ),
        Message::SubscribeResponse { target, topic, result, message_id } => format!(
            "SUBSCRIBE_RESPONSE target={target} topic={topic} result={} message=0x{message_id:04X}",
            result_name(*result)
        ),
        Message::HrtRequest { message_id, period_cycles, frames, size } => format!(
            "HRT_REQUEST message=0x{message_id:04X} period={period_cycles} cycles frames={frames} \
             size={size}"
        ),
        Message::HrtGrant {
            message_id,
            period_cycles,
            offset,
            slot,
            result,
            start_us,
            len_us,
        } => {
            // A position only with frame-sized reservations; on the slot grid the slot is it.
            let at = if *len_us > 0 { format!(" at={start_us}+{len_us} us") } else { String::new() };
            format!(
                "HRT_GRANT message=0x{message_id:04X} period={period_cycles} offset={offset} \
                 slot={slot} result={result:?}{at}"
            )
        }
        Message::ParamGet { target, index } => format!("PARAM_GET target={target} index={index}"),
        Message::ParamSet { target, index, value } => {
            format!("PARAM_SET target={target} index={index} value={}", value_text(*value))
        }
        Message::ParamValue { index, value } => {
            format!("PARAM_VALUE index={index} value={}", value_text(*value))
        }
        Message::ParamError { index, fault } => {
            format!("PARAM_ERROR index={index} fault={}", fault_name(*fault))
        }
    }
}

/// A management message as a JSON object with its fields (`"type": "HEARTBEAT"`, …).
pub fn message_json(m: &Message) -> Json {
    match m {
        Message::Heartbeat { uid, name, state, uptime_s, tx_errors, rx_errors, dropped } => json!({
            "type": "HEARTBEAT", "name": name.as_str(), "uid": hex(uid), "state": state_name(*state),
            "uptime_s": uptime_s, "tx_errors": tx_errors, "rx_errors": rx_errors, "dropped": dropped,
        }),
        Message::Reboot { target } => json!({"type": "REBOOT", "target": target}),
        Message::PanicReport { text } => json!({"type": "PANIC_REPORT", "text": text.as_str()}),
        Message::Firmware { version, digest, kind, on_trial } => json!({
            "type": "FIRMWARE", "kind": kind.as_str(), "version": version_text(*version),
            "digest": hex(digest), "on_trial": on_trial,
        }),
        Message::Update { target, data } => json!({
            "type": "UPDATE", "target": target, "transfer": transfer_text(data),
        }),
        Message::Advertise { topic, type_hash, size, index, class } => {
            let name = MsgType::by_hash(*type_hash, usize::from(*size)).map(|t| t.name);
            json!({
                "type": "ADVERTISE", "topic": topic.as_str(), "type_hash": type_hash,
                "type_name": name, "size": size, "stream": index, "class": class_json(*class),
            })
        }
        Message::SubscribeRequest { target, topic, type_hash, queue_len } => json!({
            "type": "SUBSCRIBE_REQUEST", "target": target, "topic": topic.as_str(),
            "type_hash": type_hash, "queue_len": queue_len,
        }),
        Message::SubscribeResponse { target, topic, result, message_id } => json!({
            "type": "SUBSCRIBE_RESPONSE", "target": target, "topic": topic.as_str(),
            "result": result_name(*result), "message_id": message_id,
        }),
        Message::HrtRequest { message_id, period_cycles, frames, size } => json!({
            "type": "HRT_REQUEST", "message_id": message_id, "period_cycles": period_cycles,
            "frames": frames, "size": size,
        }),
        Message::HrtGrant { message_id, period_cycles, offset, slot, result, start_us, len_us } => {
            json!({
                "type": "HRT_GRANT", "message_id": message_id, "period_cycles": period_cycles,
                "offset": offset, "slot": slot, "result": format!("{result:?}"),
                "start_us": start_us, "len_us": len_us,
            })
        }
        Message::ParamGet { target, index } => {
            json!({"type": "PARAM_GET", "target": target, "index": index})
        }
        Message::ParamSet { target, index, value } => {
            json!({"type": "PARAM_SET", "target": target, "index": index, "value": value_json(*value)})
        }
        Message::ParamValue { index, value } => {
            json!({"type": "PARAM_VALUE", "index": index, "value": value_json(*value)})
        }
        Message::ParamError { index, fault } => {
            json!({"type": "PARAM_ERROR", "index": index, "fault": fault_name(*fault)})
        }
    }
}

/// Bytes as contiguous upper-case hex.
pub fn hex(b: &[u8]) -> String {
    b.iter().fold(String::new(), |mut s, x| {
        let _ = write!(s, "{x:02X}");
        s
    })
}

fn class_name(id: &FrameId) -> &'static str {
    match id.class() {
        FrameClass::Hrt => "HRT",
        FrameClass::Srt => "SRT",
        FrameClass::Nrt => "NRT",
    }
}

/// Slots a sync's mask reserves, as `1,2,5` (`-` for none).
fn slots_text(sync: &SyncFrame) -> String {
    let slots: Vec<String> =
        (1..64).filter(|s| sync.reservations & (1u64 << s) != 0).map(|s| s.to_string()).collect();
    if slots.is_empty() {
        "-".into()
    } else {
        slots.join(",")
    }
}

fn micros_text(us: u32) -> String {
    if us >= 1_000 {
        format!("{}.{}ms", us / 1_000, us % 1_000 / 100)
    } else {
        format!("{us}us")
    }
}

/// One line for a frame:
/// `TIME ID CLASS lax=L msg=MMMM frag=F SOURCE KIND [LEN] DATA | DECODED`.
pub fn report_line(r: &Report, w: &Watcher, laxity: LaxityEncoding) -> String {
    let time = r2p_canlink::frame::format_time(r.time);
    let data = hex(r.frame.data());
    let Some(id) = r.id else {
        return format!("{time} {} std (not RTCAN) [{}] {data}", r.frame.id_hex(), r.frame.len());
    };
    let lax = id.laxity.code();
    let lax = match id.class() {
        FrameClass::Srt => format!("{lax}(>={})", micros_text(laxity.lower_bound_us(id.laxity))),
        _ => lax.to_string(),
    };
    let mut line = format!(
        "{time} {:08X} {} lax={lax:<2} msg={:04X} frag={:<3} ",
        id.to_raw(),
        class_name(&id),
        id.message.0,
        id.fragment
    );
    let decoded = match &r.what {
        What::Standard => None,
        What::Reserved => {
            line.push_str("reserved ID");
            None
        }
        What::Sync(Ok(s)) => {
            let _ = write!(line, "sync cycle={:02X}", s.cycle);
            Some(format!("next cycle reserves slots {} epoch={}", slots_text(s), u8::from(s.epoch)))
        }
        What::Sync(Err(n)) => {
            line.push_str("sync");
            Some(format!("bad sync: {n} bytes, not 8"))
        }
        What::Management { node, done } => {
            let _ = write!(line, "node {} mgmt", w.node_label(*node));
            done.as_ref().map(|m| match m {
                Ok(m) => message_text(m),
                Err(e) => format!("malformed management message: {e:?}"),
            })
        }
        What::Topic { node, index, topic, done } => {
            let _ = write!(line, "node {} stream {index}", w.node_label(*node));
            match topic {
                Some(t) => {
                    let _ = write!(line, " topic {}", t.topic);
                    done.as_ref().map(|d| match t.msg_type() {
                        Some(ty) => ty
                            .decode(d)
                            .map_or_else(|e| format!("bad payload: {e}"), |v| v.to_string()),
                        None => format!("{} bytes of type 0x{:08X}", d.len(), t.type_hash),
                    })
                }
                None => None,
            }
        }
    };
    let _ = write!(line, " [{}] {data}", r.frame.len());
    if let Some(d) = decoded {
        let _ = write!(line, " | {d}");
    }
    line
}

/// A frame as a JSON object.
pub fn report_json(r: &Report, w: &Watcher, laxity: LaxityEncoding) -> Json {
    let mut o = Map::new();
    o.insert("time".into(), json!(r.time.as_secs_f64()));
    o.insert("id".into(), json!(r.frame.id()));
    o.insert("extended".into(), json!(r.frame.is_extended()));
    o.insert("data".into(), json!(hex(r.frame.data())));
    if let Some(id) = r.id {
        o.insert("class".into(), json!(class_name(&id)));
        o.insert("laxity".into(), json!(id.laxity.code()));
        if id.class() == FrameClass::Srt {
            o.insert("min_remaining_us".into(), json!(laxity.lower_bound_us(id.laxity)));
        }
        o.insert("message".into(), json!(id.message.0));
        o.insert("fragment".into(), json!(id.fragment));
    }
    let kind = match &r.what {
        What::Standard => "standard",
        What::Reserved => "reserved",
        What::Sync(s) => {
            match s {
                Ok(s) => {
                    let slots: Vec<u8> =
                        (1..64).filter(|b| s.reservations & (1u64 << b) != 0).collect();
                    o.insert(
                        "sync".into(),
                        json!({"cycle": s.cycle, "reserved_slots": slots, "epoch": s.epoch, "sender_rank": s.sender}),
                    );
                }
                Err(n) => {
                    o.insert("error".into(), json!(format!("bad sync: {n} bytes")));
                }
            }
            "sync"
        }
        What::Management { node, done } => {
            o.insert("node".into(), json!(node));
            if let Some(n) = w.node(*node) {
                o.insert("node_name".into(), json!(n.name));
            }
            match done {
                Some(Ok(m)) => {
                    o.insert("management".into(), message_json(m));
                }
                Some(Err(e)) => {
                    o.insert("error".into(), json!(format!("malformed management message: {e:?}")));
                }
                None => {}
            }
            "management"
        }
        What::Topic { node, index, topic, done } => {
            o.insert("node".into(), json!(node));
            o.insert("stream".into(), json!(index));
            if let Some(t) = topic {
                o.insert("topic".into(), json!(t.topic));
                o.insert("type".into(), json!(t.type_name()));
                if let Some(d) = done {
                    let value = t.msg_type().map(|ty| ty.decode(d));
                    match value {
                        Some(Ok(v)) => {
                            o.insert("value".into(), v.to_json());
                        }
                        Some(Err(e)) => {
                            o.insert("error".into(), json!(e));
                        }
                        None => {
                            o.insert("payload".into(), json!(hex(d)));
                        }
                    }
                }
            }
            "topic"
        }
    };
    o.insert("kind".into(), json!(kind));
    Json::Object(o)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::watch::tests::{advertise, heartbeat, management, topic};
    use r2p_canlink::{CanFrame, Stamped};
    use rtcan::Laxity;
    use std::time::Duration;

    const LOG: LaxityEncoding = LaxityEncoding::Logarithmic { tick_us: 100 };

    #[test]
    fn a_heartbeat_is_shown_frame_by_frame_then_decoded() {
        let mut w = Watcher::new();
        let frames = management(1, &heartbeat("psu", 1), 1_700_000_000_000_000);
        let lines: Vec<String> = frames.iter().map(|f| report_line(&w.feed(f), &w, LOG)).collect();
        assert_eq!(
            lines[0],
            "1700000000.000000 1F808004 NRT lax=63 msg=0100 frag=4   node 1 mgmt [8] 1100000000000000"
        );
        assert_eq!(
            lines[3],
            "1700000000.000600 1F808001 NRT lax=63 msg=0100 frag=1   node 1 (psu) mgmt [4] 03007424 | \
             HEARTBEAT name=psu uid=000000000000000000000001 state=running uptime=7s tx_errors=1 \
             rx_errors=2 dropped=3"
        );
        let j = report_json(&w.feed(&frames[3]), &w, LOG);
        assert_eq!(j["kind"], "management");
        assert_eq!(j["class"], "NRT");
        assert_eq!((j["message"].as_u64(), j["fragment"].as_u64()), (Some(0x100), Some(1)));
    }

    #[test]
    fn syncs_and_topics_are_decoded() {
        let mut w = Watcher::new();
        let sync = SyncFrame::new(0x45, 0b110, false).to_frame();
        let s = Stamped {
            time: Duration::from_micros(5),
            frame: CanFrame::extended(sync.id().to_raw(), sync.payload()).unwrap(),
        };
        let line = report_line(&w.feed(&s), &w, LOG);
        assert_eq!(
            line,
            "0.000005 00002280 HRT lax=0  msg=0045 frag=0   sync cycle=45 [8] 0600000000000000 | \
             next cycle reserves slots 1,2 epoch=0"
        );
        let j = report_json(&w.feed(&s), &w, LOG);
        assert_eq!(j["sync"]["reserved_slots"], json!([1, 2]));
        assert_eq!(j["sync"]["sender_rank"], json!(0));

        let ty = MsgType::by_name("Obstacle").unwrap();
        for f in management(
            0x20,
            &advertise("obstacle", &ty, 1, BusClass::Srt { deadline_us: 5_000 }),
            0,
        ) {
            let line = report_line(&w.feed(&f), &w, LOG);
            if line.contains('|') {
                assert!(line.ends_with(
                    "| ADVERTISE topic=obstacle type=Obstacle (0x24BEC850) size=5 stream=1 class=SRT deadline 5000 us"
                ), "{line}");
            }
        }
        let f = &topic(0x20, 1, Laxity::from_code(21), &[3, 0, 0, 0, 0x3F], 100)[0];
        let r = w.feed(f);
        assert_eq!(
            report_line(&r, &w, LOG),
            "0.000100 0A900080 SRT lax=21(>=3.1ms) msg=2001 frag=0   node 32 stream 1 topic obstacle \
             [5] 030000003F | channel=3 distance=0.5"
        );
        let j = report_json(&r, &w, LOG);
        assert_eq!(j["value"], json!({"channel": 3, "distance": 0.5}));
        assert_eq!(j["min_remaining_us"], json!(3_100));
        assert_eq!(j["topic"], "obstacle");
    }

    #[test]
    fn every_management_message_has_a_line_and_an_object() {
        use r2p_management::message::HrtResult;
        let t = |s: &str| s.try_into().unwrap();
        let msgs = [
            heartbeat("x", 1),
            Message::Reboot { target: 255 },
            Message::SubscribeRequest { target: 2, topic: t("scan"), type_hash: 7, queue_len: 4 },
            Message::SubscribeResponse {
                target: 9,
                topic: t("scan"),
                result: SubscribeResult::TypeMismatch,
                message_id: 0,
            },
            Message::HrtRequest { message_id: 0x201, period_cycles: 2, frames: 1, size: 4 },
            Message::HrtGrant {
                message_id: 0x201,
                period_cycles: 2,
                offset: 1,
                slot: 3,
                result: HrtResult::Ok,
                start_us: 500,
                len_us: 167,
            },
            Message::ParamGet { target: 1, index: 4 },
            Message::ParamSet { target: 1, index: 4, value: Value::F32(1.5) },
            Message::ParamValue { index: 4, value: Value::I32(-3) },
            Message::ParamError { index: 4, fault: ParamFault::OutOfRange },
            Message::PanicReport { text: "src/lib.rs:3:5: boom".try_into().unwrap() },
        ];
        let lines: Vec<String> = msgs.iter().map(message_text).collect();
        assert_eq!(lines[1], "REBOOT target=all");
        assert_eq!(
            lines[5],
            "HRT_GRANT message=0x0201 period=2 offset=1 slot=3 result=Ok at=500+167 us"
        );
        let grid = Message::HrtGrant {
            message_id: 0x201,
            period_cycles: 2,
            offset: 1,
            slot: 3,
            result: HrtResult::Ok,
            start_us: 0,
            len_us: 0,
        };
        assert_eq!(
            message_text(&grid),
            "HRT_GRANT message=0x0201 period=2 offset=1 slot=3 result=Ok"
        );
        assert!(lines[3].contains("result=type mismatch"));
        assert_eq!(lines[7], "PARAM_SET target=1 index=4 value=f32:1.5");
        assert_eq!(lines[8], "PARAM_VALUE index=4 value=i32:-3");
        assert_eq!(lines[9], "PARAM_ERROR index=4 fault=value out of range");
        for (m, line) in msgs.iter().zip(&lines) {
            let j = message_json(m);
            assert!(line.starts_with(j["type"].as_str().unwrap()), "{line}");
        }
        assert_eq!(message_json(&msgs[7])["value"], json!({"type": "f32", "value": 1.5}));
        assert_eq!(lines[10], "PANIC_REPORT text=\"src/lib.rs:3:5: boom\"");
        assert_eq!(message_json(&msgs[10])["text"], "src/lib.rs:3:5: boom");
    }

    #[test]
    fn standard_frames_are_marked_not_rtcan() {
        let mut w = Watcher::new();
        let s = Stamped { time: Duration::ZERO, frame: CanFrame::standard(0x123, &[1]).unwrap() };
        assert_eq!(report_line(&w.feed(&s), &w, LOG), "0.000000 123 std (not RTCAN) [1] 01");
        assert_eq!(report_json(&w.feed(&s), &w, LOG)["kind"], "standard");
    }
}
