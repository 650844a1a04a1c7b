//! Same robot file, seed and calls → the same world, bit for bit; noise streams are
//! independent per signal.

mod common;

use r2p_world::{Robot, World};

/// A scripted run: drive, read every board's signals every millisecond, fault an encoder.
/// Returns the digest and every value read.
fn run(robot: &Robot, extra_psu_reads: usize) -> (u64, Vec<u16>, Vec<u16>) {
    let mut w = World::from_robot(robot);
    let motors = ["motor1", "motor2", "motor3"];
    let mut motor_reads = Vec::new();
    let mut other_reads = Vec::new();
    for ms in 0..1500u32 {
        if ms % 100 == 0 {
            for (k, b) in motors.iter().enumerate() {
                let d = 0.1 * f64::from((ms / 100 + k as u32) % 9) - 0.4;
                w.set_output(b, "DRV_EN", true).unwrap();
                w.set_pwm(b, "PWM_AH", (1.0 + d) / 2.0).unwrap();
                w.set_pwm(b, "PWM_BH", (1.0 - d) / 2.0).unwrap();
            }
        }
        if ms == 700 {
            w.set_encoder_connected("motor2", false).unwrap();
        }
        w.step(0.001);
        for b in motors {
            motor_reads.push(w.read_adc(b, "MOTOR_CURRENT").unwrap());
            motor_reads.push(w.read_counter(b, "ENC_A").unwrap());
        }
        for _ in 0..=extra_psu_reads {
            other_reads.push(w.read_adc("psu", "IIN_SENSE").unwrap());
        }
        for ch in ["PROX_CH0", "PROX_CH1", "PROX_CH2", "PROX_CH3"] {
            other_reads.push(w.read_adc("proximity", ch).unwrap());
        }
    }
    (w.state_digest(), motor_reads, other_reads)
}

#[test]
fn same_seed_same_world() {
    let robot = common::triskar();
    let (d1, m1, o1) = run(&robot, 0);
    let (d2, m2, o2) = run(&robot, 0);
    assert_eq!(d1, d2);
    assert_eq!(m1, m2);
    assert_eq!(o1, o2);
}

#[test]
fn another_seed_changes_the_noise_not_the_physics() {
    let robot = common::triskar();
    let mut other = robot.clone();
    other.seed += 1;
    let (d1, m1, _) = run(&robot, 0);
    let (d2, m2, _) = run(&other, 0);
    assert_ne!(d1, d2);
    assert_ne!(m1, m2, "ADC noise differs");
    // Physics does not depend on the noise.
    let mut a = World::from_robot(&robot);
    let mut b = World::from_robot(&other);
    for w in [&mut a, &mut b] {
        w.set_output("motor1", "DRV_EN", true).unwrap();
        w.set_pwm("motor1", "PWM_AH", 0.8).unwrap();
        w.step(0.5);
    }
    assert_eq!(a.pose(), b.pose());
    assert_eq!(a.wheel(0), b.wheel(0));
}

#[test]
fn reading_one_board_more_often_leaves_the_others_noise_alone() {
    let robot = common::triskar();
    let (d1, m1, _) = run(&robot, 0);
    let (d2, m2, _) = run(&robot, 3);
    assert_eq!(m1, m2, "the motor boards read the same values");
    assert_ne!(d1, d2, "the PSU's stream moved on");
}

#[test]
fn step_size_of_the_caller_does_not_matter_when_it_divides_the_sub_step() {
    // 1 ms steps or one 100 ms step: the same 20 µs sub-steps, the same state.
    let robot = common::triskar();
    let mut a = World::from_robot(&robot);
    let mut b = World::from_robot(&robot);
    for w in [&mut a, &mut b] {
        w.set_output("motor3", "DRV_EN", true).unwrap();
        w.set_pwm("motor3", "PWM_AH", 0.9).unwrap();
    }
    for _ in 0..100 {
        a.advance_ns(1_000_000);
    }
    b.advance_ns(100_000_000);
    assert_eq!(a.pose(), b.pose());
    assert_eq!(a.wheel(2), b.wheel(2));
    assert_eq!(a.time_ns(), b.time_ns());
}
