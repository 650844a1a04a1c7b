//! `r2p nodes` and `r2p topics`: what heartbeats and advertisements say, as tables.

use std::io::Write;
use std::time::{Duration, Instant};

use serde_json::json;

use crate::args::{emit, BusArgs};
use crate::describe::{class_json, class_text, hex, state_name};
use crate::error::CliError;
use crate::session::Session;
use crate::watch::{NodeInfo, TopicInfo, Watcher};

/// Steps `s` for `d` (a live bus) or to its end (a trace).
pub fn listen(s: &mut Session, d: Duration) -> Result<(), CliError> {
    let start = Instant::now();
    while !s.ended() && (s.is_trace() || start.elapsed() < d) {
        s.step(Duration::from_millis(5))?;
    }
    Ok(())
}

/// Lays out rows as columns two spaces apart (the last column is not padded).
fn table(rows: &[Vec<String>]) -> Vec<String> {
    let cols = rows.first().map_or(0, Vec::len);
    let widths: Vec<usize> =
        (0..cols).map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0)).collect();
    rows.iter()
        .map(|r| {
            let mut line = String::new();
            for (c, cell) in r.iter().enumerate() {
                if c + 1 == cols {
                    line.push_str(cell);
                } else {
                    line.push_str(&format!("{cell:<w$}  ", w = widths[c]));
                }
            }
            line
        })
        .collect()
}

/// `1.4.2 3f0a9c1e5b7d2468`, `(on trial)` while it has not confirmed itself, `-` if unheard.
fn firmware_text(n: &NodeInfo) -> String {
    n.firmware.as_ref().map_or_else(
        || "-".into(),
        |f| {
            let trial = if f.on_trial { " (on trial)" } else { "" };
            format!("{} {}{trial}", f.version_text(), f.digest_hex())
        },
    )
}

fn node_row(n: &NodeInfo) -> Vec<String> {
    vec![
        n.id.to_string(),
        n.name.clone(),
        hex(&n.uid),
        state_name(n.state).to_string(),
        format!("{}s", n.uptime_s),
        n.tx_errors.to_string(),
        n.rx_errors.to_string(),
        n.dropped.to_string(),
        firmware_text(n),
        n.panic.clone().unwrap_or_else(|| "-".into()),
    ]
}

/// The `nodes` table (header first).
pub fn nodes_table(w: &Watcher) -> Vec<String> {
    let mut rows = vec![[
        "NODE",
        "NAME",
        "UNIQUE ID",
        "STATE",
        "UPTIME",
        "TX_ERR",
        "RX_ERR",
        "DROPPED",
        "FIRMWARE",
        "LAST PANIC",
    ]
    .map(String::from)
    .to_vec()];
    rows.extend(w.nodes().map(node_row));
    table(&rows)
}

/// Runs `r2p nodes`: listens without sending.
pub fn nodes(bus: &BusArgs, mut s: Session, out: &mut dyn Write) -> Result<(), CliError> {
    listen(&mut s, bus.timeout)?;
    let w = s.watcher();
    if w.nodes().next().is_none() {
        return Err(CliError::new(format!(
            "no heartbeat heard on {} {} ({} frames seen): no module is running there{}",
            s.describe(),
            if s.is_trace() {
                "in the whole trace".to_string()
            } else {
                format!("within {:?}", bus.timeout)
            },
            w.frames(),
            if s.is_trace() { "" } else { ", or it needs longer (--timeout)" }
        )));
    }
    if bus.json {
        for n in w.nodes() {
            let j = json!({
                "node": n.id, "name": n.name, "uid": hex(&n.uid), "state": state_name(n.state),
                "uptime_s": n.uptime_s, "tx_errors": n.tx_errors, "rx_errors": n.rx_errors,
                "dropped": n.dropped, "panic": n.panic,
                "firmware": n.firmware.as_ref().map(|f| json!({
                    "version": f.version_text(), "digest": f.digest_hex(), "kind": f.kind,
                    "on_trial": f.on_trial,
                })),
            });
            emit(out, &j.to_string())?;
        }
    } else {
        for line in nodes_table(w) {
            emit(out, &line)?;
        }
    }
    Ok(())
}

fn publisher(w: &Watcher, t: &TopicInfo) -> String {
    w.node_label(t.node)
}

/// The advertised topics, by name then publisher, without the CLI's own node's.
pub fn sorted_topics(w: &Watcher, own: Option<u8>) -> Vec<TopicInfo> {
    let mut topics: Vec<TopicInfo> = w.topics().filter(|t| Some(t.node) != own).cloned().collect();
    topics.sort_by(|a, b| (a.topic.as_str(), a.node).cmp(&(b.topic.as_str(), b.node)));
    topics
}

/// The `topics` table (header first).
pub fn topics_table(w: &Watcher, topics: &[TopicInfo]) -> Vec<String> {
    let mut rows = vec![["TOPIC", "TYPE", "SIZE", "PUBLISHER", "MESSAGE ID", "CLASS"]
        .map(String::from)
        .to_vec()];
    rows.extend(topics.iter().map(|t| {
        vec![
            t.topic.clone(),
            t.type_name(),
            t.size.to_string(),
            publisher(w, t),
            format!("0x{:04X}", t.message()),
            class_text(t.class),
        ]
    }));
    table(&rows)
}

