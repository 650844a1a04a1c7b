//! `module_core`: what every R2P module image on the STM32F103 shares (used by the psu,
//! proximity, motor, imu and template images): clocks from the board file, the bus controller,
//! the node on an interrupt executor driven by the TDMA slot timer (TIM2's compare,
//! [`slot_timer`]), parameters in the flash map's parameter pages, the status LEDs, the
//! application's 1 kHz step, reboot on request, and the image's trial after an update. An
//! image's `main` keeps only what is its module's own (its I/O, its application, its node
//! configuration):
//!
//! ```ignore
//! let p = module_core::init::<{ board::HSE_HZ }, { board::SYSCLK_HZ }>();
//! let pins = board::take_pins!(p);
//! let leds = module_core::leds!(board, pins); // outputs first
//! let mut can = Can::new(p.CAN, pins.can_rx, pins.can_tx, Irqs);
//! module_core::enable_can::<{ board::SYSCLK_HZ }>(&mut can).await;
//! let flash = module_core::load_params(&PARAMS, p.FLASH, p.IWDG, module_core::linked!());
//! let app = App::new(ENDPOINTS.build(&PARAMS), &PARAMS);
//! let config = node_config(uid(), &PARAMS);
//! module_core::start_bus(config, &PARAMS, |node| app.register(node), can, p.TIM2, module_core::linked!());
//! // and in the application's task, every millisecond:
//! let mut ms = module_core::EveryMs::new(&PARAMS, flash);
//! loop {
//!     let command = app.step(ms.now(), &sample);
//!     ms.next().await;
//! }
//! ```
//!
//! Nodes are tasks with priorities, as in the footprint image (targets/shared/footprint_core.rs):
//! the bus runs on an interrupt executor that preempts the application's 1 kHz step in thread
//! mode.
//!
//! Three things are called a module's "core"; this is the firmware one, for the F103 images
//! only (it uses embassy-stm32). Not `r2p-module` (firmware/crates/r2p-module: the HAL-free
//! parts every module *application* shares, on the MCU and in the emulator), nor
//! `hardware/core` (the KiCad sheet every module *board* shares: MCU, CAN, bus jacks).
//!
//! Behind the bootloader: each image is linked at the active slot of the F103's flash map
//! (firmware/images.toml; build_image.rs writes memory.x from it). After an update it is on
//! trial (`../../shared/trial.rs`, r2p-boot's `trial`): it confirms itself once its node is
//! running, hears the sync and its parameters loaded, within 15 s, under a 20 s independent
//! watchdog started only on a trial boot; otherwise it resets unconfirmed and the bootloader
//! swaps the previous image back. A sync master (the PSU) "hears the sync" by holding the
//! master role: it sends the syncs itself.
//!
//! Interrupt priorities: the slot timer (and with it the bus executor) alone at the highest;
//! the CAN receive interrupts and the time driver (TIM4) one below, so that neither holds a
//! slot boundary back except for their short critical sections.
#![no_std]

use core::cell::RefCell;
use core::future::Future;
use core::mem::ManuallyDrop;
use core::sync::atomic::{AtomicBool, AtomicU8, Ordering};

use embassy_executor::InterruptExecutor;
use embassy_stm32::can::Can;
use embassy_stm32::flash::Flash;
use embassy_stm32::gpio::{Input, Level, Output};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::peripherals::{FLASH, IWDG, TIM2};
use embassy_stm32::{pac, rcc, time::Hertz, Config, Peri, Peripherals};
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::once_lock::OnceLock;
use embassy_time::{Duration, Instant, Ticker};
use r2p_boot::layout::{Partition, STM32F103CB as MAP};
use r2p_module::{leds, FlashParams};
use r2p_node::node::STARTING_HEARTBEATS;
use r2p_node::{Node, NodeConfig, NodeError, ParamStore};
use rtcan::cycle::ClockState;
use rtcan::failover::Role;
use rtcan_bxcan::BxCan;
use static_cell::StaticCell;
// The global defmt logger: RTT, read by `probe-rs run` (`cargo run`, docs/flashing.md).
use defmt_rtt as _;

defmt::timestamp!("{=u64:us}", now().as_micros());

mod analog;
pub mod can_timing;
mod panic;
pub mod slot_timer;
#[path = "../../../shared/trial.rs"]
mod trial;
pub mod update;
pub use analog::{analog_input, AnalogInputs};
use slot_timer::SlotTimer;
use trial::Confirmation;
use update::SharedFlash;

