//! The Triskar2 robot file (robots/triskar2.toml) on emulated boards: every module's default
//! firmware against the world model, with the numbers users rely on.

use r2p_emu::robot::{BoardNode, EmuRobot};
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_msgs::{Battery, Proximity, PsuEvent, WheelSetpoint, WheelState};
use r2p_node::{ImportState, NoParams, NodeConfig, RemotePublisher, RemoteSubscriber};
use r2p_world::robot_file::{BaseController, ParamValue, Robot};
use rtcan::failover::Role;
use rtcan::CycleConfig;

const MS: u64 = 1_000_000;
const S: u64 = 1_000_000_000;

fn robot_file() -> Robot {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../robots/triskar2.toml");
    Robot::load(path).unwrap_or_else(|e| panic!("{e}"))
}

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

/// A topic received on the observer: its subscriber and the import to register.
fn incoming<T: r2p_node::Wire + Copy + Default + Send + Sync + 'static>(
    name: &'static str,
) -> (&'static Subscriber<'static, T, 64>, &'static RemotePublisher<'static, T>) {
    let topic: &'static Topic<'static, T, { pool_size(&[64], 1) }, 1> =
        leak(Topic::new(name, T::default()));
    let publisher = leak(Publisher::new(topic, Class::NonRealTime));
    let sub = leak(Subscriber::new());
    topic.subscribe(sub).unwrap();
    (sub, leak(RemotePublisher::new(publisher, topic)))
}

/// A test tool on the spare port: a node that imports what the test watches (and exports
/// what it commands), as `r2p echo` / `r2p pub` would.
struct Observer {
    battery: &'static Subscriber<'static, Battery, 64>,
    events: &'static Subscriber<'static, PsuEvent, 64>,
    ranges: &'static Subscriber<'static, Proximity, 64>,
    state: &'static Subscriber<'static, WheelState, 64>,
    setpoint: &'static Publisher<'static, WheelSetpoint>,
}

