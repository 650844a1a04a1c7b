//! The IMU module's parameters: the table the node serves over the bus (PARAM_GET / PARAM_SET,
//! ranges checked by the store), the [`Config`] the application reads from it every step, and
//! the sensor set-up ([`SensorConfig`]) fixed at boot.

use r2p_drivers::lsm6dso::{self, AccelScale, GyroScale, Odr};
use r2p_module::param_doc::{boot, doc, ParamDoc};
use r2p_node::{NoParams, Param, ParamStore, Typed};

/// Module instance: selects the node name and topic from [`crate::NAMES`] (at boot).
pub const INSTANCE: u16 = 0;
/// `imu` publication rate, Hz.
pub const RATE_HZ: u16 = 1;
/// Output data rate of both sensors, as the LSM6DSO's ODR code (at boot).
pub const ODR: u16 = 2;
/// Gyroscope full scale, index into [`GYRO_RANGES`] (at boot).
pub const GYRO_RANGE: u16 = 3;
/// Accelerometer full scale, index into [`ACCEL_RANGES`] (at boot).
pub const ACCEL_RANGE: u16 = 4;
/// Length of the still window the gyro bias is averaged over at start, ms.
pub const BIAS_MS: u16 = 5;
/// A gyro sample this far from the window's mean restarts the window, °/s.
pub const STILL_DPS: u16 = 6;
/// Time constant of the roll/pitch complementary filter, ms.
pub const TILT_TAU_MS: u16 = 7;
/// The accelerometer corrects roll/pitch only while |a| is within this fraction of g.
pub const ACCEL_GATE: u16 = 8;

/// Time constant of the heading's correction towards the magnetometer, ms.
pub const HEADING_TAU_MS: u16 = 9;
/// Time constant of the gyro bias tracking, s (0: the boot estimate is kept).
pub const BIAS_TAU_S: u16 = 10;
/// Magnetic declination at the site, degrees east.
pub const DECLINATION_DEG: u16 = 11;
/// Hard iron: the offset removed from the measured field, µT, x (y, z follow).
pub const MAG_OFFSET_X: u16 = 12;
/// Soft iron: the symmetric matrix applied after the offset, xx (xy, xz, yy, yz, zz follow).
pub const MAG_SOFT_XX: u16 = 15;
/// Whether the heading follows the magnetometer (1) or only the gyro (0).
pub const MAG_HEADING: u16 = 21;
/// `mag` publication rate, Hz.
pub const MAG_RATE_HZ: u16 = 22;
/// `baro` publication rate, Hz.
pub const BARO_RATE_HZ: u16 = 23;
/// Sea-level pressure the altitude is computed under, Pa.
pub const QNH_PA: u16 = 24;
/// Time constant of the altitude/vertical speed filter, ms.
pub const VERTICAL_TAU_MS: u16 = 25;
/// GNSS receiver's navigation rate and the `gnss` publication rate, Hz (at boot).
pub const GNSS_RATE_HZ: u16 = 26;

/// Number of parameters.
pub const COUNT: usize = 27;

/// Gyroscope full scales by `gyro_range`: ±125, ±250, ±500, ±1000, ±2000 °/s.
pub const GYRO_RANGES: [GyroScale; 5] = [
    GyroScale::Dps125,
    GyroScale::Dps250,
    GyroScale::Dps500,
    GyroScale::Dps1000,
    GyroScale::Dps2000,
];
/// Accelerometer full scales by `accel_range`: ±2, ±4, ±8, ±16 g.
pub const ACCEL_RANGES: [AccelScale; 4] =
    [AccelScale::G2, AccelScale::G4, AccelScale::G8, AccelScale::G16];
/// Highest ODR code: 833 Hz. The application is stepped every millisecond and polls the
/// sensor's data-ready flag then, so faster rates would lose samples.
pub const ODR_MAX: u32 = Odr::Hz833 as u32;

