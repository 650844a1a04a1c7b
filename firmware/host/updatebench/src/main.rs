//! `r2p-updatebench`: `r2p update`'s transfer of the committed motor image to the emulated
//! Triskar2's motor1 while the robot drives, on a 1 Mbit/s bus at each background load asked for
//! (default 0 %, 10 %, 60 %: the robot's own traffic plus [`load`]'s SRT messages). Prints one
//! JSON object per load point (`"bench": "update"`); `scripts/r2ptools/bench.py` tabulates them,
//! the idle bus being the baseline. All figures are the emulator's virtual time.

mod load;

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::Ordering::Relaxed;
use std::sync::Mutex;

use embassy_boot::State;
use r2p_boot::sender::{Phase, Sender, DEFAULT_WINDOW};
use r2p_boot::sign::{sign, Meta};
use r2p_boot::transfer::{Msg, Status};
use r2p_boot::{image_digest, Version, TRAILER_LEN};
use r2p_emu::boards::firmware::{active_trailer, boot_state, development_seed, MCU};
use r2p_emu::robot::{BoardNode, EmuRobot};
use r2p_node::{NoParams, NodeConfig, UpdateSink};
use r2p_world::robot_file::Robot;
use rtcan::{CycleConfig, Frame};

use load::{LoadPublisher, LoadSubscriber};

const MS: u64 = 1_000_000;
const S: u64 = 1_000 * MS;
/// When the load is measured (the robot booted, driving, the load subscribed) and for how long.
const SETTLE: u64 = 3 * S;
const MEASURED: u64 = 2 * S;
/// `r2p update`'s: back after 400 ms without progress.
const RESEND_MS: u64 = 400;