/// Offset from the flash base of the parameter pages (the flash map's `params` partition,
/// firmware/images.toml), where an image's `FlashParams` live: an update never touches them.
pub const PARAMS_BASE: u32 = MAP.params.offset;

/// Binds a module image's interrupts, as `embassy_stm32::bind_interrupts!` does, with the
/// bxCAN's four that every image needs written once: the receive FIFOs to
/// `rtcan_bxcan::RxStamp` alone (it stamps each frame's start of frame and empties the FIFOs:
/// embassy's receive handler after it would mask the FIFO's interrupt, `FMPIE`, which only
/// embassy's `read` unmasks, so the image would stop hearing frames after the first), the
/// transmit interrupt to `rtcan_bxcan::TransmitWake` (embassy's would clear the frames' results
/// the driver reads; this one only wakes the bus task, with the feature `framed-reservations`,
/// and is `UnusedIrq` without) and the status change interrupt to `rtcan_bxcan::UnusedIrq`
/// (embassy's only serves its `read` and `write`).
/// Any others the image needs follow in the braces, in `bind_interrupts!`'s form:
///
/// ```ignore
/// module_core::bind_can_interrupts!(struct Irqs {
///     ADC1_2 => adc::InterruptHandler<ADC1>;
/// });
/// ```
#[macro_export]
macro_rules! bind_can_interrupts {
    (struct $name:ident { $($others:tt)* }) => {
        $crate::__private::rtcan_bxcan::bind_bxcan_interrupts!(struct $name {
            can: CAN, rx0: USB_LP_CAN1_RX0, rx1: CAN1_RX1, sce: CAN1_SCE, tx: USB_HP_CAN1_TX;
            $($others)*
        });
    };
}

/// What [`bind_can_interrupts!`] names from the image's point of view (not an API).
#[doc(hidden)]
pub mod __private {
    pub use embassy_stm32;
    pub use rtcan_bxcan;
}

/// The node of a module image: up to 4 exports and 2 imports, 32 queued frames, 4 streams in
/// reassembly, messages up to 64 bytes; the bus master's side only in an image built with the
/// `master` feature (the PSU's: rank 0), which the others do without (2 KB of flash).
pub type ModuleNode = Node<'static, 4, 2, 32, 4, 64, { cfg!(feature = "master") }>;

/// The PLL multiplier that makes `sysclk_hz` from `hse_hz` (the F1's PLL multiplies by
/// 2…16); evaluated at compile time from the board constants (`const { pll_mul(..) }`), so a
/// board file with an impossible clock fails to build.
pub const fn pll_mul(hse_hz: u32, sysclk_hz: u32) -> u32 {
    let mul = sysclk_hz / hse_hz;
    assert!(
        mul * hse_hz == sysclk_hz && mul >= 2 && mul <= 16,
        "board file: sysclk_hz must be 2..16 times hse_hz"
    );
    assert!(sysclk_hz <= 72_000_000, "board file: the F103 runs at most 72 MHz");
    mul
}

/// Clocks from the board file's constants: SYSCLK = `pll_mul` × the crystal; APB1 at half
/// (bxCAN, ≤ 36 MHz), APB2 at full speed, the ADC at APB2 / 6 (12 MHz at 72 MHz, ≤ 14 MHz).
pub fn clocks(hse_hz: u32, pll_mul: u32) -> Config {
    let mut config = Config::default();
    config.rcc.hse = Some(rcc::Hse { freq: Hertz(hse_hz), mode: rcc::HseMode::Oscillator });
    config.rcc.pll = Some(rcc::Pll {
        src: rcc::PllSource::HSE,
        prediv: rcc::PllPreDiv::DIV1,
        mul: rcc::PllMul::from_bits((pll_mul - 2) as u8),
    });
    config.rcc.sys = rcc::Sysclk::PLL1_P;
    config.rcc.ahb_pre = rcc::AHBPrescaler::DIV1;
    config.rcc.apb1_pre = rcc::APBPrescaler::DIV2;
    config.rcc.apb2_pre = rcc::APBPrescaler::DIV1;
    config.rcc.adc_pre = rcc::ADCPrescaler::DIV6;
    config
}

