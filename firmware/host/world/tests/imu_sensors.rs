//! The IMU module's magnetometer, barometer and GNSS receiver in the world (issue 21): what
//! they read of the base's pose at the robot file's site against hand-worked values, the
//! same devices from the same seed, and sensors unplugged and plugged again.

mod common;

use r2p_world::gnss::{FixType, GnssParams};
use r2p_world::imu_module::ImuSensor;
use r2p_world::magnetic::MagParams;
use r2p_world::pressure::{isa_pressure, BaroParams};
use r2p_world::{Pose, Robot, World};

/// The Triskar2 at a site with a round field (F 50 µT, I 60°, D 0: B_enu = (0, 25, −43.301)
/// µT), 300 m up under a 100 000 Pa sea-level pressure, and an IMU module at the centre with
/// the robot's iron: hard (10, −5, 2) µT, soft 1.2 along the base's x.
fn robot(seed: u64, extra: &str) -> Robot {
    let text = std::fs::read_to_string(common::triskar_path())
        .unwrap()
        .replace("seed = 2013", &format!("seed = {seed}"))
        + "\n[site]\nfield_intensity_ut = 50.0\nfield_inclination_deg = 60.0\n\
           field_declination_deg = 0.0\naltitude_m = 300.0\nsea_level_pressure_pa = 100000.0\n\
           \n[[modules]]\nkind = \"imu\"\nname = \"imu\"\nuid = \"0070001F3137510939383538\"\n\
           hard_iron_ut = [10.0, -5.0, 2.0]\n\
           soft_iron = [[1.2, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]\n"
        + extra;
    Robot::parse(&text, "site.toml").unwrap_or_else(|e| panic!("{e}"))
}

fn mean_field(w: &mut World, n: usize) -> [f64; 3] {
    let mut sum = [0.0; 3];
    for _ in 0..n {
        let s = w.sample_magnetometer("imu").unwrap();
        assert_eq!(s.temperature_c, MagParams::LIS3MDL.temperature_c);
        for (acc, b) in sum.iter_mut().zip(s.field_ut) {
            *acc += b;
        }
    }
    sum.map(|x| x / n as f64)
}

#[test]
fn the_magnetometer_reads_the_sites_field_through_the_robots_iron() {
    let mut w = World::from_robot(&robot(2013, ""));
    let offset = w.imu_module("imu").unwrap().magnetometer.offset_ut();
    // Facing east (θ = 0): the base's axes are east, north, up. S·B + h =
    // (1.2·0 + 10, 25 − 5, −43.301 + 2).
    // Facing north (θ = 90°): the base's x is north, its y west: B_base = (25, 0, −43.301),
    // S·B + h = (30 + 10, 0 − 5, −41.301).
    let z = -50.0 * 60f64.to_radians().sin() + 2.0;
    for (theta, hand) in [(0.0, [10.0, 20.0, z]), (90.0, [40.0, -5.0, z])] {
        w.set_pose(Pose::new(0.0, 0.0, f64::to_radians(theta)));
        let want = [0, 1, 2].map(|i| hand[i] + offset[i]);
        let expected = w.imu_module("imu").unwrap().magnetometer.expected(w.pose().theta);
        for i in 0..3 {
            assert!((expected[i] - want[i]).abs() < 1e-9, "{theta}°: {expected:?} vs {want:?}");
        }
        // n = 4000 samples of σ 0.32-0.41 µT: the mean within 5 standard errors (0.025-0.032 µT).
        let n = 4000;
        let mean = mean_field(&mut w, n);
        for i in 0..3 {
            let tol = 5.0 * MagParams::LIS3MDL.noise_ut[i] / (n as f64).sqrt();
            assert!((mean[i] - want[i]).abs() < tol, "{theta}°: {mean:?} vs {want:?}");
        }
    }
    // The device's own offset is within the part's bound.
    assert!(offset.iter().all(|o| o.abs() <= MagParams::LIS3MDL.offset_ut), "{offset:?}");
}

