//! Footprint image for the gateway's STM32F407VG: the same shared core as the F103 footprint
//! image (executor, time, bxCAN on CAN1 at PB8/PB9, RTCAN, middleware, management) and nothing
//! else, so `make firmware` can report what is left for the gateway's Ethernet stack.
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
    can: CAN1, rx0: CAN1_RX0, rx1: CAN1_RX1, sce: CAN1_SCE, tx: CAN1_TX;
});

/// 168 MHz SYSCLK from the 8 MHz crystal; APB1 at 42 MHz clocks bxCAN.
fn clocks() -> Config {
    let mut config = Config::default();
    config.rcc.hse = Some(rcc::Hse { freq: Hertz(8_000_000), mode: rcc::HseMode::Oscillator });
    config.rcc.pll_src = rcc::PllSource::HSE;
    config.rcc.pll = Some(rcc::Pll {
        prediv: rcc::PllPreDiv::DIV4,
        mul: rcc::PllMul::MUL168,
        divp: Some(rcc::PllPDiv::DIV2),
        divq: Some(rcc::PllQDiv::DIV7),
        divr: None,
    });
    config.rcc.sys = rcc::Sysclk::PLL1_P;
    config.rcc.ahb_pre = rcc::AHBPrescaler::DIV1;
    config.rcc.apb1_pre = rcc::APBPrescaler::DIV4;
    config.rcc.apb2_pre = rcc::APBPrescaler::DIV2;
    config
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let p = embassy_stm32::init(clocks());
    let mut can = Can::new(p.CAN1, p.PB8, p.PB9, Irqs);
    can.modify_config().set_bitrate(1_000_000);
    can.enable().await;
    let can = BxCan::new(can, pac::CAN1, 1_000_000);
    footprint_core::run(spawner, can, embassy_stm32::uid::uid());
}