/// The parameter table with its defaults and ranges (index = position = the constants above).
pub const DEFAULTS: [Param; COUNT] = [
    Param::u32("instance", 0, 0, 3),
    Param::u32("rate_hz", 50, 1, 200),
    Param::u32("odr", Odr::Hz104 as u32, Odr::Hz12_5 as u32, ODR_MAX),
    Param::u32("gyro_range", 2, 0, 4),
    Param::u32("accel_range", 1, 0, 3),
    Param::u32("bias_ms", 1000, 0, 10_000),
    Param::f32("still_dps", 1.0, 0.1, 10.0),
    Param::u32("tilt_tau_ms", 2000, 10, 60_000),
    Param::f32("accel_gate", 0.1, 0.0, 1.0),
    Param::u32("heading_tau_ms", 5000, 100, 600_000),
    Param::u32("bias_tau_s", 100, 0, 3600),
    Param::f32("declination_deg", 0.0, -180.0, 180.0),
    Param::f32("mag_offset_x", 0.0, -400.0, 400.0),
    Param::f32("mag_offset_y", 0.0, -400.0, 400.0),
    Param::f32("mag_offset_z", 0.0, -400.0, 400.0),
    Param::f32("mag_soft_xx", 1.0, -4.0, 4.0),
    Param::f32("mag_soft_xy", 0.0, -4.0, 4.0),
    Param::f32("mag_soft_xz", 0.0, -4.0, 4.0),
    Param::f32("mag_soft_yy", 1.0, -4.0, 4.0),
    Param::f32("mag_soft_yz", 0.0, -4.0, 4.0),
    Param::f32("mag_soft_zz", 1.0, -4.0, 4.0),
    Param::u32("mag_heading", 0, 0, 1),
    Param::u32("mag_rate_hz", 10, 1, 80),
    Param::u32("baro_rate_hz", 10, 1, 25),
    Param::f32("qnh_pa", 101_325.0, 85_000.0, 110_000.0),
    Param::u32("vertical_tau_ms", 1000, 100, 60_000),
    Param::u32("gnss_rate_hz", 1, 1, 10),
];

/// Documentation of each parameter (index = position).
pub const DOCS: [ParamDoc; COUNT] = [
    boot("", "module name: 0 `imu`, 1 `imu1`, 2 `imu2`, 3 `imu3` (node and topic name)"),
    doc("Hz", "rate of the `imu` topic"),
    boot(
        "",
        "sensor output data rate: 1 12.5 Hz, 2 26 Hz, 3 52 Hz, 4 104 Hz, 5 208 Hz, 6 416 Hz, \
         7 833 Hz (the LSM6DSO's ODR code)",
    ),
    boot("", "gyroscope full scale: 0 ±125, 1 ±250, 2 ±500, 3 ±1000, 4 ±2000 °/s"),
    boot("", "accelerometer full scale: 0 ±2, 1 ±4, 2 ±8, 3 ±16 g"),
    doc(
        "ms",
        "the gyro bias is the mean over this long a still window after boot; 0 = no \
         estimate (bias 0)",
    ),
    doc("°/s", "a gyro sample this far from the window's mean means motion: the window restarts"),
    doc(
        "ms",
        "time constant of the roll/pitch complementary filter (gyro below, accelerometer above)",
    ),
    doc(
        "",
        "the accelerometer corrects roll/pitch only while its magnitude is within this \
         fraction of g (not while the base accelerates hard)",
    ),
    doc("ms", "time constant of the heading's correction towards the magnetometer"),
    doc("s", "time constant of the gyro bias tracking after boot; 0 = keep the boot estimate"),
    doc("°", "magnetic declination at the site, east positive (NOAA's World Magnetic Model)"),
    doc("µT", "hard iron x: subtracted from the field (`r2p imu calibrate` writes mag_*)"),
    doc("µT", "hard iron y"),
    doc("µT", "hard iron z"),
    doc("", "soft iron matrix (symmetric), xx: applied after the offset"),
    doc("", "soft iron xy"),
    doc("", "soft iron xz"),
    doc("", "soft iron yy"),
    doc("", "soft iron yz"),
    doc("", "soft iron zz"),
    doc(
        "",
        "1: the heading follows the magnetometer (`r2p imu calibrate` turns it on once the \
         field is calibrated); 0: gyro only (uncalibrated, steel floors, strong motors)",
    ),
    doc("Hz", "rate of the `mag` topic"),
    doc("Hz", "rate of the `baro` topic"),
    doc(
        "Pa",
        "sea-level pressure for the altitude: the local QNH, or 101325 for pressure altitude",
    ),
    doc("ms", "time constant of the altitude and vertical speed filter"),
    boot("Hz", "GNSS receiver's navigation rate and the `gnss` topic's rate"),
];

