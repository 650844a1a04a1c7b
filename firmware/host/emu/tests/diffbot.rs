//! The Diffbot robot file (robots/diffbot.toml) on emulated boards: the IMU module's default
//! firmware reads the world's IMU through the `r2p-drivers` LSM6DSO driver over the simulated
//! SPI bus and register model, and its `imu` topic, received over the bus by a tool node,
//! follows the base's yaw rate and heading while the test turns the robot on the spot.

use r2p_emu::robot::{BoardNode, EmuRobot};
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_msgs::{Imu, WheelSetpoint};
use r2p_node::{NoParams, NodeConfig, RemotePublisher, RemoteSubscriber};
use r2p_world::imu::ImuParams;
use r2p_world::robot_file::Robot;
use rtcan::CycleConfig;

const MS: u64 = 1_000_000;
/// Wheel speed of the turn, rad/s: ±6 rad/s on 50 mm wheels 0.30 m apart is 2 rad/s.
const WHEEL: f32 = 6.0;

fn robot_file() -> Robot {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../robots/diffbot.toml");
    Robot::load(path).unwrap_or_else(|e| panic!("{e}"))
}

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

/// A test tool on the spare port, as `r2p echo imu` and `r2p pub motorN/setpoint` would be.
struct Tool {
    imu: &'static Subscriber<'static, Imu, 64>,
    left: &'static Publisher<'static, WheelSetpoint>,
    right: &'static Publisher<'static, WheelSetpoint>,
}

