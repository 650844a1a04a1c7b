//! Default firmware of the R2P IMU module (STM32F103CB): the application of `r2p-app-imu` on
//! three ST sensors — the LSM6DSO (accelerometer and gyro) and the LPS22HH (barometer; or an
//! LPS22DF) sharing SPI1, each with its chip select, and the LIS3MDL (magnetometer) alone on
//! SPI2 with its own (it has no I2C-disable bit: deselected on a shared bus it would listen to
//! the others' traffic as I2C; hardware/imu/README.md) — through the `r2p-drivers` drivers (the
//! same drivers and poll the emulated board runs over its simulated SPI buses); an external u-blox receiver on USART1 (interrupt-driven ring buffers, the link
//! `r2p_app_imu::gnss::Link` sets up) with its time pulse captured by TIM3_CH4; the status LEDs,
//! bxCAN and parameters in flash. Pins come only from the board file (firmware/boards/imu.toml) through the generated
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
use embassy_stm32::timer::input_capture::{CapturePin, InputCapture};
use embassy_stm32::timer::low_level::{CountingMode, InputCaptureMode, InputTISelection};
use embassy_stm32::timer::Channel;
use embassy_stm32::usart::{self, BufferedUart};
use embassy_time::Instant;
use embassy_time::Timer;
use embedded_hal_bus::spi::{ExclusiveDevice, NoDelay, RefCellDevice};
use embedded_io::{Read, Write};
use embedded_io_async::ReadReady;
use module_core::{EveryMs, Leds, ModuleFlash};
use r2p_app_imu::gnss::{Action, Link};
use r2p_app_imu::{params, sensor, App, Storage};
use r2p_drivers::lis3mdl::{self, Lis3mdl};
use r2p_drivers::lps22::{self, Lps22};
use r2p_drivers::lsm6dso::{Lsm6dso, SpiBus};
use r2p_module::{FlashParams, ParamValues};

mod board {
    include!(concat!(env!("OUT_DIR"), "/board.rs"));
}

module_core::bind_can_interrupts!(
    struct Irqs {
        USART1 => usart::BufferedInterruptHandler<embassy_stm32::peripherals::USART1>;
        TIM3 => embassy_stm32::timer::CaptureCompareInterruptHandler<embassy_stm32::peripherals::TIM3>;
    }
);

static PARAMS: FlashParams<{ params::COUNT }> =
    FlashParams::new(&params::DEFAULTS, &PARAM_VALUES, module_core::PARAMS_BASE);
static PARAM_VALUES: ParamValues<{ params::COUNT }> = ParamValues::new();
static ENDPOINTS: Storage = Storage::new();

/// SPI clock: the LSM6DSO takes up to 10 MHz; SPI1 divides its 72 MHz APB2 clock by powers of
/// two and embassy picks the fastest not above this, 4.5 MHz (a 15-byte burst in ~30 µs).
/// SPI2, the LIS3MDL's (10 MHz at most: DS9463's SPI timing, tc(SPC) ≥ 100 ns; NOT VERIFIED
/// here), divides the 36 MHz APB1 clock: 4.5 MHz as well (its 10-byte burst in ~20 µs).
const SPI_HZ: u32 = 5_000_000;
/// The sensors' boot time after power-up before they answer (LSM6DSO datasheet DS12140:
/// 10 ms; the LIS3MDL's and LPS22HH's are shorter, NOT VERIFIED).
const SENSOR_BOOT_MS: u64 = 10;

/// The MCU's SPI in master mode, blocking.
type Bus = Spi<'static, BlockingMode, spi::mode::Master>;

/// One sensor on the shared SPI1 with its chip select.
type Device<'a> = RefCellDevice<'a, Bus, Output<'static>, NoDelay>;

/// The LIS3MDL, alone on SPI2 with its chip select.
type MagDevice = ExclusiveDevice<Bus, Output<'static>, NoDelay>;

/// The three sensors, each set up by the poll (and again after it stops answering).
type Parts<'a> =
    sensor::Sensors<SpiBus<Device<'a>>, lis3mdl::SpiBus<MagDevice>, lps22::SpiBus<Device<'a>>>;

/// The GNSS receiver's port and its time pulse.
struct Gnss<'a> {
    uart: BufferedUart<'a>,
    link: Link,
    /// TIM3 counting µs (1 MHz), channel 4 capturing the pulse's rising edge.
    pps: InputCapture<'a, embassy_stm32::peripherals::TIM3>,
}

impl Gnss<'_> {
    /// One step at `now_us`: the link's action, the bytes received (a NAV-PVT among them), the
    /// pulse's edge if one was captured (on the module's clock: the capture's count is TIM3's
    /// at the edge, which shares the 72 MHz clock with the time base; the count and the time
    /// are read within a few µs of each other).
    fn poll(&mut self, now_us: u64, sample: &mut r2p_app_imu::Sample) {
        match self.link.poll(now_us) {
            Some(Action::Send { baud }) => {
                let _ = self.uart.set_baudrate(baud);
                // 86 bytes into a 128-byte transmit buffer: sent by the interrupt, no wait.
                let _ = self.uart.write_all(self.link.config());
            }
            Some(Action::Listen { baud }) => {
                let _ = self.uart.set_baudrate(baud);
            }
            None => {}
        }
        let mut buf = [0u8; 64];
        for _ in 0..8 {
            if !self.uart.read_ready().unwrap_or(false) {
                break;
            }
            // An overrun's error: the decoder drops the frame it hit.
            if let Ok(n) = self.uart.read(&mut buf) {
                if let Some(p) = self.link.receive(now_us, &buf[..n]) {
                    sample.gnss = Some(p);
                }
            }
        }
        if self.pps.get_input_interrupt(Channel::Ch4) {
            // Reading the capture clears its flag.
            let at = self.pps.get_capture_value(Channel::Ch4);
            let count = embassy_stm32::pac::TIM3.cnt().read().cnt();
            let now = Instant::now().as_micros();
            sample.pps_us = Some(now - u64::from(count.wrapping_sub(at)));
        }
    }
}

