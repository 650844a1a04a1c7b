//! `r2p-canlink`: runs an in-memory CAN hub with a socketcand server so that CAN tools
//! (python-can's `socketcand` interface, socketcand clients) can join it. See `--help`.

use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use r2p_canlink::hub::DEFAULT_QUEUE;
use r2p_canlink::service::{
    parse_command_line, run_main, unknown_option, HubService, ServiceOptions, StopConditions,
};
use r2p_canlink::{BroadcastHub, CanFrame, Config, Hub};

const HELP: &str = "\
r2p-canlink: lets CAN tools join R2P's emulated bus over TCP (no SocketCAN needed)

USAGE:
    r2p-canlink serve [--socketcand ADDR] [--channel NAME] [--log FILE]
                      [--heartbeat ID:PERIOD_MS]... [--queue N] [--no-stdin]
    r2p-canlink --help

serve runs an in-memory CAN bus with a socketcand-protocol server on it. Every client and
in-process participant sees every other's frames.

OPTIONS:
    --socketcand ADDR      listen on ADDR only [default: 127.0.0.1:29536]
    --channel NAME         the bus name clients open [default: vcan0]
    --log FILE             append every frame to FILE as a candump log
                           (readable by canplayer, log2asc and python-can's can.LogReader)
    --heartbeat ID:MS      publish a frame with identifier ID (hex; extended if written with
                           8 digits or above 7FF) every MS milliseconds, carrying a 32-bit
                           big-endian counter (repeatable)
    --queue N              frames queued per client before it loses frames [default: 1024]
    --no-stdin             do not stop when standard input closes

Stops on SIGTERM, SIGINT or when standard input closes (unless it is /dev/null or --no-stdin).

EXAMPLE (python-can):
    can.Bus(interface=\"socketcand\", host=\"127.0.0.1\", port=29536, channel=\"vcan0\")
";

struct Heartbeat {
    frame_id: u32,
    extended: bool,
    period: Duration,
}

struct Options {
    service: ServiceOptions,
    heartbeats: Vec<Heartbeat>,
    queue: usize,
}

fn parse_heartbeat(s: &str) -> Result<Heartbeat, String> {
    let bad = || format!("--heartbeat {s}: expected ID:PERIOD_MS, e.g. 1ABC0000:100");
    let (id, ms) = s.split_once(':').ok_or_else(bad)?;
    let digits = id.trim_start_matches("0x");
    let frame_id = u32::from_str_radix(digits, 16).map_err(|_| bad())?;
    let extended = digits.len() == 8 || frame_id > 0x7FF;
    CanFrame::new(frame_id, extended, &[]).map_err(|e| format!("--heartbeat {s}: {e}"))?;
    let ms: u64 = ms.parse().map_err(|_| bad())?;
    if ms == 0 {
        return Err(format!("--heartbeat {s}: the period must be at least 1 ms"));
    }
    Ok(Heartbeat { frame_id, extended, period: Duration::from_millis(ms) })
}

fn parse_args(args: &[String]) -> Result<Options, String> {
    let (mut service, mut heartbeats, mut queue) =
        (ServiceOptions::default(), Vec::new(), DEFAULT_QUEUE);
    parse_command_line(args, "serve", &mut service, |arg, value| {
        match arg {
            "--heartbeat" => heartbeats.push(parse_heartbeat(&value()?)?),
            "--queue" => {
                let v = value()?;
                queue = v
                    .parse()
                    .ok()
                    .filter(|&n| n > 0)
                    .ok_or(format!("--queue {v}: expected a positive number"))?;
            }
            other => return Err(unknown_option(other)),
        }
        Ok(())
    })?;
    Ok(Options { service, heartbeats, queue })
}

fn spawn_heartbeat(hub: Arc<BroadcastHub>, hb: Heartbeat, stop: Arc<AtomicBool>) -> JoinHandle<()> {
    thread::spawn(move || {
        let me = hub.join();
        let mut counter: u32 = 0;
        let mut next = Instant::now();
        while !stop.load(Ordering::SeqCst) {
            let frame = CanFrame::new(hb.frame_id, hb.extended, &counter.to_be_bytes())
                .expect("checked id");
            hub.send(me, frame);
            counter = counter.wrapping_add(1);
            next += hb.period;
            // Sleep in short steps so that stopping is prompt.
            while !stop.load(Ordering::SeqCst) {
                let now = Instant::now();
                if now >= next {
                    break;
                }
                thread::sleep((next - now).min(Duration::from_millis(50)));
            }
        }
    })
}

fn serve(opts: Options) -> Result<(), String> {
    let stop_when = StopConditions::install(opts.service.watch_stdin);
    let mut service = HubService::new(
        opts.service.log.as_deref(),
        &opts.service.channel,
        opts.queue.max(DEFAULT_QUEUE),
    )?;
    let config = Config {
        addr: opts.service.addr,
        channel: opts.service.channel.clone(),
        queue: opts.queue,
    };
    let server = service.listen(config, "another r2p-canlink or socketcand")?;
    eprintln!(
        "r2p-canlink: socketcand on {} channel {}",
        server.local_addr(),
        opts.service.channel
    );

    let heartbeats: Vec<_> = opts
        .heartbeats
        .into_iter()
        .map(|hb| spawn_heartbeat(service.hub.clone(), hb, service.stop.clone()))
        .collect();

    let why = loop {
        if let Some(why) = stop_when.reason() {
            break why;
        }
        thread::sleep(Duration::from_millis(50));
    };

    service.stopping();
    for h in heartbeats {
        let _ = h.join();
    }
    let stats = server.stats();
    let (clients, frames_in, frames_out, errors) = (
        stats.clients.load(Ordering::Relaxed),
        stats.frames_in.load(Ordering::Relaxed),
        stats.frames_out.load(Ordering::Relaxed),
        stats.errors.load(Ordering::Relaxed),
    );
    server.shutdown();
    let hub = service.hub.clone();
    let mut summary = format!(
        "r2p-canlink: stopped ({why}): {} frames on the bus, {clients} clients, {frames_in} frames from clients, \
         {frames_out} to clients, {errors} errors, {} frames dropped",
        hub.sent(),
        hub.dropped()
    );
    if service.finish()? {
        summary.push_str(", log written");
    }
    eprintln!("{summary}");
    Ok(())
}

fn main() -> ExitCode {
    run_main("r2p-canlink", HELP, |args| parse_args(args).and_then(serve))
}
