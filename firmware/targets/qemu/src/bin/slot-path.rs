//! Cortex-M3 benchmark under QEMU (run by `scripts/bench`): instructions from the slot timer's
//! call of `Node::slot_tick` to the HRT frame's mailbox request (`try_transmit`), the path a
//! slot timer's compare interrupt runs before the frame can start, and of the whole call; and
//! from the master's call to its sync's request.
//! Then the same slots as a module runs them (`module-core`'s `slot_timer`): the node in a task
//! of an interrupt executor, the compare interrupt waking it and running the executor in the
//! same interrupt; counted from the instruction that pends the interrupt (standing in for the
//! timer's compare event) to the mailbox request.
//!
//! With the feature `framed` the nodes use frame-sized reservations (issue 22,
//! `NodeConfig::hrt_blocks` = 2) and the module's slot timer fires where its node asks
//! (`next_slot_at`: its reservation's start among others), not at every grid boundary; the
//! interrupt half is left out (it adds the same wake and poll as on the grid). A second half
//! times the short path a transmit-complete or a publish runs (`Node::top_up`), with an SRT
//! stream from the module to the master.
//!
//! A master and a module with an HRT stream every cycle on the suite's loopback bus; the
//! module also receives the master's frames and the stream's subscriber, so its receive queue
//! is not empty at its slot boundaries. Instructions are counted with SysTick under `-icount`,
//! calibrated on 10 000 `nop`s as in `bench`.
#![no_std]
#![no_main]
// The frame-sized bench replaces the grid's, and leaves the interrupt half out.
#![cfg_attr(feature = "framed", allow(dead_code, unused_imports, unreachable_code))]

use core::cell::Cell;
use core::fmt::Write;
use core::future::poll_fn;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use core::task::Poll;

use cortex_m::interrupt::InterruptNumber;
use cortex_m::peripheral::NVIC;
use cortex_m_rt::exception;
use cortex_m_semihosting::{debug, hio};
use embassy_executor::InterruptExecutor;
use embassy_sync::waitqueue::AtomicWaker;
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_module as _; // the memory routines the module images link (a copy runs on the slot path)
use r2p_node::testbus::{run_slots, uid, Bus, TestNode};
use r2p_node::{HrtState, NoParams, NodeConfig, RemotePublisher, RemoteSubscriber};
use r2p_qemu_tests::icount::{self, ten_thousand_nops, RELOAD};
use rtcan::controller::{BusState, ErrorCounters, Filter, Received, TxError, TxMode, TxResult};
use rtcan::{CanController, CycleConfig, Frame, Laxity, Micros};

const CYCLE: CycleConfig = CycleConfig { bit_rate: 1_000_000, cycle_us: 4_000, slots: 16 };

/// The executor the node's task runs on, in the "compare" interrupt (IRQ 0 of the lm3s6965).
static EXECUTOR: InterruptExecutor = InterruptExecutor::new();
/// The compare event happened (set before the interrupt is pended).
static COMPARE: AtomicBool = AtomicBool::new(false);
/// Compare events handled by the interrupt.
static EVENTS: AtomicU32 = AtomicU32::new(0);
static SLOT_WAKER: AtomicWaker = AtomicWaker::new();
/// SysTick when the HRT frame of the current slot was requested (`u32::MAX`: none).
static REQUESTED_AT: AtomicU32 = AtomicU32::new(u32::MAX);

/// IRQ 0, the slot timer's interrupt here.
#[derive(Clone, Copy)]
struct CompareIrq;

// SAFETY: 0 is a device interrupt of the lm3s6965 (its vector is cortex-m-rt's default table).
unsafe impl InterruptNumber for CompareIrq {
    fn number(self) -> u16 {
        0
    }
}

/// Device interrupts: IRQ 0 is the slot timer's compare, as `module-core`'s `TIM2` handler:
/// wake the bus task, run the executor.
#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    if irqn == 0 {
        if COMPARE.swap(false, Ordering::Relaxed) {
            EVENTS.fetch_add(1, Ordering::Relaxed);
            SLOT_WAKER.wake();
        }
        // SAFETY: IRQ 0 is reserved for this executor.
        unsafe { EXECUTOR.on_interrupt() }
    }
}

