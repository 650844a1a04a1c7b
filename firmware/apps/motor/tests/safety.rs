//! Faults: each one latches, acts on the bridge, is published, and clears only by command.

mod common;

use common::*;
use r2p_app_motor::params::index;
use r2p_app_motor::Faults;
use r2p_management::message::Value;

const SPEED: u8 = 1;
const ALL: u8 = 0xFF;

#[test]
fn the_watchdog_stops_the_motor_under_control_then_brakes_until_cleared() {
    let mut r = Rig::calibrated();
    r.hold(SPEED, 15.0, 300, |_| {});
    assert!((r.speed() - 15.0).abs() < 0.2);
    let last_setpoint = r.now_us - 10 * MS; // `hold` sent its last setpoint 10 steps ago
    let mut fired = None;
    let mut stopped = None;
    let mut braked = None;
    let mut peak: f64 = 0.0;
    for _ in 0..1000 {
        let now = r.now_us;
        let cmd = r.step();
        peak = peak.max(r.motor.i.abs());
        if fired.is_none() && r.app.faults() == Faults::WATCHDOG {
            fired = Some(now);
        }
        if fired.is_some() && stopped.is_none() && r.speed().abs() < 0.2 {
            stopped = Some(now);
        }
        if braked.is_none() && cmd.brake {
            assert!(cmd.bridge_enable && cmd.duty == 0.0);
            braked = Some(now);
        }
    }
    let (fired, stopped, braked) = (fired.unwrap(), stopped.unwrap(), braked.unwrap());
    let after = (fired - last_setpoint) / MS;
    let stop_ms = (stopped - fired) / MS;
    println!("watchdog: fired {after} ms after the last setpoint, stopped {stop_ms} ms later, peak {peak:.2} A");
    assert_eq!(after, 251, "watchdog_ms = 250: fires on the first step past it");
    assert!((250..=252).contains(&after), "watchdog fired after {after} ms (watchdog_ms = 250)");
    // From 15 rad/s at the 10 A limit (368 rad/s²): ≥ 41 ms.
    assert!((40..=150).contains(&stop_ms), "stopped in {stop_ms} ms");
    assert!(peak <= 10.5, "braking stays within the current limit: {peak:.2} A");
    // The brake closes once the measured speed (a 5 ms window, filtered) is under 0.2 rad/s.
    let lag = (braked as i64 - stopped as i64) / 1000;
    assert!((-5..=20).contains(&lag), "braked {lag} ms after the motor stopped");
    assert_eq!(r.take_events().iter().map(|e| e.raised).collect::<Vec<_>>(), [Faults::WATCHDOG.0]);
    // Setpoints do not restart it while the fault is latched.
    r.hold(SPEED, 10.0, 200, |r| assert!(r.last.brake));
    assert!(r.speed().abs() < 0.05);
    assert_eq!(r.app.stats().ignored_setpoints, 20);
    // Cleared: idle (bridge off), then the next setpoint runs the motor again.
    r.clear(Faults::WATCHDOG.0);
    let cmd = r.step();
    assert!(!cmd.bridge_enable && r.app.faults().is_empty());
    let e = r.take_events();
    assert_eq!((e.len(), e[0].raised, e[0].faults), (1, 0, 0), "the clear is an event too");
    r.hold(SPEED, 10.0, 200, |_| {});
    assert!((r.speed() - 10.0).abs() < 0.2, "{}", r.speed());
}

#[test]
fn the_watchdog_waits_for_the_first_setpoint() {
    let mut r = Rig::new();
    r.run_ms(3000);
    assert!(r.app.faults().is_empty());
    assert!(!r.last.bridge_enable, "idle: bridge off");
    r.send(SPEED, 1.0);
    r.run_ms(251);
    assert!(r.app.faults().is_empty());
    r.run_ms(1);
    assert_eq!(r.app.faults(), Faults::WATCHDOG);
}

