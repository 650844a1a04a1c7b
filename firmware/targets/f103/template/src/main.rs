//! Firmware of the R2P module template (STM32F103CB): the application of `r2p-app-template`
//! (heartbeat, one topic) on the shared core — bxCAN, the node runtime, parameters in flash and
//! the status LEDs (module_core). Pins come only from the board file
//! (firmware/boards/template.toml) through the generated `board` module. A new module's image
//! starts as a copy of this one.
#![no_std]
#![no_main]

use embassy_executor::Spawner;
use embassy_stm32::can::Can;
use module_core::{EveryMs, Leds, ModuleFlash};
use r2p_app_template::{params, App, Sample, Storage};
use r2p_module::{FlashParams, ParamValues};

mod board {
    include!(concat!(env!("OUT_DIR"), "/board.rs"));
}

module_core::bind_can_interrupts!(
    struct Irqs {}
);

static PARAMS: FlashParams<{ params::COUNT }> =
    FlashParams::new(&params::DEFAULTS, &PARAM_VALUES, module_core::PARAMS_BASE);
static PARAM_VALUES: ParamValues<{ params::COUNT }> = ParamValues::new();
static ENDPOINTS: Storage = Storage::new();

/// The application: one step per millisecond in thread mode.
///
/// Awaited by `main` rather than spawned as a task of its own: a spawn can fail, and the
/// drop glue of the arguments it would then drop (the board's I/O, never dropped otherwise)
/// cost flash; `main`'s task holds this future instead.
async fn run(mut app: App<'static>, mut leds: Leds, flash: ModuleFlash) -> ! {
    let mut ms = EveryMs::new(&PARAMS, flash);
    loop {
        let c = app.step(ms.now(), &Sample { status: module_core::led_status() });
        leds.show([c.led_status, c.led_bus, c.led_fault]);
        ms.next().await;
    }
}

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    let p = module_core::init::<{ board::HSE_HZ }, { board::SYSCLK_HZ }>();
    let pins = board::take_pins!(p);
    // Outputs first: the LEDs take their boot levels at once.
    let leds = module_core::leds!(board, pins);

    let mut can = Can::new(p.CAN, pins.can_rx, pins.can_tx, Irqs);
    module_core::enable_can::<{ board::SYSCLK_HZ }>(&mut can).await;
    let flash = module_core::load_params(&PARAMS, p.FLASH, p.IWDG, module_core::linked!());
    let app = App::new(ENDPOINTS.build(), &PARAMS);
    let config = r2p_app_template::node_config(embassy_stm32::uid::uid());
    module_core::start_bus(
        config,
        &PARAMS,
        |node| app.register(node),
        can,
        p.TIM2,
        module_core::linked!(),
    );

    run(app, leds, flash).await
}
