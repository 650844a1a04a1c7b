//! The IMU board: the module's firmware on an LSM6DSO behind SPI1, here the simulated SPI bus
//! ([`SimSpi`]) and the register model ([`Lsm6dsoModel`]), whose samples come from the world's
//! IMU on the board's mount ([`r2p_world::World::sample_imu`]). The firmware's side is the
//! MCU's: the `r2p-drivers` LSM6DSO driver configured at boot with the application's sensor
//! set-up, then polled every millisecond by `r2p_app_imu::sensor::poll`.
//!
//! A reboot is a power cycle of the board, the sensor included: the register model starts
//! from its reset values and the driver configures it again (the device's offsets and noise
//! stream belong to the world and carry on).

use r2p_app_imu as app;
use r2p_drivers::lsm6dso::Lsm6dso;

use super::{leak, load_params, node, persist, Booted, Ctx, Leds};
use crate::periph::lsm6dso::Lsm6dsoModel;
use crate::periph::shared;
use crate::periph::spi::SimSpi;

/// Boots the IMU firmware.
pub fn imu(ctx: Ctx<'_>) -> Result<Booted, String> {
    let params = load_params(app::params::DEFAULTS, ctx.flash)?;
    let mut a = app::App::new(app::Endpoints::leak(params), params);
    let config = app::node_config(ctx.module.uid.0, params);
    let mut n = node(config, &ctx, params)?;
    a.register(&mut n).map_err(|e| format!("registering topics: {e:?}"))?;
    let mut leds = Leds::new(&ctx, config.heartbeat_period_us);
    let device = shared(Lsm6dsoModel::new());
    // The device's clock starts at boot (both sensors are still powered down: no sample).
    device.borrow_mut().advance_with(ctx.boot_us * 1000, |_| unreachable!("sensors off"));
    let mut sensor = Lsm6dso::new_spi(SimSpi::new(device.clone()));
    // As on the MCU: a sensor that does not answer leaves the module running, reporting
    // "no data" (status 2, fault LED).
    let initialised = sensor.init(a.sensor_config()).is_ok();
    let (world, flash) = (ctx.world, ctx.flash);
    let name: &'static str = leak(ctx.module.name.clone()).as_str();
    Ok((
        n,
        Box::new(move |now, node| {
            {
                let mut w = world.borrow_mut();
                device.borrow_mut().advance_with(now * 1000, |odr_hz| {
                    w.sample_imu(name, odr_hz).unwrap_or_else(|e| panic!("{e}"))
                });
            }
            let sample = app::sensor::poll(&mut sensor, initialised, leds.status(now, node, false));
            a.step(now, &sample);
            persist(params, flash);
        }),
    ))
}
