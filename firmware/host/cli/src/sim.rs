//! `r2p sim`: runs a robot file on emulated boards — in virtual time into a trace, or in real
//! time behind a socketcand server (and a SocketCAN interface) so that tools join the robot.

use std::io::Write;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use clap::Args;
use r2p_emu::robot::EmuRobot;
use r2p_emu::serve::{self, Serve};

use crate::args::{emit, parse_seconds, BusArgs, DEFAULT_SOCKETCAND};
use crate::error::CliError;

/// `r2p sim` options.
#[derive(Args, Debug)]
pub struct SimArgs {
    /// Robot file describing the modules, their wiring and the world (e.g. robots/triskar2.toml)
    pub robot: PathBuf,
    /// Pace virtual time against the wall clock and serve the bus: socketcand on --socketcand's
    /// address (default 127.0.0.1:29536) and, with --socketcan IFACE, a kernel CAN interface
    #[arg(long)]
    pub realtime: bool,
    /// Stop after this many seconds (of virtual time, or of real time with --realtime);
    /// required without --realtime
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    pub seconds: Option<Duration>,
    /// Write the bus's frames to FILE: pcap (Wireshark) if it ends in .pcap, the decoded topics
    /// as MCAP (Foxglove, the mcap library) if it ends in .mcap (without --realtime: for a live
    /// bus, `r2p record`), else a candump log
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// Override the robot file's seed (sensor noise and bus faults)
    #[arg(long)]
    pub seed: Option<u64>,
    /// With --realtime: keep running when standard input closes
    #[arg(long)]
    pub no_stdin: bool,
    /// With --realtime: also serve the bus through the robot's gateway, on ADDR (IP:PORT): the
    /// gateway application's own socketcand server (the code its STM32F407 image runs), over
    /// host TCP — the endpoint a real robot's gateway serves on its Ethernet port
    #[arg(long, value_name = "ADDR")]
    pub gateway: Option<SocketAddr>,
    /// With --realtime: connect the robot's gateway to the Zenoh router at ENDPOINT
    /// (tcp/HOST:PORT, e.g. tcp/127.0.0.1:7447, rmw_zenoh's router): its topics become ROS 2
    /// topics (/odom, /gateway/status, ...) and /cmd_vel drives the base (docs/ros2.md)
    #[arg(long, value_name = "ENDPOINT")]
    pub zenoh: Option<String>,
    /// With --zenoh: the ROS domain ID
    #[arg(long, value_name = "ID", default_value_t = 0)]
    pub ros_domain: u32,
    /// With --zenoh: the ROS namespace of the gateway's node and topics (none by default)
    #[arg(long, value_name = "NS", default_value = "")]
    pub ros_namespace: String,
    /// With --realtime: power MODULE off at SECONDS (of virtual time, from the start), as if its
    /// supply were cut: it stops sending at once, a frame on the wire cut short (repeatable;
    /// fault injection for tools, e.g. `r2p ui` showing it lost)
    #[arg(long, value_name = "MODULE@SECONDS", value_parser = parse_power_off)]
    pub power_off: Vec<(String, Duration)>,
    /// Without --realtime: also write the base's true pose, its odometry and the command every
    /// 50 ms to FILE (CSV), for plots
    #[arg(long, value_name = "FILE")]
    pub trajectory: Option<PathBuf>,
}

