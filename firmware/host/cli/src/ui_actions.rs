//! What the page asks `r2p ui` to send: reading a module's parameters, setting one, publishing
//! a message. Each runs the CLI's own command code (`r2p param`, `r2p pub`) on a session of
//! its own, as if typed at the command line: the page can send nothing the CLI would refuse,
//! and a value that does not parse is refused before the bus is even opened. `open` opens that
//! session (on the bus the command line names; tests give an in-process bus).

use r2p_management::message::ParamFault;
use serde_json::{json, Value as Json};

use crate::args::BusArgs;
use crate::describe::{fault_name, value_json};
use crate::error::CliError;
use crate::param::{self, ParamCommand};
use crate::publish::{self, PubArgs};
use crate::session::Session;
use crate::types::MsgType;

/// Opens a session on the bus.
pub type Open = dyn Fn() -> Result<Session, CliError> + Send + Sync;

/// Parameter indices read at most (a module's parameters are numbered from 0 without gaps:
/// the first unknown index ends the list).
pub const MAX_PARAMS: u16 = 64;

/// The bus options with JSON output (the commands' answers are parsed back).
fn as_json(bus: &BusArgs) -> BusArgs {
    BusArgs { json: true, ..bus.clone() }
}

/// Reads parameters 0, 1, … of `node` until it answers "unknown parameter index": one
/// session, the same requests (and retries) as `r2p param get`.
pub fn read_params(bus: &BusArgs, open: &Open, node: &str) -> Result<Json, CliError> {
    let mut s = open()?;
    s.join()?;
    let target = param::resolve(node, bus, &mut s)?;
    let mut params = Vec::new();
    for index in 0..MAX_PARAMS {
        let get = |h: &mut crate::host::HostNode| h.get_param(target, index);
        match param::ask(&mut s, bus, target, index, "PARAM_GET", get)? {
            Ok(v) => {
                let mut j = value_json(v);
                j["index"] = json!(index);
                params.push(j);
            }
            Err(ParamFault::UnknownIndex) => break,
            Err(f) => params.push(json!({"index": index, "error": fault_name(f)})),
        }
    }
    Ok(json!({"node": target.get(), "params": params}))
}

/// The value as `r2p param set` takes it: typed (`f32:1.5`) when the page knows the
/// parameter's type, so a value that does not parse is refused before anything is sent.
pub fn typed_value(ty: Option<&str>, value: &str) -> String {
    match ty {
        Some(t @ ("u32" | "i32" | "f32" | "bool")) => format!("{t}:{}", value.trim()),
        _ => value.trim().to_string(),
    }
}

/// Sets parameter `index` of `node` exactly as `r2p param set NODE INDEX VALUE` does; returns
/// the value the module now holds (its answer), or the CLI's error (the module's refusal, such
/// as "value out of range", or why the value does not parse).
pub fn set_param(
    bus: &BusArgs,
    open: &Open,
    node: &str,
    index: u16,
    ty: Option<&str>,
    value: &str,
) -> Result<Json, CliError> {
    let value = typed_value(ty, value);
    // Checked before the bus is opened (`param::run` checks it again).
    if let Some(Err(e)) = param::parse_typed(&value) {
        return Err(CliError::new(format!(
            "parameter {index} of node {node}: {e}; nothing was sent"
        )));
    }
    let cmd = ParamCommand::Set { node: node.to_string(), index, value };
    let mut out = Vec::new();
    param::run(&cmd, &as_json(bus), open()?, &mut out)?;
    serde_json::from_slice(&out)
        .map_err(|e| CliError::new(format!("r2p param's answer did not parse: {e}")))
}

/// Publishes one message as `r2p pub TOPIC VALUES… [--type T] [--deadline-us US]` does
/// (waiting for a subscriber up to the bus timeout).
pub fn publish(
    bus: &BusArgs,
    open: &Open,
    topic: &str,
    values: Vec<String>,
    ty: Option<String>,
    deadline_us: Option<u32>,
) -> Result<Json, CliError> {
    // Checked before the bus is opened (`publish::run` checks it again once it has joined).
    if let Some(t) = &ty {
        MsgType::by_name(t).and_then(|m| m.encode_args(&values)).map_err(CliError::new)?;
    }
    let args =
        PubArgs { topic: topic.to_string(), values, ty, rate: None, count: None, deadline_us };
    publish::run(&args, bus, open()?, &mut Vec::new())?;
    Ok(json!({"published": topic}))
}

/// The page's request body, as JSON.
pub fn body(text: &str) -> Result<Json, CliError> {
    serde_json::from_str(text).map_err(|e| CliError::new(format!("bad request body: {e}")))
}