/// Starts the chip with the clocks of a board file's `HSE_HZ` and `SYSCLK_HZ` (checked at
/// compile time: [`pll_mul`]) and hands out its peripherals.
pub fn init<const HSE_HZ: u32, const SYSCLK_HZ: u32>() -> Peripherals {
    let pll_mul = const { pll_mul(HSE_HZ, SYSCLK_HZ) };
    embassy_stm32::init(clocks(HSE_HZ, pll_mul))
}

/// The bus's bit rate (docs/bus.md).
pub const BIT_RATE: u32 = 1_000_000;

/// Sets the bus controller to [`BIT_RATE`] from the board's `SYSCLK_HZ` (APB1, the bxCAN's
/// clock, runs at half: [`clocks`]), its timing computed at compile time ([`can_timing`]); the
/// future completes when it has joined the bus. Await it before building the application and
/// its node, so that neither lives across this await (and in `main`'s future). Not an
/// `async fn`: `main`'s future holds the controller once, not a second time in this function's.
pub fn enable_can<'a, const SYSCLK_HZ: u32>(
    can: &'a mut Can<'static>,
) -> impl Future<Output = ()> + 'a {
    let timing = const { can_timing::bit_timing(SYSCLK_HZ / 2, BIT_RATE) };
    can.modify_config().set_bit_timing(timing);
    can.enable()
}

/// The high-priority executor the bus runs on: in the slot timer's interrupt (TIM2), which
/// runs it at each compare and when the executor pends it.
static BUS_EXECUTOR: InterruptExecutor = InterruptExecutor::new();

const RUNNING: u8 = 1;
const SYNCED: u8 = 2;
const TRAFFIC: u8 = 4;
const STORAGE_FAULT: u8 = 8;

/// The node's state for the LEDs, written by the bus task, read by the application's step.
static LED_INPUTS: AtomicU8 = AtomicU8::new(0);
/// A REBOOT request arrived: the application's task persists parameters, then resets.
static REBOOT: AtomicBool = AtomicBool::new(false);
/// This boot is a new image's trial (read at boot from the bootloader's state).
static ON_TRIAL: AtomicBool = AtomicBool::new(false);
/// The image has just confirmed itself: the bus task says so in FIRMWARE.
static TRIAL_OVER: AtomicBool = AtomicBool::new(false);
/// The chip's flash, made at boot ([`load_params`]), shared with the bus task.
static SHARED_FLASH: StaticCell<SharedFlash> = StaticCell::new();
/// The shared flash, for [`start_bus`]'s update sink.
static FLASH_FOR_BUS: OnceLock<&'static SharedFlash> = OnceLock::new();

/// The node's state as the status LEDs show it (the application adds its faults).
pub fn led_status() -> leds::Status {
    let b = LED_INPUTS.load(Ordering::Relaxed);
    leds::Status {
        running: b & RUNNING != 0,
        synced: b & SYNCED != 0,
        traffic: b & TRAFFIC != 0,
        fault: false,
        storage_fault: b & STORAGE_FAULT != 0,
    }
}

/// Where the node lives: a static, so that the bus task's future holds a pointer rather than
/// the node (an `async fn`'s arguments are stored twice in its future; the node is ~3 KB).
static NODE: StaticCell<ModuleNode> = StaticCell::new();

