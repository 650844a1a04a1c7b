//! The application driven through `App::step` with raw counts as the LSM6DSO gives them, at
//! its output data rate, polled every millisecond as the MCU and the emulated board do.

use std::boxed::Box;
use std::vec::Vec;

use r2p_drivers::lsm6dso::{AccelScale, GyroScale, RawSample, G};
use r2p_drivers::{lis3mdl, lps22};
use r2p_management::message::Value;
use r2p_middleware::Subscriber;
use r2p_msgs::Imu;
use r2p_node::{ParamStore, RamParams};

use crate::endpoints::SPARE_QUEUE;
use crate::params::{self, COUNT, DEFAULTS};
use crate::{
    App, Endpoints, Reading, Sample, SENSOR_BARO, SENSOR_IMU, SENSOR_MAG, STATUS_CALIBRATING,
    STATUS_NO_DATA, STATUS_OK,
};

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

/// Counts for `v` at sensitivity `per_lsb` (round to nearest, as the sensor's output).
fn counts(v: f32, per_lsb: f32) -> i16 {
    (v / per_lsb).round() as i16
}

struct Rig {
    app: App<'static>,
    params: &'static RamParams<COUNT>,
    sub: &'static Subscriber<'static, Imu, SPARE_QUEUE>,
    published: Vec<(u64, Imu)>,
    now_us: u64,
    /// Next sensor sample, µs (104 Hz).
    next_sample_us: u64,
    fault_led: bool,
    /// The magnetometer's field (µT), or `None` for a magnetometer that does not answer.
    field: Option<[f32; 3]>,
    /// The barometer's pressure (Pa), or `None` for one that does not answer.
    pressure: Option<f32>,
}

/// The Earth's field (µT) a level sensor facing east measures at a site with 23.7 µT
/// horizontal and 41 µT down (Milan-like), declination 0.
const EAST_FIELD: [f32; 3] = [0.0, 23.7, -41.0];

impl Rig {
    fn new(set: &[(u16, Value)]) -> Self {
        let params = leak(RamParams::new(DEFAULTS));
        // The heading from the gyro only (the default) unless a test turns the magnetometer's
        // on: the rig's field does not turn with the rates the tests give.
        assert_eq!(params.get(params::MAG_HEADING), Ok(Value::U32(0)));
        for (i, v) in set {
            params.set(*i, *v).unwrap();
        }
        let ep = Endpoints::leak(params);
        let sub = leak(Subscriber::new());
        ep.imu.topic.subscribe(sub).unwrap();
        Self {
            app: App::new(ep, params),
            params,
            sub,
            published: Vec::new(),
            now_us: 0,
            next_sample_us: 9_615,
            fault_led: false,
            field: Some(EAST_FIELD),
            pressure: Some(101_325.0),
        }
    }

    /// `ms` steps with the sensor reading `raw` at 104 Hz (flagged fresh at the first step
    /// after each sample time, as the data-ready flag is polled).
    fn run(&mut self, ms: u64, raw: RawSample, sensor_ok: bool) {
        for _ in 0..ms {
            let fresh = self.now_us >= self.next_sample_us;
            if fresh {
                self.next_sample_us += 9_615;
            }
            // The magnetometer at 80 Hz, the barometer at 25 Hz, from boot.
            let mag = match self.field {
                None => Reading::Failed,
                Some(f) if self.now_us % 12_500 < 1000 => {
                    Reading::Fresh(lis3mdl::Sample { field_ut: f, temp_c: 25.0, overrun: false })
                }
                Some(_) => Reading::Idle,
            };
            let baro = match self.pressure {
                None => Reading::Failed,
                Some(p) if self.now_us.is_multiple_of(40_000) => {
                    Reading::Fresh(lps22::Sample { pressure_pa: p, temp_c: 25.0, overrun: false })
                }
                Some(_) => Reading::Idle,
            };
            let s = Sample { fresh, raw, sensor_ok, mag, baro, ..Sample::default() };
            self.fault_led = self.app.step(self.now_us, &s).led_fault;
            while let Some(m) = self.sub.try_recv() {
                self.published.push((self.now_us, *m));
            }
            self.now_us += 1000;
        }
    }
}

