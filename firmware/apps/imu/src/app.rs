//! The IMU application: one step per millisecond, sans-IO.

use r2p_drivers::lsm6dso::RawSample;
use r2p_drivers::ubx::NavPvt;
use r2p_drivers::{lis3mdl, lps22};
use r2p_module::leds;
use r2p_module::TopicNode;
use r2p_msgs::{Barometer, GnssFix, Imu, MagneticField};
use r2p_node::{NodeError, ParamStore};

use crate::ahrs::Ahrs;
use crate::altitude::{isa_altitude, Vertical};
use crate::bias::BiasEstimator;
use crate::endpoints::Endpoints;
use crate::gnss::Gnss;
use crate::params::{Config, SensorConfig};

/// `Imu::status`: estimates are valid.
pub const STATUS_OK: u8 = 0;
/// `Imu::status`: estimating the gyro bias; hold the robot still (heading held at 0).
pub const STATUS_CALIBRATING: u8 = 1;
/// `Imu::status`: no data from the sensor (it failed to initialise, or stopped answering).
pub const STATUS_NO_DATA: u8 = 2;

/// Sample periods without new data after which the sensor counts as lost.
pub const LOST_AFTER_PERIODS: u64 = 10;

/// `Imu::sensors`: the LSM6DSO answers.
pub const SENSOR_IMU: u8 = 1;
/// `Imu::sensors`: the magnetometer answers (and the heading follows it if `mag_heading`).
pub const SENSOR_MAG: u8 = 2;
/// `Imu::sensors`: the barometer answers.
pub const SENSOR_BARO: u8 = 4;
/// `Imu::sensors`: the GNSS receiver sends epochs.
pub const SENSOR_GNSS: u8 = 8;

/// One step's read of a sensor that has its own data-ready flag.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Reading<T> {
    /// Not initialised at boot, or this step's bus transaction failed.
    #[default]
    Failed,
    /// It answered: no new sample since the last step.
    Idle,
    /// A new sample.
    Fresh(T),
}

/// A sensor's liveness: the time of its last fresh sample, lost after
/// [`LOST_AFTER_PERIODS`] of its period without one (or on a failed read).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Liveness {
    last_us: Option<u64>,
    failed: bool,
}

impl Liveness {
    fn see<T>(&mut self, now_us: u64, r: &Reading<T>) {
        self.failed = matches!(r, Reading::Failed);
        if let Reading::Fresh(_) = r {
            self.last_us = Some(now_us);
        }
    }

    fn alive(&self, now_us: u64, period_us: u64) -> bool {
        !self.failed && self.last_us.is_some_and(|t| now_us - t <= LOST_AFTER_PERIODS * period_us)
    }
}

/// What the board-support layer reads before each step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// The LSM6DSO flagged new gyro data (STATUS_REG's GDA) and `raw` holds it.
    pub fresh: bool,
    /// The burst read from OUT_TEMP_L: temperature, gyro and accel counts.
    pub raw: RawSample,
    /// The sensor answered: it initialised, and this step's bus transactions succeeded.
    pub sensor_ok: bool,
    /// The node's state for the status LEDs (running, synced, traffic, storage fault).
    pub status: leds::Status,
    /// The LIS3MDL's read (field in µT, sensor axes aligned with the LSM6DSO's on the board).
    pub mag: Reading<lis3mdl::Sample>,
    /// The barometer's read.
    pub baro: Reading<lps22::Sample>,
    /// A NAV-PVT the GNSS receiver's link decoded this step ([`crate::gnss::Link`]).
    pub gnss: Option<NavPvt>,
    /// The time pulse's last rising edge captured since the previous step, µs (the module's
    /// clock, as `now_us`).
    pub pps_us: Option<u64>,
}

/// What the board-support layer applies after each step (logical levels: `true` = on).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Command {
    /// `LED_STATUS`.
    pub led_status: bool,
    /// `LED_BUS`.
    pub led_bus: bool,
    /// `LED_FAULT`: also on while the sensor gives no data.
    pub led_fault: bool,
}

