//! Default firmware of the R2P IMU module (STM32F103CB): the application of `r2p-app-imu` on
//! three ST sensors sharing SPI1 — the LSM6DSO (accelerometer and gyro), the LIS3MDL
//! (magnetometer) and the LPS22DF (barometer), each with its chip select — through the
//! `r2p-drivers` drivers (the same drivers and poll the emulated board runs over its simulated
//! SPI bus), the status LEDs, bxCAN and parameters in flash. Pins come only from the board file (firmware/boards/imu.toml) through the generated
//! `board` module.
#![no_std]
#![no_main]

use core::cell::RefCell;

use embassy_executor::Spawner;
use embassy_stm32::can::Can;
use embassy_stm32::gpio::Output;
use embassy_stm32::mode::Blocking as BlockingMode;
use embassy_stm32::spi::{self, Spi, MODE_3};
use embassy_stm32::time::Hertz;
use embassy_time::Timer;
use embedded_hal_bus::spi::{NoDelay, RefCellDevice};
use module_core::{EveryMs, Leds, ModuleFlash};
use r2p_app_imu::{params, sensor, App, Storage};
use r2p_drivers::lis3mdl::{self, Lis3mdl};
use r2p_drivers::lps22df::{self, Lps22df};
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
/// The sensors' boot time after power-up before they answer (LSM6DSO datasheet DS12140:
/// 10 ms; the LIS3MDL's and LPS22DF's are shorter, NOT VERIFIED).
const SENSOR_BOOT_MS: u64 = 10;

/// One sensor on the shared SPI1 with its chip select.
type Device<'a> =
    RefCellDevice<'a, Spi<'static, BlockingMode, spi::mode::Master>, Output<'static>, NoDelay>;

/// The three sensors on SPI1, each set up by the poll (and again after it stops answering).
type Parts<'a> =
    sensor::Sensors<SpiBus<Device<'a>>, lis3mdl::SpiBus<Device<'a>>, lps22df::SpiBus<Device<'a>>>;

/// The board's I/O the application step reads and drives.
struct Io<'a> {
    sensors: Parts<'a>,
    leds: Leds,
}

/// The application: one step per millisecond in thread mode (the LSM6DSO's 2-byte status
/// read and its 15-byte burst when the gyro has a new sample; the LIS3MDL's 10-byte and the
/// LPS22DF's 7-byte bursts, status first).
///
/// Awaited by `main` rather than spawned as a task of its own: a spawn can fail, and the
/// drop glue of the arguments it would then drop (the board's I/O, never dropped otherwise)
/// cost flash; `main`'s task holds this future instead.
async fn run(mut app: App<'static>, mut io: Io<'_>, flash: ModuleFlash) -> ! {
    let mut ms = EveryMs::new(&PARAMS, flash);
    let config = app.sensor_config();
    loop {
        let sample = io.sensors.poll(ms.now(), config, module_core::led_status());
        let c = app.step(ms.now(), &sample);
        io.leds.show([c.led_status, c.led_bus, c.led_fault]);
        ms.next().await;
    }
}

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    let p = module_core::init::<{ board::HSE_HZ }, { board::SYSCLK_HZ }>();
    let pins = board::take_pins!(p);

    // Outputs first: the chip selects deselect the sensors and the LEDs take their boot levels.
    let cs = board::imu_cs(pins.imu_cs);
    let mag_cs = board::mag_cs(pins.mag_cs);
    let baro_cs = board::baro_cs(pins.baro_cs);
    let leds = module_core::leds!(board, pins);
    // INT1 is wired for users' firmware (wake-up, FIFO thresholds); the default firmware polls
    // the data-ready flag over SPI, as the emulated board does. Held as an input with its pull.
    let _int1 = board::imu_int1(pins.imu_int1);
    let _mag_drdy = board::mag_drdy(pins.mag_drdy);
    let _baro_int = board::baro_int(pins.baro_int);

    let mut config = spi::Config::default();
    config.mode = MODE_3;
    config.frequency = Hertz(SPI_HZ);
    let bus =
        RefCell::new(Spi::new_blocking(p.SPI1, pins.imu_sck, pins.imu_mosi, pins.imu_miso, config));
    let device = |cs| match RefCellDevice::new_no_delay(&bus, cs) {
        Ok(d) => d,
        Err(e) => match e {},
    };
    let sensors = sensor::Sensors::new(
        Lsm6dso::new_spi(device(cs)),
        Lis3mdl::new_spi(device(mag_cs)),
        Lps22df::new_spi(device(baro_cs)),
    );

    let mut can = Can::new(p.CAN, pins.can_rx, pins.can_tx, Irqs);
    module_core::enable_can::<{ board::SYSCLK_HZ }>(&mut can).await;
    let flash = module_core::load_params(&PARAMS, p.FLASH, p.IWDG);
    let app = App::new(ENDPOINTS.build(&PARAMS), &PARAMS);
    Timer::after_millis(SENSOR_BOOT_MS).await;
    // The parts are set up by the first poll, after their boot time: a part that does not
    // answer leaves the module on the bus, reporting it (`Imu::sensors`, "no data") and
    // publishing what the others give; it is set up again when it answers.
    let config = r2p_app_imu::node_config(embassy_stm32::uid::uid(), &PARAMS);
    module_core::start_bus(config, &PARAMS, |node| app.register(node), can, p.TIM2);

    run(app, Io { sensors, leds }, flash).await
}