/// Raw counts for rates (rad/s) and specific force (m/s²) at the default full scales.
fn raw(rate: [f32; 3], accel: [f32; 3]) -> RawSample {
    let g = GyroScale::Dps500.rad_s_per_lsb();
    let a = AccelScale::G4.m_s2_per_lsb();
    RawSample { temp: 1280, gyro: rate.map(|r| counts(r, g)), accel: accel.map(|x| counts(x, a)) }
}

const UP: [f32; 3] = [0.0, 0.0, G];

#[test]
fn readings_are_scaled_with_the_full_scale_set_at_boot() {
    // ±2000 °/s and ±16 g: 1000 counts = 70 °/s; 2049 counts = 1.000 g.
    let mut r = Rig::new(&[
        (params::GYRO_RANGE, Value::U32(4)),
        (params::ACCEL_RANGE, Value::U32(3)),
        (params::BIAS_MS, Value::U32(0)),
    ]);
    assert_eq!(r.app.sensor_config().gyro_scale, GyroScale::Dps2000);
    // Changed after boot: the sensor still runs at what it was set to, and so does scaling.
    r.params.set(params::GYRO_RANGE, Value::U32(0)).unwrap();
    let s = RawSample { temp: -256, gyro: [1000, -1000, 0], accel: [0, 2049, -2049] };
    r.run(20, s, true);
    let m = r.app.state();
    assert!((m.rate[0] - 70f32.to_radians()).abs() < 1e-5, "{:?}", m.rate);
    assert!((m.rate[1] + 70f32.to_radians()).abs() < 1e-5);
    assert!((m.accel[1] - G).abs() < 2e-3 && (m.accel[2] + G).abs() < 2e-3, "{:?}", m.accel);
    assert_eq!(m.temperature, 24.0);
    assert_eq!(r.app.sensor_config().gyro_scale, GyroScale::Dps2000);

    // The defaults: ±500 °/s, ±4 g.
    let mut r = Rig::new(&[(params::BIAS_MS, Value::U32(0))]);
    r.run(20, RawSample { temp: 0, gyro: [0, 0, 1000], accel: [8197, 0, 0] }, true);
    let m = r.app.state();
    assert!((m.rate[2] - 17.5f32.to_radians()).abs() < 1e-5, "{:?}", m.rate);
    assert!((m.accel[0] - G).abs() < 2e-3, "{:?}", m.accel);
}

#[test]
fn the_bias_is_estimated_at_rest_and_removed() {
    // Zero-rate offsets of 0.8, −0.5, 0.9 °/s: within the LSM6DSO's ±1 °/s.
    let offset = [0.8f32, -0.5, 0.9].map(f32::to_radians);
    let still = raw(offset, UP);
    let mut r = Rig::new(&[]);
    r.run(500, still, true);
    assert_eq!(r.app.state().status, STATUS_CALIBRATING);
    assert_eq!(r.app.gyro_bias(), None);
    r.run(600, still, true);
    assert_eq!(r.app.state().status, STATUS_OK);
    let lsb = GyroScale::Dps500.rad_s_per_lsb();
    for (b, o) in r.app.gyro_bias().unwrap().iter().zip(offset) {
        assert!((b - o).abs() <= lsb / 2.0 + 1e-7, "{b} vs {o}");
    }
    // Still for a minute more: the heading does not move, the rates read 0.
    r.run(60_000, still, true);
    let m = r.app.state();
    assert!(m.yaw.abs() < 1e-4, "{}", m.yaw);
    assert!(m.rate.iter().all(|x| x.abs() < 1e-6), "{:?}", m.rate);
    assert!(m.roll.abs() < 1e-4 && m.pitch.abs() < 1e-4);

    // Without the estimate (bias_ms = 0) the same offset (51 counts: 0.8925 °/s) turns the
    // heading: 8.8 ° over the 9.87 s from the second sample to the last.
    // (Within 0.15°: the x and y offsets hold the estimate tilted by the rate the accelerometer
    // must correct, and a tilted body's x and y axes have a share of the vertical.)
    let mut r = Rig::new(&[(params::BIAS_MS, Value::U32(0))]);
    r.run(10_000, still, true);
    let drift = r.app.state().yaw.to_degrees();
    assert!((drift - 0.8925 * 9.865).abs() < 0.15, "{drift}°");
}