/// Runs `r2p topics`: joins the bus (so modules advertise again) and listens.
pub fn topics(bus: &BusArgs, mut s: Session, out: &mut dyn Write) -> Result<(), CliError> {
    let own = if s.is_trace() { None } else { Some(s.join()?.node_id().get()) };
    listen(&mut s, bus.timeout)?;
    // The node ID may have moved while listening (a conflict).
    let own = own.and(s.host().map(|h| h.node_id().get()));
    let w = s.watcher();
    let topics = sorted_topics(w, own);
    if topics.is_empty() {
        return Err(CliError::new(format!(
            "no topic advertised on {} {} ({} nodes heard)",
            s.describe(),
            if s.is_trace() {
                "in the whole trace".to_string()
            } else {
                format!("within {:?}", bus.timeout)
            },
            w.nodes().count()
        )));
    }
    if bus.json {
        for t in &topics {
            let j = json!({
                "topic": t.topic, "type": t.type_name(), "type_hash": t.type_hash,
                "size": t.size, "node": t.node,
                "node_name": w.node(t.node).map(|n| n.name.clone()),
                "message_id": t.message(), "class": class_json(t.class),
            });
            emit(out, &j.to_string())?;
        }
    } else {
        for line in topics_table(w, &topics) {
            emit(out, &line)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::MsgType;
    use crate::watch::tests::{advertise, heartbeat, management};
    use r2p_management::message::{BusClass, Message};

    #[test]
    fn tables_line_up() {
        let mut w = Watcher::new();
        let scan = MsgType::by_name("uint32[4]").unwrap();
        for f in management(1, &heartbeat("psu", 1), 0)
            .into_iter()
            .chain(management(2, &heartbeat("motor", 2), 1_000))
            .chain(management(
                2,
                &advertise("scan", &scan, 2, BusClass::Srt { deadline_us: 20_000 }),
                2_000,
            ))
            .chain(management(
                2,
                &advertise(
                    "setpoint",
                    &MsgType::by_name("uint32").unwrap(),
                    1,
                    BusClass::Hrt { period_cycles: 2 },
                ),
                3_000,
            ))
        {
            w.feed(&f);
        }
        assert_eq!(
            nodes_table(&w),
            [
                "NODE  NAME   UNIQUE ID                 STATE    UPTIME  TX_ERR  RX_ERR  DROPPED  FIRMWARE  LAST PANIC",
                "1     psu    000000000000000000000001  running  7s      1       2       3        -         -",
                "2     motor  000000000000000000000002  running  7s      1       2       3        -         -",
            ]
        );
        let topics = sorted_topics(&w, None);
        assert_eq!(
            topics_table(&w, &topics),
            [
                "TOPIC     TYPE       SIZE  PUBLISHER  MESSAGE ID  CLASS",
                "scan      uint32[4]  16    2 (motor)  0x0202      SRT deadline 20000 us",
                "setpoint  uint32     4     2 (motor)  0x0201      HRT every 2 cycles",
            ]
        );
        assert!(sorted_topics(&w, Some(2)).is_empty(), "the CLI's own topics are left out");
    }

    #[test]
    fn nodes_show_the_firmware_a_module_runs_and_forget_it_when_it_boots_again() {
        let mut w = Watcher::new();
        let firmware = |on_trial| Message::Firmware {
            version: 0x0104_0002,
            digest: [0x72, 0x92, 0x12, 0xe7, 0x69, 0xdf, 0x4a, 0xa1],
            kind: "motor".try_into().unwrap(),
            on_trial,
        };
        let mut rebooted = heartbeat("motor", 2);
        if let Message::Heartbeat { uptime_s, .. } = &mut rebooted {
            *uptime_s = 0;
        }
        let feed = |w: &mut Watcher, m: &Message, t: u64| {
            for f in management(2, m, t) {
                w.feed(&f);
            }
        };
        feed(&mut w, &heartbeat("motor", 2), 1_000);
        feed(&mut w, &firmware(true), 2_000);
        assert!(nodes_table(&w)[1].contains("  1.4.2 729212e769df4aa1 (on trial)  "));
        feed(&mut w, &firmware(false), 3_000);
        feed(&mut w, &heartbeat("motor", 2), 4_000); // same boot: it stands
        assert!(nodes_table(&w)[1].contains("  1.4.2 729212e769df4aa1  "), "{:?}", nodes_table(&w));
        feed(&mut w, &rebooted, 5_000); // a new boot: not yet said
        assert_eq!(w.node(2).unwrap().firmware, None);
        let unsigned = Message::Firmware {
            version: 0,
            digest: [0; 8],
            kind: "motor".try_into().unwrap(),
            on_trial: false,
        };
        feed(&mut w, &unsigned, 6_000);
        assert!(nodes_table(&w)[1].contains("  unsigned 0000000000000000  "));
    }

    #[test]
    fn nodes_show_the_panic_a_module_reported_until_it_boots_again() {
        let mut w = Watcher::new();
        let report =
            Message::PanicReport { text: "panic, calls: 08002a1e 0800b3c2".try_into().unwrap() };
        let mut rebooted = heartbeat("motor", 2);
        if let Message::Heartbeat { uptime_s, .. } = &mut rebooted {
            *uptime_s = 0;
        }
        let feed = |w: &mut Watcher, m: &Message, t: u64| {
            for f in management(2, m, t) {
                w.feed(&f);
            }
        };
        feed(&mut w, &report, 500); // before any heartbeat: not yet a node, ignored
        assert!(w.node(2).is_none());
        feed(&mut w, &heartbeat("motor", 2), 1_000);
        feed(&mut w, &report, 2_000);
        feed(&mut w, &heartbeat("motor", 2), 3_000); // same boot: the report stands
        assert_eq!(
            nodes_table(&w)[1],
            "2     motor  000000000000000000000002  running  7s      1       2       3        -         \
             panic, calls: 08002a1e 0800b3c2"
        );
        feed(&mut w, &rebooted, 4_000); // uptime back to 0: a new boot, no report yet
        assert_eq!(w.node(2).unwrap().panic, None);
        assert!(nodes_table(&w)[1].ends_with("  -"));
    }
}