/// The parameters the application runs with, read from the store every
/// [`crate::app::CONFIG_PERIOD_US`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Time between two `imu` messages, µs.
    pub period_us: u64,
    /// Still window for the bias, µs (0: no estimate).
    pub bias_us: u64,
    /// Stillness threshold, rad/s.
    pub still_rad_s: f32,
    /// Complementary filter time constant, s.
    pub tilt_tau_s: f32,
    /// Accelerometer gate, fraction of g.
    pub accel_gate: f32,
    /// The filter's gains (from the time constants above and the heading's and bias's).
    pub gains: crate::ahrs::Gains,
    /// Declination, rad east.
    pub declination: f32,
    /// The magnetometer's calibration.
    pub mag_cal: crate::mag_cal::MagCal,
    /// Whether the heading follows the magnetometer.
    pub mag_heading: bool,
    /// Time between two `mag` messages, µs.
    pub mag_period_us: u64,
    /// Time between two `baro` messages, µs.
    pub baro_period_us: u64,
    /// Sea-level pressure, Pa.
    pub qnh_pa: f32,
    /// Altitude filter's time constant, s.
    pub vertical_tau_s: f32,
}

impl Config {
    /// Reads every run-time parameter (a missing or mistyped one falls back to its default).
    pub fn read(store: &dyn ParamStore) -> Self {
        let t = typed(store);
        let u = |i| t.u32(i);
        let period = |i| 1_000_000 / u64::from(u(i).max(1));
        let tilt_tau_s = u(TILT_TAU_MS) as f32 * 1e-3;
        let accel_gate = t.f32(ACCEL_GATE);
        let f = |i: u16| t.f32(i);
        Self {
            period_us: period(RATE_HZ),
            bias_us: u64::from(u(BIAS_MS)) * 1000,
            still_rad_s: t.f32(STILL_DPS).to_radians(),
            tilt_tau_s,
            accel_gate,
            gains: crate::ahrs::Gains {
                tilt_tau_s,
                heading_tau_s: u(HEADING_TAU_MS) as f32 * 1e-3,
                bias_tau_s: u(BIAS_TAU_S) as f32,
                accel_gate,
            },
            declination: f(DECLINATION_DEG).to_radians(),
            mag_cal: crate::mag_cal::MagCal {
                offset: core::array::from_fn(|i| f(MAG_OFFSET_X + i as u16)),
                soft: {
                    let s: [f32; 6] = core::array::from_fn(|i| f(MAG_SOFT_XX + i as u16));
                    [[s[0], s[1], s[2]], [s[1], s[3], s[4]], [s[2], s[4], s[5]]]
                },
            },
            mag_heading: u(MAG_HEADING) == 1,
            mag_period_us: period(MAG_RATE_HZ),
            baro_period_us: period(BARO_RATE_HZ),
            qnh_pa: f(QNH_PA),
            vertical_tau_s: u(VERTICAL_TAU_MS) as f32 * 1e-3,
        }
    }
}

/// How the sensor is set up: read once at boot, since the board-support layer configures the
/// LSM6DSO then and the readings must be scaled with what the sensor was actually set to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SensorConfig(pub lsm6dso::Config);

impl SensorConfig {
    /// The set-up the parameters ask for (out-of-table values fall back to the defaults).
    pub fn read(store: &dyn ParamStore) -> Self {
        let (t, defaults) = (typed(store), Typed::new(&NoParams, &DEFAULTS));
        let pick = |i: u16, n: usize| {
            let v = t.u32(i) as usize;
            if v < n {
                v
            } else {
                defaults.u32(i) as usize
            }
        };
        let odr = Odr::from_code(t.u32(ODR).min(ODR_MAX) as u8)
            .filter(|o| *o != Odr::Off)
            .unwrap_or(Odr::Hz104);
        SensorConfig(lsm6dso::Config {
            accel_odr: odr,
            accel_scale: ACCEL_RANGES[pick(ACCEL_RANGE, ACCEL_RANGES.len())],
            gyro_odr: odr,
            gyro_scale: GYRO_RANGES[pick(GYRO_RANGE, GYRO_RANGES.len())],
        })
    }

