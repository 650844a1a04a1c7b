//! The command line: `r2p [BUS OPTIONS] COMMAND …` (clap derive; `--help` on every command).

use std::io::Write;

use clap::{Parser, Subcommand};

use crate::args::{open_link, BusArgs};
use crate::error::CliError;
use crate::session::Session;
use crate::{
    echo, flash, keys, listing, magcal, monitor, param, publish, record, sim, timing, traces, ui,
    update,
};

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
  r2p imu calibrate --seconds 60     # turn the robot; writes the magnetometer's calibration
  r2p --trace bus.log monitor        # offline, from a candump log or pcap
  r2p convert bus.log bus.pcap       # for Wireshark
  r2p --trace bus.log timing         # the cycle's timing (candump -H -L can0 > bus.log)
  r2p flash motor                    # firmware/images/motor.elf through an SWD probe
  r2p ui                             # the bus in the browser: http://127.0.0.1:8023/";

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

/// The commands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Print every frame, decoded: class and laxity, message ID, fragment, sender, topic,
    /// management messages and topic values (one line per frame)
    Monitor(monitor::MonitorArgs),
    /// Record the topics on the bus, decoded, into an MCAP file (Foxglove, the mcap
    /// libraries): one channel per topic, JSON with each type's JSON Schema
    Record(record::RecordArgs),
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
    /// The IMU module: calibrate its magnetometer (imu calibrate)
    #[command(subcommand)]
    Imu(magcal::ImuCommand),
    /// Send a trace's frames (candump log or pcap) onto the bus again
    Replay(traces::ReplayArgs),
    /// Convert a trace between candump log and pcap (by the output's extension)
    Convert(traces::ConvertArgs),
    /// Measure the RTCAN cycle in a trace (--trace) with hardware timestamps: how regularly
    /// the syncs start each cycle, where each HRT stream's frames start in theirs
    Timing(timing::TimingArgs),
    /// Run a robot file on emulated boards: in virtual time into a trace (--seconds, --log), or
    /// in real time (--realtime) serving socketcand on --socketcand's address and, with
    /// --socketcan IFACE, bridging to a kernel CAN interface
    Sim(sim::SimArgs),
    /// Write a module's committed image (firmware/images/MODULE.elf) through an SWD probe with
    /// probe-rs, then reset the module (docs/flashing.md)
    Flash(flash::FlashArgs),
    /// Make a key pair for signing images (the secret seed in FILE, its public half in
    /// FILE.pub), outside the repository
    Keygen(keys::KeygenArgs),
    /// Sign a module's image for the bootloader (image, then a 128-byte trailer with its kind,
    /// MCU, version and ed25519 signature)
    Sign(keys::SignArgs),
    /// Send a signed image to a module (or --all of its kind) over the bus, reboot it into the
    /// image and wait until it has confirmed itself (docs/flashing.md)
    Update(update::UpdateArgs),
    /// Serve a web page for the live bus on --bind:--port (127.0.0.1:8023): modules, topics,
    /// values plotted, the RTCAN cycle, parameters and publishing (docs in README.md)
    Ui(ui::UiArgs),
}

/// Runs a parsed command line, printing results to `out`.
pub fn run(cli: Cli, out: &mut dyn Write) -> Result<(), CliError> {
    let bus = &cli.bus;
    match cli.command {
        Command::Convert(args) => traces::convert(&args, bus, out),
        Command::Replay(args) => traces::replay(&args, bus, out),
        Command::Timing(args) => timing::run(&args, bus, out),
        Command::Monitor(args) => monitor::run(&args, bus, Session::new(open_link(bus)?), out),
        Command::Record(args) => record::run(&args, bus, Session::new(open_link(bus)?), out),
        Command::Nodes => listing::nodes(bus, Session::new(open_link(bus)?), out),
        Command::Topics => listing::topics(bus, Session::new(open_link(bus)?), out),
        Command::Echo(args) => echo::run(&args, bus, Session::new(open_link(bus)?), out),
        Command::Pub(args) => publish::run(&args, bus, Session::new(open_link(bus)?), out),
        Command::Param(cmd) => param::run(&cmd, bus, Session::new(open_link(bus)?), out),
        Command::Imu(cmd) => magcal::run(&cmd, bus, Session::new(open_link(bus)?), out),
        Command::Sim(args) => sim::run(&args, bus, out),
        Command::Flash(args) => flash::run(&args, out),
        Command::Keygen(args) => keys::keygen(&args, out),
        Command::Sign(args) => keys::sign_image(&args, out),
        Command::Ui(args) => ui::run(&args, bus, out),
        Command::Update(args) => update::run(&args, bus, || Ok(Session::new(open_link(bus)?)), out),
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use clap::CommandFactory;

    use super::*;

    #[test]
    fn the_command_line_is_consistent_and_documented() {
        Cli::command().debug_assert();
        let mut cmd = Cli::command();
        for sub in cmd.get_subcommands_mut() {
            assert!(sub.get_about().is_some(), "{} has no help", sub.get_name());
        }
    }

    #[test]
    fn an_update_names_a_missing_image_before_it_looks_for_a_bus() {
        // Port 9 on loopback: nothing listens, so opening the bus would fail if it came first.
        let cli = Cli::try_parse_from([
            "r2p",
            "update",
            "motor1",
            "/nonexistent/motor.signed.bin",
            "--socketcand",
            "127.0.0.1:9",
        ])
        .unwrap();
        let e = run(cli, &mut Vec::new()).err().unwrap().to_string();
        assert!(e.starts_with("/nonexistent/motor.signed.bin: "), "{e}");
        assert!(e.contains("r2p sign"), "{e}");
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
}
