//! `r2p imu calibrate`: the magnetometer's hard- and soft-iron calibration, run by the user
//! (issue 21). It subscribes to the IMU module's `mag` topic (`imu/mag`, `imuN/mag`) as
//! `r2p echo` does, shows the headings covered while the user turns the robot, fits the raw
//! field ([`r2p_magcal::ellipsoid`]: 3-D, or x/y only for a robot that turns on the floor), reports
//! the fit's quality and, unless it is refused or `--dry-run`, sets the module's `mag_offset_*`
//! and `mag_soft_*` parameters (the module keeps them in flash), reads them back and prints them.
//!
//! The parameters are found by name in the IMU application's own table
//! (`r2p_app_imu::params::DEFAULTS`, the source the module's image is built from), so their
//! indices and ranges cannot drift from the firmware's; the bus carries indices only.
//!
//! Nothing is lost on a refusal: the module's parameters are written only after every check has
//! passed, and if a write fails part-way the values already written are set back to what the
//! module held before.

use std::io::Write;
use std::time::{Duration, Instant};

use clap::{Args, Subcommand};
use r2p_management::message::Value;
use r2p_management::NodeId;
use r2p_msgs::{MagneticField, R2pMessage};
use r2p_node::{Event, Param};
use serde_json::json;

use crate::args::{emit, parse_seconds, BusArgs};
use crate::describe::result_name;
use crate::error::CliError;
use crate::param::{ask, refused, resolve};
use crate::session::Session;
use r2p_magcal::coverage::{Coverage, SECTORS};
use r2p_magcal::ellipsoid::{fit, Fit, Kind, MAX_AXIS_RATIO, MIN_DETERMINACY};
use r2p_magcal::rules::{
    check, check_sectors, choose, coverage, in_range, keep_z, midrange, values, Slot, OFFSET,
    PLANAR_RATIO, SOFT,
};

/// `r2p imu` subcommands.
#[derive(Subcommand, Debug)]
pub enum ImuCommand {
    /// Calibrate the magnetometer (hard and soft iron): turn the robot while it collects the
    /// raw field, fit it, write the module's mag_offset_* and mag_soft_* parameters and read
    /// them back (docs/magnetometer-calibration.md)
    Calibrate(CalibrateArgs),
}

/// `r2p imu calibrate` options.
#[derive(Args, Debug)]
pub struct CalibrateArgs {
    /// The IMU module: its name as heartbeats give it (imu, imu1, …) or its node ID
    #[arg(long, default_value = "imu")]
    pub node: String,
    /// How long to collect samples while the robot turns
    #[arg(long, value_name = "SECONDS", default_value = "60", value_parser = parse_seconds)]
    pub seconds: Duration,
    /// Fit the x/y ellipse only (a robot that can only turn on the floor); the z terms are
    /// left as they are. Chosen by itself when the field's z spread is under a quarter of its
    /// horizontal spread
    #[arg(long, conflicts_with = "full")]
    pub planar: bool,
    /// Fit the 3-D ellipsoid: the robot must be rolled and pitched as well as turned
    #[arg(long)]
    pub full: bool,
    /// Collect, fit and report, but write nothing
    #[arg(long)]
    pub dry_run: bool,
}

/// How often the progress line is printed.
const PROGRESS: Duration = Duration::from_secs(1);

/// The index of `mag_heading` in `table`, if the firmware has it (a u32 switch): a written
/// calibration turns the magnetic heading on.
pub fn heading_switch(table: &[Param]) -> Option<u16> {
    table
        .iter()
        .position(|p| p.name == "mag_heading" && matches!(p.max, Value::U32(1)))
        .map(|i| i as u16)
}

/// Finds each parameter the calibration writes in `table` (the IMU application's).
pub fn layout(table: &[Param]) -> Result<Vec<Slot>, CliError> {
    let names = OFFSET.iter().copied().chain(SOFT.iter().map(|s| s.0));
    names
        .map(|name| {
            let (index, p) =
                table.iter().enumerate().find(|(_, p)| p.name == name).ok_or_else(|| {
                    CliError::new(format!(
                        "the IMU firmware this r2p was built with has no parameter {name:?}: \
                         build r2p from the same source as the module's image"
                    ))
                })?;
            match (p.min, p.max) {
                (Value::F32(min), Value::F32(max)) => {
                    Ok(Slot { name, index: index as u16, min, max })
                }
                _ => Err(CliError::new(format!(
                    "the IMU firmware's parameter {name:?} is not an f32: build r2p from the same \
                     source as the module's image"
                ))),
            }
        })
        .collect()
}