#[test]
fn the_barometer_reads_the_sites_atmosphere_and_the_receiver_its_place() {
    let mut w = World::from_robot(&robot(2013, ""));
    let offset = w.imu_module("imu").unwrap().barometer.offset_pa();
    // 100 000 · (1 − 0.0065 · 300 / 288.15)^5.25588 = 100 000 · e^(5.25588 · −0.0067903)
    // = 96 494.1 Pa.
    let p = isa_pressure(300.0, 100_000.0);
    assert!((p - 96_494.1).abs() < 0.1, "{p}");
    let n = 2000;
    let mean =
        (0..n).map(|_| w.sample_pressure("imu").unwrap().pressure_pa).sum::<f64>() / n as f64;
    let tol = 5.0 * BaroParams::LPS22HH.noise_pa / f64::from(n).sqrt();
    assert!((mean - (p + offset)).abs() < tol, "{mean} vs {}", p + offset);
    assert!(offset.abs() <= BaroParams::LPS22HH.offset_pa);
    // The receiver has no fix before its time to first fix, then one near the antenna.
    w.set_pose(Pose::new(3.0, -4.0, 1.0));
    assert_eq!(w.gnss_antenna("imu").unwrap().enu, [3.0, -4.0, 0.0], "the module at the centre");
    assert_eq!(w.gnss_fix("imu").unwrap().fix, FixType::None);
    w.set_substep_ns(1_000_000);
    w.advance_ns(30_000_000_000);
    let fix = w.gnss_fix("imu").unwrap();
    assert_eq!((fix.fix, fix.satellites), (FixType::Fix3d, GnssParams::UBLOX_M8.satellites));
    let origin = w.site().origin();
    let a = w.gnss_antenna("imu").unwrap();
    let enu = origin.enu_to(&fix.position);
    // Within 5 σ of the receiver's error (σ 2.12 m per horizontal axis, 2 m vertical).
    let (h, v) = (5.0 * GnssParams::UBLOX_M8.sigma_h_m, 5.0 * GnssParams::UBLOX_M8.sigma_v_m);
    assert!((enu[0] - a.enu[0]).abs() < h && (enu[1] - a.enu[1]).abs() < h, "{enu:?}");
    assert!((enu[2] - a.enu[2]).abs() < v, "{enu:?}");
    assert!((origin.height_m - (300.0 + 47.0)).abs() < 1e-9);
}

/// Every sensor's readings for a scripted run.
fn readings(seed: u64) -> Vec<f64> {
    let mut w = World::from_robot(&robot(seed, ""));
    w.set_substep_ns(1_000_000);
    let mut out = Vec::new();
    for k in 0..40 {
        w.set_pose(Pose::new(0.1 * f64::from(k), 0.0, 0.05 * f64::from(k)));
        out.extend(w.sample_magnetometer("imu").unwrap().field_ut);
        out.push(w.sample_pressure("imu").unwrap().pressure_pa);
        out.push(w.gnss_fix("imu").unwrap().position.lat_deg);
        out.extend(w.sample_imu("imu", 104.0).unwrap().gyro);
        w.step(1.0);
    }
    out
}

#[test]
fn the_same_seed_gives_the_same_devices_and_noise() {
    let a = readings(5);
    assert_eq!(a, readings(5));
    let b = readings(6);
    assert!(a.iter().zip(&b).all(|(x, y)| x != y), "another seed: every reading differs");
    // The devices themselves: offsets from the seed.
    let d = |seed| {
        let w = World::from_robot(&robot(seed, ""));
        let m = w.imu_module("imu").unwrap().clone();
        (m.magnetometer.offset_ut(), m.barometer.offset_pa())
    };
    assert_eq!(d(5), d(5));
    assert_ne!(d(5), d(6));
}

#[test]
fn an_unplugged_sensor_cannot_be_sampled_until_plugged_again() {
    let mut w = World::from_robot(&robot(1, "unplugged = [\"gnss\"]\n"));
    assert!(!w.imu_sensor_connected("imu", ImuSensor::Gnss).unwrap());
    let e = w.gnss_fix("imu").unwrap_err().to_string();
    assert_eq!(
        e,
        "board `imu`: its gnss (GNSS receiver) is unplugged: nothing to sample \
         (set_imu_sensor_connected)"
    );
    w.set_imu_sensor_connected("imu", ImuSensor::Gnss, true).unwrap();
    assert!(w.imu_sensor_connected("imu", ImuSensor::Gnss).unwrap());
    assert!(w.gnss_fix("imu").is_ok());
    for (s, sample) in [
        (
            ImuSensor::Magnetometer,
            (|w: &mut World| w.sample_magnetometer("imu").map(|_| ())) as fn(&mut World) -> _,
        ),
        (ImuSensor::Barometer, |w: &mut World| w.sample_pressure("imu").map(|_| ())),
        (ImuSensor::AccelGyro, |w: &mut World| w.sample_imu("imu", 104.0).map(|_| ())),
    ] {
        assert!(sample(&mut w).is_ok());
        w.set_imu_sensor_connected("imu", s, false).unwrap();
        let e = sample(&mut w).unwrap_err().to_string();
        assert!(e.contains(&format!("its {} ({}) is unplugged", s.name(), s.part())), "{e}");
        assert!(!w.imu_sensor_connected("imu", s).unwrap());
        w.set_imu_sensor_connected("imu", s, true).unwrap();
        assert!(sample(&mut w).is_ok());
    }
    // The antenna's truth is there plugged or not; other boards are refused by name.
    w.set_imu_sensor_connected("imu", ImuSensor::Gnss, false).unwrap();
    assert!(w.gnss_antenna("imu").is_ok());
    let e = w.set_imu_sensor_connected("motor1", ImuSensor::Gnss, false).unwrap_err();
    assert_eq!(e.to_string(), "board `motor1`: is a motor board, not an imu board");
    let e = w.sample_magnetometer("imu9").unwrap_err().to_string();
    assert!(e.contains("no board `imu9`"), "{e}");
    let e = w.sample_pressure("psu").unwrap_err().to_string();
    assert_eq!(e, "board `psu`: is a psu board, not an imu board");
    assert!(w.imu_sensor_connected("gateway", ImuSensor::Barometer).is_err());
}