const USAGE: &str = "usage: r2p-updatebench [--robot NAME] [--module NAME] [--loads L1,...] [--image FILE] [--window N]
  --robot NAME  robots/NAME.toml (default triskar2)
  --module NAME the motor module to update (default motor1)
  --loads ...   background loads as fractions of the bus (default 0,0.1,0.6)
  --image FILE  the image to send, unsigned (default firmware/images/motor.bin), signed here
                with the development key as motor 0.2.0
  --window N    blocks in flight (default: r2p update's)";

fn main() -> ExitCode {
    let Args { robot: name, module, loads, image, window } = match parse() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}{}{USAGE}", if e.is_empty() { "" } else { "\n" });
            return ExitCode::from(2);
        }
    };
    let bytes = match std::fs::read(&image) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{}: {e} (build the images with `make firmware`)", image.display());
            return ExitCode::FAILURE;
        }
    };
    let meta = Meta { version: Version { major: 0, minor: 2, patch: 0 }, kind: "motor", mcu: MCU };
    let signed: &'static [u8] = match sign(&bytes, &meta, &development_seed()) {
        Ok(s) => s.leak(),
        Err(e) => {
            eprintln!("{}: cannot sign it: {e:?}", image.display());
            return ExitCode::FAILURE;
        }
    };
    let base = match robot(&name, 0).map(|mut r| background(&mut r)) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::FAILURE;
        }
    };
    for target in loads {
        match point(&name, &module, target, base, signed, window) {
            Ok(line) => println!("{line}"),
            Err(e) => {
                eprintln!("load {target}: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    ExitCode::SUCCESS
}

struct Args {
    robot: String,
    module: String,
    loads: Vec<f64>,
    image: PathBuf,
    window: u32,
}

fn parse() -> Result<Args, String> {
    let mut loads = vec![0.0, 0.1, 0.6];
    let mut window = DEFAULT_WINDOW;
    let (mut robot, mut module) = ("triskar2".to_string(), "motor1".to_string());
    let mut image = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../images/motor.bin"));
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "--help" || flag == "-h" {
            return Err(String::new());
        }
        let value = it.next().ok_or(format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--loads" => {
                loads = value
                    .split(',')
                    .map(|s| s.trim().parse::<f64>().ok().filter(|l| (0.0..0.95).contains(l)))
                    .collect::<Option<_>>()
                    .ok_or(format!("--loads {value}: fractions in [0, 0.95), comma-separated"))?;
            }
            "--image" => image = PathBuf::from(value),
            "--robot" => robot = value,
            "--module" => module = value,
            "--window" => {
                window = value
                    .parse()
                    .ok()
                    .filter(|w| (1..=64).contains(w))
                    .ok_or(format!("--window {value}: blocks in flight, 1 to 64"))?
            }
            _ => return Err(format!("unknown option {flag}")),
        }
    }
    Ok(Args { robot, module, loads, image, window })
}

/// Robot `name` with `spares` ports beyond the robot's tool port.
fn robot(name: &str, spares: usize) -> Result<EmuRobot, String> {
    let path = format!("{}/../../../robots/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    let robot = Robot::load(path).map_err(|e| e.to_string())?;
    EmuRobot::build_with_spares(robot, 1 + spares)
}

/// Share of the bus the frames sent in `[from, to)` took, those of `port` apart: (others, port's).
fn shares(
    r: &EmuRobot,
    from: u64,
    to: u64,
    port: Option<usize>,
    also: impl Fn(usize, &Frame) -> bool,
) -> (f64, f64) {
    let bus = r.sim.bus();
    let (mut others, mut own) = (0u64, 0u64);
    for (_, p, f) in bus.frames().filter(|(t, _, _)| (from..to).contains(t)) {
        if Some(p) == port || also(p, &f) {
            own += bus.frame_ns(&f);
        } else {
            others += bus.frame_ns(&f);
        }
    }
    let span = (to - from) as f64;
    (others as f64 / span, own as f64 / span)
}

/// Runs the robot to [`SETTLE`] and measures its traffic over [`MEASURED`].
fn background(r: &mut EmuRobot) -> f64 {
    r.sim.run_until(SETTLE + MEASURED);
    shares(r, SETTLE, SETTLE + MEASURED, None, |_, _| false).0
}

fn node(r: &EmuRobot, name: &'static str, last: u8) -> BoardNode {
    let mut uid = [0xFEu8; 12];
    uid[11] = last;
    let cycle = CycleConfig { cycle_us: r.robot.bus.cycle_us, ..CycleConfig::DEFAULT };
    BoardNode::new(NodeConfig { cycle, ..NodeConfig::new(uid, name) }, &NoParams)
        .expect("a bench node's configuration is valid")
}

/// The statuses the tool hears.
struct Heard(Mutex<Vec<Status>>);

impl UpdateSink for Heard {
    fn handle(&self, _from: u8, msg: &[u8], _answer: &mut [u8; 64]) -> usize {
        if let Ok(Msg::Status(s)) = Msg::decode(msg) {
            self.0.lock().unwrap().push(s);
        }
        0
    }
}

/// One load point: the load added, the transfer, the reboot into the image and its confirmation.
fn point(
    name: &str,
    module: &str,
    target: f64,
    base: f64,
    signed: &'static [u8],
    window: u32,
) -> Result<String, String> {
    let mut r = robot(name, 2)?;
    let (tool_port, pub_port, sub_port) = (r.spare_port(), r.spare_port() + 1, r.spare_port() + 2);
    // The load's rate: what the robot leaves to reach `target`, in frames of the load's size.
    let sample = Frame::from_raw(0x0D00_0000, &[0x55; load::SIZE]).expect("a valid frame");
    let frame_s = r.sim.bus().frame_ns(&sample) as f64 / 1e9;
    let rate = ((target - base).max(0.0)) / frame_s;
    let publisher: &'static LoadPublisher = Box::leak(Box::new(LoadPublisher::new(rate)));
    let subscriber: &'static LoadSubscriber = Box::leak(Box::default());
    let mut p = node(&r, "load-pub", 1);
    p.export(publisher).map_err(|e| format!("{e:?}"))?;
    let mut s = node(&r, "load-sub", 2);
    s.import(subscriber).map_err(|e| format!("{e:?}"))?;
    r.sim.add_board(p, pub_port, Some(Box::new(move |now, _: &mut BoardNode| publisher.step(now))));
    r.sim.add_board(s, sub_port, None);
    let measured = background(&mut r);

    let m = r.board(module).ok_or(format!("{name} has no module {module}"))?;
    let target_id = r.sim.node(m).node_id();
    let heard: &'static Heard = Box::leak(Box::new(Heard(Mutex::new(Vec::new()))));
    let sender: &'static Mutex<Sender<'static>> =
        Box::leak(Box::new(Mutex::new(Sender::new(signed, 7, window, RESEND_MS))));
    let mut tool = node(&r, "r2p-cli", 3);
    tool.set_update_sink(heard);
    let tool_board = r.sim.add_board(
        tool,
        tool_port,
        Some(Box::new(move |now: u64, node: &mut BoardNode| {
            let mut s = sender.lock().unwrap();
            for st in heard.0.lock().unwrap().drain(..) {
                s.on_status(&st, now / 1_000);
            }
            let mut buf = [0u8; 64];
            while node.tx_pending() < 16 {
                let Some(msg) = s.poll(now / 1_000) else { break };
                let n = msg.encode(&mut buf);
                let _ = node.send_update(target_id, &buf[..n]);
            }
        })),
    );
    let missed_before: u32 =
        (0..r.sim.boards()).filter(|&i| i != m).map(|i| r.sim.node(i).stats().hrt_missed).sum();
    let start = r.sim.now_ns();
    let done = |_: &_| matches!(sender.lock().unwrap().phase(), Phase::Done | Phase::Refused(_));
    if !r.sim.run_while(10 * MS, start + 900 * S, done) {
        return Err(format!(
            "transfer unfinished after 900 s: {:?}",
            sender.lock().unwrap().phase()
        ));
    }
    if let Phase::Refused(why) = sender.lock().unwrap().phase() {
        return Err(format!("{module} refused the image: {}", why.message()));
    }
    let end = r.sim.now_ns();
    let missed: u32 =
        (0..r.sim.boards()).filter(|&i| i != m).map(|i| r.sim.node(i).stats().hrt_missed).sum();
    // The robot's boards sit on the ports of their index: the module's answers are its
    // management stream's frames.
    let (others, update) = shares(&r, start, end, Some(tool_port), |port, f| {
        port == m && f.id().message.0 & 0xFF == 0
    });

    // The reboot, the swap and the new image's confirmation, as `r2p update` waits for them.
    let boots = r.boards[m].boots.get();
    let rebooted = r.sim.now_ns();
    while r.boards[m].boots.get() == boots {
        if r.sim.now_ns() > rebooted + 10 * S {
            return Err(format!("{module} did not reset on REBOOT within 10 s"));
        }
        let id = r.sim.node(m).node_id().get();
        r.sim.node_mut(tool_board).request_reboot(id).map_err(|e| format!("{e:?}"))?;
        r.sim.run_for(300 * MS);
    }
    let digest = image_digest(&signed[..signed.len() - TRAILER_LEN]);
    let flash = r.boards[m].flash;
    let confirmed = |_: &_| {
        boot_state(flash) == Some(State::Boot)
            && active_trailer(flash).is_some_and(|t| t.digest == digest)
    };
    if !r.sim.run_while(100 * MS, rebooted + 120 * S, confirmed) {
        return Err(format!("{module} did not confirm the new image within 120 s of the reboot"));
    }
    let secs = |ns: u64| ns as f64 / S as f64;
    let s = sender.lock().unwrap();
    Ok(serde_json::json!({
        "bench": "update",
        "robot": name,
        "module": module,
        "target_load": target,
        "robot_load": base,
        "background_load": measured,
        "background_during": others,
        "image_bytes": signed.len(),
        "window": window,
        "transfer_s": secs(end - start),
        "kib_per_s": signed.len() as f64 / 1024.0 / secs(end - start),
        "update_share": update,
        "reboot_to_confirmed_s": secs(r.sim.now_ns() - rebooted),
        "hrt_missed_others": missed - missed_before,
        "timeouts": s.timeouts,
        "goes_back": s.fast_goes_back,
        "load_dropped": publisher.dropped.load(Relaxed),
        "load_deadline_misses": publisher.missed.load(Relaxed),
        "load_received": subscriber.received.load(Relaxed),
    })
    .to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_load_node_brings_the_bus_to_the_load_asked_for_and_the_update_still_lands() {
        let image: Vec<u8> = (0..6_000u32).map(|i| i.wrapping_mul(2_654_435_761) as u8).collect();
        let meta =
            Meta { version: Version { major: 0, minor: 2, patch: 0 }, kind: "motor", mcu: MCU };
        let signed = sign(&image, &meta, &development_seed()).unwrap().leak();
        let base = background(&mut robot("diffbot", 0).unwrap());
        assert!((0.02..0.08).contains(&base), "the diffbot's own traffic: {base}");
        let line = point("diffbot", "left", 0.3, base, signed, DEFAULT_WINDOW).unwrap();
        let p: serde_json::Value = serde_json::from_str(&line).unwrap();
        let load = p["background_load"].as_f64().unwrap();
        assert!((0.29..0.33).contains(&load), "30 % asked for, {load} measured");
        assert!(p["background_during"].as_f64().unwrap() > 0.27, "{line}");
        assert!(p["load_received"].as_u64().unwrap() > 1_000, "the load reached its subscriber");
        assert_eq!(p["hrt_missed_others"], 0, "{line}");
        assert_eq!(p["timeouts"], 0, "{line}");
        assert!(p["update_share"].as_f64().unwrap() > 0.05, "{line}");
    }
}
