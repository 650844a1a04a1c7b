//! Cortex-M4 benchmark under QEMU (run by `scripts/bench`, not by the test suite; built for
//! thumbv7em-none-eabihf, the core of the gateway's STM32F407, FPU included): instructions per
//! event of the gateway's work, through the functions its image calls (firmware/targets/f407/
//! gateway's `run`, `zenoh` and `client` tasks, and its bus task's tap):
//!
//! - `base_step`: one 1 ms step of the base controller (`r2p_app_base::App::step`, Triskar2's
//!   defaults: IK at 100 Hz, odometry at 20 Hz), reading its parameters through the gateway's
//!   joined table as the image does, fed as the bus feeds it (the wheels' states at 100 Hz,
//!   the ranges at 20 Hz with an obstacle in front half of the time, `cmd_vel` at 20 Hz);
//! - `gateway_step`: the gateway's own 1 ms step (`App::step`: the imports' queues, the LEDs,
//!   `gateway/status` once a second), fed the IMU's and PSU's topics at their default rates;
//!   `handover`: then the latest values handed to the ROS 2 task (`run`'s copy into `LATEST`);
//! - ROS 2 (`RosBridge` on an open Zenoh session): `poll` with nothing due; one `/odom` sample
//!   (CDR, rmw_zenoh's attachment, the Zenoh frame) over that; one second of polls every 5 ms
//!   (the `zenoh` task's read timeout) with every topic's latest value, as the image runs it;
//!   one `/cmd_vel` put received (`receive`, the key compared, the Twist decoded), taken
//!   (`take_cmd`) and published to the base controller;
//! - socketcand: one frame from the bus to one raw-mode client, from the controller's receive
//!   through the bus tap (`BusTap::run`) and the link's queue to the client's session
//!   (`server::serve`, polled as its task is) writing `< frame … >` to its stream (in memory
//!   here: embassy-net's socket write is not counted).
//!
//! The baseline, same run and core: the IMU's Euler-angle complementary filter (as `fusion`
//! counts it, here in hard float). Counted as `bench` counts (SysTick under `-icount`,
//! calibrated on 10 000 `nop`s), each event on its own and summed, less the empty count's
//! overhead; the node's own work on the frames (decoding, reassembly) is outside the counts.
//! No heap here, as none in the gateway's image (it sets no global allocator): its topics in
//! static cells, its buffers in its tasks' futures (static in embassy-executor).
#![no_std]
#![no_main]

use core::cell::{Cell, RefCell};
use core::convert::Infallible;
use core::fmt::Write;
use core::future::Future;
use core::hint::black_box;
use core::pin::pin;
use core::task::{Context, Poll, Waker};

use cortex_m_semihosting::{debug, hio};
use r2p_app_base as base;
use r2p_app_gateway::params::{followed_by, Offset};
use r2p_app_gateway::ros::{zid_of, Latest, RosBridge, RosConfig};
use r2p_app_gateway::server::{self, serve};
use r2p_app_gateway::{App, BusLink, BusTap, NetState, Sample, Storage};
use r2p_app_imu::attitude::Attitude;
use r2p_module::leds;
use r2p_msgs::{
    Barometer, Battery, GnssFix, Imu, MagneticField, Odometry, Proximity, R2pMessage, Twist2D,
    WheelState,
};
use r2p_node::{Export, Import, RamParams};
use r2p_qemu_tests::icount::{self, ten_thousand_nops, ticks};
use rtcan::controller::{BusState, ErrorCounters, Filter, Received, TxError, TxMode, TxResult};
use rtcan::{CanController, Frame};

/// The gateway's and the base controller's parameters in one table, as the image keeps them
/// (its `PARAMS`, a FlashParams whose `get` is this RamParams').
static PARAMS: RamParams<{ r2p_app_gateway::params::COUNT + base::params::COUNT }> =
    RamParams::new(followed_by(base::params::DEFAULTS));
/// The base controller's part, as the image's `BaseParams` indexes it.
static BASE_PARAMS: Offset<'static> =
    Offset { store: &PARAMS, first: r2p_app_gateway::params::COUNT as u16 };
static BASE: base::Storage = base::Storage::new();
static ENDPOINTS: Storage = Storage::new();
static LINK: BusLink = BusLink::new();
/// The latest values for the ROS 2 task, as the image keeps them.
static LATEST: cortex_m::interrupt::Mutex<Cell<Latest>> =
    cortex_m::interrupt::Mutex::new(Cell::new(Latest::NONE));
