//! The IMU and LiDAR models fed by the whole world: what they read of the Triskar2 base
//! spinning up and spinning steadily, and of the room's box.

mod common;

use r2p_world::imu::{ideal_reading, Imu, ImuParams, G};
use r2p_world::lidar::{Lidar, LidarParams};
use r2p_world::{Pose, World};

fn spin(w: &mut World, d: f64) {
    for b in ["motor1", "motor2", "motor3"] {
        w.set_output(b, "DRV_EN", true).unwrap();
        w.set_pwm(b, "PWM_AH", (1.0 + d) / 2.0).unwrap();
        w.set_pwm(b, "PWM_BH", (1.0 - d) / 2.0).unwrap();
    }
}

#[test]
fn twist_rate_is_the_derivative_of_the_twist() {
    // Spinning up: ω̇ from the dynamics matches the finite difference of ω over 1 ms
    // (semi-implicit Euler: exact per sub-step, so within the change of ω̇ over 1 ms).
    let mut w = common::triskar_world();
    spin(&mut w, 0.4);
    w.step(0.05);
    let w0 = w.twist().wz;
    w.step(0.001);
    let (w1, rate) = (w.twist().wz, w.twist_rate().wz);
    let fd = (w1 - w0) / 0.001;
    assert!(rate > 1.0, "spinning up: {rate}");
    assert!((fd - rate).abs() < 0.02 * rate, "finite difference {fd} vs ω̇ {rate}");
    // At rest after set_pose.
    w.set_pose(Pose::default());
    assert_eq!(w.twist_rate().wz, 0.0);
}

#[test]
fn spinning_base_gives_yaw_rate_and_centripetal_acceleration() {
    // 3 s at duty 0.4: steady spin at 4.107 rad/s (tests/world.rs solves it by hand).
    let mut w = common::triskar_world();
    spin(&mut w, 0.4);
    w.step(3.0);
    let wz = w.twist().wz;
    assert!((wz - 4.107).abs() < 0.001, "{wz}");
    // An ideal IMU 0.1 m ahead of the centre: gyro z = ω, accel x = −ω²·0.1 (≈ −1.69 m/s²).
    let mount = Pose::new(0.1, 0.0, 0.0);
    let (g, a) = ideal_reading(&mount, &w.twist(), &w.twist_rate());
    assert_eq!(g[2], wz);
    assert!((a[0] + wz * wz * 0.1).abs() < 1e-6, "{a:?}");
    assert!(a[1].abs() < 1e-6 && a[2] == G, "{a:?}");
    // The LSM6DSO at 104 Hz: mean of 1000 samples within 5 standard errors of its own
    // expected reading, and that within the datasheet's offset and gain bounds of the truth.
    let mut imu = Imu::new(ImuParams::LSM6DSO, mount, 42, 1000);
    let e = imu.expected(&w.twist(), &w.twist_rate());
    let n = 1000;
    let mean = (0..n).map(|_| imu.sample(&w, 104.0).gyro[2]).sum::<f64>() / n as f64;
    let se = ImuParams::LSM6DSO.gyro_sigma(104.0) / (n as f64).sqrt();
    assert!((mean - e.gyro[2]).abs() < 5.0 * se, "{mean} vs {}", e.gyro[2]);
    let bound = 0.01 * wz + 1f64.to_radians();
    assert!((e.gyro[2] - wz).abs() <= bound, "{} vs {wz}", e.gyro[2]);
}

#[test]
fn lidar_on_the_triskar_sees_the_box_ahead() {
    // The box's near face is at x = 1.0; a LiDAR at the front ranger's mount (0.30 m ahead)
    // sees it at 0.70 m.
    let w = common::triskar_world();
    let mut l = Lidar::new(LidarParams::TFMINI_S, Pose::new(0.30, 0.0, 0.0), 5, 0);
    let d = l.true_distance(&w.pose(), w.obstacles()).unwrap();
    assert!((d - 0.70).abs() < 1e-12, "{d}");
    for _ in 0..100 {
        let r = l.measure(&w.pose(), w.obstacles());
        assert!((i32::from(r.dist_cm) - 70).abs() <= 8, "{r:?}");
    }
    // Facing the west wall from the centre: 2 m.
    let mut back =
        Lidar::new(LidarParams::TFMINI_S, Pose::new(0.0, 0.0, std::f64::consts::PI), 5, 1);
    // The round post at x = −0.9 (radius 0.1) is in the way: 0.8 m.
    assert!((back.true_distance(&w.pose(), w.obstacles()).unwrap() - 0.8).abs() < 1e-3);
    assert!((i32::from(back.measure(&w.pose(), w.obstacles()).dist_cm) - 80).abs() <= 8);
}

/// The Triskar2 file with an IMU module 0.1 m ahead of the centre, turned 90°.
fn with_imu() -> World {
    let text = std::fs::read_to_string(common::triskar_path()).unwrap()
        + "\n[[modules]]\nkind = \"imu\"\nname = \"imu\"\nuid = \"0070001F3137510939383538\"\n\
           pose = { x_m = 0.1, y_m = 0.0, theta_deg = 90.0 }\n";
    World::from_robot(&r2p_world::Robot::parse(&text, "triskar-imu.toml").unwrap())
}

#[test]
fn an_imu_board_samples_its_own_device_at_its_mount() {
    let mut w = with_imu();
    let imu = w.imu("imu").unwrap().clone();
    assert_eq!(imu.mount, Pose::new(0.1, 0.0, std::f64::consts::FRAC_PI_2));
    // Its device errors come from the robot's seed: the same file gives the same device.
    assert_eq!(with_imu().imu("imu").unwrap().gyro_offset(), imu.gyro_offset());
    spin(&mut w, 0.4);
    w.step(3.0);
    let wz = w.twist().wz;
    let e = imu.expected(&w.twist(), &w.twist_rate());
    // Turned 90° (its x along the base's y, its y along the base's −x): the centripetal
    // acceleration, ω²·0.1 towards the centre (the base's −x), is along the sensor's +y.
    assert!((e.accel[1] - imu.accel_offset()[1]) > 0.98 * wz * wz * 0.1, "{e:?}");
    assert!((e.accel[0] - imu.accel_offset()[0]).abs() < 0.05, "{e:?}");
    let n = 1000;
    let mean = (0..n).map(|_| w.sample_imu("imu", 104.0).unwrap().gyro[2]).sum::<f64>() / n as f64;
    let se = ImuParams::LSM6DSO.gyro_sigma(104.0) / (n as f64).sqrt();
    assert!((mean - e.gyro[2]).abs() < 5.0 * se, "{mean} vs {}", e.gyro[2]);
    let err = w.sample_imu("motor1", 104.0).unwrap_err().to_string();
    assert_eq!(err, "board `motor1`: is a motor board, not an imu board");
    assert!(w.sample_imu("imu9", 104.0).unwrap_err().to_string().contains("no board `imu9`"));
}
