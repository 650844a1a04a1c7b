//! Default application of the R2P IMU module: an ST LSM6DSO 6-axis IMU (gyroscope and
//! accelerometer) on SPI.
//!
//! The board-support layer configures the sensor at boot with [`App::sensor_config`] (output
//! data rate and full scales from the parameters) through the `r2p-drivers` LSM6DSO driver,
//! then every millisecond polls its data-ready flag and hands the raw counts to [`App::step`].
//! The application scales them with the configured full scales, estimates the gyro's
//! zero-rate offset while the robot stands still after boot ([`bias`]), integrates the heading
//! and estimates roll and pitch with a complementary filter ([`attitude`]), and publishes it
//! all on the `imu` topic ([`r2p_msgs::Imu`]).
//!
//! Sans-IO (module application contract): the MCU image (firmware/targets/f103/imu) and the
//! emulated board (firmware/host/emu, the same driver over a simulated SPI bus and a register
//! model of the LSM6DSO) run the same [`App::step`]. The README's generated section lists the
//! topic, parameters and LEDs.
#![no_std]
#![warn(missing_docs)]

#[cfg(any(test, feature = "std"))]
extern crate std;

pub mod ahrs;
pub mod altitude;
mod app;
pub mod attitude;
pub mod bias;
pub mod endpoints;
pub mod gnss;
pub mod mag_cal;
pub mod params;
#[cfg(any(test, feature = "std"))]
pub mod readme;
pub mod sensor;

#[cfg(test)]
mod tests;

pub use app::{
    App, Command, Reading, Sample, BARO_PERIOD_US, LOST_AFTER_PERIODS, MAG_PERIOD_US, SENSOR_BARO,
    SENSOR_GNSS, SENSOR_IMU, SENSOR_MAG, STATUS_CALIBRATING, STATUS_NO_DATA, STATUS_OK,
};
pub use endpoints::{names, Endpoints, Names, Storage, NAMES};

use r2p_node::{NodeConfig, ParamStore};

/// The IMU module's node configuration: its name from the `instance` parameter, no master
/// rank, the modules' slot lead.
pub fn node_config(uid: [u8; 12], params: &dyn ParamStore) -> NodeConfig {
    NodeConfig {
        slot_lead_us: r2p_node::MODULE_SLOT_LEAD_US,
        sync_lead_us: r2p_node::MODULE_SYNC_LEAD_US,
        framed_leads: r2p_node::MODULE_FRAMED_LEADS,
        ..NodeConfig::module(uid, names(params).node)
    }
}