    /// Samples per second.
    pub fn odr_hz(&self) -> f32 {
        self.0.gyro_odr.hz()
    }
}

/// The GNSS rate the parameters ask for, Hz (1–10; at boot).
pub fn gnss_rate_hz(store: &dyn ParamStore) -> u32 {
    typed(store).u32(GNSS_RATE_HZ).clamp(1, 10)
}

/// The parameters as the application reads them: each as its type, the default from
/// [`DEFAULTS`] if the store lacks it.
pub fn typed(store: &dyn ParamStore) -> Typed<'_> {
    Typed::new(store, &DEFAULTS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use r2p_management::message::ParamFault;
    use r2p_management::message::Value;
    use r2p_node::{NoParams, RamParams};

    #[test]
    fn defaults_are_in_range_and_named_uniquely() {
        for (i, p) in DEFAULTS.iter().enumerate() {
            assert_eq!(p.check(p.value), Ok(()), "{}", p.name);
            assert!(DEFAULTS[..i].iter().all(|q| q.name != p.name), "{} twice", p.name);
        }
    }

    #[test]
    fn sensor_config_follows_the_store() {
        let c = SensorConfig::read(&NoParams);
        assert_eq!(c.0, lsm6dso::Config::default(), "104 Hz, ±4 g, ±500 °/s: the driver's own");
        assert_eq!(c.odr_hz(), 104.0);
        let store = RamParams::new(DEFAULTS);
        store.set(GYRO_RANGE, Value::U32(4)).unwrap();
        store.set(ACCEL_RANGE, Value::U32(0)).unwrap();
        store.set(ODR, Value::U32(7)).unwrap();
        let c = SensorConfig::read(&store);
        assert_eq!(c.0.gyro_scale, GyroScale::Dps2000);
        assert_eq!(c.0.accel_scale, AccelScale::G2);
        assert_eq!((c.0.gyro_odr, c.0.accel_odr), (Odr::Hz833, Odr::Hz833));
        store.set(GYRO_RANGE, Value::U32(0)).unwrap();
        assert_eq!(SensorConfig::read(&store).0.gyro_scale, GyroScale::Dps125);
    }

    #[test]
    fn config_follows_the_store_and_falls_back_to_defaults() {
        let store = RamParams::new(DEFAULTS);
        store.set(RATE_HZ, Value::U32(200)).unwrap();
        store.set(STILL_DPS, Value::F32(2.0)).unwrap();
        let c = Config::read(&store);
        assert_eq!(c.period_us, 5_000);
        assert!((c.still_rad_s - 2f32.to_radians()).abs() < 1e-7);
        let d = Config::read(&NoParams);
        assert_eq!((d.period_us, d.bias_us), (20_000, 1_000_000));
        assert_eq!((d.tilt_tau_s, d.accel_gate), (2.0, 0.1));
    }

    #[test]
    fn out_of_range_values_are_refused() {
        let store = RamParams::new(DEFAULTS);
        for (i, bad) in [
            (GYRO_RANGE, Value::U32(5)),
            (ACCEL_RANGE, Value::U32(4)),
            (ODR, Value::U32(8)), // 1.66 kHz: faster than the 1 kHz poll
            (ODR, Value::U32(0)), // power-down
            (RATE_HZ, Value::U32(0)),
            (BIAS_MS, Value::U32(10_001)),
            (TILT_TAU_MS, Value::U32(5)),
            (STILL_DPS, Value::F32(f32::NAN)),
            (ACCEL_GATE, Value::F32(1.5)),
        ] {
            assert_eq!(
                store.set(i, bad),
                Err(ParamFault::OutOfRange),
                "{}",
                DEFAULTS[i as usize].name
            );
        }
        assert_eq!(store.set(BIAS_MS, Value::F32(1.0)), Err(ParamFault::WrongType));
        assert_eq!(Config::read(&store), Config::read(&RamParams::new(DEFAULTS)));
        assert_eq!(SensorConfig::read(&store), SensorConfig::read(&NoParams));
    }
}
