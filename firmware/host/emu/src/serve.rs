//! Running a sim for users: in virtual time into a candump log, or in real time behind a
//! socketcand server (shared by `r2p-emu demo` and `r2p sim`).

use std::fs::File;
use std::io::BufWriter;
use std::net::SocketAddr;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use r2p_canlink::hub::DEFAULT_QUEUE;
use r2p_canlink::pcap::write_pcap;
use r2p_canlink::service::{HubService, StopConditions};
use r2p_canlink::socketcan::SocketCanBridge;
use r2p_canlink::{Config, Stamped};

use crate::bridge::Bridge;
use crate::{Runtime, Sim};

/// Candump logs of virtual-time runs are stamped from this Unix time.
pub const EPOCH_S: u64 = 1_700_000_000;

/// How to serve a sim in real time.
#[derive(Clone, Debug)]
pub struct Serve {
    /// socketcand listening address.
    pub addr: SocketAddr,
    /// Bus name clients open and logs name.
    pub channel: String,
    /// Append every frame the hub carries to this candump log.
    pub log: Option<String>,
    /// Stop after this many seconds.
    pub seconds: Option<f64>,
    /// Stop when standard input closes.
    pub watch_stdin: bool,
    /// Also bridge the bus to this kernel CAN interface (SocketCAN, Linux).
    pub socketcan: Option<String>,
    /// Power board `i` off at virtual time `t`, for each `(t, i)` (fault injection).
    pub power_off: Vec<(Duration, usize)>,
}

/// Runs `seconds` of virtual time as fast as possible and writes the bus's frames to `path`:
/// a pcap file (SocketCAN link type, for Wireshark) if it ends in `.pcap`, a candump log on
/// `channel` otherwise. Returns the wall time taken.
pub fn run_virtual<N: Runtime>(
    sim: &mut Sim<'_, N>,
    seconds: f64,
    path: &str,
    channel: &str,
) -> Result<Duration, String> {
    let file = File::create(path).map_err(|e| format!("cannot create log {path}: {e}"))?;
    let wall = Instant::now();
    sim.run_until((seconds * 1e9) as u64);
    let took = wall.elapsed();
    if path.ends_with(".pcap") {
        write_pcap(BufWriter::new(file), &stamped_frames(sim.bus()))
            .map_err(|e| format!("writing {path}: {e}"))?;
    } else {
        sim.write_candump(BufWriter::new(file), channel, Duration::from_secs(EPOCH_S))
            .map_err(|e| format!("writing the log: {e}"))?;
    }
    Ok(took)
}

/// The frames `bus` carried, stamped as virtual-time traces are: [`EPOCH_S`] plus their end of
/// frame.
pub fn stamped_frames(bus: &r2p_vbus::Bus) -> Vec<Stamped> {
    crate::bus_frames(bus)
        .into_iter()
        .map(|(t, _, frame)| Stamped {
            time: Duration::from_secs(EPOCH_S) + Duration::from_nanos(t),
            frame,
        })
        .collect()
}

/// Runs `sim` against the wall clock with a socketcand server on `opts.addr`; tools' frames
/// enter the bus through `spare_port`. `what` names the robot in messages. Returns the summary
/// line (why it stopped, counters) once it stops.
pub fn run_realtime<N: Runtime>(
    sim: &mut Sim<'_, N>,
    spare_port: usize,
    what: &str,
    opts: &Serve,
) -> Result<String, String> {
    let stop_when = StopConditions::install(opts.watch_stdin);
    let mut service = HubService::new(opts.log.as_deref(), &opts.channel, 16 * DEFAULT_QUEUE)?;
    let hub = service.hub.clone();
    let kernel_can = match &opts.socketcan {
        Some(iface) => Some(
            SocketCanBridge::start(iface, hub.clone(), DEFAULT_QUEUE)
                .map_err(|e| format!("--socketcan {iface}: {e}"))?,
        ),
        None => None,
    };
    let config = Config { addr: opts.addr, channel: opts.channel.clone(), queue: DEFAULT_QUEUE };
    let server = service.listen(config, "another r2p-emu, r2p-canlink or socketcand")?;
    eprintln!(
        "r2p-emu: {what} in real time, socketcand on {} channel {}",
        server.local_addr(),
        opts.channel
    );

    let mut bridge = Bridge::new(sim, spare_port, hub.clone(), DEFAULT_QUEUE);
    let limit = opts.seconds.map(Duration::from_secs_f64);
    let mut why = "--seconds";
    bridge.run_realtime_with(sim, Instant::now(), limit, &opts.power_off, || {
        match stop_when.reason() {
            Some(reason) => {
                why = reason;
                true
            }
            None => false,
        }
    });

    service.stopping();
    let clients = server.stats().clients.load(Ordering::Relaxed);
    server.shutdown();
    let s = bridge.stats();
    // The frames the bridge port actually sent on the virtual bus (one pass over the log).
    let on_bus = sim.bus().frames().filter(|f| f.1 == bridge.port()).count();
    let mut summary = format!(
        "r2p-emu: stopped ({why}) at {:.3} s of virtual time: {} frames to tools, {} injected from tools \
         ({on_bus} sent on the virtual bus), {} standard-ID frames dropped, {} not queued, \
         {} tap overflows, {clients} clients, max lag {} us",
        sim.now_ns() as f64 / 1e9,
        s.to_hub,
        s.injected,
        s.standard_dropped,
        s.not_queued,
        bridge.overflows(),
        s.max_lag_us,
    );
    if service.finish()? {
        summary.push_str(", log written");
    }
    if let Some(b) = kernel_can {
        b.stop();
        summary.push_str(" (SocketCAN bridged)");
    }
    Ok(summary)
}
