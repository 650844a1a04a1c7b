//! The DC motor controller module's default firmware on its STM32F103CB: the board-support
//! layer of `r2p-app-motor` (firmware/apps/motor).
//!
//! - **Pins** only from the generated `board.rs` (firmware/boards/motor.toml).
//! - **Control**, at the highest software priority (an interrupt executor on USART2's vector):
//!   every millisecond read the encoder and the ADC, run `App::step`, apply the command to the
//!   bridge and the LEDs.
//! - **Bus**, one priority lower (an interrupt executor on USART3's vector, as in the shared
//!   core's footprint image): the node runtime, driven by the TDMA slot timer.
//! - **Thread mode**: parameters to flash (only while the bridge is off: a page erase stalls
//!   the CPU for ~20 ms, control loop included) and reboots.
#![no_std]
#![no_main]

mod bridge;
mod sensors;

#[allow(dead_code)]
mod board {
    include!(concat!(env!("OUT_DIR"), "/board.rs"));
}

use core::sync::atomic::{AtomicBool, AtomicU8, Ordering::Relaxed};

use embassy_executor::{InterruptExecutor, Spawner};
use embassy_stm32::can::{
    Can, Rx0InterruptHandler, Rx1InterruptHandler, SceInterruptHandler, TxInterruptHandler,
};
use embassy_stm32::flash::{Blocking, Flash, FLASH_SIZE, MAX_ERASE_SIZE};
use embassy_stm32::gpio::Output;
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::peripherals::{ADC1, CAN};
use embassy_stm32::{adc, bind_interrupts, pac, rcc, time::Hertz, Config};
use embassy_time::{Duration, Instant, Ticker, Timer};
use panic_halt as _;
use r2p_app_motor::params::{self, COUNT};
use r2p_app_motor::{App, Command, Endpoints, Names, Sample};
use r2p_module::leds::Status;
use r2p_module::FlashParams;
use r2p_node::{Node, NodeConfig};
use rtcan::cycle::ClockState;
use rtcan_bxcan::BxCan;

use bridge::Bridge;
use sensors::Sensors;

bind_interrupts!(struct Irqs {
    USB_LP_CAN1_RX0 => Rx0InterruptHandler<CAN>;
    CAN1_RX1 => Rx1InterruptHandler<CAN>;
    CAN1_SCE => SceInterruptHandler<CAN>;
    USB_HP_CAN1_TX => TxInterruptHandler<CAN>;
    ADC1_2 => adc::InterruptHandler<ADC1>;
});

/// Flash kept for the parameters at its end (build.rs; its linker script keeps the image out).
const PARAMS_BYTES: usize = parse(env!("R2P_PARAMS_BYTES"));
const _: () = assert!(PARAMS_BYTES == 2 * MAX_ERASE_SIZE, "FlashParams uses two erase pages");
/// Where the parameters live: the last two erase pages of flash.
const PARAMS_OFFSET: u32 = (FLASH_SIZE - PARAMS_BYTES) as u32;

/// A decimal number at compile time.
const fn parse(s: &str) -> usize {
    let (b, mut i, mut n) = (s.as_bytes(), 0, 0);
    while i < b.len() {
        n = n * 10 + (b[i] - b'0') as usize;
        i += 1;
    }
    n
}
/// CAN bit rate (the R2P bus, docs/bus.md).
const CAN_BIT_RATE: u32 = 1_000_000;

static PARAMS: FlashParams<COUNT> = FlashParams::new(params::DEFAULTS, PARAMS_OFFSET);

static CONTROL_EXECUTOR: InterruptExecutor = InterruptExecutor::new();
static BUS_EXECUTOR: InterruptExecutor = InterruptExecutor::new();

#[interrupt]
unsafe fn USART2() {
    // SAFETY: the interrupt is reserved for this executor (started in `main`).
    unsafe { CONTROL_EXECUTOR.on_interrupt() }
}

#[interrupt]
unsafe fn USART3() {
    // SAFETY: the interrupt is reserved for this executor (started in `main`).
    unsafe { BUS_EXECUTOR.on_interrupt() }
}

/// The bridge is driven: no flash erase now.
static BRIDGE_ON: AtomicBool = AtomicBool::new(false);
/// Storing parameters failed (fault LED blinks).
static STORAGE_FAULT: AtomicBool = AtomicBool::new(false);
/// The bus asked this module to reboot.
static REBOOT: AtomicBool = AtomicBool::new(false);
/// The node's state for the LEDs: bit 0 running, 1 synced, 2 traffic.
static NODE_STATUS: AtomicU8 = AtomicU8::new(0);

type MotorNode = Node<'static, 2, 2, 32, 4, 64>;

/// SYSCLK from the crystal through the PLL; APB1 at half (bxCAN, ≤ 36 MHz), APB2 and TIM1 at
/// SYSCLK, the ADC at SYSCLK / 6 (≤ 14 MHz).
fn clocks() -> Config {
    const _: () = assert!(
        board::SYSCLK_HZ == board::HSE_HZ * 9,
        "the board file's clocks need PLL × 9 (8 MHz crystal → 72 MHz)"
    );
    let mut config = Config::default();
    config.rcc.hse = Some(rcc::Hse { freq: Hertz(board::HSE_HZ), mode: rcc::HseMode::Oscillator });
    config.rcc.pll = Some(rcc::Pll {
        src: rcc::PllSource::HSE,
        prediv: rcc::PllPreDiv::DIV1,
        mul: rcc::PllMul::MUL9,
    });
    config.rcc.sys = rcc::Sysclk::PLL1_P;
    config.rcc.ahb_pre = rcc::AHBPrescaler::DIV1;
    config.rcc.apb1_pre = rcc::APBPrescaler::DIV2;
    config.rcc.apb2_pre = rcc::APBPrescaler::DIV1;
    config.rcc.adc_pre = rcc::ADCPrescaler::DIV6;
    config
}

