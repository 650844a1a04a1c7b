//! The cascade on a simulated 24 V, 70 W gear motor (tests/common/motor.rs), with the default
//! parameters: the numbers README.md states.

mod common;

use common::*;
use r2p_app_motor::Faults;

const SPEED: u8 = 1;
const POSITION: u8 = 2;
const TORQUE: u8 = 0;

/// Rise time 10 → 90 % (ms), overshoot (% of the step) and the time after which the speed
/// stays within 2 % (ms) of a response `out` (one value per ms) to a step to `target`.
fn step_metrics(out: &[f64], target: f64) -> (usize, f64, usize) {
    let t10 = out.iter().position(|&w| w / target >= 0.1).expect("reaches 10 %");
    let t90 = out.iter().position(|&w| w / target >= 0.9).expect("reaches 90 %");
    let peak = out.iter().map(|&w| w / target).fold(0.0, f64::max);
    let settled = out.iter().rposition(|&w| (w / target - 1.0).abs() > 0.02).map_or(0, |k| k + 1);
    (t90 - t10, 100.0 * (peak - 1.0), settled)
}

#[test]
fn speed_step_rises_within_50_ms_without_overshoot() {
    let mut r = Rig::calibrated();
    let mut out = Vec::new();
    r.hold(SPEED, 10.0, 400, |r| out.push(r.speed()));
    let (rise, overshoot, settled) = step_metrics(&out, 10.0);
    println!(
        "10 rad/s step: rise {rise} ms, overshoot {overshoot:.2} %, within 2 % after {settled} ms"
    );
    // At the 10 A limit the output accelerates at k·I/(J·N) = 252 rad/s²: 10 → 90 % takes at
    // least 32 ms.
    assert!((32..=50).contains(&rise), "rise time {rise} ms");
    assert!(overshoot <= 3.0, "overshoot {overshoot:.2} %");
    assert!(settled <= 100, "settled after {settled} ms");
    let w = r.app.measured().speed;
    assert!((w - 10.0).abs() < 0.05, "measured speed {w}");
    assert!(r.app.faults().is_empty());
}

#[test]
fn a_large_step_is_paced_by_the_current_limit_and_the_current_stays_within_it() {
    let mut r = Rig::calibrated();
    let mut out = Vec::new();
    r.hold(SPEED, 20.0, 400, |r| out.push(r.speed()));
    let (rise, overshoot, settled) = step_metrics(&out, 20.0);
    println!("20 rad/s step: rise {rise} ms, overshoot {overshoot:.2} %, within 2 % after {settled} ms, peak {:.2} A", r.motor.peak_current);
    // At 10 A the motor accelerates the output at 252 rad/s²: 10 → 90 % of 20 rad/s takes at
    // least 63 ms.
    assert!((63..=90).contains(&rise), "rise time {rise} ms");
    assert!(overshoot <= 3.0, "overshoot {overshoot:.2} %");
    assert!(r.motor.peak_current <= 10.5, "peak current {:.2} A", r.motor.peak_current);
    // And back down through zero to −20 rad/s.
    let mut back = Vec::new();
    r.hold(SPEED, -20.0, 400, |r| back.push(r.speed() + 20.0));
    let (rise, overshoot, _) =
        step_metrics(&back.iter().map(|w| -(w - 40.0)).collect::<Vec<_>>(), 40.0);
    // 32 rad/s of the 40 rad/s swing at 252 rad/s²: at least 127 ms.
    assert!(rise <= 160 && overshoot <= 3.0, "reverse: {rise} ms, {overshoot:.2} %");
    assert!((r.speed() + 20.0).abs() < 0.2);
}

#[test]
fn position_is_held_against_a_load_step() {
    let mut r = Rig::calibrated();
    let mut out = Vec::new();
    r.hold(POSITION, 1.0, 500, |r| out.push(r.motor.output_position()));
    let t90 = out.iter().position(|&x| x >= 0.9).unwrap();
    let peak = out.iter().cloned().fold(0.0, f64::max);
    assert!(t90 <= 150, "reaches 0.9 rad after {t90} ms");
    assert!(peak <= 1.005, "overshoot to {peak:.4} rad");
    assert!((out[499] - 1.0).abs() < 0.002, "{}", out[499]);
    // A 2 N·m load (4.4 A at the motor) steps on and stays.
    r.motor.load = 2.0;
    let mut dev = Vec::new();
    r.hold(POSITION, 1.0, 500, |r| dev.push(r.motor.output_position() - 1.0));
    let worst = dev.iter().cloned().fold(0.0, |a: f64, x| a.max(x.abs()));
    let back = dev.iter().rposition(|x| x.abs() > 0.005).map_or(0, |k| k + 1);
    println!("position: 0.9 rad after {t90} ms, peak {peak:.4} rad; 2 N·m load: {worst:.4} rad at worst, within 5 mrad after {back} ms");
    assert!(worst < 0.08, "deviation {worst:.4} rad");
    assert!(back <= 250, "back within 5 mrad after {back} ms");
    assert!(dev[499].abs() < 0.001, "no steady-state error: {}", dev[499]);
    let i = r.app.measured().current;
    assert!((i - 4.42).abs() < 0.2, "holding the load takes 2 / (0.0302 × 15) = 4.42 A: {i}");
}

