//! Footprint image: the shared core on an STM32F103CB and nothing else — Embassy executor and
//! time, bxCAN at 1 Mbit/s (PA11/PA12, the pins every R2P module core uses), RTCAN, the
//! middleware and the node runtime (../../shared/footprint_core.rs) — so `make firmware` and
//! `make bench` report what the core costs and what is left for a module's application.
#![no_std]
#![no_main]

use embassy_executor::Spawner;
use embassy_stm32::can::Can;
use embassy_stm32::{pac, rcc, time::Hertz, Config};
use panic_halt as _;
use rtcan_bxcan::BxCan;

#[path = "../../../shared/footprint_core.rs"]
mod footprint_core;

rtcan_bxcan::bind_bxcan_interrupts!(struct Irqs {
    can: CAN, rx0: USB_LP_CAN1_RX0, rx1: CAN1_RX1, sce: CAN1_SCE, tx: USB_HP_CAN1_TX;
});

/// 72 MHz SYSCLK from the 8 MHz crystal; APB1 at 36 MHz clocks bxCAN.
fn clocks() -> Config {
    let mut config = Config::default();
    config.rcc.hse = Some(rcc::Hse { freq: Hertz(8_000_000), mode: rcc::HseMode::Oscillator });
    config.rcc.pll = Some(rcc::Pll {
        src: rcc::PllSource::HSE,
        prediv: rcc::PllPreDiv::DIV1,
        mul: rcc::PllMul::MUL9,
    });
    config.rcc.sys = rcc::Sysclk::PLL1_P;
    config.rcc.ahb_pre = rcc::AHBPrescaler::DIV1;
    config.rcc.apb1_pre = rcc::APBPrescaler::DIV2;
    config.rcc.apb2_pre = rcc::APBPrescaler::DIV1;
    config
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let p = embassy_stm32::init(clocks());
    let mut can = Can::new(p.CAN, p.PA11, p.PA12, Irqs);
    can.modify_config().set_bitrate(1_000_000);
    can.enable().await;
    let can = BxCan::new(can, pac::CAN, 1_000_000);
    footprint_core::run(spawner, can, embassy_stm32::uid::uid());
}
