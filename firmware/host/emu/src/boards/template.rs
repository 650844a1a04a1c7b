//! The module template's board: the core alone (bus, LEDs), nothing wired to the world. Also
//! the stub model of a module `scripts/new-module` scaffolds, until it gets its own board here.

use r2p_app_template as app;

use super::{load_params, node, persist, Booted, Ctx, Leds};

/// Boots the template firmware.
pub fn template(ctx: Ctx<'_>) -> Result<Booted, String> {
    let params = load_params(app::params::DEFAULTS, ctx.flash)?;
    let mut a = app::App::new(app::Endpoints::leak(), params);
    let config = app::node_config(ctx.module.uid.0);
    let mut n = node(config, &ctx, params)?;
    a.register(&mut n).map_err(|e| format!("registering topics: {e:?}"))?;
    let mut leds = Leds::new(&ctx, config.heartbeat_period_us);
    let flash = ctx.flash;
    Ok((
        n,
        Box::new(move |now, node| {
            a.step(now, &app::Sample { status: leds.status(now, node, false) });
            persist(params, flash);
        }),
    ))
}
