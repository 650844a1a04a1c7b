//! The command line: `r2p [BUS OPTIONS] COMMAND …` (clap derive; `--help` on every command).

use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

use clap::{Args, Parser, Subcommand};
use rtcan::LaxityEncoding;

use crate::error::CliError;
use crate::link::{Link, SocketcandLink, TraceLink};
use crate::session::Session;
use crate::{echo, listing, monitor, param, publish, sim, traces};

/// socketcand's address when no bus is named: where `r2p-emu demo --realtime` and
/// `r2p-canlink serve` listen by default.
pub const DEFAULT_SOCKETCAND: &str = "127.0.0.1:29536";

const ABOUT: &str = "R2P host tool: watch and talk to an R2P robot's CAN bus";

const LONG_ABOUT: &str = "\
R2P host tool: watch and talk to an R2P robot's CAN bus — a real one through a kernel CAN \
interface (--socketcan), an emulated one or any socketcand server over TCP (--socketcand, the \
default: 127.0.0.1:29536), or a recorded trace (--trace, candump log or pcap).

echo, pub and param join the bus as a module would (a node named r2p-cli with its own node ID, \
heartbeats, subscriptions); monitor and nodes only listen.";

const EXAMPLES: &str = "\
Examples:
  r2p sim robots/triskar2.toml --realtime &   # the Triskar2 on socketcand 127.0.0.1:29536
  r2p sim robots/triskar2.toml --seconds 10 --log run.pcap
  r2p-emu demo --realtime &          # a three-board demo on socketcand 127.0.0.1:29536
  r2p nodes                          # psu, motor, control
  r2p topics
  r2p echo scan --count 3
  r2p monitor --count 20
  r2p param get motor 0
  r2p pub speed --type float32 1.5
  r2p --trace bus.log monitor        # offline, from a candump log or pcap
  r2p convert bus.log bus.pcap       # for Wireshark";

/// `r2p`: see `--help`.
#[derive(Parser, Debug)]
#[command(name = "r2p", version, about = ABOUT, long_about = LONG_ABOUT, after_help = EXAMPLES)]
pub struct Cli {
    /// Which bus.
    #[command(flatten)]
    pub bus: BusArgs,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

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
    /// topics and echo
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

/// The commands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Print every frame, decoded: class and laxity, message ID, fragment, sender, topic,
    /// management messages and topic values (one line per frame)
    Monitor(monitor::MonitorArgs),
    /// List the nodes on the bus from their heartbeats (listens for --timeout)
    Nodes,
    /// List the advertised topics: name, type, publisher, class (joins the bus so that every
    /// module advertises again, then listens for --timeout)
    Topics,
    /// Subscribe to a topic as a module does and print every message
    Echo(echo::EchoArgs),
    /// Publish a message on a topic, once or at --rate
    Pub(publish::PubArgs),
    /// Read or set a module's parameter (PARAM_GET / PARAM_SET)
    #[command(subcommand)]
    Param(param::ParamCommand),
    /// Send a trace's frames (candump log or pcap) onto the bus again
    Replay(traces::ReplayArgs),
    /// Convert a trace between candump log and pcap (by the output's extension)
    Convert(traces::ConvertArgs),
    /// Run a robot file on emulated boards: in virtual time into a trace (--seconds, --log), or
    /// in real time (--realtime) serving socketcand on --socketcand's address and, with
    /// --socketcan IFACE, bridging to a kernel CAN interface
    Sim(sim::SimArgs),
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

/// Runs a parsed command line, printing results to `out`.
pub fn run(cli: Cli, out: &mut dyn Write) -> Result<(), CliError> {
    let bus = &cli.bus;
    match cli.command {
        Command::Convert(args) => traces::convert(&args, bus, out),
        Command::Replay(args) => traces::replay(&args, bus, out),
        Command::Monitor(args) => monitor::run(&args, bus, Session::new(open_link(bus)?), out),
        Command::Nodes => listing::nodes(bus, Session::new(open_link(bus)?), out),
        Command::Topics => listing::topics(bus, Session::new(open_link(bus)?), out),
        Command::Echo(args) => echo::run(&args, bus, Session::new(open_link(bus)?), out),
        Command::Pub(args) => publish::run(&args, bus, Session::new(open_link(bus)?), out),
        Command::Param(cmd) => param::run(&cmd, bus, Session::new(open_link(bus)?), out),
        Command::Sim(args) => sim::run(&args, bus, out),
    }
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
    use clap::CommandFactory;

    #[test]
    fn the_command_line_is_consistent_and_documented() {
        Cli::command().debug_assert();
        let mut cmd = Cli::command();
        for sub in cmd.get_subcommands_mut() {
            assert!(sub.get_about().is_some(), "{} has no help", sub.get_name());
        }
    }

    #[test]
    fn bus_options_go_before_or_after_the_command_and_exclude_each_other() {
        let a = Cli::try_parse_from(["r2p", "--socketcand", "h:1", "nodes"]).unwrap();
        let b = Cli::try_parse_from(["r2p", "nodes", "--socketcand", "h:1", "--timeout", "0.5"])
            .unwrap();
        assert_eq!(a.bus.socketcand.as_deref(), Some("h:1"));
        assert_eq!(
            (b.bus.socketcand.as_deref(), b.bus.timeout),
            (Some("h:1"), Duration::from_millis(500))
        );
        assert!(Cli::try_parse_from([
            "r2p",
            "nodes",
            "--socketcand",
            "h:1",
            "--socketcan",
            "vcan0"
        ])
        .is_err());
        assert!(Cli::try_parse_from(["r2p", "nodes", "--timeout", "0"]).is_err());
        assert!(Cli::try_parse_from(["r2p", "nodes", "--timeout", "-1"]).is_err());
        let p = Cli::try_parse_from(["r2p", "pub", "t", "--type", "int32", "-5", "--timeout", "2"])
            .unwrap();
        assert_eq!(p.bus.timeout, Duration::from_secs(2));
        assert!(matches!(p.command, Command::Pub(a) if a.values == ["-5"]));
        let p = Cli::try_parse_from(["r2p", "param", "set", "motor", "0", "-1.5"]).unwrap();
        assert!(
            matches!(p.command, Command::Param(param::ParamCommand::Set { value, .. }) if value == "-1.5")
        );
    }

    #[test]
    fn laxity_encodings_parse() {
        assert_eq!(parse_laxity("log:100"), Ok(LaxityEncoding::Logarithmic { tick_us: 100 }));
        assert_eq!(parse_laxity("linear:50"), Ok(LaxityEncoding::Linear { tick_us: 50 }));
        for bad in ["log", "log:0", "cubic:5", "linear:x"] {
            assert!(parse_laxity(bad).is_err(), "{bad}");
        }
    }
}