/// The three status LEDs; `levels` are (status, bus, fault), true = lit.
struct Leds([Output<'static>; 3]);

impl Leds {
    fn show(&mut self, levels: [bool; 3]) {
        let active_low =
            [board::LED_STATUS_ACTIVE_LOW, board::LED_BUS_ACTIVE_LOW, board::LED_FAULT_ACTIVE_LOW];
        for ((led, lit), low) in self.0.iter_mut().zip(levels).zip(active_low) {
            led.set_level((lit != low).into());
        }
    }
}

/// The 1 kHz control loop.
#[embassy_executor::task]
async fn control(ep: Endpoints<'static>, mut sensors: Sensors, mut bridge: Bridge, mut leds: Leds) {
    let mut app = App::new(ep, &PARAMS);
    let mut ticker = Ticker::every(Duration::from_millis(1));
    loop {
        ticker.next().await;
        let now = Instant::now().as_micros();
        let (encoder_count, current_adc, vmot_adc) = sensors.read().await;
        let bits = NODE_STATUS.load(Relaxed);
        let sample = Sample {
            encoder_count,
            current_adc,
            vmot_adc,
            driver_fault: bridge::take_break_flag(),
            status: Status {
                running: bits & 1 != 0,
                synced: bits & 2 != 0,
                traffic: bits & 4 != 0,
                fault: false,
                storage_fault: STORAGE_FAULT.load(Relaxed),
            },
        };
        let cmd: Command = app.step(now, &sample);
        bridge.apply(&cmd);
        BRIDGE_ON.store(cmd.bridge_enable, Relaxed);
        leds.show(cmd.leds);
    }
}

/// The node, at every slot boundary of the TDMA cycle (or of the free-running slot clock on a
/// bus without a master).
#[embassy_executor::task]
async fn bus(ep: Endpoints<'static>, mut can: BxCan<'static>, uid: [u8; 12]) {
    let mut node: MotorNode =
        Node::new(NodeConfig::new(uid, ep.names.node), &PARAMS).expect("valid node configuration");
    ep.register(&mut node).expect("room for the motor's topics on its node");
    let heartbeat_us = u64::from(NodeConfig::new([0; 12], "").heartbeat_period_us);
    let mut received = 0;
    let mut last_traffic = 0;
    loop {
        let now = Instant::now().as_micros();
        node.slot_tick(now, &mut can);
        while node.next_event().is_some() {} // parameters persist from `is_dirty`
        if node.take_reboot_request() {
            REBOOT.store(true, Relaxed);
        }
        let stats = node.stats();
        if stats.frames_received != received {
            received = stats.frames_received;
            last_traffic = now;
        }
        let running = now >= 2 * heartbeat_us; // its `Starting` heartbeats are out
        let synced = matches!(node.clock().state(now), ClockState::Running(_));
        let traffic = received > 0 && now - last_traffic < 1_000_000;
        NODE_STATUS
            .store(u8::from(running) | u8::from(synced) << 1 | u8::from(traffic) << 2, Relaxed);
        Timer::at(Instant::from_micros(node.next_slot_at(now))).await;
    }
}

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    let p = embassy_stm32::init(clocks());
    let pins = board::take_pins!(p);

    let mut flash = Flash::new_blocking(p.FLASH);
    if PARAMS.load(&mut flash).is_err() {
        STORAGE_FAULT.store(true, Relaxed);
    }
    let names = Names::from_params(&PARAMS);
    let ep = r2p_app_motor::endpoints!(names);

    let bridge = Bridge::new(
        p.TIM1,
        bridge::Pins {
            ah: pins.pwm_ah,
            al: pins.pwm_al,
            bh: pins.pwm_bh,
            bl: pins.pwm_bl,
            fault: pins.drv_fault,
            enable: board::drv_en(pins.drv_en),
        },
    );
    let sensors =
        Sensors::new(p.ADC1, pins.motor_current, pins.vmot_sense, p.TIM3, pins.enc_a, pins.enc_b);
    let leds = Leds([
        board::led_status(pins.led_status),
        board::led_bus(pins.led_bus),
        board::led_fault(pins.led_fault),
    ]);

    let mut can = Can::new(p.CAN, pins.can_rx, pins.can_tx, Irqs);
    can.modify_config().set_bitrate(CAN_BIT_RATE);
    can.enable().await;
    let can = BxCan::new(can, pac::CAN);

    interrupt::USART2.set_priority(Priority::P5);
    CONTROL_EXECUTOR.start(interrupt::USART2).spawn(control(ep, sensors, bridge, leds)).unwrap();
    interrupt::USART3.set_priority(Priority::P6);
    BUS_EXECUTOR.start(interrupt::USART3).spawn(bus(ep, can, embassy_stm32::uid::uid())).unwrap();

    persist(&mut flash).await
}

/// Writes changed parameters to flash while the bridge is off, and reboots on request.
async fn persist(flash: &mut Flash<'static, Blocking>) -> ! {
    loop {
        Timer::after_millis(100).await;
        let reboot = REBOOT.load(Relaxed);
        if PARAMS.is_dirty() && (!BRIDGE_ON.load(Relaxed) || reboot) {
            let ok = PARAMS.commit(flash).is_ok();
            STORAGE_FAULT.store(!ok, Relaxed);
        }
        if reboot {
            cortex_m::peripheral::SCB::sys_reset();
        }
    }
}
