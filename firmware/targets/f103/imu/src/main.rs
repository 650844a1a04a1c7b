//! Default firmware of the R2P IMU module (STM32F103CB): the application of `r2p-app-imu` on
//! an ST LSM6DSO on SPI1, through the `r2p-drivers` driver (the same driver and poll the
//! emulated board runs over its simulated SPI bus), the status LEDs, bxCAN and parameters in
//! flash. Pins come only from the board file (firmware/boards/imu.toml) through the generated
//! `board` module.
#![no_std]
#![no_main]

use embassy_executor::Spawner;
use embassy_stm32::can::Can;
use embassy_stm32::gpio::Output;
use embassy_stm32::mode::Blocking as BlockingMode;
use embassy_stm32::spi::{self, Spi, MODE_3};
use embassy_stm32::time::Hertz;
use embassy_time::Timer;
use embedded_hal_bus::spi::{ExclusiveDevice, NoDelay};
use module_core::{EveryMs, Leds, ModuleFlash};
use r2p_app_imu::{params, sensor, App, Storage};
use r2p_drivers::lsm6dso::{Lsm6dso, SpiBus};
use r2p_module::FlashParams;

mod board {
    include!(concat!(env!("OUT_DIR"), "/board.rs"));
}

module_core::bind_can_interrupts!(
    struct Irqs {}
);

static PARAMS: FlashParams<{ params::COUNT }> =
    FlashParams::new(params::DEFAULTS, module_core::PARAMS_BASE);
static ENDPOINTS: Storage = Storage::new();

/// SPI clock: the LSM6DSO takes up to 10 MHz; SPI1 divides its 72 MHz APB2 clock by powers of
/// two and embassy picks the fastest not above this, 4.5 MHz (a 15-byte burst in ~30 µs).
const SPI_HZ: u32 = 5_000_000;
/// The LSM6DSO's boot time after power-up before it answers (datasheet DS12140: 10 ms).
const SENSOR_BOOT_MS: u64 = 10;

/// The sensor on SPI1 with its chip select.
type Imu = Lsm6dso<
    SpiBus<
        ExclusiveDevice<Spi<'static, BlockingMode, spi::mode::Master>, Output<'static>, NoDelay>,
    >,
>;

/// The board's I/O the application step reads and drives.
struct Io {
    imu: Imu,
    /// [`Lsm6dso::init`] succeeded at boot.
    initialised: bool,
    leds: Leds,
}

/// The application: one step per millisecond in thread mode (a 2-byte status read, and a
/// 15-byte burst when the gyro has a new sample).
///
/// Awaited by `main` rather than spawned as a task of its own: a spawn can fail, and the
/// drop glue of the arguments it would then drop (the board's I/O, never dropped otherwise)
/// cost flash; `main`'s task holds this future instead.
async fn run(mut app: App<'static>, mut io: Io, flash: ModuleFlash) -> ! {
    let mut ms = EveryMs::new(&PARAMS, flash);
    loop {
        let sample = sensor::poll(&mut io.imu, io.initialised, module_core::led_status());
        let c = app.step(ms.now(), &sample);
        io.leds.show([c.led_status, c.led_bus, c.led_fault]);
        ms.next().await;
    }
}

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    let p = module_core::init::<{ board::HSE_HZ }, { board::SYSCLK_HZ }>();
    let pins = board::take_pins!(p);

    // Outputs first: the chip select deselects the sensor and the LEDs take their boot levels.
    let cs = board::imu_cs(pins.imu_cs);
    let leds = module_core::leds!(board, pins);
    // INT1 is wired for users' firmware (wake-up, FIFO thresholds); the default firmware polls
    // the data-ready flag over SPI, as the emulated board does. Held as an input with its pull.
    let _int1 = board::imu_int1(pins.imu_int1);

    let mut config = spi::Config::default();
    config.mode = MODE_3;
    config.frequency = Hertz(SPI_HZ);
    let bus = Spi::new_blocking(p.SPI1, pins.imu_sck, pins.imu_mosi, pins.imu_miso, config);
    let device = match ExclusiveDevice::new_no_delay(bus, cs) {
        Ok(d) => d,
        Err(e) => match e {},
    };
    let mut imu = Lsm6dso::new_spi(device);

    let mut can = Can::new(p.CAN, pins.can_rx, pins.can_tx, Irqs);
    module_core::enable_can::<{ board::SYSCLK_HZ }>(&mut can).await;
    let flash = module_core::load_params(&PARAMS, p.FLASH, p.IWDG);
    let app = App::new(ENDPOINTS.build(&PARAMS), &PARAMS);
    Timer::after_millis(SENSOR_BOOT_MS).await;
    // A sensor that does not answer leaves the module on the bus, reporting "no data".
    let initialised = imu.init(app.sensor_config()).is_ok();
    let config = r2p_app_imu::node_config(embassy_stm32::uid::uid(), &PARAMS);
    module_core::start_bus(config, &PARAMS, |node| app.register(node), can, p.TIM2);

    run(app, Io { imu, initialised, leds }, flash).await
}