#[test]
fn the_heading_integrates_the_z_rate_counter_clockwise_in_radians() {
    let mut r = Rig::new(&[]);
    r.run(1100, raw([0.0; 3], UP), true);
    assert_eq!(r.app.state().status, STATUS_OK);
    // 0.5 rad/s counter-clockwise for 2 s: +1 rad (within the rate's quantisation, 0.15 m°/s).
    let t0 = r.now_us;
    r.run(2000, raw([0.0, 0.0, 0.5], UP), true);
    let dt = (r.now_us - t0) as f32 * 1e-6;
    let yaw = r.app.state().yaw;
    assert!((yaw - 0.5 * dt).abs() < 0.01, "{yaw} rad after {dt} s");
    assert!(r.app.state().rate[2] > 0.49);
    // Clockwise at 1 rad/s for 3 s: 1 − 3 = −2 rad.
    r.run(3000, raw([0.0, 0.0, -1.0], UP), true);
    let yaw = r.app.state().yaw;
    assert!((yaw + 2.0).abs() < 0.02, "{yaw}");
    // On to −4 rad: wrapped to 2π − 4.
    r.run(2000, raw([0.0, 0.0, -1.0], UP), true);
    let yaw = r.app.state().yaw;
    assert!((yaw - (2.0 * core::f32::consts::PI - 4.0)).abs() < 0.03, "{yaw}");
}

#[test]
fn roll_and_pitch_follow_the_accelerometer_at_rest() {
    // Mounted pitched 5° nose down, rolled −3°: level at once when the bias window closes.
    let (p, q) = (5f32.to_radians(), -3f32.to_radians());
    let acc = [-G * p.sin(), G * p.cos() * q.sin(), G * p.cos() * q.cos()];
    let mut r = Rig::new(&[]);
    r.run(1500, raw([0.0; 3], acc), true);
    let m = r.app.state();
    assert!((m.pitch - p).abs() < 2e-3 && (m.roll - q).abs() < 2e-3, "{} {}", m.pitch, m.roll);
}

#[test]
fn publishes_at_its_rate() {
    let mut r = Rig::new(&[(params::RATE_HZ, Value::U32(25))]);
    r.run(2000, raw([0.0; 3], UP), true);
    assert_eq!(r.published.len(), 50);
    assert!(r.published.windows(2).all(|w| w[1].0 - w[0].0 == 40_000));
    assert_eq!(r.published.last().unwrap().1, r.app.state());
}

#[test]
fn a_silent_sensor_reads_no_data_and_lights_the_fault_led() {
    let mut r = Rig::new(&[]);
    r.run(50, raw([0.0; 3], UP), false);
    assert_eq!(r.app.state().status, STATUS_NO_DATA);
    assert!(r.fault_led);
    r.run(1200, raw([0.0; 3], UP), true);
    assert_eq!(r.app.state().status, STATUS_OK);
    assert!(!r.fault_led);
    // Data-ready never set again: lost after 10 periods (~96 ms), not before.
    let mut s = Sample {
        fresh: false,
        raw: raw([0.0; 3], UP),
        sensor_ok: true,
        mag: Reading::Fresh(lis3mdl::Sample { field_ut: EAST_FIELD, ..Default::default() }),
        baro: Reading::Fresh(lps22::Sample { pressure_pa: 101_325.0, ..Default::default() }),
        ..Sample::default()
    };
    let last = r.now_us;
    for k in 0..120 {
        let c = r.app.step(last + k * 1000, &s);
        let lost = r.app.state().status == STATUS_NO_DATA;
        assert_eq!(c.led_fault, lost);
        // The last sample came at most one period before `last`.
        if k <= 86 {
            assert!(!lost, "{k} ms");
        }
        if k >= 98 {
            assert!(lost, "{k} ms");
        }
    }
    s.fresh = true;
    r.app.step(last + 120_000, &s);
    assert_eq!(r.app.state().status, STATUS_OK);
}