/// The node, handed once from `main` to the bus task on the interrupt executor: `Send` because
/// a `Node` is (its parameter store, exports and imports are `Sync`, which the compiler checks
/// where they are registered), so no `unsafe` claim is needed.
struct BusNode(&'static mut ModuleNode);

/// The bus: the node driven by the TDMA slot timer at interrupt priority (a rank-0 PSU sends
/// the syncs; every other module follows them, as every node of a bus with a cycle must).
///
/// The driver and the timer come in `ManuallyDrop`: a spawn can fail, and the drop glue of the
/// arguments it would then drop (the bxCAN's and its pins' teardown) cost every module image
/// ~100 B. It never runs: this one spawn of a one-task pool cannot fail (and if it did, the
/// `unwrap` resets the module). The task owns them as before; its poll is instruction for
/// instruction the same (`r2ptools.slotpath`).
#[embassy_executor::task]
async fn bus(
    node: BusNode,
    mut can: ManuallyDrop<BxCan<'static>>,
    mut timer: ManuallyDrop<SlotTimer>,
    running_after_us: u64,
) {
    let node = node.0;
    let (mut frames, mut last_frame_at) = (0u32, None::<u64>);
    // Frame-sized reservations: a transmit-complete or a publish runs the node's short path.
    #[cfg(feature = "framed-reservations")]
    let mut woken = slot_timer::Woken::Timer;
    loop {
        let now = Instant::now().as_micros();
        #[cfg(feature = "framed-reservations")]
        if woken == slot_timer::Woken::Event {
            node.top_up(now, &mut *can);
        } else {
            node.slot_tick(now, &mut *can);
        }
        #[cfg(not(feature = "framed-reservations"))]
        node.slot_tick(now, &mut *can);
        // Parameters are persisted from the store's dirty flags, not from these events.
        while node.next_event().is_some() {}
        if node.take_reboot_request() {
            REBOOT.store(true, Ordering::Relaxed);
        }
        if TRIAL_OVER.swap(false, Ordering::Relaxed) {
            node.set_firmware(update::running_image("", false)); // confirmed
        }
        let received = node.stats().frames_received;
        if received != frames {
            (frames, last_frame_at) = (received, Some(now));
        }
        let synced = node.role() == Role::Master
            || matches!(node.clock().state(now), ClockState::Running(_));
        let traffic = last_frame_at.is_some_and(|t| now - t < 1_000_000);
        let mut bits = 0;
        for (on, bit) in [(now >= running_after_us, RUNNING), (synced, SYNCED), (traffic, TRAFFIC)]
        {
            if on {
                bits |= bit;
            }
        }
        LED_INPUTS.fetch_and(STORAGE_FAULT, Ordering::Relaxed);
        LED_INPUTS.fetch_or(bits, Ordering::Relaxed);
        #[cfg(feature = "framed-reservations")]
        {
            if node.wakes_on_transmit() {
                can.arm_transmit_wake();
            }
            timer.wait_until::<true>(node.next_slot_at(now)).await;
            woken = timer.woken();
        }
        #[cfg(not(feature = "framed-reservations"))]
        timer.wait_until::<false>(node.next_slot_at(now)).await;
    }
}

/// Makes the module's node from `config` and `params`, lets `register` export and import the
/// application's topics on it, and starts it on the bus executor with the RTCAN driver on
/// `can`, its slot boundaries from TIM2's compare; if this boot followed a panic, the node
/// reports it (panic.rs). An image `linked` in the active slot reports its firmware from its
/// trailer and takes updates over the bus.
///
/// # Panics
/// If `config` is not a valid node configuration or the node has no room for the topics
/// `register` gives it (bugs of the image, found at boot).
pub fn start_bus(
    config: NodeConfig,
    params: &'static dyn ParamStore,
    register: impl FnOnce(&mut ModuleNode) -> Result<(), NodeError>,
    can: Can<'static>,
    tim2: Peri<'static, TIM2>,
    linked: Linked,
) {
    // Made in its static: moving the ~3 KB node out of `Result::expect` cost 248 B of code.
    let node =
        NODE.init_with(|| ModuleNode::new(config, params).expect("valid node configuration"));
    register(node).expect("room for the module's topics on its node");
    if linked == Linked::ActiveSlot {
        if let Some(flash) = FLASH_FOR_BUS.try_get() {
            node.set_update_sink(update::sink(flash, config.name));
        }
        node.set_firmware(update::running_image(config.name, ON_TRIAL.load(Ordering::Relaxed)));
    } else {
        // Flashed alone at the flash base: no trailer, no slot to update.
        node.set_firmware(r2p_node::FirmwareId {
            kind: config.name.try_into().unwrap_or_default(),
            ..r2p_node::FirmwareId::default()
        });
    }
    #[allow(unused_mut)] // frame-sized reservations set its transmit wake
    let mut can = BxCan::new(can, pac::CAN, BIT_RATE);
    // Frame-sized reservations: the transmit interrupt and the application's publishes for the
    // bus wake the bus task (`Node::wakes_on_transmit`, `Node::releases_waiting`).
    #[cfg(feature = "framed-reservations")]
    {
        can.on_transmit(slot_timer::wake_bus);
        node.wake_on_release(slot_timer::wake_bus);
        interrupt::USB_HP_CAN1_TX.set_priority(Priority::P1);
    }
    if let Some(text) = r2p_panic::take_last() {
        defmt::warn!("the last reset followed a panic: {=[u8]:a}", text);
        node.set_panic_report(text);
    }
    defmt::info!("{=str}: on the bus as node {=u8}", config.name, node.node_id().get());
    let running_after_us = u64::from(STARTING_HEARTBEATS) * u64::from(config.heartbeat_period_us);
    for irq in [interrupt::USB_LP_CAN1_RX0, interrupt::CAN1_RX1, interrupt::TIM4] {
        irq.set_priority(Priority::P1);
    }
    interrupt::TIM2.set_priority(Priority::P0);
    let node = BusNode(node);
    let timer = SlotTimer::new(tim2);
    BUS_EXECUTOR
        .start(interrupt::TIM2)
        .spawn(bus(node, ManuallyDrop::new(can), ManuallyDrop::new(timer), running_after_us))
        .unwrap();
}

/// The module's flash as the application's task keeps it: the parameter pages and the
/// bootloader's state, in which the image confirms itself after an update.
///
/// The flash is shared with the bus task, which writes updates into the DFU slot
/// ([`update`]); each use holds a critical section.
pub struct ModuleFlash {
    flash: &'static SharedFlash,
    /// The bootloader's state partition, as the update sink reaches it too (one copy of the
    /// state's code in the image).
    state: update::Part,
    confirmation: Confirmation,
}

impl ModuleFlash {
    /// Feeds the trial's watchdog, for a task that cannot [`persist`] now (the motor's, while
    /// its bridge is driven).
    pub fn feed_watchdog(&mut self) {
        self.confirmation.feed();
    }

    /// Polls the trial with the node's health (running, synced, parameters working).
    fn poll_trial(&mut self) {
        let b = LED_INPUTS.load(Ordering::Relaxed);
        let healthy = b & RUNNING != 0 && b & SYNCED != 0 && b & STORAGE_FAULT == 0;
        let now_ms = now().as_millis();
        let was_on_trial = self.confirmation.on_trial();
        if !self.confirmation.poll(&mut self.state, now_ms, healthy) {
            defmt::warn!("trial: confirming this image failed");
            LED_INPUTS.fetch_or(STORAGE_FAULT, Ordering::Relaxed);
        } else if was_on_trial && !self.confirmation.on_trial() {
            TRIAL_OVER.store(true, Ordering::Relaxed);
        }
    }
}

/// The time driver's clock, read out of line for thread mode (the application's step, the
/// trial, the logs' time stamps): inlined, each call carried its own copy of the read (~35 B).
/// The bus task reads it inline, on the slot path.
#[inline(never)]
fn now() -> Instant {
    Instant::now()
}

/// Loads the parameters from flash (defaults where nothing valid is stored) and, for an image
/// `linked` in the active slot, reads the bootloader's state: on a trial boot the independent
/// watchdog (`iwdg`) starts. The flash, for [`persist`].
pub fn load_params<const N: usize>(
    params: &FlashParams<N>,
    flash: Peri<'static, FLASH>,
    iwdg: Peri<'static, IWDG>,
    linked: Linked,
) -> ModuleFlash {
    let flash: &'static SharedFlash =
        SHARED_FLASH.init(Mutex::new(RefCell::new(Flash::new_blocking(flash))));
    if flash.lock(|f| params.load(&mut *f.borrow_mut())).is_err() {
        defmt::warn!("parameters: reading them from flash failed, defaults used");
        LED_INPUTS.fetch_or(STORAGE_FAULT, Ordering::Relaxed);
    }
    let mut state = update::state_partition(flash);
    let confirmation = if linked == Linked::ActiveSlot {
        let whole = Partition { offset: 0, size: MAP.state.size };
        Confirmation::at_boot(&mut state, whole, iwdg, now().as_millis())
    } else {
        Confirmation::not_on_trial()
    };
    ON_TRIAL.store(confirmation.on_trial(), Ordering::Relaxed);
    let _ = FLASH_FOR_BUS.init(flash);
    ModuleFlash { flash, state, confirmation }
}

/// Where an image is linked, as its build script linked it (`build_image.rs`'s `Link`, which
/// also writes its memory.x): [`linked!`] in the image's `main` says which, and
/// [`load_params`] and [`start_bus`] take it. A constant of the image, so the branch for the
/// other place is not in it (176 B of a module image in a slot: the firmware ID of an image
/// flashed alone); it was read at run time from the vector table's address, which the same
/// memory.x placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Linked {
    /// In the flash map's active slot, behind the bootloader: it has the bootloader's state
    /// partition, is on trial after an update and takes updates over the bus.
    ActiveSlot,
    /// Alone at the flash base: no bootloader, so no state partition (its own code may lie
    /// there), no trial, no updates over the bus.
    FlashBase,
}

