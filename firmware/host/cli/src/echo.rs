//! `r2p echo TOPIC`: subscribes as a module does (the host node imports the topic with the
//! type its publisher advertises) and prints every message, decoded by that type. Over a
//! trace it decodes the topic's frames as recorded.

use std::io::Write;
use std::time::{Duration, Instant};

use clap::Args;
use r2p_node::Event;
use serde_json::json;

use crate::args::{emit, BusArgs};
use crate::describe::{hex, result_name};
use crate::error::CliError;
use crate::listing::sorted_topics;
use crate::session::Session;
use crate::watch::{TopicInfo, Watcher, What};

/// `r2p echo` options.
#[derive(Args, Debug)]
pub struct EchoArgs {
    /// The topic's name, as its publisher advertises it
    pub topic: String,
    /// Stop after N messages; until then it waits for them however long they take (--timeout
    /// covers the advertisement and the subscription only): an event topic such as a fault
    /// may never publish
    #[arg(long, value_name = "N")]
    pub count: Option<u64>,
}

/// The topics seen, for an "unknown topic" error.
fn seen(w: &Watcher) -> String {
    let topics = sorted_topics(w, None);
    if topics.is_empty() {
        return "none".into();
    }
    topics
        .iter()
        .map(|t| format!("{} (node {}, {})", t.topic, w.node_label(t.node), t.type_name()))
        .collect::<Vec<_>>()
        .join(", ")
}

fn unknown(topic: &str, s: &Session, waited: &str) -> CliError {
    CliError::new(format!(
        "unknown topic {topic:?}: no module advertised it on {} {waited}; topics seen: {}",
        s.describe(),
        seen(s.watcher())
    ))
}

/// One message as a line.
fn line(t: &TopicInfo, bytes: &[u8], json: bool) -> String {
    let decoded = t.msg_type().map(|ty| ty.decode(bytes));
    if json {
        let mut j = json!({"topic": t.topic, "node": t.node, "type": t.type_name()});
        match decoded {
            Some(Ok(v)) => j["value"] = v.to_json(),
            Some(Err(e)) => j["error"] = json!(e),
            None => j["payload"] = json!(hex(bytes)),
        }
        j.to_string()
    } else {
        match decoded {
            Some(Ok(v)) => v.to_string(),
            Some(Err(e)) => format!("bad message ({e}): {}", hex(bytes)),
            None => format!("{} (type 0x{:08X}, unknown to r2p)", hex(bytes), t.type_hash),
        }
    }
}

/// Runs `r2p echo`.
pub fn run(
    args: &EchoArgs,
    bus: &BusArgs,
    mut s: Session,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    if s.is_trace() {
        return from_trace(args, bus, s, out);
    }
    s.join()?.want_import(&args.topic);
    let start = Instant::now();
    let mut subscribed_at: Option<Instant> = None;
    let mut info: Option<TopicInfo> = None;
    let mut shown = 0u64;
    loop {
        s.step(Duration::from_millis(2))?;
        let host = s.host().expect("joined");
        if let Some(e) = host.import_error() {
            return Err(e.clone());
        }
        if info.is_none() {
            info = host.imported().cloned();
            if info.is_some() {
                subscribed_at = Some(Instant::now());
            }
        }
        while let Some(e) = host.next_event() {
            match e {
                Event::Subscribed { .. } => subscribed_at = None,
                Event::SubscriptionRefused { from, result, .. } => {
                    return Err(CliError::new(format!(
                        "node {} refused the subscription to {:?}: {}",
                        from.get(),
                        args.topic,
                        result_name(result)
                    )))
                }
                _ => {}
            }
        }
        let messages = host.take_messages();
        let Some(t) = &info else {
            if start.elapsed() >= bus.timeout {
                return Err(unknown(&args.topic, &s, &format!("within {:?}", bus.timeout)));
            }
            continue;
        };
        if subscribed_at.is_some_and(|at| at.elapsed() >= bus.timeout) {
            return Err(CliError::new(format!(
                "node {} advertised {:?} but did not answer the subscription within {:?}",
                s.watcher().node_label(t.node),
                args.topic,
                bus.timeout
            )));
        }
        for m in messages {
            emit(out, &line(t, &m, bus.json))?;
            shown += 1;
            if args.count.is_some_and(|n| shown >= n) {
                return Ok(());
            }
        }
    }
}

/// `r2p echo` over a trace: the topic's messages as recorded.
fn from_trace(
    args: &EchoArgs,
    bus: &BusArgs,
    mut s: Session,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let mut shown = 0u64;
    while !s.ended() {
        for r in s.step(Duration::ZERO)? {
            if let What::Topic { topic: Some(t), done: Some(bytes), .. } = &r.what {
                if t.topic == args.topic {
                    emit(out, &line(t, bytes, bus.json))?;
                    shown += 1;
                    if args.count.is_some_and(|n| shown >= n) {
                        return Ok(());
                    }
                }
            }
        }
    }
    if s.watcher().topic(&args.topic).is_none() {
        return Err(unknown(&args.topic, &s, "in the whole trace"));
    }
    Ok(())
}