/// The bus task: every slot, waits for the compare, then ticks the module (timed) and the
/// master, as a module's `bus` task waits for its `SlotTimer`.
#[embassy_executor::task]
async fn bus_task(
    bus: &'static mut Bus<2>,
    m: &'static mut TestNode<'static>,
    a: &'static mut TestNode<'static>,
) {
    let step = Micros::from(CYCLE.slot_us());
    let mut seen = EVENTS.load(Ordering::Relaxed);
    loop {
        poll_fn(|cx| {
            SLOT_WAKER.register(cx.waker());
            let events = EVENTS.load(Ordering::Relaxed);
            if events == seen {
                Poll::Pending
            } else {
                seen = events;
                Poll::Ready(())
            }
        })
        .await;
        let now = bus.now.get();
        if now.is_multiple_of(Micros::from(CYCLE.cycle_us)) {
            let _ = A_PUB.publish_with(|v| *v = now as u32);
        }
        let mut can = Timed { inner: bus.port(1), hrt_at: Cell::new(None) };
        a.slot_tick(now, &mut can);
        REQUESTED_AT.store(can.hrt_at.get().unwrap_or(u32::MAX), Ordering::Relaxed);
        m.slot_tick(now, &mut bus.port(0));
        while M_SUB.try_recv().is_some() {}
        bus.arbitrate();
        bus.now.set(now + step);
    }
}

/// The frame-sized bench's SRT stream from the module to the master: a four-frame message
/// every fourth slot, so that the short path (`Node::top_up`) finds a release to queue or a
/// queued frame to load behind one that just went.
static B_T: Topic<'static, [u32; 6], { pool_size(&[2], 1) }, 1> = Topic::new("scan", [0; 6]);
static B_PUB: Publisher<'static, [u32; 6]> =
    Publisher::new(&B_T, Class::AsyncRealTime { deadline_us: 4_000 });
static B_OUT: RemoteSubscriber<'static, [u32; 6], 2> = RemoteSubscriber::new(&B_PUB);
static B_M: Topic<'static, [u32; 6], { pool_size(&[2], 1) }, 1> = Topic::new("scan", [0; 6]);
static B_MPUB: Publisher<'static, [u32; 6]> = Publisher::new(&B_M, Class::NonRealTime);
static B_IN: RemotePublisher<'static, [u32; 6]> = RemotePublisher::new(&B_MPUB, &B_M);
static B_SUB: Subscriber<'static, [u32; 6], 2> = Subscriber::new();

static A_T: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("setpoint", 0);
static A_PUB: Publisher<'static, u32> =
    Publisher::new(&A_T, Class::SyncRealTime { period_us: 4_000 });
static A_OUT: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&A_PUB);
static M_T: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("setpoint", 0);
static M_PUB: Publisher<'static, u32> = Publisher::new(&M_T, Class::NonRealTime);
static M_IN: RemotePublisher<'static, u32> = RemotePublisher::new(&M_PUB, &M_T);
static M_SUB: Subscriber<'static, u32, 4> = Subscriber::new();

/// A controller that notes the SysTick value when an HRT frame is requested.
struct Timed<C> {
    inner: C,
    hrt_at: Cell<Option<u32>>,
}

/// The frame-sized bench: SysTick when the first SRT/NRT frame of the current call was
/// requested (`u32::MAX`: none).
#[cfg(feature = "framed")]
static QUEUED_AT: AtomicU32 = AtomicU32::new(u32::MAX);

/// SysTick when the master's sync was requested (`u32::MAX`: none).
static SYNC_AT: AtomicU32 = AtomicU32::new(u32::MAX);

impl<C: CanController> CanController for Timed<C> {
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        if frame.id().laxity == Laxity::HRT && frame.id().message.0 >= 0x100 {
            self.hrt_at.set(Some(icount::now()));
        }
        #[cfg(feature = "framed")]
        if frame.id().laxity != Laxity::HRT && QUEUED_AT.load(Ordering::Relaxed) == u32::MAX {
            QUEUED_AT.store(icount::now(), Ordering::Relaxed);
        }
        if frame.id().laxity == Laxity::HRT && frame.id().message.0 < 0x100 {
            SYNC_AT.store(icount::now(), Ordering::Relaxed);
        }
        self.inner.try_transmit(frame)
    }
    fn set_tx_mode(&mut self, mode: TxMode) {
        self.inner.set_tx_mode(mode)
    }
    fn take_tx_result(&mut self) -> Option<TxResult> {
        self.inner.take_tx_result()
    }
    fn try_receive(&mut self) -> Option<Received> {
        self.inner.try_receive()
    }
    fn set_filters(&mut self, filters: &[Filter]) {
        self.inner.set_filters(filters)
    }
    fn abort_pending(&mut self) -> usize {
        self.inner.abort_pending()
    }
    fn bus_state(&self) -> BusState {
        self.inner.bus_state()
    }
    fn error_counters(&self) -> ErrorCounters {
        self.inner.error_counters()
    }
}