/// The base controller's topics for the `/cmd_vel` count (its `cmd_vel` the bridge feeds).
static BASE_CMD: base::Storage = base::Storage::new();

/// One second of 1 ms steps, twice.
const STEPS: u32 = 2_000;
/// `/cmd_vel` puts received.
const CMDS: u32 = 100;
/// Frames forwarded to the client.
const FRAMES: u32 = 200;
/// Euler filter steps (the baseline).
const EULER_STEPS: u32 = 1_000;

fn out() -> hio::HostStream {
    hio::hstdout().unwrap_or_else(|_| fail(""))
}

fn fail(why: &str) -> ! {
    let _ = writeln!(hio::hstdout().unwrap(), "gateway bench: {why}");
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

/// Encodes `m` and hands it to `import`, as the node does with a message from the bus.
fn deliver<T: R2pMessage>(import: &dyn Import, m: &T) {
    let mut buf = [0u8; 64];
    let n = m.encode(&mut buf).unwrap_or_else(|_| fail("encode"));
    if import.publish_bytes(&buf[..n]).is_err() {
        fail("an import refused a message");
    }
}

/// Takes what the exports queued, as the node does when it sends them.
fn drain(exports: &[&dyn Export]) {
    let mut buf = [0u8; 64];
    for e in exports {
        while let Some(r) = e.pop_encoded(&mut buf) {
            black_box(r.ok());
        }
    }
}

/// Sum, count, largest of per-event tick counts.
#[derive(Default, Clone, Copy)]
struct Tally {
    sum: u64,
    n: u32,
    max: u32,
}

impl Tally {
    fn add(&mut self, t: u32) {
        self.sum += u64::from(t);
        self.n += 1;
        self.max = self.max.max(t);
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut p = cortex_m::Peripherals::take().unwrap();
    icount::start(&mut p.SYST);
    let nops = ticks(|| (0..10).for_each(|_| ten_thousand_nops()));
    // Ticks of `ticks` around nothing: taken off each event's count.
    let mut empty = Tally::default();
    for _ in 0..100 {
        empty.add(ticks(|| {}));
    }
    let overhead = empty.sum as f64 / f64::from(empty.n);
    let insn = |t: &Tally| {
        (t.sum as f64 / f64::from(t.n.max(1)) - overhead).max(0.0) * 100_000.0 / nops as f64
    };
    let insn_max = |t: &Tally| (f64::from(t.max) - overhead).max(0.0) * 100_000.0 / nops as f64;

    // The baseline: the Euler filter, inputs varying step to step.
    let mut euler = Attitude::default();
    let e = ticks(|| {
        for i in 0..EULER_STEPS {
            let w = (i % 64) as f32 * 1e-3;
            euler.update(
                black_box([0.01 + w, -0.02 + w, 0.3]),
                [0.3 - w, 0.2 + w, 9.8],
                0.0096,
                2.0,
                0.1,
            );
        }
    });
    let euler_insn = e as f64 * 100_000.0 / nops as f64 / f64::from(EULER_STEPS);
    black_box(euler.yaw);

    let (base_step, base_ik) = base_steps();
    let (gateway_step, handover) = gateway_steps();
    let ros = ros_events();
    let frame = forward_frames();

    let _ = writeln!(
        out(),
        "{{\"bench\":\"cortex_m4_gateway\",\"euler_filter_insn\":{:.0},\
         \"base_step_insn\":{:.0},\"base_step_max_insn\":{:.0},\"base_ik_step_insn\":{:.0},\
         \"gateway_step_insn\":{:.0},\"gateway_step_max_insn\":{:.0},\"handover_insn\":{:.0},\
         \"ros_poll_idle_insn\":{:.0},\"ros_odom_insn\":{:.0},\"ros_per_second_insn\":{:.0},\
         \"ros_per_second_polls\":{},\"ros_per_second_samples\":{},\"ros_cmd_vel_insn\":{:.0},\
         \"can_frame_to_client_insn\":{:.0},\"can_frame_to_client_max_insn\":{:.0}}}",
        euler_insn,
        insn(&base_step),
        insn_max(&base_step),
        insn(&base_ik),
        insn(&gateway_step),
        insn_max(&gateway_step),
        insn(&handover),
        insn(&ros.idle),
        insn(&ros.odom) - insn(&ros.idle),
        insn(&ros.second) * f64::from(ros.second.n),
        ros.second.n,
        ros.second_samples,
        insn(&ros.cmd),
        insn(&frame),
        insn_max(&frame),
    );
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}

/// The base controller's steps: all of them, and those that ran the IK.
fn base_steps() -> (Tally, Tally) {
    let names = base::Names::from_params(&BASE_PARAMS);
    let ends = BASE.build(names, base::params::ik_period_us(&BASE_PARAMS));
    let (imports, exports, cmd_local) = (ends.imports, ends.exports, ends.cmd_local);
    // The motors subscribe to their setpoints and something to `odom`: the node activates the
    // exports with the subscribers' queue length.
    for e in exports {
        e.activate(2);
    }
    let mut app = base::App::new(ends, &BASE_PARAMS);
    let (mut all, mut ik) = (Tally::default(), Tally::default());
    let ik_period_us = u64::from(base::params::ik_period_us(&BASE_PARAMS));
    for i in 0..STEPS {
        let now = 1_000 + u64::from(i) * 1_000;
        if i % 10 == 3 {
            for (w, import) in imports[3..].iter().enumerate() {
                let speed = 5.0 + (i % 97) as f32 * 0.01 + w as f32;
                deliver(*import, &WheelState { speed, ..WheelState::default() });
            }
        }
        if i % 50 == 7 {
            // An obstacle 0.4 m ahead (under the 0.45 m stop distance) in the second of each
            // two seconds.
            let front = if (i / 1_000) % 2 == 1 { 0.4 } else { 1.2 };
            let r = Proximity { distance: [front, 1.5, 1.5, 1.5], ..Proximity::default() };
            deliver(imports[2], &r);
        }
        if i % 50 == 20 {
            let vx = 0.3 + (i % 7) as f32 * 0.01;
            let _ = cmd_local.publish_with(|m| *m = Twist2D { vx, vy: 0.1, wz: 0.5 });
        }
        let t = ticks(|| app.step(black_box(now)));
        all.add(t);
        if now.is_multiple_of(ik_period_us) {
            ik.add(t);
        }
        drain(&exports);
    }
    if app.dropped != 0 || app.pose().0 == 0.0 {
        fail("the base controller dropped setpoints or did not move");
    }
    (all, ik)
}

/// The gateway's own steps.
fn gateway_steps() -> (Tally, Tally) {
    let ep = ENDPOINTS.build();
    let status_export: &dyn Export = ep.status.remote;
    status_export.activate(2);
    let imports: [&dyn Import; 5] =
        [ep.imu.remote, ep.mag.remote, ep.baro.remote, ep.gnss.remote, ep.battery.remote];
    let mut app = App::new(ep, &LINK);
    let running = leds::Status { running: true, synced: true, traffic: true, ..Default::default() };
    let net = NetState { link_up: true, ip: Some([192, 168, 1, 50]), dhcp: true, ros_filtered: 0 };
    let sample = Sample { status: running, net };
    let (mut all, mut handover) = (Tally::default(), Tally::default());
    for i in 0..STEPS {
        let now = 1_000 + u64::from(i) * 1_000;
        // The IMU at 50 Hz, its magnetometer and barometer at 10 Hz, GNSS at 1 Hz, the
        // battery at 10 Hz (their modules' default rates).
        if i % 20 == 1 {
            deliver(imports[0], &Imu { yaw: i as f32 * 1e-3, ..Imu::default() });
        }
        if i % 100 == 2 {
            deliver(imports[1], &MagneticField::default());
            deliver(imports[2], &Barometer::default());
            deliver(imports[4], &Battery { voltage: 24.0, ..Battery::default() });
        }
        if i % 1_000 == 3 {
            deliver(imports[3], &GnssFix::default());
        }
        all.add(ticks(|| {
            black_box(app.step(black_box(now), &sample));
        }));
        // What the image's `run` task then hands the ROS 2 task: the latest values, under a
        // critical section (the base controller's pose, velocity and ranges are its fields).
        let odom = black_box(Odometry { x: i as f32 * 1e-3, ..Odometry::default() });
        handover.add(ticks(|| {
            let (status, battery, imu) = (app.status(&net), app.battery(), app.imu());
            let mirrored = app.mirrored();
            let (mag, baro, gnss) = app.imu_extras();
            let status = Some(status);
            let proximity = None;
            let odom = Some(odom);
            let latest =
                Latest { status, battery, imu, mag, baro, gnss, mirrored, odom, proximity };
            cortex_m::interrupt::free(|cs| LATEST.borrow(cs).set(latest));
        }));
        drain(&[status_export]);
    }
    if app.imu().is_none() || app.battery().is_none() {
        fail("the gateway's step did not take its imports");
    }
    (all, handover)
}

struct Ros {
    idle: Tally,
    odom: Tally,
    second: Tally,
    second_samples: u32,
    cmd: Tally,
}

/// A bridge on a session the router has opened (its INIT ack and OPEN ack, as r2p-app-gateway's
/// tests script them).
fn opened(out: &mut [u8]) -> RosBridge {
    let cfg = RosConfig { domain: 0, namespace: "", zid: zid_of([0x5A; 12]) };
    let mut b = RosBridge::new(&cfg).unwrap_or_else(|| fail("keys"));
    b.connect(0, out).unwrap_or_else(|_| fail("INIT"));
    b.receive(1, &[0x21, 0x09, 0x00, 0xAA, 0x01, 0xCC], out).unwrap_or_else(|_| fail("OPEN"));
    b.receive(2, &[0x62, 10, 0], out).unwrap_or_else(|_| fail("declarations"));
    b
}

fn ros_events() -> Ros {
    let mut out = [0u8; 6 * 1024];
    let mut r = Ros {
        idle: Tally::default(),
        odom: Tally::default(),
        second: Tally::default(),
        second_samples: 0,
        cmd: Tally::default(),
    };
    // `/odom` alone: 20 Hz among polls every 5 ms.
    let mut b = opened(&mut out);
    let mut latest = Latest::default();
    for i in 0..400u32 {
        let now = 10_000 + u64::from(i) * 5_000;
        latest.odom =
            Some(Odometry { x: i as f32 * 1e-3, vx: 0.3, wz: 0.1, ..Odometry::default() });
        let before = b.stats().published;
        let t = ticks(|| {
            if b.poll(now, (now * 1_000) as i64, &latest, &mut out).is_err() {
                fail("poll failed");
            }
        });
        if b.stats().published == before {
            r.idle.add(t);
        } else {
            r.odom.add(t);
        }
    }
    // 2 s at 20 Hz, from the first poll (the first period is counted from the declarations).
    if !(40..=41).contains(&r.odom.n) {
        fail("/odom not at 20 Hz");
    }
    // Every topic, one second of polls every 5 ms.
    let mut b = opened(&mut out);
    let mut latest = Latest {
        odom: Some(Odometry::default()),
        battery: Some(Battery { voltage: 24.0, ..Battery::default() }),
        proximity: Some(Proximity { distance: [1.0; 4], ..Proximity::default() }),
        imu: Some(Imu::default()),
        mag: Some(MagneticField::default()),
        baro: Some(Barometer::default()),
        gnss: Some(GnssFix::default()),
        status: Some(r2p_msgs::GatewayStatus::default()),
        ..Latest::NONE
    };
    // Two seconds; the second is counted (the first poll publishes every topic at once).
    let mut start = 0;
    for i in 0..400u32 {
        let now = 10_000 + u64::from(i) * 5_000;
        if let Some(o) = latest.odom.as_mut() {
            o.x = i as f32 * 1e-3;
        }
        if i == 200 {
            start = b.stats().published;
        }
        let t = ticks(|| {
            if b.poll(now, (now * 1_000) as i64, &latest, &mut out).is_err() {
                fail("poll failed");
            }
        });
        if i >= 200 {
            r.second.add(t);
        }
    }
    r.second_samples = b.stats().published - start;
    // `/cmd_vel`: a PUT on its key in full (FRAME, reliable; PUSH with the key; PUT; CDR of a
    // Twist: 4-byte header, six f64).
    let mut b = opened(&mut out);
    let mut key: heapless::String<128> = heapless::String::new();
    let _ =
        write!(key, "0/cmd_vel/geometry_msgs::msg::dds_::Twist_/{}", r2p_zenoh::types::TWIST.hash);
    let ends = BASE_CMD.build(base::Names::of([1, 2, 3], 0), 10_000);
    for i in 0..CMDS {
        let mut batch: heapless::Vec<u8, 256> = heapless::Vec::new();
        let _ = batch.extend_from_slice(&[0x25, i as u8, 0x3D, 0x00, key.len() as u8]);
        let _ = batch.extend_from_slice(key.as_bytes());
        let _ = batch.extend_from_slice(&[0x01, 52, 0, 1, 0, 0]);
        for v in [0.2 + f64::from(i) * 1e-3, 0.0, 0.0, 0.0, 0.0, -0.5] {
            let _ = batch.extend_from_slice(&v.to_le_bytes());
        }
        let now = 20_000 + u64::from(i) * 50_000;
        r.cmd.add(ticks(|| {
            if b.receive(now, &batch, &mut out).is_err() {
                fail("receive failed");
            }
            if let Some(c) = b.take_cmd(now) {
                let _ = ends.cmd_local.publish_with(|m| *m = c);
            }
        }));
        if ends.cmd.try_recv().is_none() {
            fail("/cmd_vel did not reach the base controller");
        }
    }
    r
}

/// A bxCAN with one received frame at a time (the tap's controller).
struct OneFrame(Option<Received>);

impl CanController for OneFrame {
    fn try_transmit(&mut self, _: &Frame) -> Result<(), TxError> {
        Err(TxError::MailboxesFull)
    }
    fn set_tx_mode(&mut self, _: TxMode) {}
    fn take_tx_result(&mut self) -> Option<TxResult> {
        None
    }
    fn try_receive(&mut self) -> Option<Received> {
        self.0.take()
    }
    fn set_filters(&mut self, _: &[Filter]) {}
    fn abort_pending(&mut self) -> usize {
        0
    }
    fn bus_state(&self) -> BusState {
        BusState::ErrorActive
    }
    fn error_counters(&self) -> ErrorCounters {
        ErrorCounters::default()
    }
}

/// The client's connection, in memory: what it sends, what the server wrote.
struct Wire {
    to_server: &'static [u8],
    written: heapless::Vec<u8, 512>,
}

struct Pipe<'a>(&'a RefCell<Wire>);

impl embedded_io_async::ErrorType for Pipe<'_> {
    type Error = Infallible;
}

