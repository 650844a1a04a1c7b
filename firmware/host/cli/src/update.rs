//! `r2p update NODE IMAGE` and `r2p update --all IMAGE`: a signed image (`r2p sign`) to modules
//! over the bus, on whatever link the CLI has (emulated robot, socketcand, SocketCAN, the
//! gateway), as NRT management traffic. r2p-boot's sender moves it (windowed, resumable: a
//! module that reboots mid-way gets it again from the start), the module checks it where it
//! landed and marks it; then a REBOOT swaps it in, and the command waits until the module runs
//! it and has confirmed itself (or reports its rollback). Updating the gateway through its own
//! endpoint, the link goes down with its reset: the command connects again and goes on waiting.
//! docs/flashing.md, "Updates over the bus".

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use clap::Args;
use r2p_boot::sender::{Phase, Sender};
use r2p_boot::transfer::Msg;
use r2p_boot::{Trailer, TRAILER_LEN};
use r2p_management::message::Message;
use r2p_management::NodeId;

use crate::args::{emit, BusArgs};
use crate::describe::version_text;
use crate::error::CliError;
use crate::param::resolve;
use crate::session::Session;
use crate::watch::{Firmware, What};

/// `r2p update` options.
#[derive(Args, Debug, Clone)]
pub struct UpdateArgs {
    /// NODE IMAGE: the module (its node ID, or its name as heartbeats give it) and the signed
    /// image; with --all, IMAGE alone
    #[arg(num_args = 1..=2, value_name = "NODE IMAGE", required = true)]
    pub targets: Vec<String>,
    /// Update every module whose kind (as its FIRMWARE message says) is the image's
    #[arg(long)]
    pub all: bool,
    /// Blocks (48 bytes each) in flight at once: one suits modules that write each block as it
    /// arrives (every F103 module: docs/flashing.md); more only for a receiver that buffers
    #[arg(long, default_value_t = r2p_boot::sender::DEFAULT_WINDOW, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub window: u32,
    /// Leave the image marked in the module's update slot: it swaps in at the module's next reset
    #[arg(long)]
    pub no_reboot: bool,
}

/// How long the sender waits for an answer before it goes back and sends again.
const RESEND_AFTER_MS: u64 = 400;
/// With no answer at all for this long, the module is taken not to take updates.
const SILENT_FOR: Duration = Duration::from_secs(10);
/// How long a module may take to come back running the new image and confirm it: the slowest
/// swap (the F103's 8.2 s, the gateway's F407 16.2 s), its boot, and the trial's 15 s.
const CONFIRM_WITHIN: Duration = Duration::from_secs(40);
/// REBOOT again after this long while the module still runs its old boot.
const REBOOT_AGAIN: Duration = Duration::from_millis(500);
/// Listening for FIRMWARE messages (every 8 heartbeats, 0.8 s by default) before choosing.
const HEAR_FIRMWARE: Duration = Duration::from_millis(1_800);

/// A signed image read from a file, checked as far as the host can.
struct Image {
    bytes: Vec<u8>,
    trailer: Trailer,
    path: PathBuf,
}