#[test]
fn over_current_trips_after_trip_ms_and_stays_off_until_cleared() {
    // Idle (bridge off), so that the controller does not react to the injected readings: the
    // sensor reads 15 A (above the 14 A trip) for 4 ms, then from 10 ms on for good.
    let mut r = Rig::calibrated();
    let from = r.now_us;
    r.tamper = Box::new(move |now, s| {
        let t = now - from;
        if !(4 * MS..10 * MS).contains(&t) {
            s.current_adc = r2p_app_motor::frontend::current_counts(
                15.0,
                2048.0,
                r2p_app_motor::frontend::HALL_MV_PER_A,
            );
        }
    });
    let mut tripped = None;
    for _ in 0..30 {
        let now = r.now_us;
        r.step();
        if tripped.is_none() && r.app.faults().any(Faults::OVER_CURRENT) {
            tripped = Some((now - from) / MS);
        }
    }
    // 4 ms above the limit is not enough (trip_ms = 5); from 10 ms on it trips at 15.
    assert_eq!(tripped, Some(15));
    assert!(!r.last.bridge_enable);
    let e = r.take_events();
    assert_eq!(e.len(), 1);
    assert_eq!((e[0].raised, e[0].faults), (Faults::OVER_CURRENT.0, Faults::OVER_CURRENT.0));
    assert!((e[0].current - 15.0).abs() < 0.02, "{}", e[0].current);
    r.tamper = Box::new(|_, _| {});
    r.hold(SPEED, 5.0, 100, |r| assert!(!r.last.bridge_enable, "latched: the bridge stays off"));
    r.clear(ALL);
    r.hold(SPEED, 5.0, 300, |_| {});
    assert!(r.app.faults().is_empty());
    assert!((r.speed() - 5.0).abs() < 0.1);
}

#[test]
fn a_trip_threshold_below_the_current_limit_trips_on_a_real_over_current() {
    let mut r = Rig::with_params(&[(index::TRIP_CURRENT, Value::F32(6.0))]);
    r.run_ms(100);
    let mut above = None;
    let mut tripped = None;
    r.hold(SPEED, 20.0, 100, |r| {
        let now = r.now_us;
        if above.is_none() && r.motor.i > 6.0 {
            above = Some(now);
        }
        if tripped.is_none() && !r.app.faults().is_empty() {
            tripped = Some(now);
        }
    });
    assert_eq!(r.app.faults(), Faults::OVER_CURRENT);
    let after = (tripped.unwrap() - above.unwrap()) / MS;
    assert!((5..=7).contains(&after), "tripped {after} ms after the current passed 6 A");
    assert!(!r.last.bridge_enable && r.motor.i == 0.0, "bridge off, no current");
}

#[test]
fn a_lost_encoder_latches_after_the_timeout_and_disables_the_bridge() {
    let mut r = Rig::calibrated();
    r.hold(SPEED, 10.0, 300, |_| {});
    r.motor.encoder_connected = false;
    let from = r.now_us;
    let mut latched = None;
    r.hold(SPEED, 10.0, 300, |r| {
        if latched.is_none() && r.app.faults().any(Faults::ENCODER_LOSS) {
            latched = Some((r.now_us - from) / MS);
        }
    });
    let latched = latched.expect("encoder loss latched");
    println!("encoder unplugged at 10 rad/s: latched after {latched} ms");
    assert!(
        (100..=110).contains(&latched),
        "latched after {latched} ms (encoder_timeout_ms = 100)"
    );
    assert_eq!(r.app.faults(), Faults::ENCODER_LOSS);
    assert!(!r.last.bridge_enable);
    assert_eq!(r.take_events()[0].raised, Faults::ENCODER_LOSS.0);
    // Cleared while still unplugged: it latches again once driving.
    r.clear(ALL);
    r.hold(SPEED, 10.0, 400, |_| {});
    assert_eq!(r.app.faults(), Faults::ENCODER_LOSS);
    // Plugged back in and cleared: runs.
    r.motor.encoder_connected = true;
    r.clear(Faults::ENCODER_LOSS.0);
    r.hold(SPEED, 10.0, 400, |_| {});
    assert!(r.app.faults().is_empty() && (r.speed() - 10.0).abs() < 0.2);
}

#[test]
fn the_driver_fault_flag_latches_at_once() {
    let mut r = Rig::calibrated();
    r.hold(SPEED, 5.0, 100, |_| {});
    let at = r.now_us;
    r.tamper = Box::new(move |now, s| s.driver_fault = now == at);
    let cmd = r.step();
    assert_eq!(r.app.faults(), Faults::DRIVER);
    assert!(!cmd.bridge_enable && cmd.leds[2], "bridge off, fault LED on");
    // Clearing another bit leaves it.
    r.clear(Faults::OVER_CURRENT.0);
    r.run_ms(5);
    assert_eq!(r.app.faults(), Faults::DRIVER);
    r.clear(Faults::DRIVER.0);
    let cmd = r.step();
    assert!(r.app.faults().is_empty() && !cmd.leds[2]);
}

