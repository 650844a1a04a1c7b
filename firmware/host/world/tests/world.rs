//! The whole world: coupled steady states against hand-solved physics, energy and charge
//! conservation, what each board's peripherals read, faults.

mod common;

use r2p_drivers::rangers::{Reading, GP2Y0A02YK, GP2Y0A21YK, MAXSONAR_LV_EZ_5V, NO_SENSOR_BELOW_V};
use r2p_world::frontends::{self, ADC};
use r2p_world::{Pose, World};

/// Drives every motor of `w` (board names `boards`) with locked anti-phase duty `d`.
fn drive(w: &mut World, boards: &[&str], d: &[f64]) {
    for (b, d) in boards.iter().zip(d) {
        w.set_output(b, "DRV_EN", true).unwrap();
        w.set_pwm(b, "PWM_AH", (1.0 + d) / 2.0).unwrap();
        w.set_pwm(b, "PWM_BH", (1.0 - d) / 2.0).unwrap();
    }
}

const MOTORS: [&str; 3] = ["motor1", "motor2", "motor3"];

/// Mean of `n` ADC reads of `signal` without stepping (noise averages out; the state holds).
fn mean_adc(w: &mut World, board: &str, signal: &str, n: usize) -> f64 {
    (0..n).map(|_| f64::from(w.read_adc(board, signal).unwrap())).sum::<f64>() / n as f64
}