/// Runs `r2p sim`.
pub fn run(args: &SimArgs, bus: &BusArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let mut robot =
        r2p_world::Robot::load(&args.robot).map_err(|e| CliError::new(e.to_string()))?;
    if let Some(seed) = args.seed {
        robot.seed = seed;
    }
    let name = robot.name.clone();
    let mut r = EmuRobot::build(robot).map_err(CliError::new)?;
    let log = args.log.as_ref().map(|p| p.display().to_string());
    if args.realtime && log.as_deref().is_some_and(|p| p.ends_with(".mcap")) {
        return Err(CliError::new(
            "--realtime --log writes the served bus's frames (pcap or candump): record its topics \
             as MCAP with `r2p record FILE.mcap` while it runs, or drop --realtime",
        ));
    }
    if !args.realtime {
        if let Some((m, _)) = args.power_off.first() {
            return Err(CliError::new(format!(
                "--power-off {m}@…: powers a module off while tools watch: add --realtime"
            )));
        }
        if let Some(a) = args.gateway {
            return Err(CliError::new(format!(
                "--gateway {a} serves the bus in real time: add --realtime"
            )));
        }
        if let Some(z) = &args.zenoh {
            return Err(CliError::new(format!(
                "--zenoh {z} connects the gateway in real time: add --realtime"
            )));
        }
        let (Some(seconds), Some(path)) = (args.seconds, log.as_deref()) else {
            return Err(CliError::new(
                "without --realtime, give --seconds N and --log FILE (the run goes as fast as it can into the trace)",
            ));
        };
        if let Some(csv) = &args.trajectory {
            write_trajectory(&mut r, seconds, csv)?;
        }
        let wall = if path.ends_with(".mcap") {
            record_virtual(&mut r, seconds, path)?
        } else {
            serve::run_virtual(&mut r.sim, seconds.as_secs_f64(), path, &bus.channel)
                .map_err(CliError::new)?
        };
        let p = r.world.borrow().pose();
        let (virt, wall_s) = (seconds.as_secs_f64(), wall.as_secs_f64().max(1e-9));
        if bus.json {
            // Events the run processed: frames on the bus, node slot ticks, application steps
            // and world steps (one per millisecond).
            let st = r.sim.stats();
            let frames = r.sim.bus().frames().count() as u64;
            let world_steps = (virt * 1000.0) as u64;
            let events = frames + st.ticks + st.app_steps + world_steps;
            let line = serde_json::json!({
                "robot": name, "virtual_s": virt, "wall_s": wall_s, "ratio": virt / wall_s,
                "frames": frames, "ticks": st.ticks, "app_steps": st.app_steps,
                "world_steps": world_steps, "events": events, "events_per_s": events as f64 / wall_s,
            });
            return emit(out, &line.to_string());
        }
        emit(
            out,
            &format!(
                "r2p sim: {name}: {:.1} s of virtual time in {:.2} s ({:.0}x real time), {} frames {} {path}; base at x {:.3} m, y {:.3} m, heading {:.1}°",
                seconds.as_secs_f64(),
                wall.as_secs_f64(),
                seconds.as_secs_f64() / wall.as_secs_f64().max(1e-9),
                r.sim.bus().frames().count(),
                if path.ends_with(".mcap") { "on the bus, their topics decoded into" } else { "written to" },
                p.x,
                p.y,
                p.theta.to_degrees()
            ),
        )?;
        return Ok(());
    }
    let addr = bus.socketcand.as_deref().unwrap_or(DEFAULT_SOCKETCAND);
    let addr: SocketAddr = addr.parse().map_err(|_| {
        CliError::new(format!("--socketcand {addr}: expected IP:PORT, e.g. 127.0.0.1:29536"))
    })?;
    let mut power_off = Vec::new();
    for (m, t) in &args.power_off {
        let i = r.board(m).ok_or_else(|| {
            let names: Vec<&str> = r.boards.iter().map(|b| b.name.as_str()).collect();
            CliError::new(format!(
                "--power-off {m}@…: {name} has no module {m:?} (its modules: {})",
                names.join(", ")
            ))
        })?;
        eprintln!("r2p sim: {m} will be powered off at {:.3} s", t.as_secs_f64());
        power_off.push((*t, i));
    }
    let opts = Serve {
        addr,
        channel: bus.channel.clone(),
        log,
        seconds: args.seconds.map(|d| d.as_secs_f64()),
        watch_stdin: !args.no_stdin,
        socketcan: bus.socketcan.clone(),
        power_off,
    };
    let gateway = match args.gateway {
        Some(a) => {
            let g = r.serve_gateway(a).map_err(|e| {
                CliError::new(format!("--gateway {a}: cannot serve the bus there: {e}"))
            })?;
            eprintln!("r2p sim: {name}'s gateway serves socketcand on {}", g.local_addr());
            Some(g)
        }
        None => None,
    };
    let zenoh = match &args.zenoh {
        Some(e) => {
            let router = parse_zenoh_endpoint(e)?;
            let z =
                r.connect_zenoh(router, args.ros_domain, &args.ros_namespace).map_err(|err| {
                    CliError::new(format!("--zenoh {e}: cannot connect the gateway: {err}"))
                })?;
            eprintln!(
                "r2p sim: {name}'s gateway is a Zenoh client of {router} (ROS domain {})",
                args.ros_domain
            );
            Some(z)
        }
        None => None,
    };
    let spare = r.spare_port();
    let summary = serve::run_realtime(&mut r.sim, spare, &name, &opts).map_err(CliError::new)?;
    if let Some(g) = gateway {
        g.shutdown();
    }
    if let Some(z) = zenoh {
        z.shutdown();
    }
    emit(out, &summary.replacen("r2p-emu:", "r2p sim:", 1))
}

