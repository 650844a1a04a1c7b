//! The TFmini-S driver (r2p-drivers) against the emulator's paced UART and TFmini-S model,
//! fed by the world's LiDAR model looking at the Triskar2 room's box.

use r2p_drivers::tfmini::{Range, Tfmini};
use r2p_emu::periph::tfmini::TfminiModel;
use r2p_emu::periph::uart::{SimUart, UartError};
use r2p_world::lidar::{Lidar, LidarParams};
use r2p_world::{Pose, Robot, World};

const BAUD: u32 = 115_200;

/// World, LiDAR model, sensor model and the driver on its UART, stepped every 1 ms.
struct Rig {
    world: World,
    lidar: Lidar,
    sensor: TfminiModel,
    drv: Tfmini<SimUart>,
    overrun_errors: u32,
    ranges_cm: Vec<i16>,
}

impl Rig {
    /// The LiDAR at the front ranger's mount (0.30 m ahead), the box face 0.70 m ahead of it.
    fn new(seed: u64, rx_capacity: usize) -> Self {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../robots/triskar2.toml");
        Rig {
            world: World::from_robot(&Robot::load(path).unwrap()),
            lidar: Lidar::new(LidarParams::TFMINI_S, Pose::new(0.30, 0.0, 0.0), seed, 900),
            sensor: TfminiModel::new(),
            drv: Tfmini::new(SimUart::new(BAUD, rx_capacity)),
            overrun_errors: 0,
            ranges_cm: Vec::new(),
        }
    }

    /// Runs `ms` milliseconds, polling the driver every `poll_every` ms.
    fn run(&mut self, ms: u64, poll_every: u64) {
        for _ in 0..ms {
            let t = self.world.time_ns() + 1_000_000;
            self.world.advance_to_ns(t);
            self.sensor.update(t, self.drv.uart_mut(), &mut self.lidar, &self.world);
            self.drv.uart_mut().advance_to(t);
            if (t / 1_000_000).is_multiple_of(poll_every) {
                self.poll();
            }
        }
    }

    fn poll(&mut self) {
        loop {
            match self.drv.poll() {
                Ok(Some(f)) => self.ranges_cm.push(f.dist),
                Ok(None) => return,
                Err(UartError::Overrun) => self.overrun_errors += 1,
                Err(e) => panic!("{e}"),
            }
        }
    }

    /// Bytes the sensor sent that have fully arrived (the last frame may be on the wire).
    fn bytes_arrived(&self) -> u64 {
        let s = self.drv.uart().stats();
        s.received + s.overruns
    }
}

#[test]
fn reads_the_box_within_accuracy_at_100_hz() {
    let mut rig = Rig::new(1, 64);
    rig.run(1000, 1);
    // Frames at 10, 20, … 1000 ms; the one sent at 1000 ms is still on the wire (781 µs).
    assert_eq!(rig.sensor.frames(), 100);
    assert_eq!(rig.drv.stats().frames, 99);
    assert_eq!(rig.drv.stats().checksum_errors, 0);
    assert_eq!(rig.drv.stats().discarded_bytes, 0);
    assert_eq!(rig.drv.uart().stats().overruns, 0);
    // Box at 0.70 m: every frame within the ±6 cm accuracy (σ 2 cm; ±8 cm = 4σ), mean
    // within 1 cm.
    let n = rig.ranges_cm.len() as f64;
    assert!(rig.ranges_cm.iter().all(|&d| (d - 70).abs() <= 8), "{:?}", rig.ranges_cm);
    let mean = rig.ranges_cm.iter().map(|&d| f64::from(d)).sum::<f64>() / n;
    assert!((mean - 70.0).abs() < 1.0, "{mean}");
    let f = rig.drv.latest().unwrap();
    assert_eq!(f.strength, (16_000.0f64 * 0.9 / 0.49).min(65_534.0).round() as u16);
    assert_eq!(f.temperature_c(), 40.0);
    assert!(matches!(f.range(), Range::Metres(m) if (m - 0.70).abs() <= 0.08));
}

#[test]
fn bytes_arrive_at_the_baud_rate() {
    let mut rig = Rig::new(1, 64);
    rig.run(10, 1000); // first frame sent at 10 ms, not yet on the MCU side
    let byte_ns = rig.drv.uart().byte_ns();
    assert_eq!(byte_ns, 86_806);
    let t0 = 10_000_000;
    rig.drv.uart_mut().advance_to(t0 + 9 * byte_ns - 1);
    assert_eq!(rig.drv.uart().rx_waiting(), 8);
    assert_eq!(rig.drv.poll(), Ok(None));
    rig.drv.uart_mut().advance_to(t0 + 9 * byte_ns);
    assert!(rig.drv.poll().unwrap().is_some(), "the 9th byte completes the frame");
}

