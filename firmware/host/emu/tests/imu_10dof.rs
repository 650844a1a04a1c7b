//! Issue 21 on the Diffbot (robots/diffbot.toml): the IMU module's default firmware with its
//! three sensors on the emulated board's rig — the magnetometer's heading through turns, after
//! the calibration `r2p imu calibrate` fits to the robot's own spin, against the gyro's; the
//! barometer's altitude; a sensor unplugged and plugged back mid-run. A tool node receives `imu`,
//! `imu/mag`, `imu/baro` and `imu/gnss` over the bus, as `r2p echo` would, and drives the wheels.

use r2p_emu::robot::{BoardNode, EmuRobot};
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_msgs::{Barometer, GnssFix, Imu, MagneticField, WheelSetpoint};
use r2p_node::{NoParams, NodeConfig, RemotePublisher, RemoteSubscriber};
use r2p_world::gnss::GnssParams;
use r2p_world::imu_module::ImuSensor;
use r2p_world::robot_file::Robot;
use rtcan::CycleConfig;

/// The receiver the IMU module's world model has.
const GNSS: GnssParams = GnssParams::UBLOX_M8;

const MS: u64 = 1_000_000;
/// Wheel speed of a turn, rad/s: ±6 rad/s on 50 mm wheels 0.30 m apart is 2 rad/s.
const WHEEL: f32 = 6.0;

fn diffbot_text() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../robots/diffbot.toml");
    std::fs::read_to_string(path).unwrap()
}

/// The Diffbot with its IMU module's table extended by `extra` lines (iron, parameters).
fn robot(extra: &str) -> Robot {
    let text = diffbot_text();
    let anchor = "kind = \"imu\"\n";
    assert!(text.contains(anchor));
    let text = text.replacen(anchor, &format!("{anchor}{extra}\n"), 1);
    Robot::parse(&text, "diffbot-imu.toml").unwrap_or_else(|e| panic!("{e}"))
}

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

struct Tool {
    imu: &'static Subscriber<'static, Imu, 64>,
    mag: &'static Subscriber<'static, MagneticField, 64>,
    baro: &'static Subscriber<'static, Barometer, 64>,
    gnss: &'static Subscriber<'static, GnssFix, 64>,
    left: &'static Publisher<'static, WheelSetpoint>,
    right: &'static Publisher<'static, WheelSetpoint>,
}

fn import<T: r2p_node::Wire + Default + Copy + Send + Sync + 'static>(
    node: &mut BoardNode,
    name: &'static str,
) -> &'static Subscriber<'static, T, 64> {
    let topic: &'static Topic<'static, T, { pool_size(&[64], 1) }, 1> =
        leak(Topic::new(name, T::default()));
    let publisher = leak(Publisher::new(topic, Class::NonRealTime));
    let sub = leak(Subscriber::new());
    topic.subscribe(sub).unwrap();
    node.import(leak(RemotePublisher::new(publisher, topic))).unwrap();
    sub
}

