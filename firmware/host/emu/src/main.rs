//! `r2p-emu`: runs the built-in demo robot on the emulated bus, in virtual time (a deterministic
//! candump log) or in real time with a socketcand server so that CAN tools join it. See `--help`.

use std::fs::File;
use std::io::BufWriter;
use std::net::SocketAddr;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use r2p_canlink::hub::DEFAULT_QUEUE;
use r2p_canlink::server::DEFAULT_ADDR;
use r2p_canlink::service::{listen_error, spawn_logger, StopConditions};
use r2p_canlink::{BroadcastHub, Config, Server};
use r2p_emu::bridge::Bridge;
use r2p_emu::demo;

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
const EPOCH_S: u64 = 1_700_000_000;

struct Options {
    realtime: bool,
    addr: SocketAddr,
    channel: String,
    log: Option<String>,
    seconds: Option<f64>,
    seed: u64,
    watch_stdin: bool,
}

fn parse_args(args: &[String]) -> Result<Options, String> {
    let mut opts = Options {
        realtime: false,
        addr: DEFAULT_ADDR.parse().expect("default address"),
        channel: "vcan0".into(),
        log: None,
        seconds: None,
        seed: 0,
        watch_stdin: true,
    };
    let mut it = args.iter();
    match it.next().map(String::as_str) {
        Some("demo") => {}
        Some(other) => return Err(format!("unknown command {other} (try --help)")),
        None => return Err("missing command (try --help)".into()),
    }
    while let Some(arg) = it.next() {
        let mut value = || it.next().cloned().ok_or_else(|| format!("{arg} needs a value"));
        match arg.as_str() {
            "--realtime" => opts.realtime = true,
            "--socketcand" => {
                let v = value()?;
                opts.addr = v.parse().map_err(|_| {
                    format!("--socketcand {v}: expected IP:PORT, e.g. 127.0.0.1:29536")
                })?;
            }
            "--channel" => {
                let v = value()?;
                if v.is_empty() || v.contains(|c: char| c.is_whitespace() || c == '<' || c == '>') {
                    return Err(format!("--channel {v:?}: not a bus name"));
                }
                opts.channel = v;
            }
            "--log" => opts.log = Some(value()?),
            "--seconds" => {
                let v = value()?;
                opts.seconds = Some(
                    v.parse()
                        .ok()
                        .filter(|&s: &f64| s > 0.0 && s < 1e6)
                        .ok_or(format!("--seconds {v}: expected a positive number"))?,
                );
            }
            "--seed" => {
                let v = value()?;
                opts.seed = v.parse().map_err(|_| format!("--seed {v}: expected a number"))?;
            }
            "--no-stdin" => opts.watch_stdin = false,
            other => return Err(format!("unknown option {other} (try --help)")),
        }
    }
    if !opts.realtime && (opts.seconds.is_none() || opts.log.is_none()) {
        return Err("without --realtime, --seconds N and --log FILE are needed (try --help)".into());
    }
    Ok(opts)
}

fn virtual_time(opts: &Options) -> Result<(), String> {
    let (mut sim, received) = demo::build(opts.seed).ok_or("the demo robot was built already")?;
    let seconds = opts.seconds.expect("checked");
    let path = opts.log.as_deref().expect("checked");
    let file = File::create(path).map_err(|e| format!("cannot create log {path}: {e}"))?;
    let wall = Instant::now();
    sim.run_until((seconds * 1e9) as u64);
    let out = sim
        .write_candump(BufWriter::new(file), &opts.channel, Duration::from_secs(EPOCH_S))
        .map_err(|e| format!("writing the log: {e}"))?;
    drop(out);
    eprintln!(
        "r2p-emu: {seconds} s of virtual time in {:.3} s: {} frames on the bus, {} setpoints and {} scans received by control, log written to {path}",
        wall.elapsed().as_secs_f64(),
        sim.bus().frames().count(),
        received.setpoints.get(),
        received.scans.get()
    );
    Ok(())
}

fn realtime(opts: &Options) -> Result<(), String> {
    let stop_when = StopConditions::install(opts.watch_stdin);
    let (mut sim, received) = demo::build(opts.seed).ok_or("the demo robot was built already")?;
    let hub = Arc::new(BroadcastHub::new());
    let stop = Arc::new(AtomicBool::new(false));

    let logger = match &opts.log {
        Some(path) => {
            let file = File::options()
                .create(true)
                .append(true)
                .open(path)
                .map_err(|e| format!("cannot open log {path}: {e}"))?;
            Some(spawn_logger(
                hub.clone(),
                file,
                opts.channel.clone(),
                stop.clone(),
                16 * DEFAULT_QUEUE,
            ))
        }
        None => None,
    };
    let config = Config { addr: opts.addr, channel: opts.channel.clone(), queue: DEFAULT_QUEUE };
    let server = match Server::start(config, hub.clone()) {
        Ok(s) => s,
        Err(e) => {
            stop.store(true, Ordering::SeqCst);
            if let Some(l) = logger {
                let _ = l.join();
            }
            return Err(listen_error(opts.addr, &e, "another r2p-emu, r2p-canlink or socketcand"));
        }
    };
    eprintln!(
        "r2p-emu: demo robot in real time, socketcand on {} channel {}",
        server.local_addr(),
        opts.channel
    );

    let mut bridge = Bridge::new(&sim, demo::SPARE_PORT, hub.clone(), DEFAULT_QUEUE);
    let limit = opts.seconds.map(Duration::from_secs_f64);
    let mut why = "--seconds";
    bridge.run_realtime(&mut sim, Instant::now(), limit, || match stop_when.reason() {
        Some(reason) => {
            why = reason;
            true
        }
        None => false,
    });

    stop.store(true, Ordering::SeqCst);
    let clients = server.stats().clients.load(Ordering::Relaxed);
    server.shutdown();
    let s = bridge.stats();
    // The frames the bridge port actually sent on the virtual bus (one pass over the log).
    let on_bus = sim.bus().frames().filter(|f| f.1 == bridge.port()).count();
    let mut summary = format!(
        "r2p-emu: stopped ({why}) at {:.3} s of virtual time: {} frames to tools, {} injected from tools \
         ({on_bus} sent on the virtual bus), {} standard-ID frames dropped, {} not queued, \
         {} tap overflows, {clients} clients, max lag {} us, {} setpoints and {} scans received by control",
        sim.now_ns() as f64 / 1e9,
        s.to_hub,
        s.injected,
        s.standard_dropped,
        s.not_queued,
        bridge.overflows(),
        s.max_lag_us,
        received.setpoints.get(),
        received.scans.get()
    );
    if let Some(l) = logger {
        match l.join() {
            Ok(Ok(_)) => {}
            Ok(Err(e)) => return Err(format!("writing the log: {e}")),
            Err(_) => return Err("the log writer panicked".into()),
        }
        summary.push_str(", log written");
    }
    eprintln!("{summary}");
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() || args.iter().any(|a| a == "--help" || a == "-h") {
        print!("{HELP}");
        return if args.is_empty() { ExitCode::from(2) } else { ExitCode::SUCCESS };
    }
    let result =
        parse_args(&args).and_then(|o| if o.realtime { realtime(&o) } else { virtual_time(&o) });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("r2p-emu: error: {e}");
            ExitCode::from(2)
        }
    }
}