/// Where this image is linked ([`Linked`]), from its build script (`build_image.rs` sets
/// `R2P_IMAGE_LINK` for the image's crate). Use it in the image's `main`.
#[macro_export]
macro_rules! linked {
    () => {
        if matches!(env!("R2P_IMAGE_LINK").as_bytes(), b"active") {
            $crate::Linked::ActiveSlot
        } else {
            $crate::Linked::FlashBase
        }
    };
}

/// From the application's task, every 100 ms: confirms the image on trial once it is healthy
/// (or resets it when out of time), stores changed parameters (a page erase, when the log is
/// full or on the confirmation, stalls the CPU ~20–40 ms) and resets if a reboot was requested.
pub fn persist<const N: usize>(params: &FlashParams<N>, flash: &mut ModuleFlash) {
    flash.poll_trial();
    if params.is_dirty() && flash.flash.lock(|f| params.commit(&mut *f.borrow_mut())).is_err() {
        defmt::warn!("parameters: storing in flash failed");
        LED_INPUTS.fetch_or(STORAGE_FAULT, Ordering::Relaxed);
    }
    if REBOOT.load(Ordering::Relaxed) {
        defmt::info!("rebooting: asked over the bus");
        cortex_m::peripheral::SCB::sys_reset();
    }
}

/// The application's 1 kHz step in thread mode: [`next`](Self::next) waits for the next
/// millisecond and persists the parameters every 100 ms when changed (and reboots if asked to).
///
/// ```ignore
/// let mut ms = module_core::EveryMs::new(&PARAMS, flash);
/// loop {
///     let command = app.step(ms.now(), &sample);
///     ms.next().await;
/// }
/// ```
pub struct EveryMs<'a, const N: usize> {
    params: &'a FlashParams<N>,
    flash: ModuleFlash,
    ticker: Ticker,
    steps: u32,
}