/// A refusal: what, then that nothing was written.
fn refuse(why: impl std::fmt::Display) -> CliError {
    CliError::new(format!(
        "not calibrated: {why}. Nothing was written: the module keeps its calibration"
    ))
}

/// The fit's report, as lines.
fn report(fit: &Fit, cov: &Coverage, z: f64, h: f64) -> Vec<String> {
    let planar = fit.kind == Kind::Planar;
    let cell = |i: usize, j: usize| {
        if planar && (i == 2 || j == 2) {
            "     —".to_string()
        } else {
            format!("{:7.4}", fit.soft[i][j])
        }
    };
    let mut lines = vec![format!(
        "fit: {} (z spread {z:.2} µT, horizontal {h:.2} µT; planar below {PLANAR_RATIO} × \
         horizontal){}",
        fit.kind.name(),
        if planar { "; z terms not fitted, left as the module has them" } else { "" }
    )];
    let hz = if planar { "—".to_string() } else { format!("{:.2}", fit.offset[2]) };
    lines.push(format!("  hard iron h = ({:.2}, {:.2}, {hz}) µT", fit.offset[0], fit.offset[1]));
    lines.push("  soft iron S =".into());
    for i in 0..3 {
        lines.push(format!("    [{} {} {} ]", cell(i, 0), cell(i, 1), cell(i, 2)));
    }
    lines.push(format!(
        "  |S(m − h)| = {:.2} µT, residual {:.3} µT RMS ({:.2} %), {} samples",
        fit.radius,
        fit.rms,
        fit.rms_percent(),
        fit.samples
    ));
    lines.push(format!(
        "  coverage: {}/{SECTORS} heading sectors [{}], {}/6 elevation bands",
        cov.sectors_covered(),
        cov.rose(),
        cov.bands_covered()
    ));
    lines.push(format!(
        "  determinacy {:.3e} (λ2/λ1, ≥ {MIN_DETERMINACY}), axis ratio {:.3} (≤ {MAX_AXIS_RATIO})",
        fit.determinacy, fit.axis_ratio
    ));
    lines
}

fn f32_of(v: Value) -> Option<f32> {
    match v {
        Value::F32(x) => Some(x),
        _ => None,
    }
}

/// Runs `r2p imu …` with the IMU application's parameter table.
pub fn run(
    cmd: &ImuCommand,
    bus: &BusArgs,
    s: Session,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    match cmd {
        ImuCommand::Calibrate(args) => calibrate(args, bus, s, out, &r2p_app_imu::params::DEFAULTS),
    }
}

/// Collects the `raw` field of `topic` for `args.seconds`, printing the progress.
fn collect(
    args: &CalibrateArgs,
    bus: &BusArgs,
    s: &mut Session,
    target: NodeId,
    topic: &str,
    out: &mut dyn Write,
) -> Result<(Vec<[f64; 3]>, u64), CliError> {
    s.host().expect("joined").want_import(topic);
    let start = Instant::now();
    let mut collecting: Option<Instant> = None;
    let mut subscribed = false;
    let mut next = PROGRESS;
    let mut samples = Vec::new();
    let mut no_data = 0u64;
    loop {
        s.step(Duration::from_millis(2))?;
        let host = s.host().expect("joined");
        if let Some(e) = host.import_error() {
            return Err(e.clone());
        }
        while let Some(e) = host.next_event() {
            match e {
                Event::Subscribed { .. } => subscribed = true,
                Event::SubscriptionRefused { from, result, .. } => {
                    return Err(CliError::new(format!(
                        "node {} refused the subscription to {topic:?}: {}",
                        from.get(),
                        result_name(result)
                    )))
                }
                _ => {}
            }
        }
        let messages = host.take_messages();
        let Some(info) = host.imported().cloned() else {
            if start.elapsed() >= bus.timeout {
                return Err(CliError::new(format!(
                    "node {} does not publish {topic:?} (no advertisement within {:?}): its \
                     image has no magnetometer topic; update it (r2p update) to one that has",
                    s.watcher().node_label(target.get()),
                    bus.timeout
                )));
            }
            continue;
        };
        if info.type_hash != MagneticField::TYPE_HASH {
            return Err(CliError::new(format!(
                "{topic:?} carries {}, not MagneticField: r2p and the module's image come from \
                 different sources; build r2p from the image's",
                info.type_name()
            )));
        }
        let at = *collecting.get_or_insert_with(Instant::now);
        if !subscribed && at.elapsed() >= bus.timeout && samples.is_empty() {
            return Err(CliError::new(format!(
                "node {} advertised {topic:?} but did not answer the subscription within {:?}",
                s.watcher().node_label(target.get()),
                bus.timeout
            )));
        }
        for bytes in messages {
            match MagneticField::decode(&bytes) {
                Ok(m) if m.status == 0 => samples.push(m.raw.map(f64::from)),
                Ok(_) => no_data += 1,
                Err(e) => {
                    return Err(CliError::new(format!(
                        "{topic:?}: a message did not decode: {e:?}"
                    )))
                }
            }
        }
        let elapsed = at.elapsed();
        if elapsed >= next && !bus.json {
            let c = coverage(&samples, midrange(&samples));
            emit(
                out,
                &format!(
                    "{:4.0} s  [{}] {:2}/{SECTORS} sectors, {}/6 elevations, {} samples",
                    elapsed.as_secs_f64(),
                    c.rose(),
                    c.sectors_covered(),
                    c.bands_covered(),
                    samples.len()
                ),
            )?;
            next += PROGRESS;
        }
        if elapsed >= args.seconds {
            return Ok((samples, no_data));
        }
    }
}

