//! Firmware of the R2P gateway (STM32F407VG): `r2p-app-gateway` on the shared core — bxCAN
//! and the node runtime on an interrupt executor, through the gateway's bus tap — and the
//! network: embassy-stm32's RMII Ethernet driver (LAN8742A) and embassy-net, DHCP with a
//! static fallback, the socketcand server for up to four clients. Pins come only from the
//! board file (firmware/boards/gateway.toml) through the generated `board` module; network
//! settings are parameters kept in flash (r2p-module's `FlashParams`), applied at boot.
//! With a Zenoh router set (`zenoh_router`), the gateway is also a native ROS 2 node over
//! Zenoh (r2p-app-gateway's `ros`, docs/ros2.md): `/gateway/status`, `/battery_state`,
//! `/imu/data`, `/odom` out, `/cmd_vel` in. The imports only ROS 2 wants follow its Zenoh
//! subscribers (r2p-app-gateway's `demand`): the `zenoh` task decides, the bus task
//! unsubscribes and resubscribes them on the node ([`WANTED`]).
//!
//! It runs the robot-level nodes for the robot (`r2p-app-base`: inverse kinematics, obstacle
//! avoidance, odometry; Triskar2's by default), its step in the application's task, its
//! topics named by its parameters (after the gateway's own in the node's table) in static
//! cells; unless its `base_controller` parameter is off, when another node runs them: then
//! `/cmd_vel` goes on the bus as `cmd_vel` for that node (docs/ros2.md).
//!
//! The image runs behind the F407 bootloader, in the active slot of the flash map
//! (firmware/images.toml; build.rs links it there); its parameters sit in the map's two 16 KiB
//! sectors. It takes updates over the bus as a module does (`update`: r2p-module's `DfuSink`
//! over the DFU sectors). After an update it is on trial (r2p-boot's `trial`): it confirms
//! itself once its node is running and hears the master's sync (or, master itself, hears
//! another node), within 15 s, under an independent watchdog of 20 s; otherwise it resets
//! unconfirmed and the bootloader swaps the previous image back.
#![no_std]
#![no_main]

use core::cell::Cell;
use core::sync::atomic::{AtomicBool, AtomicU32, AtomicU8, Ordering};

use embassy_executor::{InterruptExecutor, Spawner};
use embassy_futures::select::{select, Either};
use embassy_net::tcp::TcpSocket;
use embassy_net::{Ipv4Address, Ipv4Cidr, Stack, StackResources, StaticConfigV4};
use embassy_stm32::can::Can;
use embassy_stm32::eth::{self, Ethernet, GenericPhy, PacketQueue, Sma};
use embassy_stm32::flash::{Bank1Region1, Blocking, Flash};
use embassy_stm32::gpio::{Level, Output};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::peripherals::{ETH, ETH_SMA};
use embassy_stm32::rng::{self, Rng};
use embassy_stm32::{pac, rcc, time::Hertz, Config};
use embassy_time::{Delay, Duration, Instant, Ticker, Timer};
use r2p_app_base as base;
use r2p_app_gateway::demand::{Feeds, Follower, GATEWAY_FEEDS};
use r2p_app_gateway::link::MAX_CLIENTS;
use r2p_app_gateway::params::{self, followed_by, Net, Offset};
use r2p_app_gateway::ros::{zid_of, Latest, RosBridge, RosConfig};
use r2p_app_gateway::server::{self, serve};
use r2p_app_gateway::Storage;
use r2p_app_gateway::{App, BusLink, BusTap, NetState, RemoteBase, RemoteBaseStorage, Sample};
use r2p_boot::layout::STM32F407VG as MAP;
use r2p_management::message::{ParamFault, Value};
use r2p_middleware::{pool_size, Class, Publisher};
use r2p_module::{leds, FlashParams, OutboundCell, ParamValues};
use r2p_msgs::{Odometry, Twist2D};
use r2p_node::node::STARTING_HEARTBEATS;
use r2p_node::{Node, ParamStore};
use rtcan::cycle::ClockState;
use rtcan::failover::Role;
use rtcan_bxcan::BxCan;
use static_cell::StaticCell;