/// A register file behind the driver: WHO_AM_I, the status flags and a sample; fails every
/// access when `fail` is set.
struct Regs {
    r: [u8; 128],
    fail: bool,
}

impl r2p_drivers::lsm6dso::RegisterBus for Regs {
    type Error = ();
    fn write_register(&mut self, reg: u8, value: u8) -> Result<(), ()> {
        if self.fail {
            return Err(());
        }
        self.r[usize::from(reg)] = value;
        Ok(())
    }
    fn read_registers(&mut self, reg: u8, buf: &mut [u8]) -> Result<(), ()> {
        if self.fail {
            return Err(());
        }
        let a = usize::from(reg);
        buf.copy_from_slice(&self.r[a..a + buf.len()]);
        Ok(())
    }
}

#[test]
fn the_poll_reads_a_burst_only_on_new_gyro_data_and_reports_bus_errors() {
    use r2p_drivers::lsm6dso::{Lsm6dso, STATUS_REG, WHO_AM_I, WHO_AM_I_VALUE};
    let mut r = [0u8; 128];
    r[usize::from(WHO_AM_I)] = WHO_AM_I_VALUE;
    r[0x20..0x2E].copy_from_slice(&[0, 1, 0xE8, 0x03, 0, 0, 0, 0, 0, 0, 0, 0, 0x05, 0x20]);
    let mut imu = Lsm6dso::new(Regs { r, fail: false });
    imu.init(params::SensorConfig::read(&r2p_node::NoParams).0).unwrap();
    let status = r2p_module::leds::Status::default();
    // No new data (accel only): no burst, the sensor answered.
    let mut bus = imu.release();
    bus.r[usize::from(STATUS_REG)] = 0b001;
    let mut imu = Lsm6dso::new(bus);
    let s = crate::sensor::poll(&mut imu, true, status);
    assert!(s.sensor_ok && !s.fresh);
    // Gyro data ready: the burst, decoded.
    let mut bus = imu.release();
    bus.r[usize::from(STATUS_REG)] = 0b010;
    let mut imu = Lsm6dso::new(bus);
    let s = crate::sensor::poll(&mut imu, true, status);
    assert!(s.sensor_ok && s.fresh);
    assert_eq!(s.raw, RawSample { temp: 256, gyro: [1000, 0, 0], accel: [0, 0, 8197] });
    // Not initialised: nothing read, no data; a failing bus: no data.
    assert!(!crate::sensor::poll(&mut imu, false, status).sensor_ok);
    let mut bus = imu.release();
    bus.fail = true;
    let s = crate::sensor::poll(&mut Lsm6dso::new(bus), true, status);
    assert!(!s.sensor_ok && !s.fresh);
}

/// The field a level sensor at heading `yaw` (ENU, rad) measures at [`EAST_FIELD`]'s site with
/// declination `d` (rad, east).
fn field_at(yaw: f32, d: f32) -> [f32; 3] {
    let a = core::f32::consts::FRAC_PI_2 - d - yaw;
    [23.7 * a.cos(), 23.7 * a.sin(), -41.0]
}

