//! `r2p param get|set NODE INDEX [VALUE]`: PARAM_GET / PARAM_SET through the host node; prints
//! the value the module holds, or why it refused.

use std::io::Write;
use std::time::{Duration, Instant};

use clap::Subcommand;
use r2p_management::message::{ParamFault, Value};
use r2p_management::NodeId;
use r2p_node::Event;
use serde_json::json;

use crate::args::{emit, BusArgs};
use crate::describe::{fault_name, value_json};
use crate::error::CliError;
use crate::session::Session;
use crate::types::{Prim, Scalar};

/// `r2p param` subcommands.
#[derive(Subcommand, Debug)]
pub enum ParamCommand {
    /// Print parameter INDEX of NODE
    Get {
        /// The module: its node ID, or its name as heartbeats give it
        node: String,
        /// The parameter's index
        index: u16,
    },
    /// Set parameter INDEX of NODE to VALUE and print the value it now holds
    Set {
        /// The module: its node ID, or its name as heartbeats give it
        node: String,
        /// The parameter's index
        index: u16,
        /// The value: typed (u32:5, i32:-3, f32:1.5, bool:true) or bare (5, 1.5, true), read
        /// in the type the parameter has now
        #[arg(allow_negative_numbers = true)]
        value: String,
    },
}

/// Parses a typed value `u32:5`; `None` if `text` has no type prefix.
pub fn parse_typed(text: &str) -> Option<Result<Value, String>> {
    let (t, v) = text.split_once(':')?;
    let prim = match t {
        "u32" => Prim::U32,
        "i32" => Prim::I32,
        "f32" => Prim::F32,
        "bool" => Prim::Bool,
        _ => return Some(Err(format!("{text:?}: the type is u32, i32, f32 or bool"))),
    };
    Some(prim.parse(v).map(to_value))
}

/// Parses a bare value in the type of `like`.
pub fn parse_like(text: &str, like: Value) -> Result<Value, String> {
    let prim = match like {
        Value::U32(_) => Prim::U32,
        Value::I32(_) => Prim::I32,
        Value::F32(_) => Prim::F32,
        Value::Bool(_) => Prim::Bool,
    };
    prim.parse(text).map(to_value).map_err(|e| format!("{e} (the parameter is {})", prim.name()))
}

fn to_value(s: Scalar) -> Value {
    match s {
        Scalar::Bool(b) => Value::Bool(b),
        Scalar::U(x) => Value::U32(x as u32),
        Scalar::I(x) => Value::I32(x as i32),
        Scalar::F32(x) => Value::F32(x),
        Scalar::F64(x) => Value::F32(x as f32),
    }
}

/// Waits for a heartbeat of `node` (an ID or a name) and returns its node ID.
pub(crate) fn resolve(node: &str, bus: &BusArgs, s: &mut Session) -> Result<NodeId, CliError> {
    let by_id = node
        .strip_prefix("0x")
        .map_or_else(|| node.parse::<u8>().ok(), |h| u8::from_str_radix(h, 16).ok());
    let start = Instant::now();
    loop {
        let w = s.watcher();
        let found: Vec<u8> = match by_id {
            Some(id) => w.node(id).map(|n| vec![n.id]).unwrap_or_default(),
            None => w.nodes().filter(|n| n.name == node).map(|n| n.id).collect(),
        };
        match found.as_slice() {
            [id] => return NodeId::new(*id).ok_or_else(|| CliError::new("bad node ID")),
            [] if start.elapsed() < bus.timeout => {}
            [] => {
                let heard: Vec<String> = w
                    .nodes()
                    .filter(|n| n.name != crate::host::NODE_NAME)
                    .map(|n| format!("{} {}", n.id, n.name))
                    .collect();
                return Err(CliError::new(format!(
                    "unknown node {node:?}: no heartbeat from it on {} within {:?}; nodes heard: {}",
                    s.describe(),
                    bus.timeout,
                    if heard.is_empty() { "none".into() } else { heard.join(", ") }
                )));
            }
            many => {
                return Err(CliError::new(format!(
                    "{} modules are named {node:?} (node IDs {}): give the node ID",
                    many.len(),
                    many.iter().map(u8::to_string).collect::<Vec<_>>().join(", ")
                )))
            }
        }
        s.step(Duration::from_millis(2))?;
    }
}

/// How long an unanswered request waits before it is sent again. A request or its answer can
/// be lost (a receiver's full FIFO, a tool's full queue); reading a parameter, and setting
/// one to a given value, do the same when done twice, so asking again is safe.
pub const RETRY: Duration = Duration::from_millis(300);

/// Sends a request (`ask`), again every [`RETRY`] while unanswered, and waits up to the
/// bus timeout for the answer about `index` from `target`.
pub(crate) fn ask(
    s: &mut Session,
    bus: &BusArgs,
    target: NodeId,
    index: u16,
    what: &str,
    ask: impl Fn(&mut crate::host::HostNode) -> Result<(), CliError>,
) -> Result<Result<Value, ParamFault>, CliError> {
    let start = Instant::now();
    let mut asked: Option<Instant> = None;
    while start.elapsed() < bus.timeout {
        let host = s.host().expect("joined");
        let again = asked.is_some_and(|t| t.elapsed() >= RETRY) && host.tx_pending() == 0;
        if asked.is_none() || again {
            ask(host)?;
            asked = Some(Instant::now());
        }
        s.step(Duration::from_millis(2))?;
        while let Some(e) = s.host().expect("joined").next_event() {
            match e {
                Event::ParamValue { from, index: i, value } if from == target && i == index => {
                    return Ok(Ok(value))
                }
                Event::ParamError { from, index: i, fault } if from == target && i == index => {
                    return Ok(Err(fault))
                }
                _ => {}
            }
        }
    }
    Err(CliError::new(format!(
        "node {} did not answer {what} of parameter {index} within {:?}",
        s.watcher().node_label(target.get()),
        bus.timeout
    )))
}

