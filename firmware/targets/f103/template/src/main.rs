//! Firmware of the R2P module template (STM32F103CB): the application of `r2p-app-template`
//! (heartbeat, one topic) on the shared core — bxCAN, the node runtime, parameters in flash and
//! the status LEDs. Pins come only from the board file (firmware/boards/template.toml) through
//! the generated `board` module. A new module's image starts as a copy of this one.
#![no_std]
#![no_main]

use embassy_executor::Spawner;
use embassy_stm32::can::Can;
use embassy_stm32::flash::{Blocking, Flash};
use embassy_stm32::gpio::Output;
use embassy_stm32::pac;
use embassy_time::{Duration, Instant, Ticker};
use r2p_app_template::{params, App, Sample, Storage};
use r2p_module::FlashParams;
use rtcan_bxcan::BxCan;

mod board {
    include!(concat!(env!("OUT_DIR"), "/board.rs"));
}

use module_core::{drive, ModuleNode};

module_core::bind_can_interrupts!(
    struct Irqs {}
);

static PARAMS: FlashParams<{ params::COUNT }> =
    FlashParams::new(params::DEFAULTS, module_core::PARAMS_BASE);
static ENDPOINTS: Storage = Storage::new();

/// The application: one step per millisecond in thread mode; parameters persisted every
/// 100 ms when changed.
#[embassy_executor::task]
async fn run(
    mut app: App<'static>,
    mut leds: [Output<'static>; 3],
    mut flash: Flash<'static, Blocking>,
) {
    let mut ticker = Ticker::every(Duration::from_millis(1));
    let mut step = 0u32;
    loop {
        let now = Instant::now().as_micros();
        let c = app.step(now, &Sample { status: module_core::led_status() });
        let [status, bus, fault] = &mut leds;
        drive(status, c.led_status, board::LED_STATUS_ACTIVE_LOW);
        drive(bus, c.led_bus, board::LED_BUS_ACTIVE_LOW);
        drive(fault, c.led_fault, board::LED_FAULT_ACTIVE_LOW);
        step = step.wrapping_add(1);
        if step.is_multiple_of(100) {
            module_core::persist(&PARAMS, &mut flash);
        }
        ticker.next().await;
    }
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let pll_mul = const { module_core::pll_mul(board::HSE_HZ, board::SYSCLK_HZ) };
    let p = embassy_stm32::init(module_core::clocks(board::HSE_HZ, pll_mul));
    let pins = board::take_pins!(p);

    // Outputs first: the LEDs take their boot levels at once.
    let leds = [
        board::led_status(pins.led_status),
        board::led_bus(pins.led_bus),
        board::led_fault(pins.led_fault),
    ];

    // The bus controller before the application and its node, so that neither lives across
    // this await (and in `main`'s future).
    let mut can = Can::new(p.CAN, pins.can_rx, pins.can_tx, Irqs);
    can.modify_config().set_bitrate(1_000_000);
    can.enable().await;

    let mut flash = Flash::new_blocking(p.FLASH);
    module_core::load_params(&PARAMS, &mut flash);
    let app = App::new(ENDPOINTS.build(), &PARAMS);
    let config = r2p_app_template::node_config(embassy_stm32::uid::uid());
    let mut node = ModuleNode::new(config, &PARAMS).unwrap();
    app.register(&mut node).unwrap();
    module_core::start_bus(node, &config, BxCan::new(can, pac::CAN, 1_000_000), p.TIM2);

    spawner.spawn(run(app, leds, flash)).unwrap();
}
