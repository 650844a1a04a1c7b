//! Sensor drivers for R2P modules: `no_std`, no heap, generic over the embedded-hal 1.0 and
//! embedded-io traits that embassy-stm32's I2C, SPI and UART drivers implement — and that the
//! emulator's simulated buses implement too (`firmware/host/emu/src/periph/`), so the same
//! driver code runs on a module and against a simulated device in virtual time.
//!
//! - [`lsm6dso`]: ST LSM6DSO 6-axis IMU (accelerometer + gyroscope) over I2C or SPI — probe,
//!   configure output data rate and full scale, read gyro + accel + temperature in one
//!   auto-incremented burst, convert to SI units with the datasheet sensitivities.
//! - [`lis3mdl`]: ST LIS3MDL 3-axis magnetometer over I2C or SPI (4-wire) — probe, configure
//!   ultra-high-performance mode, rate and full scale, read field and temperature in one
//!   burst, convert to µT with the datasheet sensitivities.
//! - [`lps22`]: ST LPS22HH and LPS22DF barometers over I2C or SPI — probe (which of the two),
//!   rate and noise reduction, read pressure and temperature in one burst (24-bit pressure in
//!   Pa).
//! - [`rangers`]: analog rangers (Sharp GP2Y0A21/GP2Y0A02 infrared, MaxBotix LV-MaxSonar-EZ):
//!   their datasheet transfer curves, voltage to distance and back, shared by the proximity
//!   firmware and the world model that emulates the sensors.
//! - [`tfmini`]: Benewake TFmini-S single-point LiDAR over UART — a frame parser that
//!   resynchronises on garbage and counts bad checksums, and the frame-rate command.
//! - [`ubx`]: u-blox GNSS receivers (M8, M9, M10) over UART — a byte-at-a-time UBX decoder
//!   (NAV-PVT, ACK-ACK/NAK; NMEA and noise skipped and counted) and the boot configuration
//!   (CFG-VALSET for M9/M10, CFG-MSG/RATE/PRT for M8) for NAV-PVT alone at 1–10 Hz, 38400 baud.
//!
//! Why our own drivers rather than crates.io's: the `lsm6dso` crate (0.2) speaks I2C only (the
//! IMU module may use SPI), reports a wrong chip as a bare `ChipDetectFailed` without the value
//! read, and makes its `blocking` and `async` features mutually exclusive with a
//! `compile_error!`, which breaks as soon as two crates of one build enable different ones;
//! `lsm6dsox` targets embedded-hal 0.2 and another part. No maintained TFmini driver exists for
//! embedded-io. Both devices need only a handful of registers or one frame format, so a small
//! driver that we test against a register-level model is the sounder choice.
//!
//! Issue 21's magnetometer and barometer: for the LIS3MDL crates.io has `lis3mdl` and
//! `lis3mdl-driver` (0.1, 2019: embedded-hal 0.2, I2C only). For the LPS22HH and LPS22DF ST
//! publishes `lps22hh-rs` and `lps22df-rs` (I2C and SPI over embedded-hal 1.0, through ST's
//! `st_mems_bus`); ours is kept because one driver serves either part on the same footprint
//! (the board's LPS22HH, or an LPS22DF), its errors name what was read (ST's say
//! `UnexpectedValue`), it reads status, pressure and temperature in one burst, and it matches
//! the other drivers' tests against register models. Its flash cost against ST's crates in the
//! IMU image is NOT measured.
//!
//! The GNSS receiver's UBX: the `ublox` crate (0.10) decodes NAV-PVT correctly (the emulator's
//! tests use it as the independent check) but costs ~6.9 KB of flash in the F103 IMU image,
//! which has ~3.7 KB left for all of issue 21; [`ubx`] decodes the one message the module
//! needs by hand (field offsets from u-blox's interface descriptions, cited there).
#![no_std]
#![warn(missing_docs)]

#[cfg(test)]
extern crate std;

pub mod lis3mdl;
pub mod lps22;
pub mod lsm6dso;
pub mod rangers;
pub mod register_bus;
pub mod tfmini;
pub mod ubx;