pub(crate) fn refused(
    s: &Session,
    target: NodeId,
    what: &str,
    index: u16,
    fault: ParamFault,
) -> CliError {
    CliError::new(format!(
        "node {} refused {what} of parameter {index}: {}",
        s.watcher().node_label(target.get()),
        fault_name(fault)
    ))
}

/// Runs `r2p param get|set`.
pub fn run(
    cmd: &ParamCommand,
    bus: &BusArgs,
    mut s: Session,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let (node, index) = match cmd {
        ParamCommand::Get { node, index } | ParamCommand::Set { node, index, .. } => (node, *index),
    };
    let typed = match cmd {
        ParamCommand::Set { value, .. } => parse_typed(value).transpose().map_err(CliError::new)?,
        ParamCommand::Get { .. } => None,
    };
    s.join()?;
    let target = resolve(node, bus, &mut s)?;
    let get =
        |s: &mut Session| ask(s, bus, target, index, "PARAM_GET", |h| h.get_param(target, index));
    let value = match cmd {
        ParamCommand::Get { .. } => {
            get(&mut s)?.map_err(|f| refused(&s, target, "PARAM_GET", index, f))?
        }
        ParamCommand::Set { value: text, .. } => {
            let value = match typed {
                Some(v) => v,
                None => {
                    let now =
                        get(&mut s)?.map_err(|f| refused(&s, target, "PARAM_GET", index, f))?;
                    parse_like(text, now).map_err(CliError::new)?
                }
            };
            ask(&mut s, bus, target, index, "PARAM_SET", |h| h.set_param(target, index, value))?
                .map_err(|f| refused(&s, target, "PARAM_SET", index, f))?
        }
    };
    if bus.json {
        let mut j = value_json(value);
        j["node"] = json!(target.get());
        j["index"] = json!(index);
        if let Some(n) = s.watcher().node(target.get()) {
            j["node_name"] = json!(n.name);
        }
        emit(out, &j.to_string())
    } else {
        emit(out, &crate::describe::value_text(value))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::{HubLink, Link, Recv};
    use crate::watch::{Watcher, What};
    use r2p_canlink::{BroadcastHub, CanFrame, Hub, Stamped};
    use r2p_management::message::Message;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;

    /// A hub link that loses the first `lose` PARAM_GET requests the tool sends.
    struct LosesRequests {
        inner: HubLink,
        watch: Watcher,
        lose: usize,
    }

    impl Link for LosesRequests {
        fn recv(&mut self, timeout: Duration) -> Result<Recv, CliError> {
            self.inner.recv(timeout)
        }
        fn send(&mut self, frame: &CanFrame) -> Result<(), CliError> {
            let r = self.watch.feed(&Stamped { time: Duration::ZERO, frame: *frame });
            if self.lose > 0
                && matches!(
                    r.what,
                    What::Management { done: Some(Ok(Message::ParamGet { .. })), .. }
                )
            {
                self.lose -= 1;
                return Ok(());
            }
            self.inner.send(frame)
        }
        fn describe(&self) -> String {
            "a lossy in-process bus".into()
        }
    }

    fn get_over(lose: usize) -> Result<String, CliError> {
        let hub = Arc::new(BroadcastHub::new());
        let stop = Arc::new(AtomicBool::new(false));
        let module = crate::host::tests::spawn_module(hub.clone(), stop.clone());
        let inner = HubLink::join(hub as Arc<dyn Hub>, 4096);
        let s = Session::new(Box::new(LosesRequests { inner, watch: Watcher::new(), lose }));
        let bus = BusArgs {
            socketcand: None,
            socketcan: None,
            trace: None,
            channel: "vcan0".into(),
            timeout: Duration::from_secs(2),
            json: false,
        };
        let cmd = ParamCommand::Get { node: "sensor".into(), index: 1 };
        let mut out = Vec::new();
        let r = run(&cmd, &bus, s, &mut out);
        stop.store(true, Ordering::SeqCst);
        module.join().unwrap();
        r.map(|()| String::from_utf8(out).unwrap())
    }

    #[test]
    fn a_lost_request_is_asked_again_until_the_timeout() {
        assert_eq!(get_over(2).unwrap().trim(), "f32:0.5", "two lost, the third answered");
        let e = get_over(usize::MAX).unwrap_err().to_string();
        assert!(e.contains("did not answer PARAM_GET of parameter 1 within 2s"), "{e}");
    }

    #[test]
    fn values_parse_typed_or_like_the_current_one() {
        assert_eq!(parse_typed("u32:5"), Some(Ok(Value::U32(5))));
        assert_eq!(parse_typed("i32:-3"), Some(Ok(Value::I32(-3))));
        assert_eq!(parse_typed("f32:1.5"), Some(Ok(Value::F32(1.5))));
        assert_eq!(parse_typed("bool:true"), Some(Ok(Value::Bool(true))));
        assert_eq!(parse_typed("5"), None);
        assert!(parse_typed("u8:5").unwrap().unwrap_err().contains("u32, i32, f32 or bool"));
        assert!(parse_typed("u32:-1").unwrap().unwrap_err().contains("does not fit uint32"));
        assert_eq!(parse_like("7", Value::U32(0)), Ok(Value::U32(7)));
        assert_eq!(parse_like("-7", Value::I32(0)), Ok(Value::I32(-7)));
        assert_eq!(parse_like("0.25", Value::F32(1.0)), Ok(Value::F32(0.25)));
        assert!(parse_like("1.5", Value::U32(0)).unwrap_err().contains("the parameter is uint32"));
    }
}