#[test]
fn overrun_bytes_are_counted_and_only_whole_frames_come_through() {
    // A 16-byte buffer read every 25 ms: 2.5 frames (22.5 bytes) arrive between reads.
    let mut rig = Rig::new(1, 16);
    rig.run(1000, 25);
    let uart = rig.drv.uart().stats();
    assert!(uart.overruns > 200, "{uart:?}");
    assert_eq!(uart.received + uart.overruns, rig.bytes_arrived());
    assert!(rig.overrun_errors > 0 && rig.overrun_errors <= 40, "{}", rig.overrun_errors);
    let st = rig.drv.stats();
    // Every received byte is in a frame, dropped by the parser, or still buffered.
    assert!(st.frames as u64 * 9 + st.discarded_bytes as u64 <= uart.received);
    assert!(uart.received - (st.frames as u64 * 9 + st.discarded_bytes as u64) < 9);
    assert!(st.discarded_bytes > 0 && st.frames > 20, "{st:?}");
    assert!(rig.ranges_cm.iter().all(|&d| (d - 70).abs() <= 8), "{:?}", rig.ranges_cm);
}

#[test]
fn corrupted_bytes_fail_the_checksum_and_are_dropped() {
    let mut rig = Rig::new(1, 64);
    rig.drv.uart_mut().corrupt_rx(0.01, 7, 0);
    rig.run(2000, 1);
    let uart = rig.drv.uart().stats();
    let st = rig.drv.stats();
    assert!(uart.corrupted >= 5, "{uart:?}");
    assert!(st.checksum_errors > 0 && u64::from(st.checksum_errors) <= uart.corrupted, "{st:?}");
    // Each corrupted byte spoils at most its own frame (the parser resynchronises inside it).
    assert!(u64::from(st.frames) + uart.corrupted >= 199, "{st:?} {uart:?}");
    assert!(rig.ranges_cm.iter().all(|&d| (d - 70).abs() <= 8), "{:?}", rig.ranges_cm);
}

#[test]
fn frame_rate_command_is_echoed_and_applied() {
    let mut rig = Rig::new(1, 64);
    rig.run(500, 1);
    let before = rig.drv.stats().frames;
    rig.drv.set_frame_rate(50).unwrap();
    rig.run(1000, 1);
    assert_eq!(rig.sensor.commands(), 1);
    assert_eq!(rig.sensor.frame_rate_hz(), 50);
    let got = rig.drv.stats().frames - before;
    assert!((49..=51).contains(&got), "{got} frames in 1 s at 50 Hz");
    // The 6-byte echo is skipped as garbage.
    assert_eq!(rig.drv.stats().discarded_bytes, 6);
    assert_eq!(rig.drv.stats().checksum_errors, 0);
}

#[test]
fn out_of_range_reads_weak_signal() {
    // A dark target (2 % reflectivity: reliable to √(16 000·0.02/100) = 1.79 m), the LiDAR
    // on the left of the base looking north.
    let mut rig = Rig::new(1, 64);
    rig.lidar = Lidar::new(
        LidarParams { reflectivity: 0.02, ..LidarParams::TFMINI_S },
        Pose::new(0.0, 0.3, std::f64::consts::FRAC_PI_2),
        1,
        900,
    );
    // North wall 1.7 m from the mount: strength 16 000·0.02/1.7² = 111 > 100 → valid.
    rig.run(100, 1);
    assert!(rig.ranges_cm.iter().all(|&d| (d - 170).abs() <= 8), "{:?}", rig.ranges_cm);
    // Move the base 0.2 m south: 1.9 m, strength 89 → Dist −1.
    rig.world.set_pose(Pose::new(0.0, -0.2, 0.0));
    rig.ranges_cm.clear();
    rig.run(100, 1);
    // The first frame read was measured before the move (its bytes were on the wire).
    assert_eq!(rig.ranges_cm.len(), 10);
    assert!((rig.ranges_cm[0] - 170).abs() <= 8);
    assert!(rig.ranges_cm[1..].iter().all(|&d| d == -1), "{:?}", rig.ranges_cm);
    assert_eq!(rig.drv.latest().unwrap().range(), Range::WeakSignal);
}

#[test]
fn same_seed_same_frames() {
    let run = |seed| {
        let mut rig = Rig::new(seed, 64);
        rig.run(500, 1);
        rig.ranges_cm
    };
    assert_eq!(run(3), run(3));
    assert_ne!(run(3), run(4));
}
