//! What an IMU module is wired to in the world (issue 21): its LSM6DSO ([`crate::imu`]), its
//! LIS3MDL magnetometer ([`crate::magnetic`]), its LPS22HH barometer ([`crate::pressure`]) and
//! the external GNSS receiver on its serial port ([`crate::gnss`]), each a device of its own
//! with its imperfections drawn once from the robot's seed, and whether each is plugged.
//!
//! **Placement.** The three ST parts sit on the module's board at its mount (the robot file's
//! `pose`), their x along the mount's heading and z up, as the LSM6DSO's does: the board
//! (hardware/imu) must place them so, or this must turn them as it does. The GNSS antenna is
//! taken at the module's place on the base, on the floor plane (its height above the floor,
//! like the sensors', is not modelled: the barometer reads the site's altitude).
//!
//! **Iron.** The robot's own hard and soft iron at the module (robot file: `hard_iron_ut`,
//! `soft_iron`; none by default) distort the Earth's field in the base frame before the
//! magnetometer's own offset and noise ([`crate::magnetic`]).
//!
//! **Seeds.** Each device has its own streams of the robot's seed, numbered by the IMU
//! module's index among the robot's IMU modules, so adding a magnetometer reading leaves the
//! LSM6DSO's noise unchanged and the same file always gives the same devices.
//!
//! **Unplugging** ([`ImuModule::set_connected`], `World::set_imu_sensor_connected`): the
//! sensor stops answering on its bus (the emulator's SPI model then reads a floating MISO,
//! 0xFF, and the GNSS line stays idle); the world's device keeps its offsets and noise stream,
//! the emulated part restarts from its power-up registers when plugged again.

use crate::geometry::{Pose, Twist};
use crate::gnss::{GnssParams, GnssReceiver};
use crate::imu::{Imu, ImuParams};
use crate::magnetic::{Iron, MagParams, Magnetometer};
use crate::pressure::{BaroParams, Barometer};
use crate::site::Site;

/// IMU module `i` draws its LSM6DSO's errors from stream `STREAM_IMU + 2i` and its noise from
/// the next (the numbers the world used before the other sensors came: kept, so the LSM6DSO's
/// readings did not change).
pub const STREAM_IMU: u64 = 30_000;
/// The magnetometer's offset from `STREAM_MAG + 2i`, its noise from the next.
pub const STREAM_MAG: u64 = 40_000;
/// The barometer's offset from `STREAM_BARO + 2i`, its noise from the next.
pub const STREAM_BARO: u64 = 50_000;
/// The GNSS receiver's error from `STREAM_GNSS + i`.
pub const STREAM_GNSS: u64 = 60_000;

/// One of an IMU module's sensors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ImuSensor {
    /// The LSM6DSO accelerometer and gyroscope.
    AccelGyro,
    /// The LIS3MDL magnetometer.
    Magnetometer,
    /// The LPS22HH barometer.
    Barometer,
    /// The external GNSS receiver (its UART and its PPS).
    Gnss,
}

impl ImuSensor {
    /// Every sensor, in the order of [`ImuModule`]'s plug states.
    pub const ALL: [ImuSensor; 4] =
        [ImuSensor::AccelGyro, ImuSensor::Magnetometer, ImuSensor::Barometer, ImuSensor::Gnss];

    /// The name a robot file's `unplugged` list uses.
    pub fn name(self) -> &'static str {
        match self {
            ImuSensor::AccelGyro => "accel_gyro",
            ImuSensor::Magnetometer => "magnetometer",
            ImuSensor::Barometer => "barometer",
            ImuSensor::Gnss => "gnss",
        }
    }

    /// The sensor called `name`.
    pub fn from_name(name: &str) -> Option<ImuSensor> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }

    /// The part, for messages.
    pub fn part(self) -> &'static str {
        match self {
            ImuSensor::AccelGyro => "LSM6DSO",
            ImuSensor::Magnetometer => "LIS3MDL",
            ImuSensor::Barometer => "LPS22HH",
            ImuSensor::Gnss => "GNSS receiver",
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// Where the GNSS antenna is and how it moves, in the world's east-north-up frame (metres
/// from the site's origin, m/s): what the receiver's solution follows.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GnssAntenna {
    /// Position (east, north, up), m.
    pub enu: [f64; 3],
    /// Velocity (east, north, up), m/s.
    pub velocity_enu: [f64; 3],
}

/// An IMU module's devices and plugs.
#[derive(Clone, Debug)]
pub struct ImuModule {
    /// Its mount on the base (the robot file's `pose`).
    pub mount: Pose,
    /// The LSM6DSO.
    pub imu: Imu,
    /// The LIS3MDL in the robot's field.
    pub magnetometer: Magnetometer,
    /// The LPS22HH.
    pub barometer: Barometer,
    /// The GNSS receiver (powered up with the world, at time 0).
    pub gnss: GnssReceiver,
    /// Altitude of the sensors above mean sea level, m (the site's floor).
    pub altitude_m: f64,
    connected: [bool; 4],
}

