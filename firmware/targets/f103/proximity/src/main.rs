//! Default firmware of the R2P proximity module (STM32F103CB): the application of
//! `r2p-app-proximity` on the board's four analog sensor inputs, the sensors' power switch and
//! its fault flag,
//! the status LEDs, bxCAN and parameters in flash. Pins come only from the board file
//! (firmware/boards/proximity.toml) through the generated `board` module.
#![no_std]
#![no_main]

use embassy_executor::Spawner;
use embassy_stm32::adc::{self, SampleTime};
use embassy_stm32::can::Can;
use embassy_stm32::gpio::{Input, Output};
use embassy_stm32::peripherals::ADC1;
use module_core::{analog_input, asserted, drive, AnalogInputs, EveryMs, Leds, ModuleFlash};
use r2p_app_proximity::{params, App, Sample, Storage};
use r2p_module::{FlashParams, ParamValues};
use static_cell::StaticCell;

mod board {
    include!(concat!(env!("OUT_DIR"), "/board.rs"));
}

module_core::bind_can_interrupts!(struct Irqs {
    ADC1_2 => adc::InterruptHandler<ADC1>;
});

static PARAMS: FlashParams<{ params::COUNT }> =
    FlashParams::new(&params::DEFAULTS, &PARAM_VALUES, module_core::PARAMS_BASE);
static PARAM_VALUES: ParamValues<{ params::COUNT }> = ParamValues::new();
static ENDPOINTS: Storage = Storage::new();
/// The board's I/O, in a static: the task takes a reference, because arguments it took by
/// value would be dropped if its spawn failed, and that drop glue (never run) cost flash
/// (as the motor's `CONTROL_IO`).
static IO: StaticCell<Io> = StaticCell::new();

/// ADC sample time: 239.5 cycles at 12 MHz (20 µs), for the inputs' 100 kΩ pull-down and
/// whatever a sensor's output impedance adds.
const SAMPLE_TIME: SampleTime = SampleTime::CYCLES239_5;

/// The board's I/O the application step reads and drives.
struct Io {
    /// PROX_CH0 … PROX_CH3.
    analog: AnalogInputs<4>,
    sensor_power: Output<'static>,
    sensor_fault: Input<'static>,
    leds: Leds,
}

/// The application: one step per millisecond in thread mode (four conversions, ~90 µs).
#[embassy_executor::task]
async fn run(mut app: App<'static>, io: &'static mut Io, flash: ModuleFlash) {
    let mut ms = EveryMs::new(&PARAMS, flash);
    loop {
        let sample = Sample {
            adc: io.analog.read().await,
            status: module_core::led_status(),
            supply_fault: asserted(&io.sensor_fault, board::SENSOR_PWR_FAULT_ACTIVE_LOW),
        };
        let c = app.step(ms.now(), &sample);
        drive(&mut io.sensor_power, c.sensor_power, board::SENSOR_PWR_EN_ACTIVE_LOW);
        io.leds.show([c.led_status, c.led_bus, c.led_fault]);
        ms.next().await;
    }
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let p = module_core::init::<{ board::HSE_HZ }, { board::SYSCLK_HZ }>();
    let pins = board::take_pins!(p);

    // Outputs first: the sensors' supply and the LEDs take their boot levels at once.
    let sensor_power = board::sensor_pwr_en(pins.sensor_pwr_en);
    let leds = module_core::leds!(board, pins);
    let io = Io {
        analog: AnalogInputs::new(
            p.ADC1,
            [
                analog_input(pins.prox_ch0),
                analog_input(pins.prox_ch1),
                analog_input(pins.prox_ch2),
                analog_input(pins.prox_ch3),
            ],
            SAMPLE_TIME,
        ),
        sensor_power,
        sensor_fault: board::sensor_pwr_fault(pins.sensor_pwr_fault),
        leds,
    };

    let mut can = Can::new(p.CAN, pins.can_rx, pins.can_tx, Irqs);
    module_core::enable_can::<{ board::SYSCLK_HZ }>(&mut can).await;
    let flash = module_core::load_params(&PARAMS, p.FLASH, p.IWDG, module_core::linked!());
    let app = App::new(ENDPOINTS.build(&PARAMS), &PARAMS);
    let config = r2p_app_proximity::node_config(embassy_stm32::uid::uid(), &PARAMS);
    module_core::start_bus(
        config,
        &PARAMS,
        |node| app.register(node),
        can,
        p.TIM2,
        module_core::linked!(),
    );

    spawner.spawn(run(app, IO.init(io), flash)).unwrap();
}