mod board {
    include!(concat!(env!("OUT_DIR"), "/board.rs"));
}
mod slot_timer;
#[path = "../../../shared/trial.rs"]
mod trial;
mod update;
use slot_timer::SlotTimer;
use trial::Confirmation;

// The bxCAN's receive interrupts to `RxStamp` alone: embassy's handler after it would mask the
// FIFO's interrupt for good (`rtcan_bxcan::bind`).
rtcan_bxcan::bind_bxcan_interrupts!(struct Irqs {
    can: CAN1, rx0: CAN1_RX0, rx1: CAN1_RX1, sce: CAN1_SCE, tx: CAN1_TX;
    ETH => eth::InterruptHandler;
    RNG => rng::InterruptHandler<embassy_stm32::peripherals::RNG>;
});

/// The gateway's node: up to 5 exports (its status and the base controller's 4, or its status
/// and `cmd_vel`) and 16 imports (its 10 and the base controller's 6, or its 10 and `odom` and
/// the ranges), 32 queued frames, 4 streams in reassembly, messages up to 64 bytes (as a
/// module's).
type GatewayNode = Node<
    'static,
    { 1 + base::endpoints::EXPORTS },
    { r2p_app_gateway::endpoints::IMPORTS + base::endpoints::IMPORTS },
    32,
    4,
    64,
>;
type Device = Ethernet<'static, ETH, GenericPhy<Sma<'static, ETH_SMA>>>;

/// The node's parameters: the gateway's, then the base controller's.
const PARAM_COUNT: usize = params::COUNT + base::params::COUNT;

/// In the flash map's parameter sectors (2 and 3, 16 KiB each: embassy-stm32's bank 1 region 1
/// starts at the flash base, so the map's offset is the region's).
static PARAMS: FlashParams<PARAM_COUNT> =
    FlashParams::new(&followed_by(base::params::DEFAULTS), &PARAM_VALUES, MAP.params.offset);
static PARAM_VALUES: ParamValues<PARAM_COUNT> = ParamValues::new();

/// The base controller's part of [`PARAMS`], as its application indexes it.
struct BaseParams;

impl ParamStore for BaseParams {
    fn get(&self, index: u16) -> Result<Value, ParamFault> {
        Offset { store: &PARAMS, first: params::COUNT as u16 }.get(index)
    }
    fn set(&self, index: u16, value: Value) -> Result<Value, ParamFault> {
        Offset { store: &PARAMS, first: params::COUNT as u16 }.set(index, value)
    }
}

/// The base controller's topics (built at boot when the gateway runs it).
static BASE: base::Storage = base::Storage::new();
/// Its odometry and ranges from the bus (built at boot when another node runs it).
static REMOTE_BASE: RemoteBaseStorage = RemoteBaseStorage::new();