impl ImuModule {
    /// The devices of the robot's IMU module number `index` (0 for the first in the file) at
    /// `mount` with the robot's iron `iron` there, at `site`, from the robot's `seed`; the
    /// sensors in `unplugged` start unplugged.
    pub fn new(
        mount: Pose,
        iron: Iron,
        unplugged: &[ImuSensor],
        site: &Site,
        seed: u64,
        index: usize,
    ) -> Self {
        let i = index as u64;
        let mut connected = [true; 4];
        for s in unplugged {
            connected[s.index()] = false;
        }
        Self {
            mount,
            imu: Imu::new(ImuParams::LSM6DSO, mount, seed, STREAM_IMU + 2 * i),
            magnetometer: Magnetometer::new(
                MagParams::LIS3MDL,
                mount,
                site.field,
                iron,
                seed,
                STREAM_MAG + 2 * i,
            ),
            barometer: Barometer::new(
                BaroParams::LPS22HH,
                site.sea_level_pa,
                seed,
                STREAM_BARO + 2 * i,
            ),
            gnss: GnssReceiver::new(
                GnssParams::UBLOX_M8,
                site.origin(),
                site.geoid_separation_m,
                seed,
                STREAM_GNSS + i,
            ),
            altitude_m: site.altitude_m,
            connected,
        }
    }

    /// Whether `sensor` is plugged.
    pub fn connected(&self, sensor: ImuSensor) -> bool {
        self.connected[sensor.index()]
    }

    /// Plugs or unplugs `sensor`.
    pub fn set_connected(&mut self, sensor: ImuSensor, connected: bool) {
        self.connected[sensor.index()] = connected;
    }

    /// The GNSS antenna for the base at `pose` moving with body twist `twist`.
    pub fn antenna(&self, pose: &Pose, twist: &Twist) -> GnssAntenna {
        let at = pose.compose(&self.mount);
        let v = twist.point_velocity(self.mount.position()).rotated(pose.theta);
        GnssAntenna { enu: [at.x, at.y, 0.0], velocity_enu: [v.x, v.y, 0.0] }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sensor_names_round_trip() {
        for s in ImuSensor::ALL {
            assert_eq!(ImuSensor::from_name(s.name()), Some(s));
        }
        assert_eq!(ImuSensor::from_name("compass"), None);
        assert_eq!(ImuSensor::Barometer.part(), "LPS22HH");
        assert_eq!(ImuSensor::Gnss.part(), "GNSS receiver");
    }

    #[test]
    fn plugs_start_as_the_file_says_and_follow_set_connected() {
        let mut m =
            ImuModule::new(Pose::default(), Iron::NONE, &[ImuSensor::Gnss], &Site::MILAN, 1, 0);
        let plugged = ImuSensor::ALL.map(|s| m.connected(s));
        assert_eq!(plugged, [true, true, true, false]);
        m.set_connected(ImuSensor::Magnetometer, false);
        m.set_connected(ImuSensor::Gnss, true);
        assert_eq!(ImuSensor::ALL.map(|s| m.connected(s)), [true, false, true, true]);
    }

    #[test]
    fn the_antenna_moves_with_the_module_not_the_base_centre() {
        // Module 0.2 m ahead of the centre; base at (1, 2) facing north (90°), turning at
        // 0.5 rad/s while driving 1 m/s forward: the module is at (1, 2.2), moving north at
        // 1 m/s and west at ω·r = 0.1 m/s.
        let m = ImuModule::new(Pose::new(0.2, 0.0, 0.0), Iron::NONE, &[], &Site::MILAN, 1, 0);
        let pose = Pose::new(1.0, 2.0, std::f64::consts::FRAC_PI_2);
        let a = m.antenna(&pose, &Twist::new(1.0, 0.0, 0.5));
        let want = GnssAntenna { enu: [1.0, 2.2, 0.0], velocity_enu: [-0.1, 1.0, 0.0] };
        for i in 0..3 {
            assert!((a.enu[i] - want.enu[i]).abs() < 1e-12, "{a:?}");
            assert!((a.velocity_enu[i] - want.velocity_enu[i]).abs() < 1e-12, "{a:?}");
        }
    }

    #[test]
    fn each_device_has_its_own_stream_and_the_site_sets_them_up() {
        let site = Site { sea_level_pa: 99_000.0, altitude_m: 300.0, ..Site::MILAN };
        let a = ImuModule::new(Pose::default(), Iron::NONE, &[], &site, 9, 0);
        let b = ImuModule::new(Pose::default(), Iron::NONE, &[], &site, 9, 1);
        assert_ne!(a.magnetometer.offset_ut(), b.magnetometer.offset_ut());
        assert_ne!(a.barometer.offset_pa(), b.barometer.offset_pa());
        assert_ne!(a.imu.gyro_offset(), b.imu.gyro_offset());
        // The LSM6DSO is the one the world had before (stream 30 000 + 2i).
        assert_eq!(
            a.imu.gyro_offset(),
            Imu::new(ImuParams::LSM6DSO, Pose::default(), 9, 30_000).gyro_offset()
        );
        assert_eq!((a.barometer.sea_level_pa, a.altitude_m), (99_000.0, 300.0));
        assert_eq!(a.gnss.origin, site.origin());
        assert_eq!(a.magnetometer.earth, site.field);
    }
}