fn setpoint(
    node: &mut BoardNode,
    name: &'static str,
) -> &'static Publisher<'static, WheelSetpoint> {
    let topic: &'static Topic<'static, WheelSetpoint, { pool_size(&[2], 1) }, 1> =
        leak(Topic::new(name, WheelSetpoint::default()));
    let p = leak(Publisher::new(topic, Class::NonRealTime));
    let out = leak(RemoteSubscriber::<'static, WheelSetpoint, 2>::new(p));
    topic.subscribe(out).unwrap();
    node.export(out).unwrap();
    p
}

fn tool(r: &mut EmuRobot) -> Tool {
    let cycle = CycleConfig { cycle_us: r.robot.bus.cycle_us, ..CycleConfig::DEFAULT };
    let mut uid = [0u8; 12];
    uid[11] = 0x7E;
    let mut node =
        BoardNode::new(NodeConfig { cycle, ..NodeConfig::new(uid, "tool") }, &NoParams).unwrap();
    let t = Tool {
        imu: import(&mut node, "imu"),
        mag: import(&mut node, "imu/mag"),
        baro: import(&mut node, "imu/baro"),
        gnss: import(&mut node, "imu/gnss"),
        left: setpoint(&mut node, "motor1/setpoint"),
        right: setpoint(&mut node, "motor2/setpoint"),
    };
    let port = r.spare_port();
    r.sim.add_board(node, port, None);
    t
}

/// What the tool received, with the world's heading when each `imu` arrived.
#[derive(Default)]
struct Log {
    imu: Vec<(u64, Imu, f64)>,
    mag: Vec<(u64, MagneticField)>,
    baro: Vec<(u64, Barometer)>,
    /// With the world's UTC (µs) and the antenna's place (lat, lon, height) when it arrived.
    gnss: Vec<(u64, GnssFix, i64, [f64; 3])>,
}

fn run(r: &mut EmuRobot, t: &Tool, ms: u64, wheels: (f32, f32), log: &mut Log) {
    for k in 0..ms {
        if k % 10 == 0 {
            let _ = t.left.publish_with(|m| *m = WheelSetpoint { mode: 1, value: wheels.0 });
            let _ = t.right.publish_with(|m| *m = WheelSetpoint { mode: 1, value: wheels.1 });
        }
        r.sim.run_for(MS);
        let now = r.sim.now_ns() / MS;
        let theta = r.world.borrow().pose().theta;
        while let Some(m) = t.imu.try_recv() {
            log.imu.push((now, *m, theta));
        }
        while let Some(m) = t.mag.try_recv() {
            log.mag.push((now, *m));
        }
        while let Some(m) = t.baro.try_recv() {
            log.baro.push((now, *m));
        }
        while let Some(m) = t.gnss.try_recv() {
            let w = r.world.borrow();
            let a = w.gnss_antenna("imu").unwrap();
            let g = w.site().origin().offset(a.enu);
            // The rig's receiver: the world started at 2026-11-27 12:00:00 UTC.
            let utc = 1_795_780_800_000_000 + (r.sim.now_ns() / 1000) as i64;
            log.gnss.push((now, *m, utc, [g.lat_deg, g.lon_deg, g.height_m]));
        }
    }
}

fn wrap(a: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    a - tau * (a / tau).round()
}

/// What `r2p imu calibrate` writes after the robot spun on the spot (its library path: the
/// coverage check, planar or full chosen from the samples, the fit, the z terms kept): from the
/// raw field the module published over `log`, as robot-file parameters with the site's
/// declination (the user's to set) and the magnetometer's heading on, as the command turns it.
fn calibration(r: &EmuRobot, log: &Log) -> String {
    use r2p_magcal::ellipsoid::{fit, Kind};
    use r2p_magcal::rules::{check, choose, coverage, keep_z, values};
    let samples: Vec<[f64; 3]> =
        log.mag.iter().filter(|m| m.1.status == 0).map(|m| m.1.raw.map(f64::from)).collect();
    let (kind, _, _) = choose(&samples, false, false);
    assert_eq!(kind, Kind::Planar, "a robot on the floor gives a planar fit");
    let mut f = fit(&samples, kind).unwrap_or_else(|e| panic!("{e}"));
    let cov = coverage(&samples, |m| {
        let c = f.apply(m);
        [c[0], c[1], 0.0]
    });
    check(&f, &cov).unwrap_or_else(|e| panic!("the command would refuse it: {e}"));
    let mean_z = samples.iter().map(|m| m[2]).sum::<f64>() / samples.len() as f64;
    keep_z(&mut f, mean_z, 0.0, 0.0, 0.0);
    let fields: Vec<String> = values(&f).iter().map(|(n, v)| format!("{n} = {v}")).collect();
    format!(
        "params = {{ mag_heading = 1, declination_deg = {}, {} }}",
        r.world.borrow().site().field.declination_deg,
        fields.join(", ")
    )
}

/// Spinning on the spot for 8 s (two and a half turns) after standing 1 s, as a user does for
/// `r2p imu calibrate`: the log of what the module published.
fn spin(r: &mut EmuRobot) -> Log {
    let t = tool(r);
    let mut log = Log::default();
    run(r, &t, 1000, (0.0, 0.0), &mut log);
    log.mag.clear();
    run(r, &t, 8000, (-WHEEL, WHEEL), &mut log);
    log
}

/// The robot's own iron at the module (base frame): a magnet and steel near it.
const IRON: &str = "hard_iron_ut = [18.0, -11.0, 25.0]\n\
                    soft_iron = [[1.15, 0.06, 0.0], [0.06, 0.88, 0.0], [0.0, 0.0, 1.0]]";

/// Standing 2 s, then six turns of 3 s at ±2 rad/s with 1 s stops: the heading error of each
/// `imu` message after the turns (rad), and the whole log.
fn turns(r: &mut EmuRobot) -> (Vec<f64>, Log) {
    let t = tool(r);
    let mut log = Log::default();
    run(r, &t, 2000, (0.0, 0.0), &mut log);
    for i in 0..6 {
        let s = if i % 3 == 2 { -WHEEL } else { WHEEL };
        run(r, &t, 3000, (-s, s), &mut log);
        run(r, &t, 1000, (0.0, 0.0), &mut log);
    }
    let end = log.imu.last().unwrap().0;
    let errors = log
        .imu
        .iter()
        .filter(|s| s.0 + 800 > end)
        .map(|s| wrap(f64::from(s.1.yaw) - s.2))
        .collect();
    (errors, log)
}

#[test]
fn a_calibrated_magnetometer_holds_the_heading_through_turns_where_the_gyro_drifts() {
    // Calibrated by the robot's own spin (the fit `r2p imu calibrate` makes of the distorted
    // field the module published): the module's heading is the world's (REP 103: from east),
    // within 0.5°, after 18 s of turning (36 rad) — from the first message on, not from 0.
    // (Measured: 0.09°; the gyro alone 0.98° on average, uncalibrated 68°.)
    let mut probe = EmuRobot::build(robot(IRON)).unwrap();
    let spun = spin(&mut probe);
    let cal = calibration(&probe, &spun);
    eprintln!("{cal}");
    drop(probe);
    let mut r = EmuRobot::build(robot(&format!("{IRON}\n{cal}"))).unwrap();
    let (err, log) = turns(&mut r);
    let worst = err.iter().fold(0f64, |m, e| m.max(e.abs())).to_degrees();
    eprintln!("calibrated: worst {worst:.3}°");
    assert!(worst < 0.5, "calibrated heading error {worst:.2}°");
    let first_ok = log.imu.iter().find(|s| s.1.status == 0).unwrap();
    assert!(wrap(f64::from(first_ok.1.yaw) - first_ok.2).abs() < 3f64.to_radians());
    assert!(log.imu.iter().filter(|s| s.0 > 1500).all(|s| s.1.sensors == 0b1111));

    // The gyro alone on the same robot (the default, mag_heading 0): the LSM6DSO's scale error
    // on 36 rad of turning leaves degrees.
    let mut g = EmuRobot::build(robot(IRON)).unwrap();
    let (err, _) = turns(&mut g);
    let gyro = err.iter().map(|e| e.abs()).sum::<f64>() / err.len() as f64;
    eprintln!("gyro only: mean {:.3}°", gyro.to_degrees());
    assert!(
        gyro.to_degrees() > 0.5 && gyro.to_degrees() > 3.0 * worst,
        "gyro only {:.2}° vs {worst:.2}°",
        gyro.to_degrees()
    );

    // Uncalibrated but on: the robot's iron and the part's offset make it useless.
    let mut u = EmuRobot::build(robot(&format!("{IRON}\nparams = {{ mag_heading = 1 }}"))).unwrap();
    let (err, _) = turns(&mut u);
    let bad = err.iter().map(|e| e.abs()).sum::<f64>() / err.len() as f64;
    eprintln!("uncalibrated: mean {:.1}°", bad.to_degrees());
    assert!(bad.to_degrees() > 10.0, "uncalibrated {:.1}°", bad.to_degrees());
}

#[test]
fn the_barometer_gives_the_sites_altitude_within_its_noise_and_offset() {
    let mut r = EmuRobot::build(robot("")).unwrap();
    let t = tool(&mut r);
    let mut log = Log::default();
    run(&mut r, &t, 10_000, (0.0, 0.0), &mut log);
    let (site_alt, offset_pa, qnh) = {
        let w = r.world.borrow();
        let m = w.imu_module("imu").unwrap();
        (m.altitude_m, m.barometer.offset_pa(), w.site().sea_level_pa)
    };
    assert_eq!(qnh, 101_325.0, "the module's default qnh_pa is the site's");
    // What the part reads is the ISA pressure there plus its own offset: the altitude the
    // module gives is that pressure's, an offset of ~8.3 cm per Pa near sea level.
    let p = r2p_world::pressure::isa_pressure(site_alt, qnh) + offset_pa;
    let want = r2p_world::pressure::isa_altitude(p, qnh);
    let later: Vec<&(u64, Barometer)> = log.baro.iter().filter(|b| b.0 > 3000).collect();
    assert!(later.len() >= 60, "imu/baro at 10 Hz: {}", later.len());
    let mean = later.iter().map(|b| f64::from(b.1.altitude)).sum::<f64>() / later.len() as f64;
    assert!((mean - want).abs() < 0.1, "altitude {mean:.3} m, the part's reading gives {want:.3}");
    // Stable: the LPS22HH's 0.65 Pa RMS noise (≈ 5.4 cm a sample at 25 Hz) through the α-β
    // filter of τ = 1 s (α = 2·dt/τ = 0.08, β = α²/4): its altitude keeps (2α² + 2β − 3αβ) /
    // (α(4 − β − 2α)) = 0.051 of the variance, σ ≈ 1.2 cm, so 0.1 m is 8 σ; its speed σ is
    // 5.4 cm · √(2β²/dt² / (α(4 − β − 2α))) ≈ 0.6 cm/s. A still robot's vertical speed is noise
    // alone.
    let spread = later.iter().map(|b| (f64::from(b.1.altitude) - mean).abs()).fold(0.0, f64::max);
    eprintln!("altitude mean {mean:.3} want {want:.3} spread {spread:.3}");
    assert!(spread < 0.1, "altitude spread {spread:.3} m");
    assert!(later.iter().all(|b| b.1.vertical_speed.abs() < 0.1 && b.1.status == 0));
    assert!((f64::from(later[0].1.pressure) - p).abs() < 3.0);
}

#[test]
fn a_sensor_unplugged_mid_run_is_reported_the_rest_published_and_it_comes_back() {
    let mut r = EmuRobot::build(robot("")).unwrap();
    let t = tool(&mut r);
    let mut log = Log::default();
    run(&mut r, &t, 2000, (0.0, 0.0), &mut log);
    // All four, the GNSS receiver configured and sending epochs (no fix yet: that is not a
    // missing receiver).
    assert_eq!(log.imu.last().unwrap().1.sensors, 0b1111);
    let connect = |r: &mut EmuRobot, s, on| {
        r.world.borrow_mut().set_imu_sensor_connected("imu", s, on).unwrap();
    };
    connect(&mut r, ImuSensor::Magnetometer, false);
    let mut off = Log::default();
    run(&mut r, &t, 1000, (0.0, 0.0), &mut off);
    // Reported within a step of the first read of all ones; `imu` goes on at 50 Hz.
    assert!(off.imu.len() >= 48, "imu still published: {}", off.imu.len());
    assert!(off.imu.iter().skip(2).all(|s| s.1.sensors == 0b1101 && s.1.status == 0));
    assert!(off.mag.iter().skip(2).all(|m| m.1.status == 2), "imu/mag says no data");
    assert!(off.baro.iter().all(|b| b.1.status == 0));
    // The barometer and the GNSS receiver too: lost after 10 of its periods (10 s at 1 Hz).
    connect(&mut r, ImuSensor::Barometer, false);
    connect(&mut r, ImuSensor::Gnss, false);
    let mut off2 = Log::default();
    run(&mut r, &t, 500, (0.0, 0.0), &mut off2);
    assert_eq!(off2.imu.last().unwrap().1.sensors, 0b1001);
    run(&mut r, &t, 12_000, (0.0, 0.0), &mut off2);
    assert_eq!(off2.imu.last().unwrap().1.sensors, 0b0001);
    assert_eq!(off2.gnss.last().unwrap().1.status, 2);
    assert!(off2.imu.len() > 500, "imu still at 50 Hz");
    // Plugged back: each part powers up unconfigured; the firmware sets it up again within its
    // retry period (1 s) and reports it.
    connect(&mut r, ImuSensor::Magnetometer, true);
    connect(&mut r, ImuSensor::Barometer, true);
    connect(&mut r, ImuSensor::Gnss, true);
    let mut back = Log::default();
    run(&mut r, &t, 2500, (0.0, 0.0), &mut back);
    let again = back.imu.iter().find(|s| s.1.sensors & 0b0110 == 0b0110).map(|s| s.0);
    assert!(again.is_some_and(|t| t < back.imu[0].0 + 1600), "back at {again:?}");
    // The receiver powers up at its factory settings: the link, silent for more than 3 s,
    // configures it again within one more round (3 s) and its epochs come at 1 Hz.
    run(&mut r, &t, 3000, (0.0, 0.0), &mut back);
    let gnss = back.imu.iter().find(|s| s.1.sensors == 0b1111).map(|s| s.0);
    assert!(gnss.is_some_and(|t| t < back.imu[0].0 + 5500), "GNSS back at {gnss:?}");
    assert_eq!(back.mag.last().unwrap().1.status, 0);
    assert_eq!(back.baro.last().unwrap().1.status, 0);
}

#[test]
fn the_gnss_receiver_is_configured_from_its_factory_settings_and_gives_position_and_pps_time() {
    // (The M8's boot, at 9600 baud and moved to 38 400 by CFG-PRT, is r2p-emu's periph_gnss.)
    // A u-blox M10 as shipped (NMEA at 38 400 baud): the firmware configures it for NAV-PVT
    // alone; its first fix comes after its time to first fix (26 s, the NEO-M8N's cold start),
    // then the position is the antenna's within the receiver's noise (5 σ: σ 2.12 m per
    // horizontal axis, 2 m vertical)
    // and UTC follows the time pulse to the microsecond.
    // A site whose geoid is not Milan's 47 m: the receiver's heights above sea level use it.
    let text = format!("{}\n[site]\ngeoid_separation_m = 52.5\n", diffbot_text());
    let mut r = EmuRobot::build(Robot::parse(&text, "diffbot-site.toml").unwrap()).unwrap();
    let t = tool(&mut r);
    let mut log = Log::default();
    run(&mut r, &t, 20_000, (0.0, 0.0), &mut log);
    run(&mut r, &t, 8_000, (2.0, 2.0), &mut log); // rolling forward at 0.05 m/s
    run(&mut r, &t, 12_000, (0.0, 0.0), &mut log);
    assert!(log.gnss.len() >= 38, "imu/gnss at 1 Hz: {}", log.gnss.len());
    let before: Vec<_> = log.gnss.iter().filter(|g| g.0 < 25_000).collect();
    assert!(before.iter().all(|g| g.1.fix_type == 0), "no fix before the TTFF");
    assert!(before.iter().filter(|g| g.0 > 3_000).all(|g| g.1.status == 0), "configured and heard");
    // No time pulse before the fix: UTC is the epochs' (once valid), not disciplined.
    assert!(before.iter().all(|g| !g.1.pps), "no pulse to discipline UTC before the fix");
    let fixed: Vec<_> = log.gnss.iter().filter(|g| g.0 > 28_000).collect();
    assert!(fixed.len() >= 10);
    for (_, f, utc, truth) in &fixed {
        assert_eq!((f.fix_type, f.status), (3, 0), "{f:?}");
        assert!(f.satellites >= 4);
        let north = (f64::from(f.latitude) * 1e-7 - truth[0]).to_radians() * 6_367_000.0;
        let east = (f64::from(f.longitude) * 1e-7 - truth[1]).to_radians()
            * 6_389_000.0
            * truth[0].to_radians().cos();
        let up = f64::from(f.altitude) - truth[2];
        let (h, v) = (5.0 * GNSS.sigma_h_m, 5.0 * GNSS.sigma_v_m);
        assert!(north.hypot(east) < h && up.abs() < v, "{north:.2} {east:.2} {up:.2} m");
        assert!(f.h_acc > 0.0 && f.h_acc < 5.0, "{}", f.h_acc);
        // UTC when the module made the message, exact to the microsecond: the module steps on
        // whole milliseconds, so the message's UTC is the world's at a whole millisecond, which
        // the bus then carried to the tool in a few ms (4 ms measured).
        assert!(f.pps, "disciplined by the pulse");
        let late = utc - f.utc_us as i64;
        assert!(late % 1000 == 0 && (0..=10_000).contains(&late), "UTC {late} µs behind");
    }
    // The altitude above sea level is the ellipsoid height less the site's geoid separation.
    let f = fixed.last().unwrap().1;
    assert!((f.altitude - f.altitude_msl - 52.5).abs() < 0.01, "{f:?}");
    assert!(log.imu.last().unwrap().1.sensors & 0b1000 != 0);
}