/// The base controller here, or its outputs for ROS 2 from the node that runs it.
// Made once at boot and kept in the application's task: no heap to box the larger variant on.
#[allow(clippy::large_enum_variant)]
enum Base {
    /// Runs in the application's task.
    Here(base::App<'static>),
    /// Runs elsewhere: its `odom` and the ranges imported.
    Elsewhere(RemoteBase<'static>),
}

/// The parameters' flash: the 16 KiB sectors, so a page of FlashParams is one sector.
type ParamFlash = Bank1Region1<'static, Blocking>;

/// The image's trial after an update (../../shared/trial.rs) and the bootloader state it
/// confirms in.
struct Trial {
    confirmation: Confirmation,
    state: update::StatePart,
}
static ENDPOINTS: Storage = Storage::new();
/// `/cmd_vel` from ROS 2, on the bus for the node that runs the base controller when the
/// gateway does not.
static CMD_VEL: OutboundCell<Twist2D, { pool_size(&[2], 1) }, 1, 2> = OutboundCell::new();
/// The latest values the ROS 2 side publishes (the application's step writes them).
static LATEST: cortex_m::interrupt::Mutex<Cell<Latest>> =
    cortex_m::interrupt::Mutex::new(Cell::new(Latest::NONE));
static LINK: BusLink = BusLink::new();
static NODE: StaticCell<GatewayNode> = StaticCell::new();

/// The bus runs here: in the slot timer's interrupt (TIM5, [`slot_timer`]).
static BUS_EXECUTOR: InterruptExecutor = InterruptExecutor::new();

const RUNNING: u8 = 1;
const SYNCED: u8 = 2;
const TRAFFIC: u8 = 4;
const STORAGE_FAULT: u8 = 8;
/// The node has heard another node (a master alone on its side of the bus is not healthy).
const HEARD_OTHERS: u8 = 16;
/// The node's state for the LEDs, written by the bus task, read by the application's step.
static LED_INPUTS: AtomicU8 = AtomicU8::new(0);
/// A REBOOT request arrived: the application's task persists parameters, then resets.
static REBOOT: AtomicBool = AtomicBool::new(false);
/// The image has just confirmed itself: the bus task says so in FIRMWARE.
static TRIAL_OVER: AtomicBool = AtomicBool::new(false);
/// Bit `k`: the import of feed `k` is wanted (the `zenoh` task writes it, the bus task applies
/// it; all wanted without a router).
static WANTED: AtomicU32 = AtomicU32::new(u32::MAX);
/// The samples the `zenoh` task's write filter held back (`RosStats::filtered`), for
/// `gateway/status` (the `zenoh` task writes it, the bus task reads it).
static FILTERED: AtomicU32 = AtomicU32::new(0);
/// The address in use came from DHCP.
static FROM_DHCP: AtomicBool = AtomicBool::new(false);

/// The node on the bus, through the tap that copies the bus to the network clients. It wakes
/// at each slot boundary from the slot timer's compare, as a module's bus task does: the base
/// controller's HRT setpoints leave in their slots.
#[embassy_executor::task]
async fn bus(
    node: &'static mut GatewayNode,
    mut can: BxCan<'static>,
    mut timer: SlotTimer,
    running_after_us: u64,
    mut follower: Follower,
) {
    let mut tap = BusTap::new(&LINK);
    let (mut frames, mut last_frame_at) = (0u32, None::<u64>);
    // Frame-sized reservations: a transmit-complete or a publish runs the node's short path.
    #[cfg(feature = "framed-reservations")]
    let mut woken = slot_timer::Woken::Timer;
    loop {
        let now = Instant::now().as_micros();
        #[cfg(feature = "framed-reservations")]
        if woken == slot_timer::Woken::Event {
            tap.run(now, &mut can, |c| node.top_up(now, c));
        } else {
            tap.run(now, &mut can, |c| node.slot_tick(now, c));
        }
        #[cfg(not(feature = "framed-reservations"))]
        tap.run(now, &mut can, |c| node.slot_tick(now, c));
        while node.next_event().is_some() {}
        follower.apply(WANTED.load(Ordering::Relaxed), node);
        if node.take_reboot_request() {
            REBOOT.store(true, Ordering::Relaxed);
        }
        if TRIAL_OVER.swap(false, Ordering::Relaxed) {
            node.set_firmware(update::running_image(false)); // confirmed
        }
        let received = node.stats().frames_received;
        if received != frames {
            (frames, last_frame_at) = (received, Some(now));
        }
        let synced = node.role() == Role::Master
            || matches!(node.clock().state(now), ClockState::Running(_));
        let traffic = last_frame_at.is_some_and(|t| now - t < 1_000_000);
        let mut bits = 0;
        let heard = node.peer_count() > 0;
        for (on, bit) in [
            (now >= running_after_us, RUNNING),
            (synced, SYNCED),
            (traffic, TRAFFIC),
            (heard, HEARD_OTHERS),
        ] {
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

#[embassy_executor::task]
async fn ethernet(mut runner: embassy_net::Runner<'static, Device>) -> ! {
    runner.run().await
}

/// DHCP first if asked; the static address if no lease comes in time (or DHCP is off).
#[embassy_executor::task]
async fn addressing(stack: Stack<'static>, net: Net) {
    if net.dhcp {
        let wait = Duration::from_millis(u64::from(net.dhcp_wait_ms));
        match select(stack.wait_config_up(), Timer::after(wait)).await {
            Either::First(()) => {
                FROM_DHCP.store(true, Ordering::Relaxed);
                return;
            }
            Either::Second(()) => {}
        }
    }
    let [a, b, c, d] = net.ip;
    let config = StaticConfigV4 {
        address: Ipv4Cidr::new(Ipv4Address::new(a, b, c, d), net.prefix_len),
        gateway: net.router.map(|[a, b, c, d]| Ipv4Address::new(a, b, c, d)),
        dns_servers: Default::default(),
    };
    stack.set_config_v4(embassy_net::ConfigV4::Static(config));
}

/// One client at a time per task, [`MAX_CLIENTS`] tasks.
#[embassy_executor::task(pool_size = MAX_CLIENTS)]
async fn client(stack: Stack<'static>, port: u16) -> ! {
    let mut rx = [0u8; 512];
    let mut tx = [0u8; 2048];
    let config = server::Config { channel: server::CHANNEL };
    loop {
        let mut socket = TcpSocket::new(stack, &mut rx, &mut tx);
        if socket.accept(port).await.is_err() {
            continue;
        }
        let _ = serve(&mut socket, &LINK, &config, &mut Delay).await;
        socket.close();
        let _ = socket.flush().await;
        socket.abort();
    }
}

/// The gateway's ROS 2 node: a Zenoh client of the router at `router`, reconnecting every
/// second while it is away. Samples are stamped with the time since boot (the gateway has no
/// wall clock).
#[embassy_executor::task]
async fn zenoh(
    stack: Stack<'static>,
    router: ([u8; 4], u16),
    domain: u32,
    zid: [u8; 16],
    cmd_vel: &'static Publisher<'static, Twist2D>,
    feeds: Feeds<'static>,
) -> ! {
    let Some(mut bridge) = RosBridge::new(&RosConfig { domain, namespace: "", zid }) else {
        loop {
            Timer::after_secs(3600).await;
        }
    };
    bridge.follow(&feeds);
    let mut rx = [0u8; 1024];
    let mut tx = [0u8; 2048];
    let mut out = [0u8; 6 * 1024];
    let mut batch = [0u8; r2p_app_gateway::ros::RX_BATCH as usize];
    let [a, b, c, d] = router.0;
    let endpoint = (Ipv4Address::new(a, b, c, d), router.1);
    loop {
        stack.wait_config_up().await;
        let mut socket = TcpSocket::new(stack, &mut rx, &mut tx);
        socket.set_timeout(Some(Duration::from_secs(20)));
        if socket.connect(endpoint).await.is_ok() {
            let _ = ros_session(&mut bridge, &mut socket, &mut out, &mut batch, cmd_vel).await;
        }
        socket.abort();
        let _ = socket.flush().await;
        Timer::after_secs(1).await;
    }
}

/// One session on a connected socket, until the link or the session fails.
async fn ros_session(
    bridge: &mut RosBridge,
    socket: &mut TcpSocket<'_>,
    out: &mut [u8],
    batch: &mut [u8],
    cmd_vel: &'static Publisher<'static, Twist2D>,
) -> Result<(), ()> {
    use embedded_io_async::Write;
    let now = || Instant::now().as_micros();
    let n = bridge.connect(now(), out).map_err(|_| ())?;
    socket.write_all(&out[..n]).await.map_err(|_| ())?;
    let (mut have, mut need) = (0usize, 2usize);
    loop {
        // Read what comes within 5 ms (a batch's 2-byte length, then the batch), then poll.
        if let Either::First(r) =
            select(socket.read(&mut batch[have..need]), Timer::after_millis(5)).await
        {
            match r {
                Ok(0) | Err(_) => return Err(()),
                Ok(k) => have += k,
            }
            if have == need && need == 2 {
                need = 2 + usize::from(u16::from_le_bytes([batch[0], batch[1]]));
                if need > batch.len() {
                    return Err(()); // larger than the batch size agreed: not a router we know
                }
            }
            if have == need && need > 2 {
                let n = bridge.receive(now(), &batch[2..need], out).map_err(|_| ())?;
                socket.write_all(&out[..n]).await.map_err(|_| ())?;
                (have, need) = (0, 2);
            }
        }
        let t = now();
        if let Some(c) = bridge.take_cmd(t) {
            let _ = cmd_vel.publish_with(|m| *m = c);
        }
        let latest = cortex_m::interrupt::free(|cs| LATEST.borrow(cs).get());
        let n = bridge.poll(t, (t * 1000) as i64, &latest, out).map_err(|_| ())?;
        WANTED.store(bridge.wanted(), Ordering::Relaxed);
        FILTERED.store(bridge.stats().filtered, Ordering::Relaxed);
        socket.write_all(&out[..n]).await.map_err(|_| ())?;
    }
}

/// The applications: one step per millisecond (the gateway's, then the base controller's if it
/// runs here, else the latest of its outputs from the bus); parameters persisted every 100 ms
/// when changed.
#[embassy_executor::task]
async fn run(
    mut app: App<'static>,
    mut base: Base,
    mut leds: [Output<'static>; 4],
    mut flash: ParamFlash,
    mut trial: Trial,
    stack: Stack<'static>,
) {
    let mut ticker = Ticker::every(Duration::from_millis(1));
    let mut step = 0u32;
    loop {
        let now = Instant::now().as_micros();
        let ip = stack.config_v4().map(|c| c.address.address().octets());
        let net = NetState {
            link_up: stack.is_link_up(),
            ip,
            dhcp: FROM_DHCP.load(Ordering::Relaxed),
            ros_filtered: FILTERED.load(Ordering::Relaxed),
        };
        let c = app.step(now, &Sample { status: led_status(), net });
        let (status, battery, imu) = (app.status(&net), app.battery(), app.imu());
        let mirrored = app.mirrored();
        let (odom, proximity) = match &mut base {
            Base::Here(b) => {
                b.step(now);
                let ((x, y, theta), (vx, vy, wz)) = (b.pose(), b.velocity());
                (Some(Odometry { x, y, theta, vx, vy, wz }), b.ranges())
            }
            Base::Elsewhere(r) => r.latest(),
        };
        let status = Some(status);
        let (mag, baro, gnss) = app.imu_extras();
        let latest = Latest { status, battery, imu, mag, baro, gnss, mirrored, odom, proximity };
        cortex_m::interrupt::free(|cs| LATEST.borrow(cs).set(latest));
        let [status, bus, fault, link] = &mut leds;
        for (out, on, active_low) in [
            (status, c.led_status, board::LED_STATUS_ACTIVE_LOW),
            (bus, c.led_bus, board::LED_BUS_ACTIVE_LOW),
            (fault, c.led_fault, board::LED_FAULT_ACTIVE_LOW),
            (link, c.led_link, board::LED_LINK_ACTIVE_LOW),
        ] {
            out.set_level(Level::from(on != active_low));
        }
        step = step.wrapping_add(1);
        if step.is_multiple_of(100) {
            let b = LED_INPUTS.load(Ordering::Relaxed);
            let healthy = b & (RUNNING | SYNCED | HEARD_OTHERS) == RUNNING | SYNCED | HEARD_OTHERS
                && b & STORAGE_FAULT == 0;
            let now_ms = Instant::now().as_millis();
            let was_on_trial = trial.confirmation.on_trial();
            if !trial.confirmation.poll(&mut trial.state, now_ms, healthy) {
                LED_INPUTS.fetch_or(STORAGE_FAULT, Ordering::Relaxed);
            } else if was_on_trial && !trial.confirmation.on_trial() {
                TRIAL_OVER.store(true, Ordering::Relaxed);
            }
            if PARAMS.is_dirty() && PARAMS.commit(&mut flash).is_err() {
                LED_INPUTS.fetch_or(STORAGE_FAULT, Ordering::Relaxed);
            }
            if REBOOT.load(Ordering::Relaxed) {
                cortex_m::peripheral::SCB::sys_reset();
            }
        }
        ticker.next().await;
    }
}

fn led_status() -> leds::Status {
    let b = LED_INPUTS.load(Ordering::Relaxed);
    leds::Status {
        running: b & RUNNING != 0,
        synced: b & SYNCED != 0,
        traffic: b & TRAFFIC != 0,
        fault: false,
        storage_fault: b & STORAGE_FAULT != 0,
    }
}

/// 168 MHz SYSCLK from the board's crystal; APB1 at 42 MHz clocks bxCAN, 48 MHz for the RNG.
fn clocks() -> Config {
    const { assert!(board::HSE_HZ == 8_000_000 && board::SYSCLK_HZ == 168_000_000) };
    let mut config = Config::default();
    config.rcc.hse = Some(rcc::Hse { freq: Hertz(board::HSE_HZ), mode: rcc::HseMode::Oscillator });
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

/// A locally administered MAC address from the MCU's unique ID.
fn mac_address(uid: &[u8; 12]) -> [u8; 6] {
    let mut h = 0x811C_9DC5u32;
    for &b in uid {
        h = (h ^ u32::from(b)).wrapping_mul(0x0100_0193);
    }
    let [a, b, c, d] = h.to_be_bytes();
    [0x02, 0x52, a, b, c, d]
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let p = embassy_stm32::init(clocks());
    let pins = board::take_pins!(p);
    let leds = [
        board::led_status(pins.led_status),
        board::led_bus(pins.led_bus),
        board::led_fault(pins.led_fault),
        board::led_link(pins.led_link),
    ];
    // Releases the PHY from reset (its boot level).
    let phy_reset = board::phy_nrst(pins.phy_nrst);
    core::mem::forget(phy_reset);

    let mut can = Can::new(p.CAN1, pins.can_rx, pins.can_tx, Irqs);
    can.modify_config().set_bitrate(1_000_000);
    can.enable().await;

    let regions = Flash::new_blocking(p.FLASH).into_blocking_regions();
    let mut flash = regions.bank1_region1;
    if PARAMS.load(&mut flash).is_err() {
        LED_INPUTS.fetch_or(STORAGE_FAULT, Ordering::Relaxed);
    }
    // Just swapped in by the bootloader (its state says Swap): on trial, under the watchdog.
    // Just rolled back (Revert): say so to the bootloader, so the next update may begin.
    let shared_state = update::share_state(regions.bank1_region2);
    let mut state = update::state_partition(shared_state);
    let whole = r2p_boot::layout::Partition { offset: 0, size: MAP.state.size };
    let confirmation = Confirmation::at_boot(&mut state, whole, p.IWDG, Instant::now().as_millis());
    let on_trial = confirmation.on_trial();
    let trial = Trial { confirmation, state };
    let net = Net::read(&PARAMS, 0);
    let uid = embassy_stm32::uid::uid();

    // The bus.
    let app = App::new(ENDPOINTS.build(), &LINK);
    let config = r2p_app_gateway::node_config(uid, board::SYSCLK_HZ);
    let mut node = GatewayNode::new(config, &PARAMS).unwrap();
    app.register(&mut node).unwrap();
    node.set_update_sink(update::sink(regions.bank1_region3, shared_state));
    node.set_firmware(update::running_image(on_trial));
    // The base controller here, or `cmd_vel` on the bus for the node that runs it.
    let (base_app, cmd_vel) = if params::base_controller(&PARAMS, 0) {
        let ik_period_us = base::params::ik_period_us(&BaseParams);
        let ends = BASE.build(base::Names::from_params(&BaseParams), ik_period_us);
        let cmd_vel = ends.cmd_local;
        static BASE_PARAMS: BaseParams = BaseParams;
        let b = base::App::new(ends, &BASE_PARAMS);
        b.register(&mut node).unwrap();
        (Base::Here(b), cmd_vel)
    } else {
        let c = CMD_VEL.build(base::names::CMD_VEL, Twist2D::default(), Class::NonRealTime);
        let c = c.unwrap();
        node.export(c.remote).unwrap();
        let remote = REMOTE_BASE.build(base::Names::from_params(&BaseParams).ranges);
        remote.register(&mut node).unwrap();
        (Base::Elsewhere(remote), c.publisher)
    };
    // The gateway's imports and, with the base elsewhere, its odometry and ranges: what only
    // ROS 2 wants (the base controller's own imports stay).
    let mut feeds = Feeds::from_slice(&GATEWAY_FEEDS).unwrap();
    if let Base::Elsewhere(remote) = &base_app {
        feeds.extend_from_slice(&remote.feeds()).unwrap();
    }
    let follower = Follower::bind(&feeds, &node);
    let running_after_us = u64::from(STARTING_HEARTBEATS) * u64::from(config.heartbeat_period_us);
    for irq in [interrupt::CAN1_RX0, interrupt::CAN1_RX1, interrupt::TIM2] {
        irq.set_priority(Priority::P1);
    }
    interrupt::TIM5.set_priority(Priority::P0);
    #[allow(unused_mut)] // frame-sized reservations set its transmit wake
    let mut can = BxCan::new(can, pac::CAN1, 1_000_000);
    // Frame-sized reservations: the transmit interrupt and the publishes for the bus wake the
    // bus task (`Node::wakes_on_transmit`, `Node::releases_waiting`).
    #[cfg(feature = "framed-reservations")]
    {
        can.on_transmit(slot_timer::wake_bus);
        node.wake_on_release(slot_timer::wake_bus);
        interrupt::CAN1_TX.set_priority(Priority::P1);
    }
    let timer = SlotTimer::new(p.TIM5);
    BUS_EXECUTOR
        .start(interrupt::TIM5)
        .spawn(bus(NODE.init(node), can, timer, running_after_us, follower))
        .unwrap();

    // The network.
    static PACKETS: StaticCell<PacketQueue<4, 4>> = StaticCell::new();
    let device = Ethernet::new(
        PACKETS.init(PacketQueue::new()),
        p.ETH,
        Irqs,
        pins.eth_ref_clk,
        pins.eth_crs_dv,
        pins.eth_rxd0,
        pins.eth_rxd1,
        pins.eth_txd0,
        pins.eth_txd1,
        pins.eth_tx_en,
        mac_address(&uid),
        p.ETH_SMA,
        pins.eth_mdio,
        pins.eth_mdc,
    );
    let mut rng = Rng::new(p.RNG, Irqs);
    let seed = rng.next_u64();
    let stack_config = if net.dhcp {
        embassy_net::Config::dhcpv4(Default::default())
    } else {
        embassy_net::Config::default()
    };
    // The socketcand clients, DHCP, and the Zenoh router.
    static RESOURCES: StaticCell<StackResources<{ MAX_CLIENTS + 3 }>> = StaticCell::new();
    let (stack, runner) =
        embassy_net::new(device, stack_config, RESOURCES.init(StackResources::new()), seed);
    spawner.spawn(ethernet(runner)).unwrap();
    spawner.spawn(addressing(stack, net)).unwrap();
    for _ in 0..MAX_CLIENTS {
        spawner.spawn(client(stack, net.tcp_port)).unwrap();
    }
    if let Some(router) = net.zenoh {
        spawner.spawn(zenoh(stack, router, net.ros_domain, zid_of(uid), cmd_vel, feeds)).unwrap();
    }
    spawner.spawn(run(app, base_app, leds, flash, trial, stack)).unwrap();
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    // Reset: a gateway that stops would cut the robot off the network until power-cycled.
    cortex_m::peripheral::SCB::sys_reset()
}
