//! Default firmware of the R2P DC motor controller (STM32F103CB): the application of
//! `r2p-app-motor` (firmware/apps/motor) on the H-bridge (TIM1), the encoder (TIM3), the Hall
//! current sensor and the motor supply (ADC1), the status LEDs, bxCAN and parameters in flash.
//! Pins come only from the board file (firmware/boards/motor.toml) through the generated
//! `board` module.
//!
//! Priorities: the control step runs on an interrupt executor of its own (USART2's vector) above
//! the bus's (module_core, USART3), so bus traffic never delays the current loop; thread mode
//! stores parameters, only while the bridge is off (a page erase stalls the CPU for ~20 ms,
//! control loop included), and reboots on request (likewise deferred until the bridge is off:
//! the module never resets with the motor driven); so is its confirmation after an update (a
//! page erase) or its rollback when out of time.
#![no_std]
#![no_main]

mod bridge;
mod sensors;

mod board {
    include!(concat!(env!("OUT_DIR"), "/board.rs"));
}

use core::sync::atomic::{AtomicBool, Ordering::Relaxed};

use embassy_executor::{InterruptExecutor, Spawner};
use embassy_stm32::adc;
use embassy_stm32::can::Can;
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::peripherals::ADC1;
use embassy_time::{Duration, Instant, Ticker, Timer};
use module_core::Leds;
use r2p_app_motor::names::NameBuf;
use r2p_app_motor::{params, App, Endpoints, Names, Sample, Storage};
use r2p_module::{FlashParams, ParamValues};
use r2p_node::NodeConfig;
use static_cell::StaticCell;

use bridge::Bridge;
use sensors::Sensors;

module_core::bind_can_interrupts!(struct Irqs {
    ADC1_2 => adc::InterruptHandler<ADC1>;
});

static PARAMS: FlashParams<{ params::COUNT }> =
    FlashParams::new(&params::DEFAULTS, &PARAM_VALUES, module_core::PARAMS_BASE);
static PARAM_VALUES: ParamValues<{ params::COUNT }> = ParamValues::new();
static ENDPOINTS: Storage = Storage::new();
static NAMES: StaticCell<NameBuf> = StaticCell::new();

/// The control loop's executor: above the bus's (P6), below the hardware's interrupts.
static CONTROL_EXECUTOR: InterruptExecutor = InterruptExecutor::new();
const CONTROL_PRIORITY: Priority = Priority::P5;

#[interrupt]
unsafe fn USART2() {
    // SAFETY: the interrupt is reserved for this executor (started in `main`).
    unsafe { CONTROL_EXECUTOR.on_interrupt() }
}

/// The bridge is driven: no flash erase, no reset now.
static BRIDGE_ON: AtomicBool = AtomicBool::new(false);

/// The control step's hardware, in a static: the task takes a reference, because arguments it
/// took by value would be dropped if its spawn failed, and that drop glue (the bridge's and
/// the sensors' teardown, never run) cost 388 B of flash.
static CONTROL_IO: StaticCell<(Sensors, Bridge, Leds)> = StaticCell::new();

/// The 1 kHz control step. The application is built here, from its endpoints, so that what
/// crosses to this executor is `Send`.
#[embassy_executor::task]
async fn control(ep: Endpoints<'static>, io: &'static mut (Sensors, Bridge, Leds)) {
    let (sensors, bridge, leds) = io;
    let mut app = App::new(ep, &PARAMS);
    let mut ticker = Ticker::every(Duration::from_millis(1));
    loop {
        ticker.next().await;
        let now = Instant::now().as_micros();
        let (encoder_count, current_adc, vmot_adc) = sensors.read();
        let sample = Sample {
            encoder_count,
            current_adc,
            vmot_adc,
            driver_fault: bridge::take_break_flag(),
            status: module_core::led_status(),
        };
        let cmd = app.step(now, &sample);
        bridge.apply(&cmd);
        BRIDGE_ON.store(cmd.bridge_enable, Relaxed);
        leds.show(cmd.leds);
    }
}

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    let p = module_core::init::<{ board::HSE_HZ }, { board::SYSCLK_HZ }>();
    let pins = board::take_pins!(p);

    // Outputs first: the driver stays disabled and the LEDs take their boot levels at once.
    let drv_en = board::drv_en(pins.drv_en);
    let leds = module_core::leds!(board, pins);
    let bridge = Bridge::new(
        p.TIM1,
        bridge::Pins {
            ah: pins.pwm_ah,
            al: pins.pwm_al,
            bh: pins.pwm_bh,
            bl: pins.pwm_bl,
            fault: pins.drv_fault,
            enable: drv_en,
        },
    );
    let sensors =
        Sensors::new(p.ADC1, pins.motor_current, pins.vmot_sense, p.TIM3, pins.enc_a, pins.enc_b);

    let mut can = Can::new(p.CAN, pins.can_rx, pins.can_tx, Irqs);
    module_core::enable_can::<{ board::SYSCLK_HZ }>(&mut can).await;
    let mut flash = module_core::load_params(&PARAMS, p.FLASH, p.IWDG, module_core::linked!());
    let names = Names::write(Names::instance(&PARAMS), NAMES.init(NameBuf::new()));
    let ep = ENDPOINTS.build(names);
    let config = NodeConfig {
        slot_lead_us: r2p_node::MODULE_SLOT_LEAD_US,
        sync_lead_us: r2p_node::MODULE_SYNC_LEAD_US,
        framed_leads: r2p_node::MODULE_FRAMED_LEADS,
        ..NodeConfig::module(embassy_stm32::uid::uid(), names.node)
    };
    module_core::start_bus(
        config,
        &PARAMS,
        |node| ep.register(node),
        can,
        p.TIM2,
        module_core::linked!(),
    );

    interrupt::USART2.set_priority(CONTROL_PRIORITY);
    let io = CONTROL_IO.init((sensors, bridge, leds));
    CONTROL_EXECUTOR.start(interrupt::USART2).spawn(control(ep, io)).unwrap();

    loop {
        Timer::after_millis(100).await;
        if !BRIDGE_ON.load(Relaxed) {
            module_core::persist(&PARAMS, &mut flash);
        } else {
            // After an update, the trial confirms (or gives up) once the bridge is off.
            flash.feed_watchdog();
        }
    }
}