#[test]
fn a_bad_current_sensor_zero_keeps_the_bridge_off() {
    let mut r = Rig::new();
    r.motor.hall_zero = 2048.0 + 200.0; // 161 mV off: sensor broken
    r.send(SPEED, 5.0);
    r.run_ms(100);
    assert_eq!(r.app.faults(), Faults::CURRENT_SENSOR);
    r.hold(SPEED, 5.0, 100, |r| assert!(!r.last.bridge_enable));
    // Within tolerance (a real sensor's zero error): calibrated away after a clear.
    r.motor.hall_zero = 2048.0 + 100.0;
    r.clear(ALL);
    r.run_ms(70);
    assert!(r.app.faults().is_empty());
    assert_eq!(r.app.current_zero(), Some(2148.0));
    r.hold(SPEED, 5.0, 300, |_| {});
    assert!((r.speed() - 5.0).abs() < 0.1);
    assert!(r.app.measured().current.abs() < 0.3, "the offset is calibrated out");
}

#[test]
fn faults_are_in_every_published_state() {
    let mut r = Rig::calibrated();
    r.send(SPEED, 1.0);
    r.run_ms(300);
    r.run_ms(20);
    let mut last = None;
    for _ in 0..20 {
        r.step();
        while let Some(s) = r.states.try_recv() {
            last = Some(s.faults);
        }
    }
    assert_eq!(last, Some(Faults::WATCHDOG.0));
}

#[test]
fn leds_show_calibration_running_bus_and_faults() {
    use r2p_module::leds::Status;
    let mut r = Rig::new();
    let node_up = Status { running: true, synced: true, ..Default::default() };
    r.tamper = Box::new(move |_, s| s.status = node_up);
    // Start at 100 ms: while calibrating (64 samples) the status LED blinks fast (5 Hz: dark from
    // 100 to 199 ms) even though the node runs, where the slow blink would be lit; the bus LED
    // follows the sync.
    r.now_us = 100 * MS;
    let mut lit = Vec::new();
    for _ in 0..900 {
        lit.push(r.step().leds);
    }
    // (The 64th sample completes the calibration in its own step.)
    assert!(lit[..63].iter().all(|l| !l[0] && l[1] && !l[2]), "calibrating: fast blink");
    // Calibrated and running: slow blink, lit 0–499 ms, dark 500–999 ms of each second.
    assert!(lit[63..400].iter().all(|l| l[0]) && lit[400..900].iter().all(|l| !l[0]));
    // A latched fault lights the fault LED.
    r.send(SPEED, 1.0);
    r.run_ms(300);
    assert!(r.last.leds[2]);
    r.clear(ALL);
    r.step();
    assert!(!r.last.leds[2]);
}

#[test]
fn a_high_supply_derates_braking_and_sets_state_bit_5_until_it_falls() {
    let mut r = Rig::calibrated();
    r.hold(SPEED, 10.0, 300, |_| {});
    assert!((r.speed() - 10.0).abs() < 0.2);
    // The supply cannot take the braking energy and sits at `regen_stop_v` (45.5 V) for 200 ms:
    // asked to stop, the motor gets no braking current and slows on its friction only.
    r.motor.vbus = 45.5;
    let mut bits = Vec::new();
    let mut least: f64 = 0.0;
    for k in 0..400u64 {
        if k == 200 {
            r.motor.vbus = 24.0;
        }
        if k % 10 == 0 {
            r.send(SPEED, 0.0);
        }
        r.step();
        if k < 200 {
            least = least.min(r.motor.i);
        }
        if k == 199 {
            assert!(r.speed() > 5.0, "still turning: {}", r.speed());
        }
        while let Some(s) = r.states.try_recv() {
            bits.push((k, s.faults));
        }
    }
    // The current loop held the current at its setpoint, 0 A: no braking, within its ripple.
    assert!(least > -0.05, "braking current while the supply was high: {least:.3} A");
    let flagged = |from: u64, to: u64| bits.iter().filter(move |(k, _)| (from..to).contains(k));
    assert!(flagged(0, 200).all(|(_, f)| *f == Faults::REGEN_LIMITED.0), "{bits:?}");
    assert!(flagged(210, 400).all(|(_, f)| *f == 0), "clears by itself: {bits:?}");
    assert!(flagged(0, 400).count() >= 39, "100 Hz states: {bits:?}");
    assert!(r.app.faults().is_empty() && r.take_events().is_empty(), "not latched, no event");
    // Once the supply fell, braking resumed: the motor stopped.
    assert!(r.speed().abs() < 0.2, "{}", r.speed());
}