fn setpoint_out(
    name: &'static str,
) -> (
    &'static Publisher<'static, WheelSetpoint>,
    &'static RemoteSubscriber<'static, WheelSetpoint, 2>,
) {
    let topic: &'static Topic<'static, WheelSetpoint, { pool_size(&[2], 1) }, 1> =
        leak(Topic::new(name, WheelSetpoint::default()));
    let p = leak(Publisher::new(topic, Class::NonRealTime));
    let out = leak(RemoteSubscriber::<'static, WheelSetpoint, 2>::new(p));
    topic.subscribe(out).unwrap();
    (p, out)
}

fn tool(r: &mut EmuRobot) -> Tool {
    let topic: &'static Topic<'static, Imu, { pool_size(&[64], 1) }, 1> =
        leak(Topic::new("imu", Imu::default()));
    let publisher = leak(Publisher::new(topic, Class::NonRealTime));
    let imu = leak(Subscriber::new());
    topic.subscribe(imu).unwrap();
    let (left, lo) = setpoint_out("motor1/setpoint");
    let (right, ro) = setpoint_out("motor2/setpoint");
    let cycle = CycleConfig { cycle_us: r.robot.bus.cycle_us, ..CycleConfig::DEFAULT };
    let mut uid = [0u8; 12];
    uid[11] = 0x7E;
    let mut node =
        BoardNode::new(NodeConfig { cycle, ..NodeConfig::new(uid, "tool") }, &NoParams).unwrap();
    node.import(leak(RemotePublisher::new(publisher, topic))).unwrap();
    node.export(lo).unwrap();
    node.export(ro).unwrap();
    let port = r.spare_port();
    r.sim.add_board(node, port, None);
    Tool { imu, left, right }
}

/// One received `imu` message with the world's truth when it arrived.
#[derive(Clone, Copy, Debug)]
struct Seen {
    t_ms: u64,
    msg: Imu,
    /// The base's yaw rate, rad/s, and unwrapped heading, rad.
    wz: f64,
    theta: f64,
}

/// Runs `ms` milliseconds, commanding wheel speeds (left, right) at 100 Hz if given, and
/// collects the `imu` messages with the world's state.
fn run(r: &mut EmuRobot, t: &Tool, ms: u64, wheels: Option<(f32, f32)>, seen: &mut Vec<Seen>) {
    for k in 0..ms {
        if let (Some((l, rt)), 0) = (wheels, k % 10) {
            let _ = t.left.publish_with(|m| *m = WheelSetpoint { mode: 1, value: l });
            let _ = t.right.publish_with(|m| *m = WheelSetpoint { mode: 1, value: rt });
        }
        r.sim.run_for(MS);
        let w = r.world.borrow();
        let theta = unwrap_near(w.pose().theta, seen.last().map_or(0.0, |s| s.theta));
        while let Some(m) = t.imu.try_recv() {
            seen.push(Seen { t_ms: r.sim.now_ns() / MS, msg: *m, wz: w.twist().wz, theta });
        }
    }
}

/// `a` plus the multiple of 2π that brings it nearest `near`.
fn unwrap_near(a: f64, near: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    a + tau * ((near - a) / tau).round()
}

#[test]
fn the_imu_topic_follows_the_base_turning_on_the_spot() {
    let mut r = EmuRobot::build(robot_file()).unwrap();
    let t = tool(&mut r);
    let (gain, offset) = {
        let w = r.world.borrow();
        let d = w.imu("imu").unwrap();
        (d.gains().0[2], d.gyro_offset()[2])
    };
    // The device has a real offset to remove (the datasheet allows ±1 °/s).
    assert!(offset.abs() > 0.1f64.to_radians(), "offset {offset}");
    let mut seen = Vec::new();

    // Standing still: the bias window (1 s) closes, then the rate reads zero within the
    // noise though the device's offset is not.
    run(&mut r, &t, 2000, None, &mut seen);
    assert!(seen.len() >= 90, "imu at 50 Hz from boot: {}", seen.len());
    assert!(seen.iter().any(|s| s.msg.status == r2p_app_imu::STATUS_CALIBRATING));
    let still: Vec<&Seen> = seen.iter().filter(|s| s.t_ms > 1200).collect();
    assert!(still.iter().all(|s| s.msg.status == r2p_app_imu::STATUS_OK));
    let p = ImuParams::LSM6DSO;
    let (sigma, lsb) = (p.gyro_sigma(104.0), 17.5e-3f64.to_radians());
    let mean = still.iter().map(|s| f64::from(s.msg.rate[2])).sum::<f64>() / still.len() as f64;
    // The bias is a 1 s mean of ~104 samples: its error is σ/√104; the mean here adds its own.
    assert!(mean.abs() < 5.0 * sigma / 104f64.sqrt() + lsb / 2.0, "still rate {mean}");
    let last = still.last().unwrap().msg;
    assert!(last.yaw.abs() < 1e-3 && last.roll.abs() < 0.03 && last.pitch.abs() < 0.03, "{last:?}");
    assert!((f64::from(last.accel[2]) - 9.81).abs() < 0.3, "{last:?}");

    // Turning counter-clockwise on the spot at ~2 rad/s for 3 s.
    let from = seen.len();
    run(&mut r, &t, 3000, Some((-WHEEL, WHEEL)), &mut seen);
    let wz_end = r.world.borrow().twist().wz;
    assert!((wz_end - 2.0).abs() < 0.1, "turning at {wz_end} rad/s");
    let steady: Vec<&Seen> = seen[from..].iter().filter(|s| s.t_ms > 3500).collect();
    assert!(steady.len() >= 70, "{}", steady.len());
    // Each message against the world when it arrived: the base's rate ripples by a few
    // mrad/s under the wheels' speed control and the message is up to a sample period
    // (~10 ms) plus the bus old, so each rate is within 0.012 rad/s and each heading within
    // 10 ms of turn of the device's gain times the truth. (The motor board's ±30 A sensor,
    // 18 mA a count and ~140 mA rms of noise, ripples the wheels more than the ±15 A one
    // did: 10.5 mrad/s at worst here, against 6.7.)
    for s in &steady {
        let err = f64::from(s.msg.rate[2]) - gain * s.wz;
        assert!(err.abs() < 0.012, "{s:?}: rate error {err}");
        let yaw_err = wrap(f64::from(s.msg.yaw) - gain * s.theta);
        assert!(yaw_err.abs() < s.wz.abs() * 0.011 + 5e-3, "{s:?}: heading error {yaw_err}");
    }
    // On average the ripple and the noise go: the mean rate is the device's gain times the
    // mean truth within 5 standard errors, half an LSB and 1 mrad/s.
    let n = steady.len() as f64;
    let mean = |f: &dyn Fn(&Seen) -> f64| steady.iter().map(|s| f(s)).sum::<f64>() / n;
    let (measured, truth) = (mean(&|s| f64::from(s.msg.rate[2])), mean(&|s| s.wz));
    let err = measured - gain * truth;
    assert!(err.abs() < 5.0 * sigma / n.sqrt() + lsb / 2.0 + 1e-3, "mean rate error {err}");

    // Stop, then stand: the heading holds where the base stopped.
    run(&mut r, &t, 500, Some((0.0, 0.0)), &mut seen);
    run(&mut r, &t, 1000, None, &mut seen);
    let end = seen.last().unwrap();
    assert!(end.wz.abs() < 1e-3, "stopped: {}", end.wz);
    let turned = end.theta;
    assert!(turned > 6.0, "turned {turned} rad");
    let err = wrap(f64::from(end.msg.yaw) - gain * turned);
    assert!(err.abs() < 5e-3, "heading {} vs gain × {turned}: {err}", end.msg.yaw);
    // Against the truth: within the datasheet's sensitivity tolerance (±1 %).
    assert!(wrap(f64::from(end.msg.yaw) - turned).abs() < 0.01 * turned + 5e-3);
}

fn wrap(a: f64) -> f64 {
    unwrap_near(a, 0.0)
}

#[test]
fn the_same_robot_file_gives_the_same_bus_trace_and_world() {
    let go = |seed_delta: u64| {
        let mut robot = robot_file();
        robot.seed += seed_delta;
        let mut r = EmuRobot::build(robot).unwrap();
        let t = tool(&mut r);
        let mut seen = Vec::new();
        run(&mut r, &t, 1500, None, &mut seen);
        run(&mut r, &t, 1000, Some((-WHEEL, WHEEL)), &mut seen);
        let digest = r.world.borrow().state_digest();
        let yaw = seen.last().unwrap().msg.yaw;
        (r.sim.bus().trace_hash(), digest, r.sim.bus().frames().count(), yaw.to_bits())
    };
    let (a, b) = (go(0), go(0));
    assert_eq!(a, b, "same file, same trace, world and IMU readings");
    assert!(a.2 > 1_000, "{} frames in 2.5 s", a.2);
    let c = go(1);
    assert_ne!(a.1, c.1, "another seed draws another IMU device and noise");
    assert_ne!(a.3, c.3);
}
