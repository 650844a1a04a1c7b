//! `r2p pub TOPIC VALUES…`: the host node exports the topic (advertises it; importers of the
//! name subscribe, since an import follows the latest advertiser) and publishes once, or at
//! `--rate`. The bus carries a topic only to subscribers, so a message goes out once a module
//! has subscribed.

use std::io::Write;
use std::time::{Duration, Instant};

use clap::Args;
use r2p_middleware::Class;
use r2p_node::Event;

use crate::args::BusArgs;
use crate::error::CliError;
use crate::session::Session;
use crate::types::MsgType;

/// `r2p pub` options.
#[derive(Args, Debug)]
pub struct PubArgs {
    /// The topic's name
    pub topic: String,
    /// The message: field=value … for a message type (arrays as v1,v2,…; fields left out are
    /// 0), or one value (v1,v2,… for an array) for a primitive type
    #[arg(allow_negative_numbers = true, value_name = "FIELD=VALUE")]
    pub values: Vec<String>,
    /// The message type (Obstacle, uint32, float32[4], …) [default: the type the topic is
    /// advertised with on the bus]
    #[arg(long = "type", value_name = "TYPE")]
    pub ty: Option<String>,
    /// Publish HZ messages per second (until --count, or until interrupted) instead of once
    #[arg(long, value_name = "HZ")]
    pub rate: Option<f64>,
    /// With --rate: stop after N messages
    #[arg(long, value_name = "N")]
    pub count: Option<u64>,
    /// Send as SRT with a deadline of US microseconds after publication (default: NRT)
    #[arg(long, value_name = "US")]
    pub deadline_us: Option<u32>,
}

/// Runs `r2p pub`.
pub fn run(
    args: &PubArgs,
    bus: &BusArgs,
    mut s: Session,
    _out: &mut dyn Write,
) -> Result<(), CliError> {
    let period = match args.rate {
        None => None,
        Some(hz) if hz.is_finite() && hz > 0.0 && hz <= 1000.0 => {
            Some(Duration::from_secs_f64(1.0 / hz))
        }
        Some(hz) => return Err(CliError::new(format!("--rate {hz}: expected 0 < HZ ≤ 1000"))),
    };
    // With --type the message is checked before anything goes on the bus.
    let given = args.ty.as_deref().map(MsgType::by_name).transpose().map_err(CliError::new)?;
    if let Some(ty) = &given {
        ty.encode_args(&args.values).map_err(CliError::new)?;
    }
    s.join()?;
    let ty = match given {
        Some(ty) => ty,
        None => advertised_type(args, bus, &mut s)?,
    };
    let bytes = ty.encode_args(&args.values).map_err(CliError::new)?;
    let class = match args.deadline_us {
        Some(d) if d > 0 => Class::AsyncRealTime { deadline_us: d },
        Some(_) => return Err(CliError::new("--deadline-us must be above 0")),
        None => Class::NonRealTime,
    };
    s.host().expect("joined").export(&args.topic, &ty, class)?;

    let start = Instant::now();
    let mut subscribers = Vec::new();
    let mut sent = 0u64;
    let mut next = Instant::now();
    let want = if period.is_some() { args.count.unwrap_or(u64::MAX) } else { 1 };
    let mut skipped = 0u64;
    loop {
        s.step(Duration::from_millis(1))?;
        let host = s.host().expect("joined");
        while let Some(e) = host.next_event() {
            if let Event::RemoteSubscriber { from, .. } = e {
                subscribers.push(from.get());
            }
        }
        if sent < want && Instant::now() >= next && (!subscribers.is_empty() || period.is_some()) {
            if host.publish(bytes.clone()) {
                sent += 1;
            } else {
                skipped += 1;
            }
            next += period.unwrap_or_default();
        }
        if sent >= want && host.tx_pending() == 0 {
            break;
        }
        if subscribers.is_empty() && period.is_none() && start.elapsed() >= bus.timeout {
            return Err(CliError::new(format!(
                "nobody subscribed to {:?} within {:?}: the bus carries a topic only to \
                 subscribers, so nothing was sent; a module must import {:?} (type {})",
                args.topic, bus.timeout, args.topic, ty.name
            )));
        }
        if sent >= want && start.elapsed() >= bus.timeout + Duration::from_secs(1) {
            return Err(CliError::new(format!(
                "the message to {:?} did not leave within {:?}",
                args.topic, bus.timeout
            )));
        }
    }
    let names: Vec<String> = subscribers.iter().map(|&n| s.watcher().node_label(n)).collect();
    let misses = s.host().map_or(0, |h| h.deadline_misses());
    eprintln!(
        "r2p: published {sent} message(s) of type {} on {:?} to node(s) {}{}{}",
        ty.name,
        args.topic,
        if names.is_empty() { "none yet".to_string() } else { names.join(", ") },
        if skipped > 0 {
            format!("; {skipped} not sent (no subscriber yet)")
        } else {
            String::new()
        },
        if misses > 0 { format!("; {misses} missed their deadline") } else { String::new() },
    );
    Ok(())
}

/// The type `args.topic` is advertised with, waiting `--timeout` for an advertisement.
fn advertised_type(args: &PubArgs, bus: &BusArgs, s: &mut Session) -> Result<MsgType, CliError> {
    let start = Instant::now();
    loop {
        if let Some(t) = s.watcher().topic(&args.topic) {
            return t.msg_type().ok_or_else(|| {
                CliError::new(format!(
                    "{:?} is advertised with type 0x{:08X} ({} bytes), which r2p does not know: \
                     give --type",
                    args.topic, t.type_hash, t.size
                ))
            });
        }
        if start.elapsed() >= bus.timeout {
            return Err(CliError::new(format!(
                "no module advertises {:?} (waited {:?}), so its type is unknown: give --type \
                 (e.g. --type uint32 or --type Obstacle)",
                args.topic, bus.timeout
            )));
        }
        s.step(Duration::from_millis(2))?;
    }
}