fn node(n: u32, name: &'static str, rank: Option<u8>) -> TestNode<'static> {
    TestNode::new(config(n, name, rank), &NoParams).unwrap()
}

fn config(n: u32, name: &'static str, rank: Option<u8>) -> NodeConfig {
    NodeConfig {
        heartbeat_period_us: 20_000,
        request_timeout_us: 30_000,
        cycle: CYCLE,
        rank,
        hrt_slots: 2,
        hrt_blocks: if cfg!(feature = "framed") { 2 } else { 0 },
        ..NodeConfig::new(uid(n), name)
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut p = cortex_m::Peripherals::take().unwrap();
    icount::start(&mut p.SYST);
    let mut out = hio::hstdout().unwrap();
    let t0 = icount::now();
    (0..10).for_each(|_| ten_thousand_nops());
    let nops = t0.wrapping_sub(icount::now()) & RELOAD;
    let insn_per_tick = 100_000.0f64 / nops as f64;

    A_T.advertise(&A_PUB).unwrap();
    A_T.subscribe(&A_OUT).unwrap();
    M_T.advertise(&M_PUB).unwrap();
    M_T.subscribe(&M_SUB).unwrap();
    B_T.advertise(&B_PUB).unwrap();
    B_T.subscribe(&B_OUT).unwrap();
    B_M.advertise(&B_MPUB).unwrap();
    B_M.subscribe(&B_SUB).unwrap();

    // The bus and the nodes in statics, not on main's stack, which the compare interrupt's
    // executor shares (by value, main's frame held them and their copies for the bus task:
    // within ~100 bytes of the stack's limit, and over it as the node grew).
    let bus: &'static mut Bus<2> = cortex_m::singleton!(: Bus<2> = Bus::slotted(CYCLE)).unwrap();
    let m: &'static mut TestNode<'static> =
        cortex_m::singleton!(: TestNode<'static> = node(1, "psu", Some(0))).unwrap();
    let a: &'static mut TestNode<'static> =
        cortex_m::singleton!(: TestNode<'static> = node(2, "motor", None)).unwrap();
    a.export(&A_OUT).unwrap();
    m.import(&M_IN).unwrap();
    if cfg!(feature = "framed") {
        a.export(&B_OUT).unwrap();
        m.import(&B_IN).unwrap();
    }
    run_slots(bus, &mut [&mut *m, &mut *a], 150_000);
    if !matches!(a.hrt_state(0), Some(HrtState::Granted { .. })) {
        let _ = writeln!(out, "slot-path: the HRT stream was not granted");
        debug::exit(debug::EXIT_FAILURE);
    }

    // The frame-sized bench instead of the grid's (it does not return).
    #[cfg(feature = "framed")]
    framed(bus, m, a, insn_per_tick, &mut out);

    // 400 cycles: A publishes every cycle; time A's slot ticks and the master's call to its
    // sync's request (the sync goes first).
    let step = Micros::from(CYCLE.slot_us());
    let (mut to_request_max, mut to_request_min, mut whole_max, mut requests) =
        (0u32, u32::MAX, 0u32, 0u32);
    let mut sync = Span::default();
    let end = bus.now.get() + 400 * Micros::from(CYCLE.cycle_us);
    while bus.now.get() < end {
        let now = bus.now.get();
        if now.is_multiple_of(Micros::from(CYCLE.cycle_us)) {
            let _ = A_PUB.publish_with(|v| *v = now as u32);
        }
        let mut can = Timed { inner: bus.port(0), hrt_at: Cell::new(None) };
        SYNC_AT.store(u32::MAX, Ordering::Relaxed);
        let start = icount::now();
        m.slot_tick(now, &mut can);
        let at = SYNC_AT.load(Ordering::Relaxed);
        if at != u32::MAX {
            sync.add(start.wrapping_sub(at) & RELOAD);
        }
        let mut can = Timed { inner: bus.port(1), hrt_at: Cell::new(None) };
        let start = icount::now();
        a.slot_tick(now, &mut can);
        let stop = icount::now();
        whole_max = whole_max.max(start.wrapping_sub(stop) & RELOAD);
        if let Some(at) = can.hrt_at.get() {
            let t = start.wrapping_sub(at) & RELOAD;
            to_request_max = to_request_max.max(t);
            to_request_min = to_request_min.min(t);
            requests += 1;
        }
        while M_SUB.try_recv().is_some() {}
        bus.arbitrate();
        bus.now.set(now + step);
    }
    if requests < 390 || sync.n < 390 {
        let n = sync.n;
        let _ = writeln!(out, "slot-path: only {requests} HRT requests, {n} syncs in 400 cycles");
        debug::exit(debug::EXIT_FAILURE);
    }

    // The same slots from the compare interrupt: the nodes move into the bus task.
    EXECUTOR.start(CompareIrq).spawn(bus_task(bus, m, a)).unwrap();
    let (mut irq_max, mut irq_min, mut irq_requests) = (0u32, u32::MAX, 0u32);
    for _ in 0..400 * u32::from(CYCLE.slots) {
        REQUESTED_AT.store(u32::MAX, Ordering::Relaxed);
        COMPARE.store(true, Ordering::Relaxed);
        let start = icount::now();
        NVIC::pend(CompareIrq);
        let at = REQUESTED_AT.load(Ordering::Relaxed);
        if at != u32::MAX {
            let t = start.wrapping_sub(at) & RELOAD;
            irq_max = irq_max.max(t);
            irq_min = irq_min.min(t);
            irq_requests += 1;
        }
    }
    if irq_requests < 390 {
        let _ = writeln!(out, "slot-path: only {irq_requests} HRT requests from the interrupt");
        debug::exit(debug::EXIT_FAILURE);
    }
    let insn = |t: u32| (t as f64 * insn_per_tick) as u32;
    let _ = writeln!(
        out,
        "{{\"bench\":\"cortex_m3_slot_path\",\"hrt_requests\":{},\"to_request_min_insn\":{},\"to_request_max_insn\":{},\"slot_tick_max_insn\":{},\"irq_hrt_requests\":{},\"irq_to_request_min_insn\":{},\"irq_to_request_max_insn\":{},\"sync_requests\":{},\"sync_min_insn\":{},\"sync_max_insn\":{}}}",
        requests,
        insn(to_request_min),
        insn(to_request_max),
        insn(whole_max),
        irq_requests,
        insn(irq_min),
        insn(irq_max),
        sync.n,
        insn(sync.min),
        insn(sync.max)
    );
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}

/// The frame-sized bench: 400 cycles as in the grid's first half, but the module ticks at
/// every time its node asks for (`next_slot_at`) as well as at the grid's boundaries, where the
/// master and the bus step; its HRT frame is requested at its reservation's start. Then 400
/// more in which the module's short path (`Node::top_up`) runs first at each boundary, as its
/// transmit-complete interrupt would after the boundary's frame went (or, every fourth slot,
/// its application's publish): from that call to its first SRT/NRT frame's request.
#[cfg(feature = "framed")]
fn framed(
    bus: &mut Bus<2>,
    m: &mut TestNode<'static>,
    a: &mut TestNode<'static>,
    insn_per_tick: f64,
    out: &mut hio::HostStream,
) -> ! {
    let step = Micros::from(CYCLE.slot_us());
    let (mut to_request_max, mut to_request_min, mut whole_max, mut requests, mut ticks) =
        (0u32, u32::MAX, 0u32, 0u32, 0u32);
    // The first SRT/NRT frame's request, in the calls that load one: the slot tick's (the
    // window's path), the short path's after a transmit-complete and after a publish.
    let mut queued = Span::default();
    // The master's call to its sync's request: the sync goes first (`Node::send_sync`).
    let mut sync = Span::default();
    let (mut after_transmit, mut after_publish) = (Span::default(), Span::default());
    let half = bus.now.get() + 400 * Micros::from(CYCLE.cycle_us);
    let end = half + 400 * Micros::from(CYCLE.cycle_us);
    while bus.now.get() < end {
        let boundary = bus.now.get();
        if boundary.is_multiple_of(Micros::from(CYCLE.cycle_us)) {
            let _ = A_PUB.publish_with(|v| *v = boundary as u32);
        }
        let mut can = Timed { inner: bus.port(0), hrt_at: Cell::new(None) };
        SYNC_AT.store(u32::MAX, Ordering::Relaxed);
        let start = icount::now();
        m.slot_tick(boundary, &mut can);
        let at = SYNC_AT.load(Ordering::Relaxed);
        if at != u32::MAX && boundary < half {
            sync.add(start.wrapping_sub(at) & RELOAD);
        }
        if boundary >= half {
            let publish = (boundary / step).is_multiple_of(4);
            if publish {
                let _ = B_PUB.publish_with(|v| *v = [boundary as u32; 6]);
            }
            let mut can = Timed { inner: bus.port(1), hrt_at: Cell::new(None) };
            QUEUED_AT.store(u32::MAX, Ordering::Relaxed);
            let start = icount::now();
            a.top_up(boundary, &mut can);
            let q = QUEUED_AT.load(Ordering::Relaxed);
            if q != u32::MAX {
                let span = if publish { &mut after_publish } else { &mut after_transmit };
                span.add(start.wrapping_sub(q) & RELOAD);
            }
        }
        // A's ticks from this boundary to the next, the boundary's included.
        let mut now = boundary;
        while now < boundary + step {
            let mut can = Timed { inner: bus.port(1), hrt_at: Cell::new(None) };
            QUEUED_AT.store(u32::MAX, Ordering::Relaxed);
            let start = icount::now();
            a.slot_tick(now, &mut can);
            let stop = icount::now();
            if boundary < half {
                ticks += 1;
                let q = QUEUED_AT.load(Ordering::Relaxed);
                if q != u32::MAX {
                    queued.add(start.wrapping_sub(q) & RELOAD);
                }
                whole_max = whole_max.max(start.wrapping_sub(stop) & RELOAD);
                if let Some(at) = can.hrt_at.get() {
                    let t = start.wrapping_sub(at) & RELOAD;
                    to_request_max = to_request_max.max(t);
                    to_request_min = to_request_min.min(t);
                    requests += 1;
                }
            }
            now = a.next_slot_at(now).max(now + 1).min(boundary + step);
        }
        while M_SUB.try_recv().is_some() {}
        while B_SUB.try_recv().is_some() {}
        bus.arbitrate();
        bus.now.set(boundary + step);
    }
    if requests < 390 || sync.n < 390 || after_transmit.n < 100 || after_publish.n < 100 {
        let (t, p) = (after_transmit.n, after_publish.n);
        let _ = writeln!(
            out,
            "slot-path: only {requests} framed HRT requests, {t} and {p} short-path requests"
        );
        debug::exit(debug::EXIT_FAILURE);
    }
    let insn = |t: u32| (t as f64 * insn_per_tick) as u32;
    let _ = writeln!(
        out,
        "{{\"bench\":\"framed_slot_path\",\"hrt_requests\":{},\"ticks\":{},\"to_request_min_insn\":{},\"to_request_max_insn\":{},\"slot_tick_max_insn\":{},\"queued_requests\":{},\"queued_min_insn\":{},\"queued_max_insn\":{},\"top_up_transmit_requests\":{},\"top_up_transmit_min_insn\":{},\"top_up_transmit_max_insn\":{},\"top_up_publish_requests\":{},\"top_up_publish_min_insn\":{},\"top_up_publish_max_insn\":{},\"sync_requests\":{},\"sync_min_insn\":{},\"sync_max_insn\":{}}}",
        requests,
        ticks,
        insn(to_request_min),
        insn(to_request_max),
        insn(whole_max),
        queued.n,
        insn(queued.min),
        insn(queued.max),
        after_transmit.n,
        insn(after_transmit.min),
        insn(after_transmit.max),
        after_publish.n,
        insn(after_publish.min),
        insn(after_publish.max),
        sync.n,
        insn(sync.min),
        insn(sync.max)
    );
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}
/// Shortest and longest of `n` measured paths (SysTick counts).
struct Span {
    n: u32,
    min: u32,
    max: u32,
}

impl Default for Span {
    fn default() -> Self {
        Self { n: 0, min: u32::MAX, max: 0 }
    }
}

impl Span {
    fn add(&mut self, t: u32) {
        (self.n, self.min, self.max) = (self.n + 1, self.min.min(t), self.max.max(t));
    }
}
