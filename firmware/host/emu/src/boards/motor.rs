//! The DC motor controller board: the H-bridge (sign-magnitude PWM on TIM1, as the MCU's
//! `bridge.rs` drives it), the encoder's 16-bit timer, the Hall current sensor and the motor
//! supply from the world; the driver's fault flag as TIM1's break input.

use r2p_app_motor as app;

use super::{adc, leak, load_params, node, persist, Booted, Ctx, Leds};

/// Boots the motor controller firmware.
pub fn motor(ctx: Ctx<'_>) -> Result<Booted, String> {
    let params = load_params(app::params::DEFAULTS, ctx.flash)?;
    let names = app::Names::from_params(params);
    let mut a = app::App::new(app::Endpoints::leak(names), params);
    let config = r2p_node::NodeConfig::module(ctx.module.uid.0, names.node);
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
                encoder_count: w.read_counter(name, "ENC_A").unwrap_or_else(|e| panic!("{e}")),
                current_adc: adc(&mut w, name, "MOTOR_CURRENT"),
                vmot_adc: adc(&mut w, name, "VMOT_SENSE"),
                // DRV_FAULT is active low and latches TIM1's break.
                driver_fault: !w.read_input(name, "DRV_FAULT").unwrap_or(true),
                status: leds.status(now, node, false),
            };
            let c = a.step(now, &sample);
            let duty = if c.brake { 0.0 } else { f64::from(c.duty.clamp(-1.0, 1.0)) };
            let (da, db) = if duty >= 0.0 { (duty, 0.0) } else { (0.0, -duty) };
            let set = |w: &mut r2p_world::World, s: &str, d: f64| {
                w.set_pwm(name, s, d).unwrap_or_else(|e| panic!("{e}"))
            };
            set(&mut w, "PWM_AH", da);
            set(&mut w, "PWM_BH", db);
            w.set_output(name, "DRV_EN", c.bridge_enable).unwrap_or_else(|e| panic!("{e}"));
            persist(params, flash);
        }),
    ))
}
