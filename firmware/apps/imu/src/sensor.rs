//! The sensors' poll both board-support layers run every step (the MCU over embassy-stm32's
//! SPI, the emulated board over the simulated SPI bus and register model), so that what the
//! application sees of the sensor is the same code on both.

use r2p_drivers::lis3mdl::Lis3mdl;
use r2p_drivers::lps22df::Lps22df;
use r2p_drivers::lsm6dso::{Lsm6dso, RegisterBus};
use r2p_module::leds;

use crate::app::{Reading, Sample};

/// Reads the data-ready flags and, when the gyro has a new sample, the 14-byte burst of
/// temperature, gyro and accel. `initialised` is whether [`Lsm6dso::init`] succeeded at boot
/// (with [`crate::App::sensor_config`]); a bus error on the way marks the step's sample
/// `sensor_ok = false`.
pub fn poll<B: RegisterBus>(
    imu: &mut Lsm6dso<B>,
    initialised: bool,
    status: leds::Status,
) -> Sample {
    let mut s = Sample { status, ..Sample::default() };
    if !initialised {
        return s;
    }
    match imu.data_ready() {
        Ok(d) if d.gyro => match imu.read_raw() {
            Ok(raw) => (s.fresh, s.raw, s.sensor_ok) = (true, raw, true),
            Err(_) => s.sensor_ok = false,
        },
        Ok(_) => s.sensor_ok = true,
        Err(_) => s.sensor_ok = false,
    }
    s
}

/// Reads the LIS3MDL's status and field in one burst (`initialised`: its `init` succeeded).
pub fn poll_mag<B: RegisterBus>(
    mag: &mut Lis3mdl<B>,
    initialised: bool,
) -> Reading<r2p_drivers::lis3mdl::Sample> {
    reading(initialised, || mag.read())
}

/// Reads the LPS22DF's status, pressure and temperature in one burst.
pub fn poll_baro<B: RegisterBus>(
    baro: &mut Lps22df<B>,
    initialised: bool,
) -> Reading<r2p_drivers::lps22df::Sample> {
    reading(initialised, || baro.read())
}

fn reading<T, E>(initialised: bool, read: impl FnOnce() -> Result<Option<T>, E>) -> Reading<T> {
    if !initialised {
        return Reading::Failed;
    }
    match read() {
        Ok(Some(s)) => Reading::Fresh(s),
        Ok(None) => Reading::Idle,
        Err(_) => Reading::Failed,
    }
}
