//! The IMU application: one step per millisecond, sans-IO.

use r2p_drivers::lsm6dso::RawSample;
use r2p_module::leds;
use r2p_module::TopicNode;
use r2p_msgs::Imu;
use r2p_node::{NodeError, ParamStore};

use crate::attitude::Attitude;
use crate::bias::BiasEstimator;
use crate::endpoints::Endpoints;
use crate::params::{Config, SensorConfig};

/// `Imu::status`: estimates are valid.
pub const STATUS_OK: u8 = 0;
/// `Imu::status`: estimating the gyro bias; hold the robot still (heading held at 0).
pub const STATUS_CALIBRATING: u8 = 1;
/// `Imu::status`: no data from the sensor (it failed to initialise, or stopped answering).
pub const STATUS_NO_DATA: u8 = 2;

/// Sample periods without new data after which the sensor counts as lost.
pub const LOST_AFTER_PERIODS: u64 = 10;

/// What the board-support layer reads before each step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sample {
    /// The LSM6DSO flagged new gyro data (STATUS_REG's GDA) and `raw` holds it.
    pub fresh: bool,
    /// The burst read from OUT_TEMP_L: temperature, gyro and accel counts.
    pub raw: RawSample,
    /// The sensor answered: it initialised, and this step's bus transactions succeeded.
    pub sensor_ok: bool,
    /// The node's state for the status LEDs (running, synced, traffic, storage fault).
    pub status: leds::Status,
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
    bias: BiasEstimator,
    attitude: Attitude,
    /// Time of the last fresh sample, µs.
    last_fresh_us: Option<u64>,
    /// The message as of the last fresh sample.
    state: Imu,
    next_publish_us: u64,
}

impl<'a> App<'a> {
    /// The application on its endpoints ([`crate::Storage::build`]) and parameter store. The
    /// sensor set-up is read now, at boot: [`Self::sensor_config`] is what the board-support
    /// layer must configure the LSM6DSO with.
    pub fn new(endpoints: Endpoints<'a>, params: &'a dyn ParamStore) -> Self {
        Self {
            ep: endpoints,
            params,
            sensor: SensorConfig::read(params),
            bias: BiasEstimator::default(),
            attitude: Attitude::default(),
            last_fresh_us: None,
            state: Imu { status: STATUS_NO_DATA, ..Imu::default() },
            next_publish_us: 0,
        }
    }

    /// The LSM6DSO set-up (rates and full scales) the readings are scaled with.
    pub fn sensor_config(&self) -> r2p_drivers::lsm6dso::Config {
        self.sensor.0
    }

    /// Exports `imu` on the module's node.
    pub fn register(&self, node: &mut impl TopicNode<'a>) -> Result<(), NodeError> {
        node.export(self.ep.imu.remote)?;
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

    /// The gyro bias estimate, rad/s, once the still window has closed.
    pub fn gyro_bias(&self) -> Option<[f32; 3]> {
        self.bias.bias()
    }

    /// One step at `now_us`: scale a fresh reading, estimate the bias or integrate the
    /// attitude, publish `imu` when due; returns the LEDs to show.
    pub fn step(&mut self, now_us: u64, sample: &Sample) -> Command {
        let cfg = Config::read(self.params);
        let period_us = (1e6 / self.sensor.odr_hz()) as u64;
        if sample.sensor_ok && sample.fresh {
            self.take(now_us, &sample.raw, &cfg, period_us);
        }
        let lost = !sample.sensor_ok
            || self.last_fresh_us.is_none_or(|t| now_us - t > LOST_AFTER_PERIODS * period_us);
        if lost {
            self.state.status = STATUS_NO_DATA;
        }
        if now_us >= self.next_publish_us {
            self.next_publish_us = next_due(self.next_publish_us, now_us, cfg.period_us);
            let m = self.state;
            self.ep.imu.publisher.publish_with(|x| *x = m);
        }
        let mut status = sample.status;
        status.fault |= lost;
        let [led_status, led_bus, led_fault] = leds::levels(status, now_us / 1000);
        Command { led_status, led_bus, led_fault }
    }

    /// A fresh reading: to SI units with the boot-time full scales, then the bias window or
    /// the filter.
    fn take(&mut self, now_us: u64, raw: &RawSample, cfg: &Config, period_us: u64) {
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
        let status = match self.bias.bias() {
            None => {
                self.bias.update(now_us, rate, cfg.bias_us, cfg.still_rad_s);
                // Still by assumption: level with the accelerometer, heading 0.
                self.attitude = Attitude::levelled(accel);
                if self.bias.bias().is_some() {
                    STATUS_OK
                } else {
                    STATUS_CALIBRATING
                }
            }
            Some(b) => {
                let rate = [rate[0] - b[0], rate[1] - b[1], rate[2] - b[2]];
                let dt = dt_us as f32 * 1e-6;
                self.attitude.update(rate, accel, dt, cfg.tilt_tau_s, cfg.accel_gate);
                STATUS_OK
            }
        };
        let b = self.bias.bias().unwrap_or([0.0; 3]);
        self.state = Imu {
            rate: [rate[0] - b[0], rate[1] - b[1], rate[2] - b[2]],
            accel,
            roll: self.attitude.roll,
            pitch: self.attitude.pitch,
            yaw: self.attitude.yaw,
            temperature: 25.0 + f32::from(raw.temp) / 256.0,
            status,
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