fn read_image(path: &str) -> Result<Image, CliError> {
    let path = PathBuf::from(path);
    let bytes = std::fs::read(&path).map_err(|e| {
        CliError::new(format!("{}: {e} (IMAGE is a signed image: `r2p sign`)", path.display()))
    })?;
    let shown = path.display();
    if bytes.len() < TRAILER_LEN {
        return Err(CliError::new(format!(
            "{shown}: {} (only {} bytes)",
            r2p_boot::Refusal::NoTrailer.message(),
            bytes.len()
        )));
    }
    let raw: &[u8; TRAILER_LEN] = bytes[bytes.len() - TRAILER_LEN..].try_into().expect("length");
    let trailer =
        Trailer::parse(raw).map_err(|r| CliError::new(format!("{shown}: {}", r.message())))?;
    if trailer.image_len as usize + TRAILER_LEN != bytes.len() {
        return Err(CliError::new(format!(
            "{shown}: {} ({} B of image before the trailer, it says {} B)",
            r2p_boot::Refusal::Truncated.message(),
            bytes.len() - TRAILER_LEN,
            trailer.image_len
        )));
    }
    Ok(Image { bytes, trailer, path })
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

/// Runs `r2p update`.
pub fn run(
    args: &UpdateArgs,
    bus: &BusArgs,
    connect: impl Fn() -> Result<Session, CliError>,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let (node, image) = match (args.all, args.targets.as_slice()) {
        (true, [image]) => (None, image),
        (false, [node, image]) => (Some(node.as_str()), image),
        (true, _) => {
            return Err(CliError::new("with --all give only IMAGE: r2p update --all IMAGE"))
        }
        (false, _) => {
            return Err(CliError::new(
                "give NODE and IMAGE (or --all IMAGE): r2p update motor1 motor.signed.bin",
            ))
        }
    };
    // The image first: a missing or refused file is the error to report, whether or not a bus
    // is reachable.
    let image = read_image(image)?;
    let mut s = connect()?;
    s.join()?;
    let targets = match node {
        Some(n) => vec![resolve(n, bus, &mut s)?],
        None => same_kind(&mut s, &image)?,
    };
    for target in targets {
        update_one(args, &mut s, &connect, target, &image, out)?;
    }
    Ok(())
}

/// Every node whose FIRMWARE message says it runs an image of the image's kind.
fn same_kind(s: &mut Session, image: &Image) -> Result<Vec<NodeId>, CliError> {
    let start = Instant::now();
    while start.elapsed() < HEAR_FIRMWARE {
        s.step(Duration::from_millis(5))?;
    }
    let kind = image.trailer.kind.as_str();
    let found: Vec<NodeId> = s
        .watcher()
        .nodes()
        .filter(|n| n.firmware.as_ref().is_some_and(|f| f.kind == kind))
        .filter_map(|n| NodeId::new(n.id))
        .collect();
    if found.is_empty() {
        let heard: Vec<String> = s
            .watcher()
            .nodes()
            .filter_map(|n| n.firmware.as_ref().map(|f| format!("{} ({})", n.name, f.kind)))
            .collect();
        return Err(CliError::new(format!(
            "--all: no module on {} says it runs a {kind} image (FIRMWARE heard from: {})",
            s.describe(),
            if heard.is_empty() { "none".into() } else { heard.join(", ") }
        )));
    }
    Ok(found)
}

/// The progress line: bar, bytes, rate and time left.
fn progress(label: &str, done: u32, total: u32, elapsed: Duration) -> String {
    const WIDTH: usize = 30;
    let share = f64::from(done) / f64::from(total.max(1));
    let filled = (share * WIDTH as f64) as usize;
    let rate = f64::from(done) / elapsed.as_secs_f64().max(1e-3);
    let left = if done == 0 {
        "--".to_string()
    } else {
        format!("{:.0} s", f64::from(total - done) / rate)
    };
    format!(
        "{label}: [{}{}] {:>3.0} % {:.1}/{:.1} KiB, {:.1} KiB/s, {left} left",
        "#".repeat(filled),
        ".".repeat(WIDTH - filled),
        share * 100.0,
        f64::from(done) / 1024.0,
        f64::from(total) / 1024.0,
        rate / 1024.0
    )
}

fn update_one(
    args: &UpdateArgs,
    s: &mut Session,
    connect: &dyn Fn() -> Result<Session, CliError>,
    target: NodeId,
    image: &Image,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let label = s.watcher().node_label(target.get());
    let uid = s.watcher().node(target.get()).map(|n| n.uid);
    // What it runs now, for the line that says what it ran before: FIRMWARE comes every 8th
    // heartbeat, so a node just heard may not have said it yet.
    let asked = Instant::now();
    while s.watcher().node(target.get()).is_some_and(|n| n.firmware.is_none())
        && asked.elapsed() < HEAR_FIRMWARE
    {
        s.step(Duration::from_millis(5))?;
    }
    let before = s.watcher().node(target.get()).and_then(|n| n.firmware.clone());
    let me = s.host().expect("joined").node_id();
    let id = (Instant::now().elapsed().subsec_nanos() as u16 ^ std::process::id() as u16).max(1);
    let mut sender = Sender::new(&image.bytes, id, args.window, RESEND_AFTER_MS);
    let start = Instant::now();
    let mut heard_at = Instant::now();
    let mut last_shown = Instant::now() - Duration::from_secs(1);
    let (mut sent, mut buf) = (0u64, [0u8; 64]);
    let terminal = std::io::stderr().is_terminal();
    while !matches!(sender.phase(), Phase::Done | Phase::Refused(_)) {
        let now_ms = start.elapsed().as_millis() as u64;
        let host = s.host().expect("joined");
        // Keep the host's queue short so a go-back resends from where the module stands.
        while host.tx_pending() < 16 {
            let Some(msg) = sender.poll(now_ms) else { break };
            let n = msg.encode(&mut buf);
            host.send_update(target, &buf[..n])?;
            sent += 1;
        }
        for r in s.step(Duration::from_millis(1))? {
            let What::Management { node, done: Some(Ok(Message::Update { target: to, data })) } =
                r.what
            else {
                continue;
            };
            if node != target.get() || to != me.get() {
                continue;
            }
            if let Ok(Msg::Status(status)) = Msg::decode(&data) {
                heard_at = Instant::now();
                sender.on_status(&status, start.elapsed().as_millis() as u64);
            }
        }
        if heard_at.elapsed() > SILENT_FOR {
            return Err(CliError::new(format!(
                "node {label} does not answer UPDATE messages (for {SILENT_FOR:?}): it left the bus, \
                 or its image runs without the bootloader and cannot be updated over the bus \
                 (`r2p flash MODULE` writes the bootloader and a signed image; docs/flashing.md)"
            )));
        }
        if last_shown.elapsed() >= Duration::from_millis(if terminal { 200 } else { 2_000 }) {
            let (done, total) = sender.progress();
            let line = progress(&label, done, total, start.elapsed());
            if terminal {
                eprint!("\r{line}");
            } else {
                eprintln!("{line}");
            }
            last_shown = Instant::now();
        }
    }
    if terminal {
        eprintln!();
    }
    let took = start.elapsed();
    if let Phase::Refused(r) = sender.phase() {
        return Err(CliError::new(format!(
            "node {label} refused {}: {}; it keeps running its image",
            image.path.display(),
            r.message()
        )));
    }
    let bytes = image.bytes.len();
    let t = &image.trailer;
    let new_version = format!("{}.{}.{}", t.version.major, t.version.minor, t.version.patch);
    let was = before
        .as_ref()
        .map_or("-".to_string(), |f| format!("{} {}", f.version_text(), hex(&f.digest)));
    emit(
        out,
        &format!(
            "{label}: {bytes} B in {:.1} s ({:.1} KiB/s), {sent} messages sent ({} resent: {} \
             timeouts, {} goes back, {} restarts), verified and marked",
            took.as_secs_f64(),
            bytes as f64 / 1024.0 / took.as_secs_f64().max(1e-3),
            sent.saturating_sub(u64::from(bytes.div_ceil(48) as u32) + 2),
            sender.timeouts,
            sender.fast_goes_back,
            sender.restarts
        ),
    )?;
    if args.no_reboot {
        return emit(
            out,
            &format!("{label}: {new_version} swaps in at its next reset (--no-reboot)"),
        );
    }
    let running = wait_confirmed(s, connect, target, uid, &t.digest, &label)?;
    emit(
        out,
        &format!(
            "{label}: {was} -> {} {}: running, confirmed (node {})",
            version_text(running.1.version),
            hex(&running.1.digest),
            running.0
        ),
    )
}

/// Waits until the module with unique ID `uid` runs the image of `digest` and has confirmed it;
/// an error if it comes back with another image (rolled back) or not at all.
///
/// It sends REBOOT first, and again every [`REBOOT_AGAIN`] while the module's old boot still
/// heartbeats: a single frame is lost if it arrives while the module's flash stalls its CPU (its
/// receive FIFOs overflow), and REBOOT is not answered. Once the module falls silent (its
/// bootloader swapping) or boots again, no more are sent: one arriving during the new image's
/// trial would reset it before it confirms, and roll it back.
///
/// A link that closes once REBOOT was sent went down with the module: the gateway, updated
/// through its own endpoint (its reset closes its connections). The command connects again
/// (`connect`) until the gateway serves again, and takes the new connection's first view of it
/// as its new boot.
fn wait_confirmed(
    s: &mut Session,
    connect: &dyn Fn() -> Result<Session, CliError>,
    target: NodeId,
    uid: Option<[u8; 12]>,
    digest: &[u8; 8],
    label: &str,
) -> Result<(u8, Firmware), CliError> {
    let start = Instant::now();
    let mut seen_new = false;
    let mut rebooted = false;
    let mut last_uptime = u32::MAX;
    let (mut heartbeats, mut heartbeat_at) = (0u64, Instant::now());
    let mut asked_at: Option<Instant> = None;
    while start.elapsed() < CONFIRM_WITHIN {
        let alive = heartbeat_at.elapsed() < Duration::from_millis(300);
        if !rebooted && alive && asked_at.is_none_or(|t| t.elapsed() >= REBOOT_AGAIN) {
            s.host().expect("joined").request_reboot(target)?;
            asked_at = Some(Instant::now());
        }
        if let Err(e) = s.step(Duration::from_millis(5)) {
            if asked_at.is_none() {
                return Err(e);
            }
            eprintln!("{label}: {e}: the link went down with it; connecting again");
            *s = reconnect(connect, start)?;
            (rebooted, last_uptime) = (true, u32::MAX);
            continue;
        }
        let Some(n) = s.watcher().nodes().find(|n| Some(n.uid) == uid) else { continue };
        if n.heartbeats != heartbeats {
            (heartbeats, heartbeat_at) = (n.heartbeats, Instant::now());
        }
        // A new boot: its uptime went back (the watcher forgets the old boot's FIRMWARE then).
        if n.uptime_s < last_uptime && last_uptime != u32::MAX {
            rebooted = true;
        }
        last_uptime = n.uptime_s;
        let Some(f) = n.firmware.clone().filter(|_| rebooted) else { continue };
        if f.digest == *digest {
            seen_new = true;
            if !f.on_trial {
                return Ok((n.id, f));
            }
        } else if seen_new {
            return Err(CliError::new(format!(
                "{label}: the new image did not confirm itself and was rolled back: it runs {} {} \
                 again (its log or `r2p monitor` during its trial say why)",
                f.version_text(),
                hex(&f.digest)
            )));
        } else {
            return Err(CliError::new(format!(
                "{label}: rebooted but runs {} {}, not the image sent (was it marked? try again)",
                f.version_text(),
                hex(&f.digest)
            )));
        }
    }
    Err(CliError::new(format!(
        "{label}: not running the new image, confirmed, within {CONFIRM_WITHIN:?} of its reboot{}",
        if seen_new { " (it runs it, still on trial)" } else { "" }
    )))
}

/// Connects again, once a second, until [`CONFIRM_WITHIN`] of `start` is over (a gateway
/// swapping its images serves nothing).
fn reconnect(
    connect: &dyn Fn() -> Result<Session, CliError>,
    start: Instant,
) -> Result<Session, CliError> {
    loop {
        std::thread::sleep(Duration::from_secs(1));
        let joined = connect().and_then(|mut s| {
            s.join()?;
            Ok(s)
        });
        match joined {
            Ok(s) => return Ok(s),
            Err(e) if start.elapsed() >= CONFIRM_WITHIN => return Err(e),
            Err(_) => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_progress_line_says_share_rate_and_time_left() {
        let l = progress("motor1", 26 * 1024, 52 * 1024, Duration::from_secs(13));
        assert_eq!(
            l,
            "motor1: [###############...............]  50 % 26.0/52.0 KiB, 2.0 KiB/s, 13 s left"
        );
        assert!(progress("m", 0, 100, Duration::ZERO).ends_with("-- left"));
    }

    #[test]
    fn files_that_are_not_signed_images_are_refused_before_the_bus() {
        let dir = std::env::temp_dir().join(format!("r2p-update-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let short = dir.join("short.bin");
        std::fs::write(&short, [0u8; 100]).unwrap();
        let e = read_image(short.to_str().unwrap()).err().unwrap().to_string();
        assert!(e.contains("not a signed R2P image") && e.contains("100 bytes"), "{e}");
        let meta = r2p_boot::sign::Meta {
            version: r2p_boot::Version { major: 1, minor: 2, patch: 3 },
            kind: "motor",
            mcu: "STM32F103CB",
        };
        let signed = r2p_boot::sign::sign(&[7u8; 1000], &meta, &[1; 32]).unwrap();
        let cut = dir.join("cut.bin");
        let mut truncated = signed[..500].to_vec();
        truncated.extend_from_slice(&signed[signed.len() - TRAILER_LEN..]);
        std::fs::write(&cut, &truncated).unwrap();
        let e = read_image(cut.to_str().unwrap()).err().unwrap().to_string();
        assert!(e.contains("shorter than its trailer says") && e.contains("it says 1000 B"), "{e}");
        let good = dir.join("good.bin");
        std::fs::write(&good, &signed).unwrap();
        assert_eq!(read_image(good.to_str().unwrap()).unwrap().trailer.kind.as_str(), "motor");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
