//! The body of the footprint images (included by `f103/footprint` and `f407/footprint`): the
//! shared core as a module runs it, and nothing else, so its size is the core's cost.
//!
//! A sensor task publishes `readings` (SRT, 10 ms deadline) to a local subscriber and, through
//! the node runtime, to any module that subscribes over the bus; a remote `setpoint` topic is
//! imported and consumed locally; the node claims its node ID, sends heartbeats, advertises,
//! answers subscriptions and parameter requests. Nodes are tasks with priorities: the bus runs
//! on an interrupt executor (preempting everything in thread mode), the sensor node on the
//! thread-mode executor. It is a measurement, not a product.

use embassy_executor::{InterruptExecutor, Spawner};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_time::{Instant, Timer};
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_node::{Node, NodeConfig, Param, RamParams, RemotePublisher, RemoteSubscriber};
use rtcan_bxcan::BxCan;

/// The high-priority executor the bus runs on, woken through an interrupt no peripheral of
/// the module uses (USART3 exists on both the F103CB and the F407VG).
static BUS_EXECUTOR: InterruptExecutor = InterruptExecutor::new();

#[interrupt]
unsafe fn USART3() {
    // SAFETY: the interrupt is reserved for this executor (started in `run`).
    unsafe { BUS_EXECUTOR.on_interrupt() }
}

static READINGS: Topic<'static, u32, { pool_size(&[4, 4], 1) }, 2> = Topic::new("readings", 0);
static READINGS_PUB: Publisher<'static, u32> =
    Publisher::new(&READINGS, Class::AsyncRealTime { deadline_us: 10_000 });
static READINGS_LOCAL: Subscriber<'static, u32, 4> = Subscriber::new();
static READINGS_OUT: RemoteSubscriber<'static, u32, 4> = RemoteSubscriber::new(&READINGS_PUB);

static SETPOINT: Topic<'static, i32, { pool_size(&[2], 1) }, 1> = Topic::new("setpoint", 0);
static SETPOINT_PUB: Publisher<'static, i32> = Publisher::new(&SETPOINT, Class::NonRealTime);
static SETPOINT_IN: RemotePublisher<'static, i32> = RemotePublisher::new(&SETPOINT_PUB, &SETPOINT);
static SETPOINT_SUB: Subscriber<'static, i32, 2> = Subscriber::new();

static PARAMS: RamParams<2> = RamParams::new([
    Param::u32("rate_hz", 100, 1, 1000),
    Param::u32("gain_milli", 1000, 0, 10_000),
]);

/// A thread-mode node: publishes a reading every 10 ms and consumes what it subscribed to
/// (its own readings locally, setpoints from the bus).
#[embassy_executor::task]
async fn sensor() {
    let mut n = 0u32;
    let mut sum = 0u32;
    loop {
        READINGS_PUB.publish_with(|m| *m = n);
        n = n.wrapping_add(1);
        while let Some(r) = READINGS_LOCAL.try_recv() {
            sum = sum.wrapping_add(*r);
        }
        if let Some(s) = SETPOINT_SUB.try_recv() {
            sum = sum.wrapping_add(*s as u32);
        }
        core::hint::black_box(sum);
        Timer::after_millis(10).await;
    }
}

/// The bus: the node runtime polled every millisecond at interrupt priority.
#[embassy_executor::task]
async fn bus(mut can: BxCan<'static>, uid: [u8; 12]) {
    let mut node: Node<'static, 2, 2, 32, 4, 64> =
        Node::new(NodeConfig::new(uid, "footprint"), &PARAMS).unwrap();
    node.export(&READINGS_OUT).unwrap();
    node.import(&SETPOINT_IN).unwrap();
    loop {
        node.poll(Instant::now().as_micros(), &mut can);
        Timer::after_millis(1).await;
    }
}

/// Wires the topics and starts the nodes: the bus at interrupt priority, the rest in thread mode.
pub fn run(spawner: Spawner, can: BxCan<'static>, uid: [u8; 12]) {
    READINGS.advertise(&READINGS_PUB).unwrap();
    READINGS.subscribe(&READINGS_LOCAL).unwrap();
    READINGS.subscribe(&READINGS_OUT).unwrap();
    SETPOINT.advertise(&SETPOINT_PUB).unwrap();
    SETPOINT.subscribe(&SETPOINT_SUB).unwrap();
    interrupt::USART3.set_priority(Priority::P6);
    BUS_EXECUTOR.start(interrupt::USART3).spawn(bus(can, uid)).unwrap();
    spawner.spawn(sensor()).unwrap();
}
