//! `r2p-emu`: runs the built-in demo robot on the emulated bus, in virtual time (a deterministic
//! candump log) or in real time with a socketcand server so that CAN tools join it. See `--help`.

use std::process::ExitCode;

use r2p_canlink::service::{parse_command_line, run_main, unknown_option, ServiceOptions};
use r2p_emu::{demo, serve};

const HELP: &str = "\
r2p-emu: runs emulated R2P boards on a virtual CAN bus

USAGE:
    r2p-emu demo --realtime [--socketcand ADDR] [--channel NAME] [--log FILE]
                 [--seconds N] [--seed S] [--no-stdin]
    r2p-emu demo --seconds N --log FILE [--channel NAME] [--seed S]
    r2p-emu --help

demo runs a built-in robot: psu (rank 0, the master), motor (publishes setpoint, HRT every
20 ms, and scan, SRT every 10 ms) and control (rank 1, subscribes to both), in TDMA mode
(10 ms cycles of 40 slots, 1 Mbit/s), heartbeats every 20 ms.

With --realtime, virtual time follows the wall clock and a socketcand server lets CAN tools
join the bus: they see every frame of the virtual bus (29-bit identifiers), and their extended
frames are sent on it through a spare port (standard-ID frames are counted and dropped).
It stops on SIGTERM, SIGINT, when standard input closes (unless it is /dev/null or --no-stdin)
or after --seconds, and prints its counters.

Without --realtime, it runs N seconds of virtual time as fast as it can and writes the bus's
frames to FILE as a candump log, stamped from 1700000000.000000: the same seed gives the
same file.

OPTIONS:
    --realtime             pace virtual time against the wall clock, serve socketcand
    --socketcand ADDR      listen on ADDR only [default: 127.0.0.1:29536]
    --channel NAME         the bus name clients open and the log names [default: vcan0]
    --log FILE             write every frame to FILE as a candump log (real time: appends
                           what the hub carries, tools' frames included)
    --seconds N            stop after N seconds (real or virtual)
    --seed S               fault seed of the virtual bus [default: 0]
    --no-stdin             do not stop when standard input closes

EXAMPLE (python-can):
    can.Bus(interface=\"socketcand\", host=\"127.0.0.1\", port=29536, channel=\"vcan0\")
";

/// Start of the virtual-time log's timestamps.
struct Options {
    realtime: bool,
    service: ServiceOptions,
    seconds: Option<f64>,
    seed: u64,
}

fn parse_args(args: &[String]) -> Result<Options, String> {
    let mut opts =
        Options { realtime: false, service: ServiceOptions::default(), seconds: None, seed: 0 };
    let Options { realtime, service, seconds, seed } = &mut opts;
    parse_command_line(args, "demo", service, |arg, value| {
        match arg {
            "--realtime" => *realtime = true,
            "--seconds" => {
                let v = value()?;
                *seconds = Some(
                    v.parse()
                        .ok()
                        .filter(|&s: &f64| s > 0.0 && s < 1e6)
                        .ok_or(format!("--seconds {v}: expected a positive number"))?,
                );
            }
            "--seed" => {
                let v = value()?;
                *seed = v.parse().map_err(|_| format!("--seed {v}: expected a number"))?;
            }
            other => return Err(unknown_option(other)),
        }
        Ok(())
    })?;
    if !opts.realtime && (opts.seconds.is_none() || opts.service.log.is_none()) {
        return Err("without --realtime, --seconds N and --log FILE are needed (try --help)".into());
    }
    Ok(opts)
}

fn virtual_time(opts: &Options) -> Result<(), String> {
    let (mut sim, received) = demo::build(opts.seed).ok_or("the demo robot was built already")?;
    let seconds = opts.seconds.expect("checked");
    let path = opts.service.log.as_deref().expect("checked");
    let took = serve::run_virtual(&mut sim, seconds, path, &opts.service.channel)?;
    eprintln!(
        "r2p-emu: {seconds} s of virtual time in {:.3} s: {} frames on the bus, {} setpoints and {} scans received by control, log written to {path}",
        took.as_secs_f64(),
        sim.bus().frames().count(),
        received.setpoints.get(),
        received.scans.get()
    );
    Ok(())
}

fn realtime(opts: &Options) -> Result<(), String> {
    let (mut sim, received) = demo::build(opts.seed).ok_or("the demo robot was built already")?;
    let serve = serve::Serve {
        addr: opts.service.addr,
        channel: opts.service.channel.clone(),
        log: opts.service.log.clone(),
        seconds: opts.seconds,
        watch_stdin: opts.service.watch_stdin,
        socketcan: None,
        power_off: Vec::new(),
    };
    let summary = serve::run_realtime(&mut sim, demo::SPARE_PORT, "demo robot", &serve)?;
    eprintln!(
        "{summary}, {} setpoints and {} scans received by control",
        received.setpoints.get(),
        received.scans.get()
    );
    Ok(())
}

fn main() -> ExitCode {
    run_main("r2p-emu", HELP, |args| {
        parse_args(args).and_then(|o| if o.realtime { realtime(&o) } else { virtual_time(&o) })
    })
}