#[test]
fn position_moves_across_many_timer_wraps() {
    let mut r = Rig::calibrated();
    // 20 rad = 95 500 counts: the 16-bit timer wraps on the way (and back on the return).
    r.hold(POSITION, 20.0, 1500, |_| {});
    assert!((r.motor.output_position() - 20.0).abs() < 0.002, "{}", r.motor.output_position());
    assert!((r.app.measured().position - 20.0).abs() < 0.002);
    assert!(r.app.encoder_count() > 95_000);
    r.hold(POSITION, -5.0, 1500, |_| {});
    assert!((r.motor.output_position() + 5.0).abs() < 0.002, "{}", r.motor.output_position());
}

#[test]
fn torque_setpoints_become_current() {
    let mut r = Rig::calibrated();
    r.motor.stalled = true;
    // 1 N·m at the output = 1 / (0.0302 × 15) = 2.208 A.
    r.hold(TORQUE, 1.0, 200, |_| {});
    assert!((r.motor.i - 2.208).abs() < 0.05, "{}", r.motor.i);
    r.hold(TORQUE, -2.0, 200, |_| {});
    assert!((r.motor.i + 4.415).abs() < 0.05, "{}", r.motor.i);
    // Beyond the limit: the limit.
    r.hold(TORQUE, 50.0, 200, |_| {});
    assert!((r.motor.i - 10.0).abs() < 0.1, "{}", r.motor.i);
}

#[test]
fn the_current_limit_holds_under_stall_and_a_stall_is_no_encoder_loss() {
    let mut r = Rig::calibrated();
    r.motor.stalled = true;
    let mut currents = Vec::new();
    r.hold(SPEED, 20.0, 2000, |r| currents.push(r.motor.i));
    let peak = currents.iter().cloned().fold(0.0, f64::max);
    let last: f64 = currents[1900..].iter().sum::<f64>() / 100.0;
    println!("stall: peak {peak:.3} A, mean of the last 100 ms {last:.3} A");
    assert!(peak <= 10.5, "peak {peak:.3} A over the 10 A limit");
    assert!((last - 10.0).abs() < 0.1, "{last}");
    assert!(r.app.faults().is_empty(), "{:?}", r.app.faults());
    // Lower the limit over the bus: the current follows within a few ms.
    use r2p_app_motor::params::index;
    use r2p_management::message::Value;
    use r2p_node::ParamStore;
    r.params.set(index::CURRENT_LIMIT, Value::F32(4.0)).unwrap();
    r.hold(SPEED, 20.0, 100, |_| {});
    assert!((r.motor.i - 4.0).abs() < 0.1, "{}", r.motor.i);
    assert_eq!(r.app.faults(), Faults::NONE);
}

#[test]
fn state_is_published_at_the_rate_parameter() {
    use r2p_app_motor::params::index;
    use r2p_management::message::Value;
    let mut r = Rig::calibrated();
    let mut n = 0;
    let mut last = None;
    r.hold(SPEED, 5.0, 1000, |r| {
        while let Some(s) = r.states.try_recv() {
            n += 1;
            last = Some(*s);
        }
    });
    assert_eq!(n, 100, "100 Hz");
    let s = last.unwrap();
    assert!((s.speed - 5.0).abs() < 0.05 && s.faults == 0, "{s:?}");
    // Published at most 10 ms ago, at 5 rad/s.
    let lag = r.motor.output_position() - f64::from(s.position);
    assert!((0.0..0.055).contains(&lag), "{lag}");
    let mut r = Rig::with_params(&[(index::PUBLISH_HZ, Value::U32(40))]);
    let mut n = 0;
    for _ in 0..1000 {
        r.step();
        while r.states.try_recv().is_some() {
            n += 1;
        }
    }
    assert_eq!(n, 40);
}