#[test]
fn the_magnetometer_gives_an_absolute_heading_and_holds_it_against_the_gyro_drift() {
    // Facing south-west (yaw −3π/4 from east) at a site with 3° declination; the gyro's z
    // offset (0.9 °/s) is not removed at boot (bias_ms = 0): gyro-only, the heading drifts
    // 54° a minute.
    let (truth, d) = (-3.0 * core::f32::consts::FRAC_PI_4, 3f32.to_radians());
    let still = raw([0.0, 0.0, 0.9f32.to_radians()], UP);
    let mag_on = [
        (params::BIAS_MS, Value::U32(0)),
        (params::MAG_HEADING, Value::U32(1)),
        (params::DECLINATION_DEG, Value::F32(3.0)),
    ];
    let mut r = Rig::new(&mag_on);
    r.field = Some(field_at(truth, d));
    r.run(200, still, true);
    // From the first sample on: the magnetometer's heading, not 0.
    let err = |r: &Rig| crate::attitude::wrap(r.app.state().yaw - truth).to_degrees();
    assert!(err(&r).abs() < 1.0, "{}°", err(&r));
    assert_eq!(r.app.state().sensors, SENSOR_IMU | SENSOR_MAG | SENSOR_BARO);
    // A minute on: held within the proportional term's steady error (the offset times the
    // heading's τ, 0.9 °/s × 5 s = 4.5°) while the integral term learns the offset (τ_b =
    // 100 s); five minutes on, the bias is learnt and the heading is right.
    r.run(60_000, still, true);
    assert!(err(&r).abs() < 4.5, "{}°", err(&r));
    r.run(300_000, still, true);
    assert!(err(&r).abs() < 0.2, "{}°", err(&r));
    let bz = r.app.gyro_bias().unwrap()[2].to_degrees();
    assert!((bz - 0.9).abs() < 0.05, "{bz} °/s");
    // The `mag` topic says the same heading, and the field as measured.
    let m = r.app.mag();
    assert_eq!((m.status, m.raw), (STATUS_OK, field_at(truth, d)));
    assert!(crate::attitude::wrap(m.heading - truth).abs() < 0.01, "{}", m.heading);

    // The declination parameter is what turns magnetic into true north: at 0 the heading is
    // 3° off.
    let mut r = Rig::new(&mag_on[..2]);
    r.field = Some(field_at(truth, d));
    r.run(1000, raw([0.0; 3], UP), true);
    assert!((err(&r) - 3.0).abs() < 0.01, "{}°", err(&r));

    // Gyro only (mag_heading 0), the same robot: the heading drifts with the offset.
    let mut r = Rig::new(&mag_on[..1]);
    r.field = Some(field_at(truth, d));
    r.run(60_000, still, true);
    let drift = crate::attitude::wrap(r.app.state().yaw).to_degrees();
    assert!((drift - 54.0).abs() < 1.0, "{drift}°");
}

#[test]
fn the_calibration_parameters_correct_a_distorted_field() {
    // Hard iron (20, −15, 5) µT and a soft iron that stretches x by 1.3: the raw heading is
    // tens of degrees off; with the inverse in the parameters the heading is right.
    let truth = 0.6f32;
    let b = field_at(truth, 0.0);
    let distorted = [1.3 * b[0] + 20.0, b[1] - 15.0, b[2] + 5.0];
    let base = [(params::MAG_HEADING, Value::U32(1)), (params::BIAS_MS, Value::U32(100))];
    let mut r = Rig::new(&base);
    r.field = Some(distorted);
    r.run(500, raw([0.0; 3], UP), true);
    let off = crate::attitude::wrap(r.app.state().yaw - truth).to_degrees();
    assert!(off.abs() > 10.0, "{off}°");
    let mut cal = base.to_vec();
    cal.extend([
        (params::MAG_OFFSET_X, Value::F32(20.0)),
        (params::MAG_OFFSET_X + 1, Value::F32(-15.0)),
        (params::MAG_OFFSET_X + 2, Value::F32(5.0)),
        (params::MAG_SOFT_XX, Value::F32(1.0 / 1.3)),
    ]);
    let mut r = Rig::new(&cal);
    r.field = Some(distorted);
    r.run(500, raw([0.0; 3], UP), true);
    let off = crate::attitude::wrap(r.app.state().yaw - truth).to_degrees();
    assert!(off.abs() < 0.1, "{off}°");
    assert_eq!(r.app.mag().raw, distorted);
    assert!(r.app.mag().field.iter().zip(b).all(|(f, b)| (f - b).abs() < 1e-4));
}

