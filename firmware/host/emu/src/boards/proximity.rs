//! The proximity board: four ranger outputs on PROX_CH0–3 from the world; the sensors' supply
//! switch and its over-current flag.

use r2p_app_proximity as app;

use super::{adc, leak, load_params, node, persist, Booted, Ctx, Leds};

/// Boots the proximity firmware.
pub fn proximity(ctx: Ctx<'_>) -> Result<Booted, String> {
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
                adc: ["PROX_CH0", "PROX_CH1", "PROX_CH2", "PROX_CH3"].map(|s| adc(&mut w, name, s)),
                status: leds.status(now, node, false),
                // SENSOR_PWR_FAULT is active low.
                supply_fault: !w.read_input(name, "SENSOR_PWR_FAULT").unwrap_or(true),
            };
            let c = a.step(now, &sample);
            w.set_output(name, "SENSOR_PWR_EN", c.sensor_power).unwrap_or_else(|e| panic!("{e}"));
            persist(params, flash);
        }),
    ))
}