impl embedded_io_async::Read for Pipe<'_> {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        core::future::poll_fn(|_| {
            let mut w = self.0.borrow_mut();
            if w.to_server.is_empty() {
                return Poll::Pending;
            }
            let n = buf.len().min(w.to_server.len());
            buf[..n].copy_from_slice(&w.to_server[..n]);
            w.to_server = &w.to_server[n..];
            Poll::Ready(Ok(n))
        })
        .await
    }
}

impl embedded_io_async::Write for Pipe<'_> {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        let mut w = self.0.borrow_mut();
        let n = buf.len().min(w.written.capacity() - w.written.len());
        let _ = w.written.extend_from_slice(&buf[..n]);
        Ok(n)
    }

    async fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// The raw-mode pause of the session, without waiting.
struct NoWait;

impl embedded_hal_async::delay::DelayNs for NoWait {
    async fn delay_ns(&mut self, _ns: u32) {}
}

fn forward_frames() -> Tally {
    let wire = RefCell::new(Wire {
        to_server: b"< open vcan0 >< rawmode >",
        written: heapless::Vec::new(),
    });
    let mut io = Pipe(&wire);
    let config = server::Config { channel: server::CHANNEL };
    let mut delay = NoWait;
    let mut session = pin!(serve(&mut io, &LINK, &config, &mut delay));
    let mut cx = Context::from_waker(Waker::noop());
    for _ in 0..4 {
        if session.as_mut().poll(&mut cx).is_ready() {
            fail("the session ended");
        }
    }
    if !wire.borrow().written.ends_with(b"< ok >< ok >") {
        fail("the session did not enter raw mode");
    }
    wire.borrow_mut().written.clear();
    let mut tap = BusTap::new(&LINK);
    let mut all = Tally::default();
    for i in 0..FRAMES {
        let data = [i as u8, 0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77];
        let frame =
            Frame::from_raw(0x0100_0000 | (i * 0x1357) & 0xF_FFFF, &data[..(i % 9) as usize])
                .unwrap_or_else(|_| fail("frame"));
        let at = 1_000_000 + u64::from(i) * 137;
        let mut can = OneFrame(Some(Received { frame, at }));
        all.add(ticks(|| {
            tap.run(at, &mut can, |c| black_box(c.try_receive()));
            let _ = session.as_mut().poll(&mut cx);
        }));
        let mut w = wire.borrow_mut();
        if !w.written.starts_with(b"< frame ") || !w.written.ends_with(b" >") {
            fail("no frame line written");
        }
        w.written.clear();
    }
    all
}