/// Runs `r2p imu calibrate` with `table` as the module's parameter table.
pub fn calibrate(
    args: &CalibrateArgs,
    bus: &BusArgs,
    mut s: Session,
    out: &mut dyn Write,
    table: &[Param],
) -> Result<(), CliError> {
    let slots = layout(table)?;
    s.join()?;
    let target = resolve(&args.node, bus, &mut s)?;
    let name = s.watcher().node(target.get()).map(|n| n.name.clone()).unwrap_or_default();
    let topic = format!("{name}/mag");
    if !bus.json {
        emit(
            out,
            &format!(
                "Calibrating the magnetometer of node {} from {topic} for {:?}. Turn the robot slowly \
                 through at least one whole turn on the floor (a planar fit), or roll, pitch and \
                 turn it through every orientation (a full fit), away from steel, magnets and \
                 running motors. The rose below marks the 10° headings seen (# seen, . not yet).",
                s.watcher().node_label(target.get()),
                args.seconds
            ),
        )?;
    }
    let (samples, no_data) = collect(args, bus, &mut s, target, &topic, out)?;
    if samples.is_empty() && no_data > 0 {
        return Err(refuse(format!(
            "the module's {no_data} messages all said \"no data\" (status 2): its magnetometer \
             does not answer; check the module with `r2p echo {topic}`"
        )));
    }
    let (kind, z, h) = choose(&samples, args.planar, args.full);
    if args.full && z < PLANAR_RATIO * h {
        return Err(refuse(format!(
            "--full needs the robot rolled and pitched, but the field's z spread ({z:.2} µT) is \
             under {PLANAR_RATIO} × its horizontal spread ({h:.2} µT): the robot only turned \
             about its vertical axis; tumble it through every orientation, or use --planar for \
             a robot that only turns on the floor"
        )));
    }
    let fit = fit(&samples, kind).map_err(|e| {
        // A short arc fits no single ellipse: the coverage about the samples' midrange says
        // why in the user's terms (turn further), so it comes first.
        check_sectors(&coverage(&samples, midrange(&samples))).map_or_else(refuse, |()| refuse(e))
    })?;
    let cov = coverage(&samples, |m| {
        let c = fit.apply(m);
        if kind == Kind::Planar {
            [c[0], c[1], 0.0]
        } else {
            c
        }
    });
    let lines = report(&fit, &cov, z, h);
    if !bus.json {
        for l in &lines {
            emit(out, l)?;
        }
    }
    check(&fit, &cov).map_err(refuse)?;
    let slot = |name: &str| *slots.iter().find(|s| s.name == name).expect("layout has every name");
    let mut fit = fit;
    if kind == Kind::Planar {
        let mut z = [0.0; 3];
        for (k, name) in ["mag_offset_z", "mag_soft_xz", "mag_soft_yz"].iter().enumerate() {
            let i = slot(name).index;
            let v = ask(&mut s, bus, target, i, "PARAM_GET", |h| h.get_param(target, i))?
                .map_err(|f| refused(&s, target, "PARAM_GET", i, f))?;
            z[k] = f32_of(v).map_or(0.0, f64::from);
        }
        let mean_z = samples.iter().map(|m| m[2]).sum::<f64>() / samples.len() as f64;
        let shift = keep_z(&mut fit, mean_z, z[0], z[1], z[2]);
        if shift != [0.0, 0.0] && !bus.json {
            emit(
                out,
                &format!(
                    "  the module's mag_soft_xz, _yz ({}, {}) mix z into x and y: h moved by \
                     ({:.2}, {:.2}) µT to ({:.2}, {:.2}) µT to cancel it while the robot is level",
                    z[1] as f32, z[2] as f32, shift[0], shift[1], fit.offset[0], fit.offset[1]
                ),
            )?;
        }
    }
    let values = values(&fit);
    in_range(&values, &slots).map_err(refuse)?;
    let mut result = json!({
        "node": target.get(),
        "topic": topic,
        "kind": kind.name(),
        "samples": fit.samples,
        "no_data": no_data,
        "offset_ut": if kind == Kind::Planar { json!(&fit.offset[..2]) } else { json!(fit.offset) },
        "soft": fit.soft,
        "radius_ut": fit.radius,
        "rms_ut": fit.rms,
        "rms_percent": fit.rms_percent(),
        "heading_sectors": cov.sectors_covered(),
        "elevation_bands": cov.bands_covered(),
        "determinacy": fit.determinacy,
        "axis_ratio": fit.axis_ratio,
        "z_spread_ut": z,
        "horizontal_spread_ut": h,
        "written": false,
    });
    if args.dry_run {
        if bus.json {
            return emit(out, &result.to_string());
        }
        return emit(out, "--dry-run: nothing written");
    }
    // What the module holds now, so that a failed write can be undone and the user sees it.
    let mut before = Vec::new();
    for (name, _) in &values {
        let i = slot(name).index;
        let v = ask(&mut s, bus, target, i, "PARAM_GET", |h| h.get_param(target, i))?
            .map_err(|f| refused(&s, target, "PARAM_GET", i, f))?;
        before.push(v);
    }
    for (k, (name, v)) in values.iter().enumerate() {
        let i = slot(name).index;
        let set =
            ask(&mut s, bus, target, i, "PARAM_SET", |h| h.set_param(target, i, Value::F32(*v)));
        let err = match set {
            Ok(Ok(_)) => continue,
            Ok(Err(f)) => refused(&s, target, "PARAM_SET", i, f),
            Err(e) => e,
        };
        let mut undo = Vec::new();
        for ((n, _), old) in values[..k].iter().zip(&before) {
            let j = slot(n).index;
            let r = ask(&mut s, bus, target, j, "PARAM_SET", |h| h.set_param(target, j, *old));
            if !matches!(r, Ok(Ok(_))) {
                undo.push(*n);
            }
        }
        return Err(CliError::new(format!(
            "writing {name} failed ({err}); {}",
            if undo.is_empty() {
                "the parameters written before it were set back: the module keeps its \
                 calibration"
                    .to_string()
            } else {
                format!(
                    "setting back {} failed too: the module holds a mixed calibration; run \
                     `r2p imu calibrate` again",
                    undo.join(", ")
                )
            }
        )));
    }
    if !bus.json {
        emit(out, "written (before → read back):")?;
    }
    let mut read = serde_json::Map::new();
    for ((name, want), old) in values.iter().zip(&before) {
        let i = slot(name).index;
        let v = ask(&mut s, bus, target, i, "PARAM_GET", |h| h.get_param(target, i))?
            .map_err(|f| refused(&s, target, "PARAM_GET", i, f))?;
        let got = f32_of(v);
        if got != Some(*want) {
            return Err(CliError::new(format!(
                "{name} reads back as {v:?} after it was set to {want}: the module did not keep \
                 it; run `r2p imu calibrate` again"
            )));
        }
        read.insert((*name).into(), json!(want));
        if !bus.json {
            let old = f32_of(*old).map_or(format!("{old:?}"), |x| format!("{x:.4}"));
            emit(out, &format!("  {name:<13} {old:>10} → {want:.4}"))?;
        }
    }
    if let Some(i) = heading_switch(table) {
        // The module's heading ignores an uncalibrated magnetometer (`mag_heading` 0 by default:
        // its zero-gauss offset alone is larger than the Earth's field); calibrated, it follows.
        let on =
            ask(&mut s, bus, target, i, "PARAM_SET", |h| h.set_param(target, i, Value::U32(1)))?
                .map_err(|f| {
                    CliError::new(format!(
                        "the calibration is written, but turning the magnetic heading on failed \
                     ({}); set it with `r2p param set {} {i} u32:1`",
                        refused(&s, target, "PARAM_SET", i, f),
                        target.get()
                    ))
                })?;
        read.insert("mag_heading".into(), crate::describe::value_json(on)["value"].clone());
        if !bus.json {
            emit(
                out,
                &format!(
                    "  {:<13} {:>10} → {} (the heading follows the magnetometer)",
                    "mag_heading",
                    "",
                    crate::describe::value_text(on)
                ),
            )?;
        }
    }
    result["written"] = json!(true);
    result["params"] = json!(read);
    if bus.json {
        emit(out, &result.to_string())
    } else {
        emit(out, "the module keeps them in flash")
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::{Arc, Mutex};

    use r2p_canlink::{BroadcastHub, Hub};
    use r2p_middleware::{pool_size, Class, Publisher, Topic};
    use r2p_node::{Node, NodeConfig, RamParams, RemoteSubscriber};

    use super::*;
    use crate::host::tests::drive;
    use crate::link::HubLink;
    use r2p_magcal::synthetic::{distortion, field, Rng};

    type Mag = Topic<'static, MagneticField, { pool_size(&[8], 1) }, 1>;

    /// The module's table as the CLI knows it: something before the calibration, so the
    /// indices are not the names' positions in [`OFFSET`] and [`SOFT`].
    const TABLE: [Param; 11] = [
        Param::u32("rate_hz", 50, 1, 200),
        Param::f32("mag_offset_x", 0.0, -400.0, 400.0),
        Param::f32("mag_offset_y", 0.0, -400.0, 400.0),
        Param::f32("mag_offset_z", 0.0, -400.0, 400.0),
        Param::f32("mag_soft_xx", 1.0, -4.0, 4.0),
        Param::f32("mag_soft_xy", 0.0, -4.0, 4.0),
        Param::f32("mag_soft_xz", 0.0, -4.0, 4.0),
        Param::f32("mag_soft_yy", 1.0, -4.0, 4.0),
        Param::f32("mag_soft_yz", 0.0, -4.0, 4.0),
        Param::f32("mag_soft_zz", 1.0, -4.0, 4.0),
        Param::u32("mag_heading", 0, 0, 1),
    ];

    /// How the robot moves: yaw and pitch (rad) at a time (s).
    type Motion = fn(f64) -> (f64, f64);

    /// An IMU module on the hub named `imu`, publishing `imu/mag` every 5 ms: the raw field of
    /// [`distortion`] as the robot moves by `motion`, with 0.3 µT of noise; its parameters are
    /// `module` (as the CLI's table, or changed to test a refusal).
    fn imu(
        hub: Arc<BroadcastHub>,
        stop: Arc<AtomicBool>,
        motion: Motion,
        module: [Param; 11],
        status: u8,
    ) -> (std::thread::JoinHandle<()>, &'static RamParams<11>) {
        let topic: &'static Mag =
            Box::leak(Box::new(Topic::new("imu/mag", MagneticField::default())));
        let publisher: &'static Publisher<'static, MagneticField> =
            Box::leak(Box::new(Publisher::new(topic, Class::NonRealTime)));
        let out: &'static RemoteSubscriber<'static, MagneticField, 8> =
            Box::leak(Box::new(RemoteSubscriber::new(publisher)));
        let params: &'static RamParams<11> = Box::leak(Box::new(RamParams::new(module)));
        topic.subscribe(out).unwrap();
        let make = move || {
            let mut uid = [0u8; 12];
            uid[11] = 0x21;
            let mut node: Node<'static, 1, 1, 32, 4, 64> =
                Node::new(NodeConfig::new(uid, "imu"), params).unwrap();
            node.export(out).unwrap();
            node
        };
        let (d, mut rng, mut n) = (distortion(), Rng::new(17), 0u128);
        let handle = drive(hub, stop, make, move |elapsed| {
            if elapsed.as_millis() / 5 > n {
                n += 1;
                let (yaw, pitch) = motion(elapsed.as_secs_f64());
                let raw = d.measure(field(yaw, pitch), 0.3, &mut rng).map(|x| x as f32);
                publisher
                    .publish_with(|m| *m = MagneticField { field: raw, raw, heading: 0.0, status });
            }
        });
        (handle, params)
    }

    fn bus(json: bool) -> BusArgs {
        BusArgs {
            socketcand: None,
            socketcan: None,
            trace: None,
            channel: "vcan0".into(),
            timeout: Duration::from_secs(2),
            json,
        }
    }

    fn args(seconds: f64, planar: bool, full: bool, dry_run: bool) -> CalibrateArgs {
        CalibrateArgs {
            node: "imu".into(),
            seconds: Duration::from_secs_f64(seconds),
            planar,
            full,
            dry_run,
        }
    }

    /// Runs the command against a module moving by `motion`; its output (or error) and the
    /// module's parameters afterwards.
    fn calibrate_over(
        a: CalibrateArgs,
        motion: Motion,
        module: [Param; 11],
        status: u8,
        json: bool,
    ) -> (Result<String, CliError>, Vec<f32>) {
        let hub = Arc::new(BroadcastHub::new());
        let stop = Arc::new(AtomicBool::new(false));
        let (handle, params) = imu(hub.clone(), stop.clone(), motion, module, status);
        let s = Session::new(Box::new(HubLink::join(hub as Arc<dyn Hub>, 4096)));
        let out = Mutex::new(Vec::new());
        let r = calibrate(&a, &bus(json), s, &mut *out.lock().unwrap(), &TABLE);
        stop.store(true, Ordering::SeqCst);
        handle.join().unwrap();
        // The nine calibration parameters, then mag_heading (as 0.0 or 1.0).
        let value = |i| match params.param(i).unwrap().value {
            Value::U32(x) => x as f32,
            v => f32_of(v).unwrap(),
        };
        let held = (1..11).map(value).collect();
        let text = String::from_utf8(out.into_inner().unwrap()).unwrap();
        (r.map(|()| text), held)
    }

    /// One turn a second on the floor.
    fn spin(t: f64) -> (f64, f64) {
        (std::f64::consts::TAU * t, 0.0)
    }

    /// Every orientation: turning and pitching at rates whose ratio is irrational.
    fn tumble(t: f64) -> (f64, f64) {
        (std::f64::consts::TAU * t / 0.9, std::f64::consts::TAU * t / (0.9 * 1.618))
    }

    /// A quarter turn, back and forth.
    fn wiggle(t: f64) -> (f64, f64) {
        ((std::f64::consts::TAU * t).sin() * 45f64.to_radians(), 0.0)
    }

    /// The module's defaults: no calibration, the magnetic heading off.
    const IDENTITY: [f32; 10] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0];

    /// What the module publishes as `field` with parameters `held` (h, then S's six): S·(m − h).
    fn as_module(held: &[f32], m: [f64; 3]) -> [f64; 3] {
        let p: Vec<f64> = held.iter().map(|&x| f64::from(x)).collect();
        let s = [[p[3], p[4], p[5]], [p[4], p[6], p[7]], [p[5], p[7], p[8]]];
        let d = [m[0] - p[0], m[1] - p[1], m[2] - p[2]];
        std::array::from_fn(|i| (0..3).map(|j| s[i][j] * d[j]).sum())
    }

    /// The horizontal field the module publishes over a level turn with `held`: its centre's
    /// distance from the origin and the spread of its radius, µT (noise-free samples).
    fn level_turn(held: &[f32]) -> (f64, f64) {
        let (d, mut rng) = (distortion(), Rng::new(1));
        let xy: Vec<[f64; 2]> = (0..360)
            .map(|deg| {
                let c = as_module(
                    held,
                    d.measure(field(f64::from(deg).to_radians(), 0.0), 0.0, &mut rng),
                );
                [c[0], c[1]]
            })
            .collect();
        let centre = [0, 1].map(|i| xy.iter().map(|c| c[i]).sum::<f64>() / 360.0);
        let r: Vec<f64> = xy.iter().map(|c| c[0].hypot(c[1])).collect();
        let (lo, hi) = r.iter().fold((f64::MAX, 0.0f64), |(lo, hi), &x| (lo.min(x), hi.max(x)));
        (centre[0].hypot(centre[1]), hi - lo)
    }

    #[test]
    fn planar_keeps_the_modules_z_terms_and_cancels_their_shift() {
        let mut module = TABLE;
        module[3].value = Value::F32(-40.0); // mag_offset_z: m_z − h_z ≈ 45 µT
        module[6].value = Value::F32(0.1); // mag_soft_xz
        module[8].value = Value::F32(-0.05); // mag_soft_yz
        let (r, held) = calibrate_over(args(2.0, false, false, false), spin, module, 0, false);
        let text = r.unwrap();
        assert!(
            text.contains("the module's mag_soft_xz, _yz (0.1, -0.05) mix z into x and y"),
            "{text}"
        );
        assert_eq!((held[2], held[5], held[7], held[8]), (-40.0, 0.1, -0.05, 1.0));
        let (off, spread) = level_turn(&held);
        assert!(off < 0.2 && spread < 0.5, "centre {off} µT off, radius spread {spread} µT");
        // Without the shift the circle would sit (0.1, −0.05)·(m_z − h_z) ≈ 5 µT off the origin.
        let mut unshifted = held.clone();
        let bz = distortion().measure(field(0.0, 0.0), 0.0, &mut Rng::new(1))[2];
        unshifted[0] -= (held[6] * 0.1 - held[4] * -0.05) * (bz + 40.0) as f32;
        unshifted[1] -= (held[3] * -0.05 - held[4] * 0.1) * (bz + 40.0) as f32;
        assert!(level_turn(&unshifted).0 > 3.0, "{:?}", level_turn(&unshifted));
    }

    #[test]
    fn spinning_on_the_floor_calibrates_x_and_y_and_leaves_z() {
        let mut module = TABLE;
        module[3].value = Value::F32(7.5); // mag_offset_z: must stay as it is
        let (r, held) = calibrate_over(args(2.5, false, false, false), spin, module, 0, false);
        let text = r.unwrap();
        assert!(text.contains("fit: planar"), "{text}");
        assert!(text.contains("z terms not fitted, left as the module has them"), "{text}");
        assert!(text.contains("36/36 heading sectors"), "{text}");
        assert!(text.contains("written (before → read back):"), "{text}");
        assert!(text.contains("  mag_offset_x      0.0000 → "), "{text}");
        assert!(!text.contains("mag_offset_z "), "{text}");
        let (d, bv) = (distortion(), field(0.0, 0.0)[2]);
        for i in 0..2 {
            let want = d.h[i] + d.w[i][2] * bv;
            assert!((f64::from(held[i]) - want).abs() < 0.2, "{held:?} want {want}");
        }
        assert_eq!((held[2], held[5], held[7], held[8]), (7.5, 0.0, 0.0, 1.0));
        assert_eq!(held[9], 1.0, "mag_heading on");
        assert!(text.contains("mag_heading              → u32:1 (the heading follows"), "{text}");
        let (off, spread) = level_turn(&held);
        assert!(off < 0.2 && spread < 0.5, "centre {off} µT off, radius spread {spread} µT");
        assert!(!text.contains("mix z into x and y"), "{text}");
        // S's x/y block undoes W's: S·W is a multiple of the identity.
        let s = [[held[3], held[4]], [held[4], held[6]]].map(|r| r.map(f64::from));
        let sw = |i: usize, j: usize| s[i][0] * d.w[0][j] + s[i][1] * d.w[1][j];
        assert!(sw(0, 1).abs() < 0.01 && (sw(0, 0) - sw(1, 1)).abs() < 0.01, "{s:?}");
    }

    #[test]
    fn tumbling_calibrates_all_nine_and_json_reports_them() {
        let (r, held) = calibrate_over(args(4.0, false, true, false), tumble, TABLE, 0, true);
        let text = r.unwrap();
        let j: serde_json::Value = serde_json::from_str(text.trim()).unwrap();
        assert_eq!((j["kind"].as_str(), j["written"].as_bool()), (Some("full"), Some(true)));
        assert!(j["rms_percent"].as_f64().unwrap() < 2.0, "{j}");
        assert!(
            j["elevation_bands"].as_u64().unwrap() >= r2p_magcal::coverage::MIN_BANDS as u64,
            "{j}"
        );
        let d = distortion();
        for i in 0..3 {
            assert!((f64::from(held[i]) - d.h[i]).abs() < 0.3, "{held:?}");
        }
        assert_eq!(j["params"]["mag_soft_zz"].as_f64().map(|x| x as f32), Some(held[8]));
        assert_eq!((j["params"]["mag_heading"].as_u64(), held[9]), (Some(1), 1.0));
        let s = nalgebra::Matrix3::new(
            held[3], held[4], held[5], held[4], held[6], held[7], held[5], held[7], held[8],
        )
        .map(f64::from);
        let sw = s * nalgebra::Matrix3::from_fn(|i, j| d.w[i][j]);
        assert!((sw - nalgebra::Matrix3::identity() * sw[(0, 0)]).abs().max() < 0.02, "{sw}");
    }

    #[test]
    fn a_quarter_turn_is_refused_and_nothing_is_written() {
        let (r, held) = calibrate_over(args(2.0, false, false, false), wiggle, TABLE, 0, false);
        let e = r.unwrap_err().to_string();
        assert!(e.starts_with("not calibrated: the samples cover "), "{e}");
        assert!(e.contains("of 36 10° heading sectors, at least 27 are needed (missing: "), "{e}");
        assert!(e.contains("turn the robot slowly through a whole turn"), "{e}");
        assert!(e.ends_with("Nothing was written: the module keeps its calibration"), "{e}");
        assert_eq!(held, IDENTITY);
    }

    #[test]
    fn a_full_fit_of_a_robot_that_only_spun_is_refused() {
        let (r, held) = calibrate_over(args(2.0, false, true, false), spin, TABLE, 0, false);
        let e = r.unwrap_err().to_string();
        assert!(e.starts_with("not calibrated: --full needs the robot rolled and pitched"), "{e}");
        assert!(e.contains("tumble it through every orientation, or use --planar"), "{e}");
        assert_eq!(held, IDENTITY);
    }

    #[test]
    fn a_dry_run_reports_and_writes_nothing() {
        let (r, held) = calibrate_over(args(2.0, true, false, true), spin, TABLE, 0, false);
        let text = r.unwrap();
        assert!(
            text.contains("fit: planar") && text.ends_with("--dry-run: nothing written\n"),
            "{text}"
        );
        assert!(text.contains("[####################################] 36/36 sectors"), "{text}");
        assert_eq!(held, IDENTITY);
    }

    #[test]
    fn a_write_the_module_refuses_sets_back_what_was_written() {
        // The module's mag_soft_yy only takes 0.9..1.0 (a narrower range than the CLI's table):
        // its PARAM_SET fails after the offsets and two soft terms are written.
        let mut module = TABLE;
        module[7] = Param::f32("mag_soft_yy", 1.0, 0.9, 1.0);
        module[1].value = Value::F32(3.0);
        let (r, held) = calibrate_over(args(2.0, true, false, false), spin, module, 0, false);
        let e = r.unwrap_err().to_string();
        assert!(e.starts_with("writing mag_soft_yy failed (node "), "{e}");
        assert!(e.contains("refused PARAM_SET of parameter 7: value out of range"), "{e}");
        assert!(e.contains("were set back: the module keeps its calibration"), "{e}");
        let mut want = IDENTITY;
        want[0] = 3.0;
        assert_eq!(held, want);
    }

    #[test]
    fn a_magnetometer_without_data_is_named() {
        let (r, held) = calibrate_over(args(1.0, false, false, false), spin, TABLE, 2, false);
        let e = r.unwrap_err().to_string();
        assert!(
            e.contains("all said \"no data\" (status 2)") && e.contains("r2p echo imu/mag"),
            "{e}"
        );
        assert_eq!(held, IDENTITY);
    }

    #[test]
    fn the_parameters_are_found_by_name_in_the_firmwares_table() {
        let slots = layout(&TABLE).unwrap();
        assert_eq!(slots.len(), 9);
        assert_eq!(slots[0], Slot { name: "mag_offset_x", index: 1, min: -400.0, max: 400.0 });
        assert_eq!(slots[8], Slot { name: "mag_soft_zz", index: 9, min: -4.0, max: 4.0 });
        // The IMU firmware's own table, the one `r2p imu calibrate` uses.
        let imu = layout(&r2p_app_imu::params::DEFAULTS).unwrap();
        assert_eq!(imu[0].index, r2p_app_imu::params::MAG_OFFSET_X);
        assert_eq!(imu[3].index, r2p_app_imu::params::MAG_SOFT_XX);
        assert_eq!((imu[0].min, imu[0].max, imu[8].min, imu[8].max), (-400.0, 400.0, -4.0, 4.0));
        let switch = heading_switch(&r2p_app_imu::params::DEFAULTS);
        assert_eq!(switch, Some(r2p_app_imu::params::MAG_HEADING));
        assert_eq!(heading_switch(&TABLE), Some(10));
        assert_eq!(heading_switch(&TABLE[..10]), None, "older firmware: no switch, none set");
        assert_eq!(heading_switch(&[Param::f32("mag_heading", 0.0, 0.0, 1.0)]), None);
        let e = layout(&TABLE[..9]).unwrap_err().to_string();
        assert!(e.contains("no parameter \"mag_soft_zz\"") && e.contains("same source"), "{e}");
        let mut bad = TABLE;
        bad[2] = Param::u32("mag_offset_y", 0, 0, 1);
        assert!(layout(&bad).unwrap_err().to_string().contains("\"mag_offset_y\" is not an f32"));
    }
}
