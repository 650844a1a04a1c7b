//! The PSU board: battery voltage and current and the bus voltage from the world's analog
//! front ends; the bus output switch and its fault flag.

use r2p_app_psu as app;

use super::{adc, leak, load_params, node, persist, Booted, Ctx, Leds};

/// Boots the PSU firmware.
pub fn psu(ctx: Ctx<'_>) -> Result<Booted, String> {
    let params = load_params(app::params::DEFAULTS, ctx.flash)?;
    let mut a = app::App::new(app::Endpoints::leak(params), params);
    let config = app::node_config(ctx.module.uid.0, params);
    let mut n = node(config, &ctx, params)?;
    a.register(&mut n).map_err(|e| format!("registering topics: {e:?}"))?;
    let mut leds = Leds::new(&ctx, config.heartbeat_period_us);
    let (world, flash) = (ctx.world, ctx.flash);
    let name: &'static str = leak(ctx.module.name.clone()).as_str();
    Ok((
        n,
        Box::new(move |now, node| {
            let mut w = world.borrow_mut();
            let sample = app::Sample {
                vin: adc(&mut w, name, "VIN_SENSE"),
                iin: adc(&mut w, name, "IIN_SENSE"),
                vout: adc(&mut w, name, "VOUT_SENSE"),
                // BUS_FAULT is active low.
                bus_fault: !w.read_input(name, "BUS_FAULT").unwrap_or(true),
                status: leds.status(now, node, false),
            };
            let c = a.step(now, &sample);
            w.set_output(name, "BUS_EN", c.bus_en).unwrap_or_else(|e| panic!("{e}"));
            persist(params, flash);
        }),
    ))
}