/// Field `key` of `j` as text, or a clear error naming it.
pub fn text_field<'a>(j: &'a Json, key: &str) -> Result<&'a str, CliError> {
    j[key].as_str().ok_or_else(|| CliError::new(format!("the request has no {key:?} (text)")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::args::open_link;
    use crate::link::HubLink;
    use r2p_canlink::{BroadcastHub, Hub};
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    use std::time::Duration;

    fn bus_at(addr: &str) -> BusArgs {
        BusArgs {
            socketcand: Some(addr.into()),
            socketcan: None,
            trace: None,
            channel: "vcan0".into(),
            timeout: Duration::from_secs(2),
            json: false,
        }
    }

    /// Port 9 on loopback, where nothing listens: an error that names the value (not the bus)
    /// shows it was refused before the bus was opened.
    fn nowhere() -> (BusArgs, Box<Open>) {
        let bus = bus_at("127.0.0.1:9");
        let b = bus.clone();
        (bus, Box::new(move || Ok(Session::new(open_link(&b)?))))
    }

    #[test]
    fn a_value_the_parameter_type_refuses_is_an_error_before_the_bus_is_opened() {
        assert_eq!(typed_value(Some("f32"), " 1.5 "), "f32:1.5");
        assert_eq!(typed_value(Some("bool"), "true"), "bool:true");
        assert_eq!(typed_value(None, "7"), "7");
        assert_eq!(typed_value(Some("u8"), "7"), "7", "not a parameter type: bare");
        let (bus, open) = nowhere();
        let e = set_param(&bus, &*open, "motor", 0, Some("u32"), "-1").unwrap_err().to_string();
        assert!(e.contains("does not fit uint32") && e.ends_with("; nothing was sent"), "{e}");
        assert!(e.starts_with("parameter 0 of node motor: "), "{e}");
        let e = set_param(&bus, &*open, "motor", 0, Some("f32"), "fast").unwrap_err().to_string();
        assert!(e.contains("fast"), "{e}");
        let e = set_param(&bus, &*open, "motor", 0, Some("f32"), "2").unwrap_err().to_string();
        assert!(e.contains("127.0.0.1:9"), "a good value goes to the bus: {e}");
    }

    #[test]
    fn a_publication_the_cli_refuses_is_refused_before_the_bus_is_opened() {
        let (bus, open) = nowhere();
        let pubs = |values: &[&str], ty: &str| {
            let values = values.iter().map(|v| v.to_string()).collect();
            publish(&bus, &*open, "speed", values, Some(ty.into()), None).unwrap_err().to_string()
        };
        assert!(pubs(&["x"], "float32").contains("\"x\""), "{}", pubs(&["x"], "float32"));
        assert!(!pubs(&["1"], "nosuchtype").contains("127.0.0.1:9"));
        assert!(pubs(&["1"], "float32").contains("127.0.0.1:9"), "a good one goes to the bus");
    }

    #[test]
    fn parameters_are_read_set_and_refused_as_r2p_param_does() {
        let hub = Arc::new(BroadcastHub::new());
        let stop = Arc::new(AtomicBool::new(false));
        let module = crate::host::tests::spawn_module(hub.clone(), stop.clone());
        let h = hub.clone();
        let open = move || -> Result<Session, CliError> {
            Ok(Session::new(Box::new(HubLink::join(h.clone() as Arc<dyn Hub>, 4096))))
        };
        let bus = bus_at("unused:1");
        let read = read_params(&bus, &open, "sensor").unwrap();
        let id = read["node"].clone();
        assert_eq!(
            read["params"],
            serde_json::json!([
                {"index": 0, "type": "u32", "value": 100},
                {"index": 1, "type": "f32", "value": 0.5},
            ])
        );
        let set = set_param(&bus, &open, "sensor", 1, Some("f32"), "1.5").unwrap();
        assert_eq!((set["value"].clone(), set["node"].clone()), (serde_json::json!(1.5), id));
        let e = set_param(&bus, &open, "sensor", 1, Some("f32"), "5").unwrap_err().to_string();
        assert!(e.contains("refused PARAM_SET of parameter 1: value out of range"), "{e}");
        let e = set_param(&bus, &open, "sensor", 0, Some("f32"), "5").unwrap_err().to_string();
        assert!(e.contains("refused PARAM_SET of parameter 0"), "a u32 set as f32: {e}");
        let read = read_params(&bus, &open, "sensor").unwrap();
        assert_eq!(read["params"][1]["value"], 1.5, "the refused values changed nothing");
        let e = read_params(&bus, &open, "nobody").unwrap_err().to_string();
        assert!(e.contains("unknown node \"nobody\""), "{e}");
        stop.store(true, Ordering::SeqCst);
        module.join().unwrap();
    }

    #[test]
    fn request_bodies_name_what_is_missing() {
        let j = body(r#"{"node": "motor"}"#).unwrap();
        assert_eq!(text_field(&j, "node").unwrap(), "motor");
        assert!(text_field(&j, "value").unwrap_err().to_string().contains("\"value\""));
        assert!(body("{").unwrap_err().to_string().contains("bad request body"));
    }
}