/// The IMU module's default application.
pub struct App<'a> {
    ep: Endpoints<'a>,
    params: &'a dyn ParamStore,
    sensor: SensorConfig,
    /// The run-time parameters as last read, and when they are read again.
    cfg: Config,
    next_config_us: u64,
    bias: BiasEstimator,
    ahrs: Ahrs,
    /// Time of the last fresh sample, µs.
    last_fresh_us: Option<u64>,
    /// The message as of the last fresh sample.
    state: Imu,
    next_publish_us: u64,
    /// The calibrated field not yet given to the filter (the magnetometer runs slower than the
    /// gyro: each of its samples corrects the heading once).
    pending_mag: Option<[f32; 3]>,
    mag_live: Liveness,
    mag: MagneticField,
    next_mag_us: u64,
    baro_live: Liveness,
    vertical: Vertical,
    baro: Barometer,
    next_baro_us: u64,
    gnss: Gnss,
    gnss_live: Liveness,
    next_gnss_us: u64,
    gnss_period_us: u64,
}

/// The magnetometer's sample period, µs (the driver's default set-up, 80 Hz).
pub const MAG_PERIOD_US: u64 = 12_500;
/// The barometer's sample period, µs (the driver's default set-up, 25 Hz).
pub const BARO_PERIOD_US: u64 = 40_000;
/// How often the run-time parameters are read again, µs: a value set over the bus takes
/// effect within this. Reading all of them costs 1 610 instructions (`make bench`): every 1 ms
/// step that was ≥ 2.2 % of the F103, more than the fusion itself; every 20 ms it is 0.1 %.
pub const CONFIG_PERIOD_US: u64 = 20_000;

impl<'a> App<'a> {
    /// The application on its endpoints ([`crate::Storage::build`]) and parameter store. The
    /// sensor set-up is read now, at boot: [`Self::sensor_config`] is what the board-support
    /// layer must configure the LSM6DSO with.
    pub fn new(endpoints: Endpoints<'a>, params: &'a dyn ParamStore) -> Self {
        Self {
            ep: endpoints,
            params,
            sensor: SensorConfig::read(params),
            cfg: Config::read(params),
            next_config_us: 0,
            bias: BiasEstimator::default(),
            ahrs: Ahrs::default(),
            last_fresh_us: None,
            state: Imu { status: STATUS_NO_DATA, ..Imu::default() },
            next_publish_us: 0,
            pending_mag: None,
            mag_live: Liveness::default(),
            mag: MagneticField { status: STATUS_NO_DATA, ..MagneticField::default() },
            next_mag_us: 0,
            baro_live: Liveness::default(),
            vertical: Vertical::default(),
            baro: Barometer { status: STATUS_NO_DATA, ..Barometer::default() },
            next_baro_us: 0,
            gnss: Gnss::default(),
            gnss_live: Liveness::default(),
            next_gnss_us: 0,
            gnss_period_us: 1_000_000 / u64::from(crate::params::gnss_rate_hz(params)),
        }
    }

    /// The LSM6DSO set-up (rates and full scales) the readings are scaled with.
    pub fn sensor_config(&self) -> r2p_drivers::lsm6dso::Config {
        self.sensor.0
    }

    /// Exports `imu`, `mag` and `baro` on the module's node.
    pub fn register(&self, node: &mut impl TopicNode<'a>) -> Result<(), NodeError> {
        node.export(self.ep.imu.remote)?;
        node.export(self.ep.mag.remote)?;
        node.export(self.ep.baro.remote)?;
        node.export(self.ep.gnss.remote)?;
        Ok(())
    }

