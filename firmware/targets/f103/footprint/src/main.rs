//! Footprint image: the shared core on an STM32F103CB and nothing else — Embassy executor and
//! time, bxCAN at 1 Mbit/s (PA11/PA12, the pins every R2P module core uses), RTCAN reassembly
//! and transmit queue, a middleware topic with a publisher task and a subscriber, node-ID
//! claiming and a management heartbeat — so `make firmware` and `make bench` report what the
//! core costs and what is left for a module's application. It is a measurement, not a product:
//! each piece is used the way a module uses it, so the linker keeps it.
#![no_std]
#![no_main]

use embassy_executor::Spawner;
use embassy_stm32::can::{
    Can, Rx0InterruptHandler, Rx1InterruptHandler, SceInterruptHandler, TxInterruptHandler,
};
use embassy_stm32::peripherals::CAN;
use embassy_stm32::{bind_interrupts, pac, rcc, time::Hertz, Config};
use embassy_time::Timer;
use panic_halt as _;
use r2p_management::message::{Message, ModuleState, ENCODED_MAX};
use r2p_management::{NodeId, NodeIdAllocator};
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use rtcan::{CanController, Expect, LaxityEncoding, Reassembler, TxQueue, Urgency};
use rtcan_bxcan::BxCan;

bind_interrupts!(struct Irqs {
    USB_LP_CAN1_RX0 => Rx0InterruptHandler<CAN>;
    CAN1_RX1 => Rx1InterruptHandler<CAN>;
    CAN1_SCE => SceInterruptHandler<CAN>;
    USB_HP_CAN1_TX => TxInterruptHandler<CAN>;
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
    let mut can = BxCan::new(can, pac::CAN);
    spawner.spawn(sensor()).unwrap();

    // The core's receive and transmit paths, as a module runs them.
    let mut node = NodeIdAllocator::new(embassy_stm32::uid::uid());
    let mut rx: Reassembler<4, 64> = Reassembler::new(20_000);
    let mut tx: TxQueue<32> = TxQueue::new(LaxityEncoding::Logarithmic { tick_us: 100 });
    let mut buf = [0u8; ENCODED_MAX];
    let mut uptime_s = 0u32;
    loop {
        let now = embassy_time::Instant::now().as_micros();
        while let Some(r) = can.try_receive() {
            if let Some(msg) = rx.accept(&r.frame, r.at, Expect::Any) {
                if let (Some((from, 0)), Ok(Message::Heartbeat { uid, .. })) =
                    (NodeId::of(msg.id), Message::decode(msg.data))
                {
                    node.on_heartbeat(from, &uid);
                }
            }
        }
        rx.expire(now);
        if let Some(m) = READINGS.try_recv() {
            let id = node.node_id().message_id(1);
            let bytes: [u8; 4] = m.to_le_bytes();
            let _ = tx.push_message(id, &bytes, Urgency::Srt { deadline: now + 10_000 });
        }
        let heartbeat = Message::Heartbeat {
            uid: embassy_stm32::uid::uid(),
            name: heapless_name(),
            state: ModuleState::Running,
            uptime_s,
            tx_errors: can.error_counters().tx,
            rx_errors: can.error_counters().rx,
            dropped: rx.stats().foreign as u16,
        };
        if let Ok(n) = heartbeat.encode(&mut buf) {
            let _ = tx.push_message(node.node_id().management(), &buf[..n], Urgency::Nrt);
        }
        tx.expire(now, |_| {});
        while let Some(frame) = tx.peek(now) {
            if can.try_transmit(&frame).is_err() {
                break;
            }
            tx.pop(now);
        }
        uptime_s = uptime_s.wrapping_add(1);
        Timer::after_millis(100).await;
    }
}

/// A reading published locally, as a sensor node would (zero copy to its subscriber).
static READINGS_TOPIC: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("readings", 0);
static READINGS_PUB: Publisher<'static, u32> =
    Publisher::new(&READINGS_TOPIC, Class::AsyncRealTime { deadline_us: 10_000 });
static READINGS: Subscriber<'static, u32, 4> = Subscriber::new();

#[embassy_executor::task]
async fn sensor() {
    READINGS_TOPIC.advertise(&READINGS_PUB).unwrap();
    READINGS_TOPIC.subscribe(&READINGS).unwrap();
    let mut n = 0u32;
    loop {
        if let Some(mut m) = READINGS_PUB.try_alloc() {
            *m = n;
            READINGS_PUB.publish(m);
        }
        n = n.wrapping_add(1);
        Timer::after_millis(10).await;
    }
}

fn heapless_name() -> heapless::String<16> {
    heapless::String::try_from("footprint").unwrap_or_default()
}