/// Runs `r` for `seconds` and writes what went over its bus as an MCAP recording (decoded
/// topics, `crate::mcap_log`), stamped as `serve::run_virtual` stamps its traces. Returns the
/// wall-clock time of the run.
fn record_virtual(r: &mut EmuRobot, seconds: Duration, path: &str) -> Result<Duration, CliError> {
    let wall = std::time::Instant::now();
    r.sim.run_until(seconds.as_nanos() as u64);
    let took = wall.elapsed();
    let stats = crate::mcap_log::write_file(path, &serve::stamped_frames(r.sim.bus()))?;
    eprintln!(
        "r2p sim: {path}: {} messages on {} channels ({} of streams not advertised in the run or \
         of unknown types, {} that did not decode)",
        stats.messages, stats.channels, stats.unknown, stats.undecodable
    );
    Ok(took)
}

/// Parses `MODULE@SECONDS` (`--power-off`).
fn parse_power_off(s: &str) -> Result<(String, Duration), String> {
    let bad = || format!("{s:?}: expected MODULE@SECONDS, e.g. imu@5");
    let (m, t) = s.rsplit_once('@').ok_or_else(bad)?;
    let t: f64 = t.parse().map_err(|_| bad())?;
    if m.is_empty() || !t.is_finite() || !(0.0..1e6).contains(&t) {
        return Err(bad());
    }
    Ok((m.to_string(), Duration::from_secs_f64(t)))
}

/// `tcp/HOST:PORT` (Zenoh's locator syntax; only TCP) as an address.
fn parse_zenoh_endpoint(e: &str) -> Result<SocketAddr, CliError> {
    let bad = || {
        CliError::new(format!(
            "--zenoh {e}: expected tcp/IP:PORT, e.g. tcp/127.0.0.1:7447 (the router's listening endpoint)"
        ))
    };
    let addr = e.strip_prefix("tcp/").ok_or_else(bad)?;
    use std::net::ToSocketAddrs;
    addr.to_socket_addrs().map_err(|_| bad())?.next().ok_or_else(bad)
}

/// Runs `r` for `seconds` in 50 ms slices, writing the base's pose (world and odometry) and the
/// command after obstacle avoidance as CSV. The trace that follows covers the same run.
fn write_trajectory(r: &mut EmuRobot, seconds: Duration, csv: &PathBuf) -> Result<(), CliError> {
    let mut text = String::from(
        "t_s,x_m,y_m,theta_rad,odom_x_m,odom_y_m,odom_theta_rad,cmd_vx,cmd_vy,cmd_wz\n",
    );
    let end = seconds.as_nanos() as u64;
    let mut t = 0;
    while t < end {
        t = (t + 50_000_000).min(end);
        r.sim.run_until(t);
        let p = r.world.borrow().pose();
        let pr = r.probe.borrow();
        let (o, c) = (pr.odometry, pr.command);
        text.push_str(&format!(
            "{:.3},{:.5},{:.5},{:.5},{:.5},{:.5},{:.5},{:.3},{:.3},{:.3}\n",
            t as f64 / 1e9,
            p.x,
            p.y,
            p.theta,
            o.0,
            o.1,
            o.2,
            c.0,
            c.1,
            c.2
        ));
    }
    std::fs::write(csv, text)
        .map_err(|e| CliError::new(format!("cannot write {}: {e}", csv.display())))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_off_names_a_module_and_a_time() {
        assert_eq!(parse_power_off("imu@5"), Ok(("imu".into(), Duration::from_secs(5))));
        assert_eq!(parse_power_off("a@b@0.5"), Ok(("a@b".into(), Duration::from_millis(500))));
        for bad in ["imu", "@5", "imu@", "imu@-1", "imu@x", "imu@inf"] {
            assert!(parse_power_off(bad).unwrap_err().contains("MODULE@SECONDS"), "{bad}");
        }
    }
}