/// The board's I/O the application step reads and drives.
struct Io<'a> {
    sensors: Parts<'a>,
    gnss: Gnss<'a>,
    leds: Leds,
}

/// The application: one step per millisecond in thread mode (the LSM6DSO's 2-byte status
/// read and its 15-byte burst when the gyro has a new sample; the LIS3MDL's 10-byte burst on
/// SPI2 and the LPS22HH's 7-byte one, status first).
///
/// Awaited by `main` rather than spawned as a task of its own: a spawn can fail, and the
/// drop glue of the arguments it would then drop (the board's I/O, never dropped otherwise)
/// cost flash; `main`'s task holds this future instead.
async fn run(mut app: App<'static>, mut io: Io<'_>, flash: ModuleFlash) -> ! {
    let mut ms = EveryMs::new(&PARAMS, flash);
    let config = app.sensor_config();
    loop {
        let now = ms.now();
        let mut sample = io.sensors.poll(now, config, module_core::led_status());
        io.gnss.poll(now, &mut sample);
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
    let mag_bus = Spi::new_blocking(p.SPI2, pins.mag_sck, pins.mag_mosi, pins.mag_miso, config);
    let mag = match ExclusiveDevice::new_no_delay(mag_bus, mag_cs) {
        Ok(d) => d,
        Err(e) => match e {},
    };
    let sensors = sensor::Sensors::new(
        Lsm6dso::new_spi(device(cs)),
        Lis3mdl::new_spi(mag),
        Lps22::new_spi(device(baro_cs)),
    );

    // The GNSS port at the link's first rate (it sets its own from then on); the pulse on
    // TIM3_CH4, TIM3 counting microseconds.
    let (mut tx_buf, mut rx_buf) = ([0u8; 128], [0u8; 256]);
    let mut uart_config = usart::Config::default();
    uart_config.baudrate = r2p_drivers::ubx::OPERATING_BAUD;
    let Ok(uart) = BufferedUart::new(
        p.USART1,
        pins.gnss_rx,
        pins.gnss_tx,
        &mut tx_buf,
        &mut rx_buf,
        Irqs,
        uart_config,
    ) else {
        panic!("USART1: 38400 baud from a 72 MHz APB2 is always reachable")
    };
    let mut pps = InputCapture::new(
        p.TIM3,
        None,
        None,
        None,
        // TIM3 not remapped (AFIO): CH4 on PB1; CH1/CH2 (PA6/PA7, SPI1's) are not enabled.
        Some(CapturePin::<_, _, embassy_stm32::gpio::AfioRemap<0>>::new(
            pins.gnss_pps,
            embassy_stm32::gpio::Pull::Down,
        )),
        Irqs,
        Hertz(1_000_000),
        CountingMode::EdgeAlignedUp,
    );
    // Below the bus: the slot timer (TIM2) is P0, CAN and the time base P1 (module-core).
    // USART1 interrupts at every received byte (3 840 a second at 38 400 baud); at the reset
    // priority, 0, each would hold off a slot boundary by its length. TIM3's is never enabled
    // at the source (the capture flag is polled), but is kept low as well.
    {
        use embassy_stm32::interrupt::{self, InterruptExt, Priority};
        interrupt::USART1.set_priority(Priority::P3);
        interrupt::TIM3.set_priority(Priority::P3);
    }
    pps.set_input_ti_selection(Channel::Ch4, InputTISelection::Normal);
    pps.set_input_capture_mode(Channel::Ch4, InputCaptureMode::Rising);
    pps.enable(Channel::Ch4);

    let mut can = Can::new(p.CAN, pins.can_rx, pins.can_tx, Irqs);
    module_core::enable_can::<{ board::SYSCLK_HZ }>(&mut can).await;
    let flash = module_core::load_params(&PARAMS, p.FLASH, p.IWDG, module_core::linked!());
    let app = App::new(ENDPOINTS.build(&PARAMS), &PARAMS);
    Timer::after_millis(SENSOR_BOOT_MS).await;
    // The parts are set up by the first poll, after their boot time: a part that does not
    // answer leaves the module on the bus, reporting it (`Imu::sensors`, "no data") and
    // publishing what the others give; it is set up again when it answers.
    let config = r2p_app_imu::node_config(embassy_stm32::uid::uid(), &PARAMS);
    module_core::start_bus(
        config,
        &PARAMS,
        |node| app.register(node),
        can,
        p.TIM2,
        module_core::linked!(),
    );

    let gnss = Gnss { uart, link: Link::new(app.gnss_rate_hz()), pps };
    run(app, Io { sensors, gnss, leds }, flash).await
}