impl<'a, const N: usize> EveryMs<'a, N> {
    /// Starts the period now; `flash` is [`load_params`]'s.
    pub fn new(params: &'a FlashParams<N>, flash: ModuleFlash) -> Self {
        Self { params, flash, ticker: Ticker::every(Duration::from_millis(1)), steps: 0 }
    }

    /// The time for this step, µs since boot.
    pub fn now(&self) -> u64 {
        now().as_micros()
    }

    /// Ends the step: every 100th polls the trial and persists the parameters ([`persist`]);
    /// then waits for the next period.
    pub async fn next(&mut self) {
        self.steps = self.steps.wrapping_add(1);
        if self.steps.is_multiple_of(100) {
            persist(self.params, &mut self.flash);
        }
        self.ticker.next().await;
    }
}

/// The status, bus and fault LEDs, each driven at its board file's `active` level.
pub struct Leds {
    outputs: [Output<'static>; 3],
    active_low: [bool; 3],
}

impl Leds {
    /// The status, bus and fault LEDs and whether each is active low (see [`leds!`]).
    pub fn new(outputs: [Output<'static>; 3], active_low: [bool; 3]) -> Self {
        Self { outputs, active_low }
    }

    /// Lights the status, bus and fault LEDs as `on` says (the application's pattern).
    pub fn show(&mut self, on: [bool; 3]) {
        for ((out, on), active_low) in self.outputs.iter_mut().zip(on).zip(self.active_low) {
            drive(out, on, active_low);
        }
    }
}

/// The image's [`Leds`] from its generated `board` module and the pins it took
/// (`board::take_pins!`): every module board has `LED_STATUS`, `LED_BUS` and `LED_FAULT`.
/// Configures the three outputs, which take their boot levels at once.
#[macro_export]
macro_rules! leds {
    ($board:ident, $pins:ident) => {
        $crate::Leds::new(
            [
                $board::led_status($pins.led_status),
                $board::led_bus($pins.led_bus),
                $board::led_fault($pins.led_fault),
            ],
            [
                $board::LED_STATUS_ACTIVE_LOW,
                $board::LED_BUS_ACTIVE_LOW,
                $board::LED_FAULT_ACTIVE_LOW,
            ],
        )
    };
}

/// Drives an output to its logical level (`on`), given the board file's `active`.
pub fn drive(out: &mut Output<'static>, on: bool, active_low: bool) {
    out.set_level(Level::from(on != active_low));
}

/// Whether an input is asserted (its logical level), given the board file's `active`.
pub fn asserted(input: &Input<'static>, active_low: bool) -> bool {
    input.is_high() != active_low
}