/// Bisection for the root of a function increasing in x on [lo, hi].
fn root(mut lo: f64, mut hi: f64, f: impl Fn(f64) -> f64) -> f64 {
    for _ in 0..200 {
        let mid = (lo + hi) / 2.0;
        if f(mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    (lo + hi) / 2.0
}

/// Steady state of a Triskar2-like robot whose `driven` wheels run at duty `d` (locked
/// anti-phase) and whose rim speeds are `rim(s)` for a speed parameter s: solved by hand
/// from the component equations (motor, gearbox, rolling resistance, dead time, battery with
/// the PSU as a constant-power load). `force` gives each driven wheel's rim force needed
/// against rolling resistance at speed s. Returns s.
struct Hand {
    robot: r2p_world::Robot,
    ocv: f64,
    bus_w: f64,
}

impl Hand {
    fn solve(&self, driven: &[(f64, f64)], d: f64, force: impl Fn(f64) -> f64) -> f64 {
        // driven: (rim speed per unit s, sign of duty)
        let r = &self.robot;
        let p = r.drive.motor;
        let (n, eta) = (r.drive.gearbox.ratio, r.drive.gearbox.efficiency);
        let rw = r.base.layout_radius();
        let rt = p.resistance_ohm + 2.0 * r.drive.bridge.switch_resistance_ohm;
        let dt = 2.0 * r.drive.bridge.dead_time_s * r.drive.bridge.pwm_hz;
        let rb = r.battery.params.internal_resistance_ohm;
        root(1e-6, 20.0, |s| {
            let mut motor_power = 0.0;
            let mut vb_needed: f64 = 0.0;
            for &(k, _) in driven {
                let wm = n * k * s / rw;
                let tau_shaft = force(s) * rw / (n * eta);
                let i = (tau_shaft + p.friction(wm)) / p.torque_constant;
                let v_term = rt * i + p.torque_constant * wm;
                vb_needed = v_term / (d - dt);
                motor_power += v_term * i;
            }
            // Battery: Vb = OCV − Rb·((P_motors + P_bus)/Vb + I_boards) at the Vb the motors
            // need (I_boards: the three motor boards' own draw from VMOT).
            let boards = 3.0 * r2p_world::motor_bus::BOARD_LOAD_A;
            let vb_source = self.ocv - rb * ((motor_power + self.bus_w) / vb_needed + boards);
            vb_needed - vb_source
        })
    }
}

trait Radius {
    fn layout_radius(&self) -> f64;
}

impl Radius for r2p_world::robot_file::BaseSpec {
    fn layout_radius(&self) -> f64 {
        match self.layout {
            r2p_world::kinematics::Layout::Omni { wheel_radius, .. } => wheel_radius,
            r2p_world::kinematics::Layout::Differential { wheel_radius, .. } => wheel_radius,
        }
    }
}

#[test]
fn spin_in_place_reaches_the_hand_solved_steady_state() {
    let robot = common::triskar();
    let mut w = World::from_robot(&robot);
    drive(&mut w, &MOTORS, &[0.4; 3]);
    w.step(3.0);
    // Pure rotation: every contact moves tangentially at L·ωz; rolling resistance
    // Crr·m·g/3 per wheel, smoothed as the model states (v/√(v² + vs²)).
    let (l, m) = (0.25, robot.base.params.mass_kg);
    let crr = robot.base.params.rolling_resistance;
    let vs = robot.base.params.rolling_smoothing;
    let per_wheel = crr * m * r2p_world::base::G / 3.0;
    let hand = Hand { ocv: w.battery().ocv(), bus_w: 5.0 * w.bus_load_a() / 0.85, robot };
    let wz = hand.solve(&[(l, 1.0); 3], 0.4, |s| per_wheel * (l * s) / (l * s).hypot(vs));
    let t = w.twist();
    // The scheme's fixed point is the exact steady state; after 3 s ≈ 58 mechanical time
    // constants (52 ms) the transient is gone to e^-58, and the battery's OCV drifts by
    // < 1e-4 V over the run, moving the steady state by < 1e-6.
    assert!((t.wz - wz).abs() < 1e-6 * wz, "ωz {} vs hand-solved {wz}", t.wz);
    assert!((wz - 4.107).abs() < 0.001, "{wz}"); // about 39 rpm
                                                 // By symmetry the centre does not move.
    let p = w.pose();
    assert!(
        p.x.abs() < 1e-9 && p.y.abs() < 1e-9 && t.vx.abs() < 1e-9 && t.vy.abs() < 1e-9,
        "{p:?} {t:?}"
    );
}

#[test]
fn two_wheels_translate_the_base_straight() {
    // Wheels at 60° and 300° driven oppositely, the 180° wheel braked: its rim does not move
    // for motion along x (its rollers do), so the base goes straight ahead.
    let robot = common::triskar();
    let mut w = World::from_robot(&robot);
    drive(&mut w, &["motor1", "motor3"], &[-0.5, 0.5]);
    w.set_output("motor2", "DRV_EN", true).unwrap();
    w.set_pwm("motor2", "PWM_AH", 0.0).unwrap();
    w.set_pwm("motor2", "PWM_BH", 0.0).unwrap();
    w.step(3.0);
    let t = w.twist();
    // Force balance along x: √3·τw/r = Crr·m·g (all three contacts move at vx).
    let m = robot.base.params.mass_kg;
    let crr = robot.base.params.rolling_resistance;
    let vs = robot.base.params.rolling_smoothing;
    let total = crr * m * r2p_world::base::G;
    let hand = Hand { ocv: w.battery().ocv(), bus_w: 5.0 * w.bus_load_a() / 0.85, robot };
    let k = 3f64.sqrt() / 2.0; // rim speed per m/s of vx
    let vx = hand.solve(&[(k, -1.0), (k, 1.0)], 0.5, |s| total / 3f64.sqrt() * s / s.hypot(vs));
    assert!((t.vx - vx).abs() < 1e-6 * vx, "vx {} vs hand-solved {vx}", t.vx);
    assert!(t.vy.abs() < 1e-9 && t.wz.abs() < 1e-9, "{t:?}");
    assert!(w.pose().theta.abs() < 1e-9 && w.pose().y.abs() < 1e-9);
    assert!(w.wheel(1).wheel_speed.abs() < 1e-9, "braked wheel stays still");
    assert!((vx - 1.492).abs() < 0.001, "{vx}");
}

#[test]
fn odometry_from_the_16_bit_counters_matches_the_pose() {
    // Read the three u16 counters every millisecond as the firmware does, unwrap them, and
    // integrate forward kinematics: the heading agrees with the world's to within one count
    // (wheel angle 2π/(4·500·15), base angle that times r/L).
    let mut w = common::triskar_world();
    let kin = w.kinematics().clone();
    drive(&mut w, &MOTORS, &[0.3, -0.2, 0.6]);
    let mut last: Vec<u16> = MOTORS.iter().map(|b| w.read_counter(b, "ENC_A").unwrap()).collect();
    let mut odo = Pose::default();
    let per_count = std::f64::consts::TAU / (4.0 * 500.0 * 15.0);
    for _ in 0..2000 {
        w.step(0.001);
        let mut dw = [0.0; 3];
        for (k, b) in MOTORS.iter().enumerate() {
            let c = w.read_counter(b, "ENC_A").unwrap();
            dw[k] = f64::from(c.wrapping_sub(last[k]) as i16) * per_count;
            last[k] = c;
        }
        odo.integrate(&kin.forward(&dw), 1.0);
    }
    let p = w.pose();
    let counts_total: f64 =
        (0..3).map(|k| w.wheel(k).motor_angle.abs()).sum::<f64>() / per_count / 15.0;
    assert!(counts_total > 3.0 * 65_536.0, "the counters wrapped several times: {counts_total}");
    let tol = 3.0 * per_count * 0.05 / 0.25 * 2.0; // ≤ one count per wheel, either end
    assert!((odo.theta - p.theta).abs() < tol, "{} vs {}", odo.theta, p.theta);
    // Position: the same count error over a lever of ≤ 1 m.
    assert!((odo.x - p.x).abs() < 0.01 && (odo.y - p.y).abs() < 0.01, "{odo:?} vs {p:?}");
}

#[test]
fn energy_is_conserved_to_first_order_in_the_sub_step() {
    // Accelerate, reverse, brake, coast: the energy drawn from the battery's source equals
    // storage + losses + bus, up to integration error. A first-order scheme's error halves
    // with the sub-step; a missing or wrong term would not shrink.
    // Residual after each phase, and the world.
    fn run(substep_ns: u64) -> (Vec<f64>, World) {
        let mut w = common::triskar_world();
        w.set_substep_ns(substep_ns);
        let mut r = Vec::new();
        drive(&mut w, &MOTORS, &[0.9, -0.3, 0.5]);
        w.step(0.4);
        r.push(w.energy_residual_j());
        drive(&mut w, &MOTORS, &[-0.6, 0.8, -0.2]);
        w.step(0.4);
        r.push(w.energy_residual_j());
        for b in MOTORS {
            w.set_pwm(b, "PWM_AH", 0.0).unwrap();
            w.set_pwm(b, "PWM_BH", 0.0).unwrap();
        }
        w.step(0.1);
        r.push(w.energy_residual_j());
        for b in MOTORS {
            w.set_output(b, "DRV_EN", false).unwrap();
        }
        w.step(0.2);
        r.push(w.energy_residual_j());
        (r, w)
    }
    let (e1, w) = run(20_000);
    let (e2, _) = run(10_000);
    let drawn = w.energy().chemical_j;
    // Smooth acceleration from rest: the asymptotic first-order regime (measured ratios
    // 2.14, 2.07, 2.03, 2.02 from 80 µs down to 5 µs).
    let ratio = e1[0] / e2[0];
    assert!((1.8..2.3).contains(&ratio), "residual ratio {ratio}: {e1:?} J vs {e2:?} J");
    // Reversal, braking and coasting add error terms of both signs (mode switches of
    // gearbox and diodes), but every phase's residual still shrinks with the sub-step. Each
    // phase's own share: the running sum may cross zero where one phase's error cancels the
    // last's (the motor boards' bulk capacitors, which smooth the battery's steps, do so after
    // the reversal).
    let phase = |e: &[f64], k: usize| e[k] - if k == 0 { 0.0 } else { e[k - 1] };
    for k in 0..e1.len() {
        let (a, b) = (phase(&e1, k), phase(&e2, k));
        assert!(b.abs() < 0.8 * a.abs(), "phase {k}: {e1:?} J vs {e2:?} J");
    }
    // And it is tiny: ~1.5e-6 of the 319 J drawn.
    assert!(e1[3].abs() < 1e-5 * drawn, "{e1:?} J of {drawn} J");
    // Every loss is there: coasting lost energy in the diodes, braking in the windings.
    let l = w.energy();
    assert!(l.diode_loss_j > 0.0 && l.gear_loss_j > 0.0 && l.rolling_loss_j > 0.0, "{l:?}");
    // Charge: the battery's coulomb count is the bridges' and the converter's draw.
    let used = w.battery().charge_used_ah() * 3600.0;
    assert!(
        (used - l.motor_charge_c - l.bus_charge_c).abs() < 1e-12 * used.abs(),
        "{used} vs {l:?}"
    );
}

#[test]
fn psu_adc_reads_battery_voltage_and_current() {
    let mut w = common::triskar_world();
    drive(&mut w, &MOTORS, &[0.25, 0.25, 0.25]);
    w.step(0.05); // accelerating: a few amps, inside the 13.2 A full scale
                  // 2000 reads: the mean of N(0, 1 LSB) noise plus quantisation has σ ≈ 1.04/√2000 =
                  // 0.023 LSB; 0.15 LSB is 6σ.
    let lsb = ADC.lsb();
    let vin = mean_adc(&mut w, "psu", "VIN_SENSE", 2000) * lsb / frontends::VIN_SENSE.ratio();
    let tol = 0.15 * lsb / frontends::VIN_SENSE.ratio();
    assert!((vin - w.supply_voltage()).abs() < tol, "{vin} vs {}", w.supply_voltage());
    assert!(w.supply_voltage() < w.battery().ocv() - 0.1, "the load pulls the battery down");
    let iin = mean_adc(&mut w, "psu", "IIN_SENSE", 2000) * lsb
        / (frontends::IIN_SHUNT_OHM * frontends::IIN_GAIN);
    let tol = 0.15 * lsb / 0.25;
    // The shunt carries the PSU's own input (the bus load through the converter), not the
    // motors': they draw from the battery directly.
    let own = w.psu_input_current();
    assert!((iin - own).abs() < tol, "{iin} vs {own}");
    let expect = 5.0 * w.bus_load_a() / 0.85 / w.supply_voltage();
    assert!((own - expect).abs() < 0.02 * expect, "{own} vs {expect}");
    assert!(w.battery().current() > 1.0 + own, "the motors draw from the battery as well");
    let vout = mean_adc(&mut w, "psu", "VOUT_SENSE", 2000) * lsb * 2.0;
    assert!((vout - 5.0).abs() < 0.15 * lsb * 2.0, "{vout}");
}

#[test]
fn motor_adc_reads_current_and_supply() {
    let mut w = common::triskar_world();
    drive(&mut w, &MOTORS, &[0.8, 0.8, 0.8]);
    w.step(0.05);
    // Hall noise 6 mV (7.4 LSB) plus ADC noise, 4000 reads: σ_mean ≈ 0.12 LSB; 6σ.
    let lsb = ADC.lsb();
    let sens = frontends::MOTOR_CURRENT.sensitivity();
    let i = (mean_adc(&mut w, "motor1", "MOTOR_CURRENT", 4000) * lsb - 1.65) / sens;
    let truth = w.wheel(0).motor_current;
    assert!((i - truth).abs() < 0.72 * lsb / sens, "{i} vs {truth}");
    let vmot = mean_adc(&mut w, "motor2", "VMOT_SENSE", 2000) * lsb / frontends::VMOT_SENSE.ratio();
    assert!((vmot - w.supply_voltage()).abs() < 0.15 * lsb * 11.0, "{vmot}");
}

#[test]
fn driver_enable_fault_and_brake() {
    let mut w = common::triskar_world();
    // DRV_EN resets low: PWM alone does nothing.
    w.set_pwm("motor1", "PWM_AH", 0.9).unwrap();
    w.set_pwm("motor1", "PWM_BH", 0.1).unwrap();
    w.step(0.1);
    assert_eq!(w.wheel(0).motor_current, 0.0);
    assert!(w.read_input("motor1", "DRV_FAULT").unwrap(), "no fault: pin high");
    w.set_output("motor1", "DRV_EN", true).unwrap();
    w.step(0.2);
    assert!(w.wheel(0).motor_speed > 100.0);
    // Brake: both low sides on. The winding is shorted, and as the electrical time constant
    // (0.2 ms) is far below the mechanical one the current follows −Ke·ω/(R + 2·Rds).
    w.set_pwm("motor1", "PWM_AH", 0.0).unwrap();
    w.set_pwm("motor1", "PWM_BH", 0.0).unwrap();
    w.step(0.01);
    let s = w.wheel(0);
    let p = r2p_world::motor::MotorParams::MAXON_RE35_24V;
    let expect = -p.torque_constant * s.motor_speed / (p.resistance_ohm + 0.02);
    // Quasi-static lag: i tracks ω with τe; ω̇·τe·Kt/R is < 1 % of i here.
    assert!(
        (s.motor_current - expect).abs() < 0.01 * expect.abs(),
        "{} vs {expect}",
        s.motor_current
    );
    assert!(s.load_torque * s.motor_speed < 0.0, "the load drives the braking motor");
    // Injected driver fault: DRV_FAULT low, bridge open, current gone within a millisecond.
    w.set_pwm("motor1", "PWM_AH", 0.9).unwrap();
    w.set_driver_fault("motor1", true).unwrap();
    assert!(!w.read_input("motor1", "DRV_FAULT").unwrap());
    w.step(0.002);
    assert_eq!(w.wheel(0).motor_current, 0.0);
    assert!(w.wheel(0).driver_fault);
}

#[test]
fn bus_switch_and_over_current_trip() {
    let mut w = common::triskar_world();
    let lsb = ADC.lsb();
    assert!(w.read_input("psu", "BUS_FAULT").unwrap());
    w.set_output("psu", "BUS_EN", false).unwrap();
    w.step(0.001);
    assert_eq!(w.bus_voltage(), 0.0);
    assert!(mean_adc(&mut w, "psu", "VOUT_SENSE", 200) < 1.0);
    w.set_output("psu", "BUS_EN", true).unwrap();
    w.step(0.001);
    assert!((mean_adc(&mut w, "psu", "VOUT_SENSE", 200) * lsb * 2.0 - 5.0).abs() < 0.01);
    // 5 A on a 4 A switch: trips, latches, BUS_FAULT low, until BUS_EN is cycled.
    w.set_bus_load_a(5.0);
    w.step(0.001);
    assert!(!w.read_input("psu", "BUS_FAULT").unwrap());
    assert_eq!(w.bus_voltage(), 0.0);
    w.set_bus_load_a(0.5);
    w.step(0.001);
    assert_eq!(w.bus_voltage(), 0.0, "latched");
    w.set_output("psu", "BUS_EN", false).unwrap();
    w.set_output("psu", "BUS_EN", true).unwrap();
    w.step(0.001);
    assert_eq!(w.bus_voltage(), 5.0);
    assert!(w.read_input("psu", "BUS_FAULT").unwrap());
}

/// Distance read on a proximity channel: `n` ranger measurements, each read once through
/// the ADC, voltages averaged, then inverted through the curve.
fn measured_volts(w: &mut World, board: &str, signal: &str, n: usize) -> f64 {
    let mut sum = 0.0;
    for _ in 0..n {
        w.step(0.05); // a new measurement each time (periods 38.3 and 49 ms)
        sum += f64::from(w.read_adc(board, signal).unwrap()) * ADC.lsb();
    }
    sum / n as f64
}

#[test]
fn rangers_see_the_room_through_their_curves() {
    let mut w = common::triskar_world();
    // Front GP2Y0A02 at (0.3, 0) facing the box at x = 1.0: 0.70 m. Averaging 100
    // measurements leaves σ = 10 mV/√100 = 1 mV of sensor noise, 1.2 mm at the curve's
    // 0.9 V/m there, plus ADC rounding (< 1 mm): 6 mm bounds it.
    let v = measured_volts(&mut w, "proximity", "PROX_CH0", 100);
    match GP2Y0A02YK.classify(v as f32) {
        Reading::Distance(d) => assert!((f64::from(d) - 0.70).abs() < 0.006, "{d}"),
        r => panic!("{r:?} at {v} V"),
    }
    // Rear GP2Y0A21 at (−0.3, 0) facing the post at (−0.9, 0), r = 0.1: 0.50 m (1.1 V/m).
    let v = measured_volts(&mut w, "proximity", "PROX_CH2", 100);
    match GP2Y0A21YK.classify(v as f32) {
        Reading::Distance(d) => assert!((f64::from(d) - 0.50).abs() < 0.006, "{d}"),
        r => panic!("{r:?} at {v} V"),
    }
    // Left: the wall 1.7 m away is beyond the GP2Y0A21's 80 cm: too far, not a distance.
    let v = measured_volts(&mut w, "proximity", "PROX_CH1", 10);
    assert_eq!(GP2Y0A21YK.classify(v as f32), Reading::TooFar, "{v} V");
    // Unplugged: the pull-down reads 0 V, "no sensor".
    w.set_ranger_connected("proximity", 3, false).unwrap();
    let v = measured_volts(&mut w, "proximity", "PROX_CH3", 10);
    assert!(v < f64::from(NO_SENSOR_BELOW_V), "{v} V: no sensor");
    // Sensors' 5 V switched off: every channel reads 0 V.
    w.set_output("proximity", "SENSOR_PWR_EN", false).unwrap();
    let v = measured_volts(&mut w, "proximity", "PROX_CH0", 3);
    assert!(v < 0.005, "{v}");
    // Back on: a fresh measurement within one period.
    w.set_output("proximity", "SENSOR_PWR_EN", true).unwrap();
    let v = measured_volts(&mut w, "proximity", "PROX_CH0", 2);
    assert!((v - 0.90).abs() < 0.05, "{v}");
    // Too near: 0.15 m from the box, below the GP2Y0A02's 20 cm, reads above its range.
    w.set_pose(Pose::new(0.55, 0.0, 0.0));
    let v = measured_volts(&mut w, "proximity", "PROX_CH0", 5);
    assert_eq!(GP2Y0A02YK.classify(v as f32), Reading::TooNear, "{v} V");
}

#[test]
fn sonar_on_a_differential_base() {
    let mut w = World::from_robot(&common::diff());
    // Sonar at (0.2, 0) facing the wall at x = 3: 2.8 m = 110.2 in → the 110 in step.
    let v = measured_volts(&mut w, "prox", "PROX_CH0", 20);
    let inches = v / (5.0 / 512.0);
    assert!((inches - 110.0).abs() < 0.2, "{inches}");
    assert!(
        matches!(MAXSONAR_LV_EZ_5V.classify(v as f32), Reading::Distance(d) if (f64::from(d) - 2.794).abs() < 0.01)
    );
    // Drive straight at it: equal duties, no turning.
    drive(&mut w, &["left", "right"], &[0.3, 0.3]);
    w.step(1.0);
    assert!(w.twist().vx > 0.1 && w.twist().wz.abs() < 1e-9 && w.pose().y.abs() < 1e-9);
    // Turn: opposite duties spin it in place.
    drive(&mut w, &["left", "right"], &[-0.3, 0.3]);
    w.step(1.0);
    assert!(w.twist().wz > 1.0 && w.twist().vx.abs() < 1e-6, "{:?}", w.twist());
}

#[test]
fn io_errors_name_board_and_signal() {
    let mut w = common::triskar_world();
    let e = w.read_adc("motor9", "MOTOR_CURRENT").unwrap_err().to_string();
    assert!(e.contains("no board `motor9`") && e.contains("motor1, motor2, motor3"), "{e}");
    let e = w.read_adc("motor1", "ENC_A").unwrap_err().to_string();
    assert_eq!(e, "board `motor1` (motor) has no analog input `ENC_A` (analog inputs: MOTOR_CURRENT, VMOT_SENSE)");
    let e = w.set_pwm("psu", "PWM_AH", 0.5).unwrap_err().to_string();
    assert!(e.contains("(PWM outputs: none)"), "{e}");
    let e = w.set_ranger_connected("proximity", 3, false).map(|_| "").unwrap_or("err");
    assert_eq!(e, "");
    let e = w.set_encoder_connected("psu", false).unwrap_err().to_string();
    assert!(e.contains("not a motor board"), "{e}");
    assert!(w.set_pwm("motor1", "PWM_AH", f64::NAN).is_err());
    let names: Vec<&str> = w.boards().map(|b| b.name).collect();
    assert_eq!(names, ["psu", "motor1", "motor2", "motor3", "proximity", "gateway"]);
}

#[test]
fn encoder_disconnection_freezes_the_counter() {
    let mut w = common::triskar_world();
    drive(&mut w, &MOTORS, &[0.5; 3]);
    w.step(0.1);
    w.set_encoder_connected("motor2", false).unwrap();
    let frozen = w.read_counter("motor2", "ENC_A").unwrap();
    let moving = w.read_counter("motor1", "ENC_A").unwrap();
    w.step(0.1);
    assert_eq!(w.read_counter("motor2", "ENC_A").unwrap(), frozen);
    assert_ne!(w.read_counter("motor1", "ENC_A").unwrap(), moving);
    assert!(w.wheel(1).motor_speed > 100.0, "the motor still turns");
}

#[test]
fn braking_back_drives_the_gearboxes() {
    // Spinning base, all bridges braking: the motors generate, so each gearbox passes the
    // motor's torque to the wheel multiplied by N/η (not N·η). Check the base's angular
    // deceleration (central difference over ±1 ms) against I_tot·ω̇z = Σ(L/r)·(N/η)·τshaft −
    // L·Crr·m·g, with I_tot = I + 3(L/r)²(Jw + (N/η)·N·Jrotor).
    let robot = common::triskar();
    let mut w = World::from_robot(&robot);
    drive(&mut w, &MOTORS, &[0.6; 3]);
    w.step(1.0);
    for b in MOTORS {
        w.set_pwm(b, "PWM_AH", 0.0).unwrap();
        w.set_pwm(b, "PWM_BH", 0.0).unwrap();
    }
    w.step(0.005);
    let before = w.twist().wz;
    w.step(0.001);
    let now = w.twist().wz;
    let states: Vec<_> = (0..3).map(|k| w.wheel(k)).collect();
    w.step(0.001);
    let acc = (w.twist().wz - before) / 0.002;
    let p = robot.drive.motor;
    let (n, eta) = (robot.drive.gearbox.ratio, robot.drive.gearbox.efficiency);
    let (l, r) = (0.25, 0.05);
    let b = &robot.base;
    let shaft: f64 = states
        .iter()
        .map(|s| p.torque_constant * s.motor_current - p.friction(s.motor_speed))
        .sum();
    let roll = l * b.params.rolling_resistance * b.params.mass_kg * r2p_world::base::G;
    let inertia = b.params.inertia_kg_m2
        + 3.0 * (l / r).powi(2) * (b.wheel_inertia_kg_m2 + n / eta * n * p.rotor_inertia);
    let expect = ((l / r) * (n / eta) * shaft - roll) / inertia;
    assert!(now > 1.0 && acc < 0.0, "braking from {now} rad/s: {acc}");
    // Central difference error ~ (Δt/τ)² with τ ≈ 30 ms: ≈ 0.1 %; 1 % bounds it. With N·η
    // instead of N/η the deceleration would differ by a third.
    assert!((acc - expect).abs() < 0.01 * expect.abs(), "{acc} vs {expect}");
    assert!(states.iter().all(|s| s.load_torque * s.motor_speed < 0.0), "generating");
}

/// Sign-magnitude drive of duty `d` on motor board `board`, as the motor image applies it.
fn sign_magnitude(w: &mut World, board: &str, d: f64) {
    w.set_output(board, "DRV_EN", true).unwrap();
    w.set_pwm(board, "PWM_AH", d.max(0.0)).unwrap();
    w.set_pwm(board, "PWM_BH", (-d).max(0.0)).unwrap();
}

#[test]
fn the_current_sampled_at_the_pwm_centre_is_the_average_and_out_of_step_it_is_not() {
    let mut w = common::triskar_world();
    sign_magnitude(&mut w, "motor1", 0.5);
    w.step(0.05);
    // A quarter period on: the end of the high side's pulse, the ripple's peak.
    w.advance_ns(12_500);
    assert!((w.pwm_phase() - 0.25).abs() < 1e-12, "{}", w.pwm_phase());
    let truth = w.wheel(0).motor_current;
    let vs = w.motor_bus_voltage();
    let p = r2p_world::motor::MotorParams::MAXON_RE35_24V;
    // Vs·d(1 − d)/(2·L·f): 1.3 A at 25 V into 0.119 mH, 20 kHz (README: up to 1.4 A on the
    // board at 44 V into 0.2 mH).
    let half = vs * 0.25 / (2.0 * p.inductance_h * 20_000.0);
    assert!(half > 1.2, "{half}");
    // 4000 reads of each: Hall noise 6 mV (7.4 LSB) plus the ADC's, σ_mean ≈ 0.12 LSB, 6σ.
    let lsb = ADC.lsb();
    let sens = frontends::MOTOR_CURRENT.sensitivity();
    let tol = 0.72 * lsb / sens;
    let amps = |code: f64| (code * lsb - 1.65) / sens;
    let n = 4000;
    let centre = amps(mean_adc(&mut w, "motor1", "MOTOR_CURRENT", n));
    let now = amps(
        (0..n).map(|_| f64::from(w.read_adc_now("motor1", "MOTOR_CURRENT").unwrap())).sum::<f64>()
            / n as f64,
    );
    println!(
        "average {truth:.3} A: at TIM1's update {centre:.3} A, a quarter period later {now:.3} A"
    );
    assert!((centre - truth).abs() < tol, "triggered at the centre: {centre} vs {truth}");
    assert!((now - truth - half).abs() < tol, "at the pulse's end: {now} vs {truth} + {half}");
    // Half a period on (the top of the count, the middle of the low side's time): the average.
    w.advance_ns(12_500);
    let top = amps(
        (0..n).map(|_| f64::from(w.read_adc_now("motor1", "MOTOR_CURRENT").unwrap())).sum::<f64>()
            / n as f64,
    );
    assert!((top - w.wheel(0).motor_current).abs() < tol, "{top}");
    // A quarter period before the bottom: the trough (the pin now, noise-free).
    w.advance_ns(12_500);
    let trough = w.pin_volts("motor1", "MOTOR_CURRENT").unwrap();
    let i = w.wheel(0).motor_current;
    assert!((frontends::MOTOR_CURRENT.amps(trough) - (i - half)).abs() < 0.02 * half, "{trough}");
}

#[test]
fn braking_into_a_supply_that_cannot_sink_charges_the_bulk_to_the_over_voltage_trip() {
    use r2p_world::motor_bus::{MotorSupply, OVER_VOLTAGE_TRIP_V};
    let mut w = common::triskar_world();
    for b in MOTORS {
        sign_magnitude(&mut w, b, 0.8);
    }
    w.step(0.5);
    w.set_motor_supply(MotorSupply::SourceOnly { drop_v: 0.5 });
    w.step(0.05);
    let driving = w.motor_bus_voltage();
    assert!((driving - (w.supply_voltage() - 0.5)).abs() < 1e-9, "the diode conducts: {driving}");
    // Down to 20 % at speed: the windings return current, the diode blocks, the 12 mF charge.
    for b in MOTORS {
        sign_magnitude(&mut w, b, 0.2);
    }
    let (mut peak, mut tripped_at, mut battery_min) = (0.0f64, None, f64::MAX);
    for ms in 0..200 {
        w.step(0.001);
        peak = peak.max(w.motor_bus_voltage());
        battery_min = battery_min.min(w.battery().current());
        if tripped_at.is_none() && !w.read_input("motor1", "DRV_FAULT").unwrap() {
            tripped_at = Some(ms);
            assert!(w.wheel(0).driver_fault && w.wheel(2).driver_fault);
        }
    }
    let tripped_at = tripped_at.expect("the over-voltage comparator fired");
    println!("bus {driving:.2} V → trip after {tripped_at} ms, peak {peak:.2} V");
    assert!(tripped_at < 100, "{tripped_at} ms");
    // The comparator coasts the bridges: a back-EMF below the bus returns nothing, so the bus
    // stops at the trip (plus a sub-step's charge), below the TVS's 50 V.
    assert!((OVER_VOLTAGE_TRIP_V..OVER_VOLTAGE_TRIP_V + 0.5).contains(&peak), "{peak}");
    assert!(battery_min >= 0.0, "the battery never took charge: {battery_min}");
    // VMOT_SENSE reads the bus, not the battery.
    let vmot =
        mean_adc(&mut w, "motor2", "VMOT_SENSE", 2000) * ADC.lsb() / frontends::VMOT_SENSE.ratio();
    assert!((vmot - w.motor_bus_voltage()).abs() < 0.15 * ADC.lsb() * 16.0 * 11.0, "{vmot}");
    assert!(vmot > w.supply_voltage() + 15.0, "{vmot} V over a {} V battery", w.supply_voltage());
}