fn observe(r: &mut EmuRobot) -> Observer {
    let (battery, bi) = incoming::<Battery>("psu/battery");
    let (events, ei) = incoming::<PsuEvent>("psu/event");
    let (ranges, ri) = incoming::<Proximity>("proximity/ranges");
    let (state, si) = incoming::<WheelState>("motor1/state");
    let topic: &'static Topic<'static, WheelSetpoint, { pool_size(&[2], 1) }, 1> =
        leak(Topic::new("motor1/setpoint", WheelSetpoint::default()));
    let setpoint = leak(Publisher::new(topic, Class::NonRealTime));
    let out = leak(RemoteSubscriber::<'static, WheelSetpoint, 2>::new(setpoint));
    topic.subscribe(out).unwrap();
    let cycle = CycleConfig { cycle_us: r.robot.bus.cycle_us, ..CycleConfig::DEFAULT };
    let mut uid = [0u8; 12];
    uid[11] = 0x7E;
    let config = NodeConfig { cycle, ..NodeConfig::new(uid, "observer") };
    let mut node = BoardNode::new(config, &NoParams).unwrap();
    for i in [bi as &dyn r2p_node::Import, ei, ri, si] {
        node.import(i).unwrap();
    }
    node.export(out).unwrap();
    let port = r.spare_port();
    r.sim.add_board(node, port, None);
    Observer { battery, events, ranges, state, setpoint }
}

fn drain<T: Copy, const Q: usize>(s: &Subscriber<'static, T, Q>) -> Vec<T> {
    std::iter::from_fn(|| s.try_recv().map(|m| *m)).collect()
}

#[test]
fn every_board_boots_with_the_psu_as_master_and_the_gateway_subscribes_to_everything() {
    let mut r = EmuRobot::build(robot_file()).unwrap();
    r.sim.run_until(S);
    let psu = r.board("psu").unwrap();
    assert_eq!(r.sim.node(psu).role(), Role::Master, "the PSU is the default sync master");
    let mut ids = Vec::new();
    for i in 0..r.sim.boards() {
        if i != psu {
            assert_eq!(r.sim.node(i).role(), Role::Slave, "{}", r.boards[i].name);
        }
        assert_eq!(r.sim.node(i).peer_count(), r.sim.boards() - 1, "{}", r.boards[i].name);
        ids.push(r.sim.node(i).node_id());
    }
    ids.sort();
    ids.dedup();
    assert_eq!(ids.len(), r.sim.boards(), "node IDs are unique");
    let g = r.board("gateway").unwrap();
    for i in 1..6 {
        assert!(
            matches!(r.sim.node(g).import_state(i), Some(ImportState::Subscribed { .. })),
            "gateway import {i}: {:?}",
            r.sim.node(g).import_state(i)
        );
    }
}

/// Runs Triskar2's teleop script for 10 s: it drives ahead, stops before the box (the
/// obstacle avoidance), turns; the odometry tracks the world. Returns the HRT statistics of the
/// node on port `controller`, which runs the base controller.
fn drive_stop_turn(r: &mut EmuRobot, controller: usize) -> r2p_node::NodeStats {
    let mut worst_odometry = 0.0f64;
    for t in 1..=100u64 {
        r.sim.run_until(t * 100 * MS);
        let w = r.world.borrow();
        let (p, o) = (w.pose(), r.probe.borrow().odometry);
        let err = (p.x - f64::from(o.0)).hypot(p.y - f64::from(o.1));
        worst_odometry = worst_odometry.max(err);
        if t == 45 {
            // Teleop asks 0.4 m/s ahead from 1 s; the box's near face is at x = 1.0 m and the
            // front ranger sits 0.30 m ahead of the centre: the proximity module's 0.45 m
            // obstacle threshold stops the base with its ranger 0.40–0.45 m from the box.
            let front = 1.0 - (p.x + 0.30);
            assert!((0.38..=0.46).contains(&front), "stopped {front:.3} m from the box");
            assert!(w.twist().vx.abs() < 0.01, "and stays stopped: {:?}", w.twist());
        }
        if t == 70 {
            // 0.8 rad/s for 2 s: 91.7°; the base ends where the wheels put it.
            let deg = p.theta.to_degrees();
            assert!((deg - 91.7).abs() < 3.0, "heading {deg:.1}°");
        }
    }
    // Odometry from the three wheels' states, integrated by the base controller, tracks the
    // truth.
    assert!(worst_odometry < 0.02, "odometry error up to {worst_odometry:.3} m");
    assert_eq!(r.probe.borrow().setpoints_dropped, 0);
    let hrt = r.sim.node(controller).stats();
    // Three a cycle from their grants on, after the modules' start (each listens for a
    // heartbeat period before it claims its node ID, then subscribes): measured 2 893 of 3 000.
    assert!(hrt.hrt_sent >= 2880, "setpoints go out every 10 ms in their slots: {hrt:?}");
    assert_eq!(hrt.hrt_missed, 0);
    hrt
}

#[test]
fn triskar2_drives_stops_before_the_box_turns_and_odometry_follows() {
    let mut r = EmuRobot::build(robot_file()).unwrap();
    assert_eq!(r.host, None, "the gateway runs the base controller by default");
    let g = r.board("gateway").unwrap();
    drive_stop_turn(&mut r, g);
}

#[test]
fn the_base_controller_moved_to_the_host_drives_triskar2_alike() {
    let mut robot = robot_file();
    robot.base_controller = Some(BaseController::Host);
    let mut r = EmuRobot::build(robot).unwrap();
    let (g, host) = (r.board("gateway").unwrap(), r.host.expect("a port for the host's node"));
    assert_eq!(r.spare_port(), host + 1, "tools keep a port of their own");
    // The teleop script's cmd_vel goes from the gateway over the bus to the host's node, whose
    // setpoints drive the wheels; the gateway sends none.
    drive_stop_turn(&mut r, host);
    assert_eq!(r.sim.node(g).stats().hrt_sent, 0, "the gateway runs no base controller");
    // For ROS 2's /odom and /range_N it imports the host's odometry and the ranges (after its
    // own seven imports).
    for i in [7, 8] {
        let s = r.sim.node(g).import_state(i);
        assert!(matches!(s, Some(ImportState::Subscribed { .. })), "import {i}: {s:?}");
    }
}

#[test]
fn the_base_controller_finds_the_motors_and_the_proximity_module_by_their_instances() {
    let mut robot = robot_file();
    // Motors 5, 6, 7 on wheels 0, 1, 2 and proximity module 2: the gateway's base controller
    // takes their topics from its wheelN_instance and proximity_instance parameters.
    for m in robot.modules.iter_mut() {
        let instance = match (m.name.as_str(), &m.wiring) {
            (_, r2p_world::robot_file::Wiring::Motor { wheel, .. }) => 5 + *wheel as i64,
            ("proximity", _) => 2,
            _ => continue,
        };
        m.params.retain(|(n, _)| n != "instance");
        m.params.push(("instance".into(), ParamValue::Int(instance)));
    }
    let mut r = EmuRobot::build(robot).unwrap();
    let g = r.board("gateway").unwrap();
    // Its imports: cmd_vel (0, published on the gateway), the obstacles, ranges and the three
    // wheel states, each subscribed to its module.
    let subscribed = r.sim.run_while(MS, S, |s| {
        (1..6).all(|i| matches!(s.node(g).import_state(i), Some(ImportState::Subscribed { .. })))
    });
    assert!(subscribed, "{:?}", (1..6).map(|i| r.sim.node(g).import_state(i)).collect::<Vec<_>>());
    // The teleop script drives it ahead from 1 s (motors 5-7 turn) until proximity2's
    // obstacle event stops it before the box, as in the default robot.
    r.sim.run_until(3 * S);
    let x = r.world.borrow().pose().x;
    let front = 1.0 - (x + 0.30);
    assert!((0.38..=0.46).contains(&front), "stopped {front:.3} m from the box");
    assert_eq!(r.probe.borrow().command, (0.0, 0.0, 0.0));
}

#[test]
fn the_same_robot_file_gives_the_same_bus_trace_and_world() {
    let run = |seed_delta: u64| {
        let mut robot = robot_file();
        robot.seed += seed_delta;
        let mut r = EmuRobot::build(robot).unwrap();
        r.sim.run_until(2 * S);
        let digest = r.world.borrow().state_digest();
        (r.sim.bus().trace_hash(), digest, r.sim.bus().frames().count())
    };
    let (a, b) = (run(0), run(0));
    assert_eq!(a, b, "same file, same trace and world");
    assert!(a.2 > 2_000, "{} frames in 2 s", a.2);
    let c = run(1);
    assert_ne!(a.1, c.1, "another seed draws other sensor noise");
}

#[test]
fn the_psu_reports_the_battery_within_its_accuracy() {
    let mut r = EmuRobot::build(robot_file()).unwrap();
    let o = observe(&mut r);
    r.sim.run_until(3 * S);
    let got = drain(o.battery);
    assert!(got.len() >= 20, "10 Hz battery messages: {}", got.len());
    let last = got.last().unwrap();
    let w = r.world.borrow();
    // Voltage: 12-bit ADC over a 52.8 V range (12.9 mV per count) and a 1 s filter.
    let v = w.supply_voltage();
    assert!((f64::from(last.voltage) - v).abs() < 0.05, "{} V vs {v:.3} V", last.voltage);
    // Current: the PSU's own input (the bus load through the converter), 1.6 mA per count.
    let i = w.psu_input_current();
    assert!(
        (f64::from(last.current) - i).abs() < 0.01 + 0.02 * i,
        "{} A vs {i:.3} A",
        last.current
    );
}

#[test]
fn an_over_current_fires_the_event_and_switches_the_bus_off() {
    let mut robot = robot_file();
    let psu = robot.modules.iter_mut().find(|m| m.name == "psu").unwrap();
    psu.params.push(("oc_threshold_a".into(), ParamValue::Float(0.4)));
    psu.params.push(("oc_time_ms".into(), ParamValue::Int(50)));
    let mut r = EmuRobot::build(robot).unwrap();
    let o = observe(&mut r);
    r.sim.run_until(S);
    assert!(r.world.borrow().bus_voltage() > 4.9);
    drain(o.events);
    // An overload on the bus side below the eFuse's limit (2.65 A, hardware/psu rev B): the bus
    // at 2.3 A, ~0.53 A at the input, so the firmware's check fires before the eFuse would.
    let load = r.world.borrow().bus_load_a();
    assert!(load < 1.5, "the robot's own bus load: {load} A");
    r.world.borrow_mut().set_bus_load_a(2.3);
    let t0 = r.sim.now_ns();
    let fired = r.sim.run_while(MS, t0 + 500 * MS, |_| !o.events.is_empty());
    assert!(fired, "no over-current event within 500 ms");
    let after = (r.sim.now_ns() - t0) / MS;
    println!("over-current event {after} ms after the fault (oc_time_ms = 50)");
    assert!(after <= 80, "{after} ms");
    r.sim.run_for(20 * MS);
    let events = drain(o.events);
    assert_eq!(events[0].kind, 1, "over-current first: {events:?}");
    assert!(events.iter().any(|e| e.kind == 4 && e.cause == 1), "then output off: {events:?}");
    assert!(r.world.borrow().bus_voltage() < 0.1, "the bus output is off");
}

#[test]
fn proximity_distances_match_the_world_and_a_missing_sensor_reads_no_sensor() {
    let mut r = EmuRobot::build(robot_file()).unwrap();
    let o = observe(&mut r);
    r.sim.run_until(2 * S);
    let last = *drain(o.ranges).last().expect("ranges at 20 Hz");
    let w = r.world.borrow();
    for ch in 0..4 {
        let truth = w.ranger("proximity", ch).unwrap().last_distance();
        match truth {
            // Inside the sensor's range: within its calibration error (3 % and 1 cm).
            Some(d) if last.status[ch] == 0 => {
                let got = f64::from(last.distance[ch]);
                assert!((got - d).abs() < 0.01 + 0.03 * d, "channel {ch}: {got:.3} m vs {d:.3} m");
            }
            // Beyond it: reported as out of range, never as a distance.
            _ => assert!(last.status[ch] == 1 || last.status[ch] == 2, "channel {ch}: {last:?}"),
        }
    }
    drop(w);
    r.world.borrow_mut().set_ranger_connected("proximity", 1, false).unwrap();
    r.sim.run_for(300 * MS);
    let last = *drain(o.ranges).last().unwrap();
    assert_eq!(last.status[1], 3, "unplugged: no sensor, {last:?}");
    assert!(last.distance[1].is_nan(), "not 0 m: {last:?}");
}

#[test]
fn a_short_on_the_sensor_rail_raises_the_supply_fault_in_ranges_and_clearing_it_recovers() {
    let mut r = EmuRobot::build(robot_file()).unwrap();
    let o = observe(&mut r);
    r.sim.run_until(2 * S);
    let before = drain(o.ranges);
    assert!(!before.is_empty() && before.iter().all(|p| !p.supply_fault), "four Sharp sensors run");
    let load = r.world.borrow().bus_load_a();
    r.world.borrow_mut().set_sensor_rail_shorted("proximity", true).unwrap();
    r.sim.run_for(300 * MS);
    let last = *drain(o.ranges).last().expect("ranges at 20 Hz");
    assert!(last.supply_fault, "the switch's flag reaches the bus: {last:?}");
    assert!(last.status.iter().all(|s| *s == 3), "the rail is down, no sensor reads: {last:?}");
    let limited = r.world.borrow().bus_load_a();
    println!("bus load {load:.3} A with the sensors, {limited:.3} A with the rail shorted");
    assert!(limited - load < 0.05, "the switch holds the short at its limit");
    r.world.borrow_mut().set_sensor_rail_shorted("proximity", false).unwrap();
    r.sim.run_for(500 * MS);
    let last = *drain(o.ranges).last().unwrap();
    assert!(!last.supply_fault, "cleared: {last:?}");
}

#[test]
fn a_motor_follows_a_speed_step_on_the_simulated_70_w_motor_and_stops_when_setpoints_stop() {
    // Without the gateway, the test drives motor1 itself.
    let mut robot = robot_file();
    robot.modules.retain(|m| m.name != "gateway");
    robot.teleop.clear();
    let mut r = EmuRobot::build(robot).unwrap();
    let o = observe(&mut r);
    r.sim.run_until(S);
    let wheel = 0;
    let target = 5.0f32; // rad/s at the wheel: 0.25 m/s rim speed
    let start = r.sim.now_ns();
    let mut trace = Vec::new();
    let mut states = Vec::new();
    for k in 0..100u64 {
        // 100 Hz setpoints for 1 s.
        let _ = o.setpoint.publish_with(|m| *m = WheelSetpoint { mode: 1, value: target });
        for _ in 0..10 {
            r.sim.run_for(MS);
            trace.push(((r.sim.now_ns() - start) / MS, r.world.borrow().wheel(wheel).wheel_speed));
        }
        let _ = k;
        states.extend(drain(o.state));
    }
    let t = |frac: f64| trace.iter().find(|(_, s)| *s >= frac * f64::from(target)).map(|p| p.0);
    let rise = t(0.9).unwrap() - t(0.1).unwrap();
    let peak = trace.iter().map(|p| p.1).fold(0.0, f64::max);
    let overshoot = (peak / f64::from(target) - 1.0).max(0.0);
    println!(
        "speed step 0 → {target} rad/s at the wheel: rise {rise} ms, overshoot {:.1} %",
        overshoot * 100.0
    );
    assert!(rise <= 150, "rise {rise} ms");
    assert!(overshoot < 0.20, "overshoot {:.1} %", overshoot * 100.0);
    assert!(states.len() >= 80, "motor1/state at 100 Hz: {}", states.len());
    assert!((states.last().unwrap().speed - target).abs() < 0.2, "{:?}", states.last());
    // Setpoints stop: the watchdog (250 ms) brings the wheel to rest and latches its bit.
    r.sim.run_for(1_000 * MS);
    assert!(r.world.borrow().wheel(wheel).wheel_speed.abs() < 0.05);
    let last = *drain(o.state).last().unwrap();
    assert_ne!(last.faults & (1 << 2), 0, "watchdog fault latched: {last:?}");
}

#[test]
fn a_rebooted_motor_board_rejoins_and_the_robot_drives_on() {
    let mut r = EmuRobot::build(robot_file()).unwrap();
    r.sim.run_until(1_500 * MS);
    let m = r.board("motor2").unwrap();
    r.sim.power(m, false);
    r.sim.run_for(200 * MS);
    r.reboot("motor2").unwrap();
    let g = r.board("gateway").unwrap();
    let back = r.sim.run_while(MS, r.sim.now_ns() + S, |s| {
        (1..6).all(|i| matches!(s.node(g).import_state(i), Some(ImportState::Subscribed { .. })))
            && s.node(m).stats().published > 0
    });
    assert!(back, "motor2 rejoined and the gateway receives its state again");
    assert_eq!(r.boards[m].boots.get(), 2);
    // Its parameters came back from flash: its topics are motor2's.
    r.sim.run_for(500 * MS);
    assert!(r.world.borrow().twist().vx.abs() > 0.0 || r.world.borrow().pose().x > 0.1);
}

#[test]
fn the_gateway_takes_over_as_master_and_hrt_setpoints_keep_flowing() {
    let mut r = EmuRobot::build(robot_file()).unwrap();
    r.sim.run_until(1_500 * MS);
    let (psu, g) = (r.board("psu").unwrap(), r.board("gateway").unwrap());
    let before = r.sim.node(g).stats().hrt_sent;
    r.sim.power(psu, false); // the PSU's MCU hangs: no more syncs
    r.sim.run_for(S);
    assert_eq!(r.sim.node(g).role(), Role::Master, "rank 1 takes over");
    let sent = r.sim.node(g).stats().hrt_sent - before;
    assert!(sent >= 250, "HRT setpoints through the takeover: {sent} in 1 s");
    let pose = r.world.borrow().pose();
    assert!(pose.x > 0.1, "the base kept driving: {pose:?}");
}

#[test]
fn the_gateways_hrt_setpoints_start_at_their_slot_boundaries_with_the_f407s_lead() {
    use r2p_emu::boards::Mcu;
    use r2p_vbus::EventKind;
    use rtcan::{Laxity, SyncFrame};
    let mut r = EmuRobot::build(robot_file()).unwrap();
    r.sim.run_until(2 * S);
    let g = r.board("gateway").unwrap();
    let cycle = CycleConfig { cycle_us: r.robot.bus.cycle_us, ..CycleConfig::DEFAULT };
    // The F407's slot timer fires its lead (10 µs) before each boundary; its path (12 µs) puts
    // the frame in the mailbox 2 µs after it. The F103's 25 µs would start it 13 µs early,
    // in the previous slot.
    let slack_ns = (Mcu::F407.slot_path_us() - u64::from(Mcu::F407.slot_lead_us())) * 1_000;
    assert_eq!(slack_ns, 2_000);
    let (mut sync_at, mut checked) = (None, 0);
    for e in r.sim.bus().trace() {
        let EventKind::Sent { start_ns, frame, .. } = e.kind else { continue };
        if SyncFrame::from_frame(&frame).is_ok() {
            sync_at = Some(start_ns);
        } else if let (Some(sync), true) =
            (sync_at, e.port == g && frame.id().laxity == Laxity::HRT)
        {
            let into_cycle = start_ns - sync;
            let slot = (0..cycle.slots)
                .rev()
                .find(|&s| u64::from(cycle.slot_offset_us(s)) * 1_000 <= into_cycle)
                .unwrap();
            let late = into_cycle - u64::from(cycle.slot_offset_us(slot)) * 1_000;
            assert!(late <= slack_ns, "HRT frame {late} ns into slot {slot}, at {start_ns} ns");
            checked += 1;
        }
    }
    assert!(checked >= 150, "the base's setpoints went out: {checked} HRT frames in 2 s");
}
