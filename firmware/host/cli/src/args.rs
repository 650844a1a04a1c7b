//! What every command shares: the bus options ([`BusArgs`]) and their parsers, opening the bus
//! they name, and writing output lines. The commands take these from here, and [`crate::cli`]
//! puts the commands together, so no command depends on the command line that lists it.

use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

use clap::Args;
use rtcan::LaxityEncoding;

use crate::error::CliError;
use crate::link::{Link, SocketcandLink, TraceLink};

/// socketcand's address when no bus is named: where `r2p-emu demo --realtime` and
/// `r2p-canlink serve` listen by default.
pub const DEFAULT_SOCKETCAND: &str = "127.0.0.1:29536";

/// Which bus, and how long to wait for it (accepted before or after the command).
#[derive(Args, Debug, Clone)]
pub struct BusArgs {
    /// Connect to a socketcand server (python-can's socketcand protocol) at HOST:PORT, such as
    /// `r2p-emu demo --realtime`; the default when no other bus is given is 127.0.0.1:29536
    #[arg(long, global = true, value_name = "HOST:PORT", conflicts_with_all = ["socketcan", "trace"])]
    pub socketcand: Option<String>,
    /// Use a kernel CAN interface (Linux SocketCAN), e.g. vcan0 or can0
    #[arg(long, global = true, value_name = "IFACE", conflicts_with = "trace")]
    pub socketcan: Option<String>,
    /// Read a recorded trace (candump log or pcap) instead of a live bus: for monitor, nodes,
    /// topics, echo, ui and timing
    #[arg(long, global = true, value_name = "FILE")]
    pub trace: Option<PathBuf>,
    /// The bus name to open on the socketcand server
    #[arg(long, global = true, value_name = "NAME", default_value = "vcan0")]
    pub channel: String,
    /// How long to wait for the bus: how long nodes and topics listen, and how long to wait
    /// for an advertisement, a subscriber or an answer before giving up
    #[arg(long, global = true, value_name = "SECONDS", default_value = "1", value_parser = parse_seconds)]
    pub timeout: Duration,
    /// Print one JSON object per line instead of text
    #[arg(long, global = true)]
    pub json: bool,
}

/// Parses a positive number of seconds.
pub fn parse_seconds(s: &str) -> Result<Duration, String> {
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v > 0.0 && *v < 1e6)
        .map(Duration::from_secs_f64)
        .ok_or_else(|| format!("{s:?} is not a positive number of seconds"))
}

/// Parses `log:TICK_US` or `linear:TICK_US`.
pub fn parse_laxity(s: &str) -> Result<LaxityEncoding, String> {
    let bad = || format!("{s:?}: expected log:TICK_US or linear:TICK_US, e.g. log:100");
    let (kind, tick) = s.split_once(':').ok_or_else(bad)?;
    let tick_us: u32 = tick.parse().ok().filter(|&t| t > 0).ok_or_else(bad)?;
    match kind {
        "log" => Ok(LaxityEncoding::Logarithmic { tick_us }),
        "linear" => Ok(LaxityEncoding::Linear { tick_us }),
        _ => Err(bad()),
    }
}

/// Opens the bus `bus` names (socketcand at 127.0.0.1:29536 if none).
pub fn open_link(bus: &BusArgs) -> Result<Box<dyn Link>, CliError> {
    if let Some(path) = &bus.trace {
        return Ok(Box::new(TraceLink::open(path)?));
    }
    if let Some(iface) = &bus.socketcan {
        #[cfg(target_os = "linux")]
        return Ok(Box::new(crate::link::SocketCanLink::open(iface)?));
        #[cfg(not(target_os = "linux"))]
        return Err(CliError::new(format!("--socketcan {iface}: SocketCAN exists on Linux only")));
    }
    let addr = bus.socketcand.as_deref().unwrap_or(DEFAULT_SOCKETCAND);
    Ok(Box::new(SocketcandLink::connect(addr, &bus.channel)?))
}

/// Writes a line to `out`; a closed output (`r2p monitor | head`) ends the command quietly.
pub fn emit(out: &mut dyn Write, line: &str) -> Result<(), CliError> {
    match writeln!(out, "{line}") {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => std::process::exit(0),
        Err(e) => Err(CliError::new(format!("writing the output: {e}"))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn laxity_encodings_parse() {
        assert_eq!(parse_laxity("log:100"), Ok(LaxityEncoding::Logarithmic { tick_us: 100 }));
        assert_eq!(parse_laxity("linear:50"), Ok(LaxityEncoding::Linear { tick_us: 50 }));
        for bad in ["log", "log:0", "cubic:5", "linear:x"] {
            assert!(parse_laxity(bad).is_err(), "{bad}");
        }
    }
}
