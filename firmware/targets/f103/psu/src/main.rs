//! Default firmware of the R2P PSU module (STM32F103CB): the application of `r2p-app-psu` on
//! the board's ADC (battery voltage and current, bus voltage), the bus-output switch and its
//! eFuse fault flag, the status LEDs, bxCAN and parameters in flash. Pins come only from the
//! board file (firmware/boards/psu.toml) through the generated `board` module.
#![no_std]
#![no_main]

use embassy_executor::Spawner;
use embassy_stm32::adc::{self, SampleTime};
use embassy_stm32::can::Can;
use embassy_stm32::gpio::{Input, Output};
use embassy_stm32::peripherals::ADC1;
use module_core::{analog_input, asserted, drive, AnalogInputs, EveryMs, Leds, ModuleFlash};
use r2p_app_psu::{params, App, Sample, Storage};
use r2p_module::{FlashParams, ParamValues};

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

/// ADC sample time: the dividers' source impedance is up to 9 kΩ; 239.5 cycles at 12 MHz
/// (20 µs) settles the sampling capacitor well within an LSB.
const SAMPLE_TIME: SampleTime = SampleTime::CYCLES239_5;

/// The board's I/O the application step reads and drives.
struct Io {
    /// VIN_SENSE, IIN_SENSE, VOUT_SENSE.
    analog: AnalogInputs<3>,
    bus_fault: Input<'static>,
    bus_en: Output<'static>,
    leds: Leds,
}

/// The application: one step per millisecond in thread mode.
///
/// Awaited by `main` rather than spawned as a task of its own: a spawn can fail, and the
/// drop glue of the arguments it would then drop (the board's I/O, never dropped otherwise)
/// cost flash; `main`'s task holds this future instead.
async fn run(mut app: App<'static>, mut io: Io, flash: ModuleFlash) -> ! {
    let mut ms = EveryMs::new(&PARAMS, flash);
    loop {
        let [vin, iin, vout] = io.analog.read().await;
        let sample = Sample {
            vin,
            iin,
            vout,
            bus_fault: asserted(&io.bus_fault, board::BUS_FAULT_ACTIVE_LOW),
            status: module_core::led_status(),
        };
        let c = app.step(ms.now(), &sample);
        drive(&mut io.bus_en, c.bus_en, board::BUS_EN_ACTIVE_LOW);
        io.leds.show([c.led_status, c.led_bus, c.led_fault]);
        ms.next().await;
    }
}

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    let p = module_core::init::<{ board::HSE_HZ }, { board::SYSCLK_HZ }>();
    let pins = board::take_pins!(p);

    // Outputs first: the bus switch and the LEDs take their boot levels at once.
    let bus_en = board::bus_en(pins.bus_en);
    let leds = module_core::leds!(board, pins);
    let io = Io {
        analog: AnalogInputs::new(
            p.ADC1,
            [
                analog_input(pins.vin_sense),
                analog_input(pins.iin_sense),
                analog_input(pins.vout_sense),
            ],
            SAMPLE_TIME,
        ),
        bus_fault: board::bus_fault(pins.bus_fault),
        bus_en,
        leds,
    };

    let mut can = Can::new(p.CAN, pins.can_rx, pins.can_tx, Irqs);
    module_core::enable_can::<{ board::SYSCLK_HZ }>(&mut can).await;
    let flash = module_core::load_params(&PARAMS, p.FLASH, p.IWDG, module_core::linked!());
    let app = App::new(ENDPOINTS.build(&PARAMS), &PARAMS);
    let config = r2p_app_psu::node_config(embassy_stm32::uid::uid(), &PARAMS);
    module_core::start_bus(
        config,
        &PARAMS,
        |node| app.register(node),
        can,
        p.TIM2,
        module_core::linked!(),
    );

    run(app, io, flash).await
}
