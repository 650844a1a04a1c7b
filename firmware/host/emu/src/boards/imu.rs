//! The IMU board: the module's firmware on the board's sensor rig ([`ImuSensors`]: the
//! LSM6DSO and LPS22HH register models on SPI1's chip selects, the LIS3MDL's alone on SPI2, the
//! GNSS receiver on USART1 and its PPS), fed from the world's devices on the board's mount. The firmware's side
//! is the MCU's: the `r2p-drivers` drivers of the three parts, set up and polled every
//! millisecond by `r2p_app_imu::sensor::Sensors` (set up again after a part stops answering).
//!
//! A reboot is a power cycle of the board, the sensors included: the register models start
//! from their reset values and the driver configures them again (the devices' offsets and
//! noise streams belong to the world and carry on).

use embedded_io::{Read, ReadReady, Write};
use r2p_app_imu as app;
use r2p_app_imu::gnss::{Action, Link};
use r2p_drivers::lis3mdl::Lis3mdl;
use r2p_drivers::lps22::Lps22;
use r2p_drivers::lsm6dso::Lsm6dso;

use super::imu_sensors::{GnssLink, ImuSensors};
use super::{load_params, node, persist, Booted, Ctx, Leds};

/// Boots the IMU firmware.
pub fn imu(ctx: Ctx<'_>) -> Result<Booted, String> {
    let params = load_params(app::params::DEFAULTS, ctx.flash)?;
    let mut a = app::App::new(app::Endpoints::leak(params), params);
    let config = app::node_config(ctx.module.uid.0, params);
    let mut n = node(config, &ctx, params)?;
    a.register(&mut n).map_err(|e| format!("registering topics: {e:?}"))?;
    let mut leds = Leds::new(&ctx, config.heartbeat_period_us);
    // The parts' clocks start at boot (their sensors still powered down: no sample).
    let mut rig =
        ImuSensors::new(&ctx.world.borrow(), &ctx.module.name, ctx.boot_us, GnssLink::DEFAULT)?;
    let mut sensors = app::sensor::Sensors::new(
        Lsm6dso::new_spi(rig.lsm6dso_spi()),
        Lis3mdl::new_spi(rig.lis3mdl_spi()),
        Lps22::new_spi(rig.lps22hh_spi()),
    );
    let config = a.sensor_config();
    let mut link = Link::new(a.gnss_rate_hz());
    let boot_us = ctx.boot_us;
    let (world, flash) = (ctx.world, ctx.flash);
    Ok((
        n,
        Box::new(move |now, node| {
            rig.advance(now, &mut world.borrow_mut());
            // As on the MCU: a part that does not answer leaves the module running, reporting
            // it (`Imu::sensors`, status 2, the fault LED), and is set up again later.
            let mut sample = sensors.poll(now, config, leds.status(now, node, false));
            // USART1 as the MCU's board-support layer drives it (what `Link` asks), and
            // TIM3_CH4's captures (since boot on the rig; the application's clock here is the
            // emulator's).
            let uart = rig.gnss_uart();
            match link.poll(now) {
                Some(Action::Send { baud }) => {
                    uart.set_baud(baud);
                    let _ = uart.write_all(link.config());
                }
                Some(Action::Listen { baud }) => uart.set_baud(baud),
                None => {}
            }
            let mut buf = [0u8; 256];
            // What the ring buffer holds (a few reads at most: an overrun is reported once).
            for _ in 0..4 {
                if !uart.read_ready().unwrap_or(true) {
                    break;
                }
                // An overrun's error: the decoder drops the frame the lost bytes were in.
                if let Ok(n) = uart.read(&mut buf) {
                    if let Some(p) = link.receive(now, &buf[..n]) {
                        sample.gnss = Some(p);
                    }
                }
            }
            sample.pps_us = rig.take_pps_us().last().map(|t| t + boot_us);
            a.step(now, &sample);
            persist(params, flash);
        }),
    ))
}
