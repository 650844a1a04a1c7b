//! Footprint image for the gateway's STM32F407VG: the shared core (Embassy executor and time,
//! bxCAN at 1 Mbit/s, RTCAN) and nothing else, so `make firmware` can report what is left for
//! the gateway's Ethernet stack. Sends one NRT frame per second on CAN1 (PB8/PB9).
#![no_std]
#![no_main]

use embassy_executor::Spawner;
use embassy_stm32::can::{
    Can, Rx0InterruptHandler, Rx1InterruptHandler, SceInterruptHandler, TxInterruptHandler,
};
use embassy_stm32::peripherals::CAN1;
use embassy_stm32::{bind_interrupts, pac, rcc, time::Hertz, Config};
use embassy_time::Timer;
use panic_halt as _;
use rtcan::{CanController, Frame, FrameId, Laxity, MessageId};
use rtcan_bxcan::BxCan;

bind_interrupts!(struct Irqs {
    CAN1_RX0 => Rx0InterruptHandler<CAN1>;
    CAN1_RX1 => Rx1InterruptHandler<CAN1>;
    CAN1_SCE => SceInterruptHandler<CAN1>;
    CAN1_TX => TxInterruptHandler<CAN1>;
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
async fn main(_spawner: Spawner) {
    let p = embassy_stm32::init(clocks());
    let mut can = Can::new(p.CAN1, p.PB8, p.PB9, Irqs);
    can.modify_config().set_bitrate(1_000_000);
    can.enable().await;
    let mut can = BxCan::new(can, pac::CAN1);

    let id = FrameId::new(Laxity::NRT, MessageId(0x0100), 0).unwrap();
    let mut count: u32 = 0;
    loop {
        if let Ok(frame) = Frame::new(id, &count.to_le_bytes()) {
            let _ = can.try_transmit(&frame);
        }
        while can.try_receive().is_some() {}
        count = count.wrapping_add(1);
        Timer::after_secs(1).await;
    }
}