#[test]
fn a_sensor_unplugged_mid_run_is_reported_and_the_rest_still_published() {
    let mut r = Rig::new(&[(params::MAG_HEADING, Value::U32(1))]);
    r.field = Some(field_at(0.0, 0.0));
    r.run(1500, raw([0.0; 3], UP), true);
    assert_eq!(r.app.state().sensors, SENSOR_IMU | SENSOR_MAG | SENSOR_BARO);
    assert!(!r.fault_led);
    // The magnetometer stops answering: reported at once, the IMU and barometer go on.
    r.field = None;
    let n = r.published.len();
    r.run(1000, raw([0.0, 0.0, 0.2], UP), true);
    let m = r.app.state();
    assert_eq!((m.status, m.sensors), (STATUS_OK, SENSOR_IMU | SENSOR_BARO));
    assert_eq!(r.app.mag().status, STATUS_NO_DATA);
    assert_eq!(r.app.baro().status, STATUS_OK);
    assert!(r.fault_led);
    assert_eq!(r.published.len() - n, 50, "imu still at 50 Hz");
    // The heading goes on with the gyro (0.2 rad/s for ~1 s).
    assert!((m.yaw - 0.2).abs() < 0.01, "{}", m.yaw);
    // The barometer too: both missing, the imu topic still says what it has.
    r.pressure = None;
    r.run(100, raw([0.0; 3], UP), true);
    assert_eq!(r.app.state().sensors, SENSOR_IMU);
    assert_eq!(r.app.baro().status, STATUS_NO_DATA);
    // Back: reported again.
    r.field = Some(field_at(0.2, 0.0));
    r.pressure = Some(101_325.0);
    r.run(100, raw([0.0; 3], UP), true);
    assert_eq!(r.app.state().sensors, SENSOR_IMU | SENSOR_MAG | SENSOR_BARO);
    assert!(!r.fault_led);
}

#[test]
fn the_barometer_gives_the_altitude_under_the_qnh_and_its_topics_their_rates() {
    // 1 000 m in the ISA (89 874.6 Pa under 101 325 Pa).
    let mut r =
        Rig::new(&[(params::MAG_RATE_HZ, Value::U32(20)), (params::BARO_RATE_HZ, Value::U32(5))]);
    r.pressure = Some(89_874.6);
    let sub_mag = leak(Subscriber::<r2p_msgs::MagneticField, SPARE_QUEUE>::new());
    let sub_baro = leak(Subscriber::<r2p_msgs::Barometer, SPARE_QUEUE>::new());
    r.app.endpoints().mag.topic.subscribe(sub_mag).unwrap();
    r.app.endpoints().baro.topic.subscribe(sub_baro).unwrap();
    let (mut mags, mut baros) = (0, 0);
    for _ in 0..2000 {
        r.run(1, raw([0.0; 3], UP), true);
        while sub_mag.try_recv().is_some() {
            mags += 1;
        }
        while sub_baro.try_recv().is_some() {
            baros += 1;
        }
    }
    assert_eq!((mags, baros), (40, 10));
    let b = r.app.baro();
    assert!((b.altitude - 1000.0).abs() < 0.5, "{}", b.altitude);
    assert!(b.vertical_speed.abs() < 1e-3 && b.pressure == 89_874.6 && b.status == STATUS_OK);
    // A QNH of 1 023.25 hPa: 44 330.8 m · (1 − (89 874.6 / 102 325)^0.190263) = 1 080.9 m.
    let mut r = Rig::new(&[(params::QNH_PA, Value::F32(102_325.0))]);
    r.pressure = Some(89_874.6);
    r.run(200, raw([0.0; 3], UP), true);
    assert!((r.app.baro().altitude - 1080.9).abs() < 0.1, "{}", r.app.baro().altitude);
}

#[test]
fn a_parameter_set_while_running_takes_effect_within_the_config_period() {
    // `imu` at 10 Hz, then at 200 Hz from a PARAM_SET at 500 ms: the first message at the new
    // rate comes within CONFIG_PERIOD_US (20 ms) plus its own 5 ms period.
    let mut r = Rig::new(&[(params::RATE_HZ, Value::U32(10)), (params::BIAS_MS, Value::U32(0))]);
    r.run(500, raw([0.0; 3], UP), true);
    let before = r.published.len();
    assert!((4..=6).contains(&before), "{before} messages at 10 Hz in 0.5 s");
    r.params.set(params::RATE_HZ, Value::U32(200)).unwrap();
    r.run(100, raw([0.0; 3], UP), true);
    let after: Vec<u64> = r.published[before..].iter().map(|m| m.0).collect();
    let within = crate::app::CONFIG_PERIOD_US + 5_000;
    assert!(after.iter().any(|&t| t > 500_000 && t <= 500_000 + within), "{after:?}");
    // From then on every 5 ms: 100 ms less the wait gives at least 15.
    assert!(after.len() >= 15, "{} messages in 100 ms after the change", after.len());
}