    /// The endpoints (the topic to subscribe to on the module, the publisher's statistics).
    pub fn endpoints(&self) -> &Endpoints<'a> {
        &self.ep
    }

    /// What `imu` carries now.
    pub fn state(&self) -> Imu {
        self.state
    }

    /// The gyro bias estimate, rad/s, once the still window has closed (then tracked).
    pub fn gyro_bias(&self) -> Option<[f32; 3]> {
        self.bias.bias().map(|_| self.ahrs.bias)
    }

    /// What `mag` carries now.
    pub fn mag(&self) -> MagneticField {
        self.mag
    }

    /// What `baro` carries now.
    pub fn baro(&self) -> Barometer {
        self.baro
    }

    /// What `gnss` carries at `now_us`.
    pub fn gnss(&self, now_us: u64) -> GnssFix {
        self.gnss.fix(now_us, self.gnss_live.alive(now_us, self.gnss_period_us))
    }

    /// The GNSS receiver's navigation rate, Hz (`gnss_rate_hz`, read at boot): the board-support
    /// layer configures the receiver with it ([`crate::gnss::Link::new`]).
    pub fn gnss_rate_hz(&self) -> u32 {
        (1_000_000 / self.gnss_period_us) as u32
    }

    /// One step at `now_us`: scale a fresh reading, estimate the bias or integrate the
    /// attitude, publish `imu` when due; returns the LEDs to show.
    pub fn step(&mut self, now_us: u64, sample: &Sample) -> Command {
        if now_us >= self.next_config_us {
            self.cfg = Config::read(self.params);
            self.next_config_us = now_us + CONFIG_PERIOD_US;
        }
        let cfg = self.cfg;
        let period_us = (1e6 / self.sensor.odr_hz()) as u64;
        self.mag_live.see(now_us, &sample.mag);
        if let Reading::Fresh(m) = sample.mag {
            self.take_mag(&m, &cfg);
        }
        let mag_alive = self.mag_live.alive(now_us, MAG_PERIOD_US);
        if !mag_alive {
            self.mag.status = STATUS_NO_DATA;
            self.pending_mag = None;
        }
        let last_baro_us = self.baro_live.last_us;
        self.baro_live.see(now_us, &sample.baro);
        if let Reading::Fresh(b) = sample.baro {
            // As the gyro's: the interval on the MCU's clock, not the nominal rate.
            let dt_us = last_baro_us.map_or(BARO_PERIOD_US, |t| now_us - t);
            self.take_baro(&b, &cfg, dt_us as f32 * 1e-6);
        }
        let baro_alive = self.baro_live.alive(now_us, BARO_PERIOD_US);
        if !baro_alive {
            self.baro.status = STATUS_NO_DATA;
        }
        if let Some(edge) = sample.pps_us {
            self.gnss.take_pps(edge);
        }
        let epoch = sample.gnss.map_or(Reading::Idle, Reading::Fresh);
        self.gnss_live.see(now_us, &epoch);
        if let Some(p) = &sample.gnss {
            self.gnss.take_epoch(now_us, p);
        }
        let gnss_alive = self.gnss_live.alive(now_us, self.gnss_period_us);
        if sample.sensor_ok && sample.fresh {
            self.take(now_us, &sample.raw, &cfg, period_us, mag_alive);
        }
        let lost = !sample.sensor_ok
            || self.last_fresh_us.is_none_or(|t| now_us - t > LOST_AFTER_PERIODS * period_us);
        if lost {
            self.state.status = STATUS_NO_DATA;
        }
        self.state.sensors = (u8::from(!lost) * SENSOR_IMU)
            | (u8::from(mag_alive) * SENSOR_MAG)
            | (u8::from(baro_alive) * SENSOR_BARO)
            | (u8::from(gnss_alive) * SENSOR_GNSS);
        if now_us >= self.next_publish_us {
            self.next_publish_us = next_due(self.next_publish_us, now_us, cfg.period_us);
            let m = self.state;
            self.ep.imu.publisher.publish_with(|x| *x = m);
        }
        if now_us >= self.next_mag_us {
            self.next_mag_us = next_due(self.next_mag_us, now_us, cfg.mag_period_us);
            let m = self.mag;
            self.ep.mag.publisher.publish_with(|x| *x = m);
        }
        if now_us >= self.next_baro_us {
            self.next_baro_us = next_due(self.next_baro_us, now_us, cfg.baro_period_us);
            let m = self.baro;
            self.ep.baro.publisher.publish_with(|x| *x = m);
        }
        if now_us >= self.next_gnss_us {
            self.next_gnss_us = next_due(self.next_gnss_us, now_us, self.gnss_period_us);
            let m = self.gnss(now_us);
            self.ep.gnss.publisher.publish_with(|x| *x = m);
        }
        let mut status = sample.status;
        // A missing magnetometer or barometer is a fault too: the module still publishes what
        // it has, and says which are missing in `Imu::sensors`. (The GNSS receiver is an
        // optional external part: its absence is reported, not a fault.)
        status.fault |= lost || !mag_alive || !baro_alive;
        let [led_status, led_bus, led_fault] = leds::levels(status, now_us / 1000);
        Command { led_status, led_bus, led_fault }
    }

    /// A fresh reading: to SI units with the boot-time full scales, then the bias window or
    /// the filter.
    fn take(&mut self, now_us: u64, raw: &RawSample, cfg: &Config, period_us: u64, mag: bool) {
        let g = self.sensor.0.gyro_scale.rad_s_per_lsb();
        let a = self.sensor.0.accel_scale.m_s2_per_lsb();
        let rate = raw.gyro.map(|c| f32::from(c) * g);
        let accel = raw.accel.map(|c| f32::from(c) * a);
        // Time between samples from the MCU's crystal clock, not the nominal ODR (the sensor's
        // own oscillator is not trimmed as tightly): the steps' 1 ms quantisation does not
        // accumulate, since the intervals sum to the true elapsed time. A gap (samples lost)
        // is integrated with the current rate, as the best guess of what happened in it.
        let dt_us = self.last_fresh_us.map_or(period_us, |t| now_us - t);
        self.last_fresh_us = Some(now_us);
        let field = self.pending_mag.take().filter(|_| mag && cfg.mag_heading);
        let status = match self.bias.bias() {
            None => {
                self.bias.update(now_us, rate, cfg.bias_us, cfg.still_rad_s);
                // Still by assumption: level with the accelerometer, heading from the
                // magnetometer (0 without one).
                let b = self.bias.bias().unwrap_or([0.0; 3]);
                let level = Ahrs::levelled(accel, 0.0, b);
                let yaw = match field {
                    Some(m) => level.magnetic_yaw(m, cfg.declination),
                    None => self.ahrs.euler().yaw,
                };
                self.ahrs = Ahrs::levelled(accel, yaw, b);
                if self.bias.bias().is_some() {
                    STATUS_OK
                } else {
                    STATUS_CALIBRATING
                }
            }
            Some(_) => {
                let dt = dt_us as f32 * 1e-6;
                self.ahrs.update(rate, accel, field, cfg.declination, dt, &cfg.gains);
                STATUS_OK
            }
        };
        let b = self.ahrs.bias;
        let e = self.ahrs.euler();
        self.state = Imu {
            rate: [rate[0] - b[0], rate[1] - b[1], rate[2] - b[2]],
            accel,
            roll: e.roll,
            pitch: e.pitch,
            yaw: e.yaw,
            temperature: 25.0 + f32::from(raw.temp) / 256.0,
            status,
            sensors: self.state.sensors,
        };
    }

    /// A fresh magnetometer sample: calibrated, kept for the filter's next step, its heading.
    fn take_mag(&mut self, m: &lis3mdl::Sample, cfg: &Config) {
        let field = cfg.mag_cal.apply(m.field_ut);
        self.pending_mag = Some(field);
        self.mag = MagneticField {
            field,
            raw: m.field_ut,
            heading: self.ahrs.magnetic_yaw(field, cfg.declination),
            status: STATUS_OK,
        };
    }

    /// A fresh barometer sample: altitude under the QNH, the vertical filter.
    fn take_baro(&mut self, b: &lps22::Sample, cfg: &Config, dt: f32) {
        let h = isa_altitude(b.pressure_pa, cfg.qnh_pa);
        self.vertical.update(h, dt, cfg.vertical_tau_s);
        self.baro = Barometer {
            pressure: b.pressure_pa,
            temperature: b.temp_c,
            altitude: self.vertical.altitude.unwrap_or(h),
            vertical_speed: self.vertical.speed,
            status: STATUS_OK,
        };
    }
}

/// The next publication time after `due` (one period on; if the step came late by more than
/// a period, one period from now so that a stall does not cause a burst).
fn next_due(due: u64, now_us: u64, period_us: u64) -> u64 {
    let next = due + period_us;
    if next <= now_us {
        now_us + period_us
    } else {
        next
    }
}
