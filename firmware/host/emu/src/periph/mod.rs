//! Simulated bus peripherals, at register and byte level, behind the same traits as the
//! MCU's drivers: an I2C controller ([`i2c::SimI2c`], `embedded_hal::i2c::I2c`), an SPI
//! device ([`spi::SimSpi`], `embedded_hal::spi::SpiDevice`) and a UART ([`uart::SimUart`],
//! `embedded_io::{Read, ReadReady, Write}`), so a sensor driver (`r2p-drivers`) runs
//! unchanged against them. Devices on them are models of real parts fed by the world:
//! [`lsm6dso::Lsm6dsoModel`] (IMU registers, samples from [`r2p_world::imu`]),
//! [`lis3mdl::Lis3mdlModel`] (magnetometer registers), [`lps22::Lps22Model`] (LPS22HH or
//! LPS22DF barometer registers), [`ubx_gnss::UbxGnssModel`] (a u-blox receiver: NMEA from its
//! factory settings, UBX configuration and UBX-NAV-PVT, from [`r2p_world::gnss`]) and
//! [`tfmini::TfminiModel`] (LiDAR frames, from [`r2p_world::lidar`]).
//!
//! Register devices implement [`registers::RegisterDevice`]; the I2C and SPI models turn bus
//! transactions into register reads and writes (address pointer, auto-increment, SPI read
//! bit). Devices are shared (`Rc<RefCell<…>>`) between the bus the driver owns and the
//! emulator step that feeds them samples in virtual time. See docs/emulation.md, "Writing a
//! new simulated peripheral".

pub mod i2c;
pub mod lis3mdl;
pub mod lps22;
pub mod lsm6dso;
pub mod registers;
pub mod spi;
pub mod tfmini;
pub mod uart;
pub mod ubx_gnss;

pub use registers::{shared, RegisterDevice, Shared};
