//! Emulated R2P boards in deterministic virtual time.
//!
//! A [`Sim`] owns an [`r2p_vbus::Bus`] and a set of boards. A board is a node runtime
//! ([`r2p_node::Node`], or anything implementing [`Runtime`]) on one port of the bus, plus an
//! application step called every millisecond of virtual time. The sim moves virtual time from
//! event to event: the bus's next event ([`Bus::next_event`]), each board's next slot boundary
//! ([`Node::next_slot_at`], TDMA mode) or poll period (unslotted mode), and the next
//! application millisecond. Nothing reads a clock and every fault is drawn from the bus's seed,
//! so the same seed and the same inputs give the same trace ([`Bus::trace_hash`]).
//!
//! Limitation: middleware topics are `static`s, so one process holds each static topic once.
//! Boards are kept apart by giving each its own set of statics (distinct `static` items per
//! board, e.g. per test); two boards must never share a topic static, or they would see each
//! other's publications without the bus.
//!
//! Frames reach a node as a bxCAN in time-triggered mode delivers them ([`SimPort`]): a 16-bit
//! bit-time counter captured at the start of frame and a receive-interrupt stamp with a
//! modelled latency; the firmware's own code (`rtcan::time_counter`) turns them into the start
//! of frame the slot clock wants.

pub mod boards;
pub mod bridge;
pub mod demo;
pub mod gateway_net;
pub mod gateway_zenoh;
pub mod periph;
pub mod robot;
pub mod serve;
mod stalled;
mod transmit_irq;

use std::io::{self, Write};
use std::time::Duration;

use boards::Mcu;
use r2p_canlink::candump::LogWriter;
use r2p_canlink::{CanFrame, Stamped};
use r2p_node::Node;
use r2p_vbus::bxcan::STAGED_LOAD_US;
use r2p_vbus::{Bus, Config};
use rtcan::{CanController, Micros};
use stalled::StalledPort;
use transmit_irq::TransmitIrq;

/// Nanoseconds per microsecond.
const NS_PER_US: u64 = 1_000;
/// Nanoseconds per millisecond (the application step's period).
const NS_PER_MS: u64 = 1_000_000;

/// What the sim needs of a node runtime. Implemented for every [`Node`].
pub trait Runtime {
    /// Unslotted mode: receive, run timers, send ([`Node::poll`]).
    fn poll(&mut self, now: Micros, can: &mut dyn CanController);
    /// TDMA mode: the slot timer ([`Node::slot_tick`]).
    fn slot_tick(&mut self, now: Micros, can: &mut dyn CanController);
    /// TDMA mode: the next slot boundary ([`Node::next_slot_at`]).
    fn next_slot_at(&self, now: Micros) -> Micros;
    /// TDMA mode: the slot timer also runs when one of the board's frames leaves its mailbox
    /// ([`Node::wakes_on_transmit`]).
    fn wakes_on_transmit(&self) -> bool {
        false
    }
    /// Messages released on the board's exports, not yet queued ([`Node::releases_waiting`]):
    /// a slot timer that wakes on transmit also wakes when they grow.
    fn releases_waiting(&self) -> usize {
        0
    }
    /// TDMA mode: what those two wakes run ([`Node::top_up`]).
    fn top_up(&mut self, now: Micros, can: &mut dyn CanController) {
        self.slot_tick(now, can);
    }
    /// True while the node sends the syncs ([`Node::role`]): a node that was not when its slot
    /// tick began and loads a sync in it took over in that tick, and loads it at the tick's
    /// end, on the slot path, not first.
    fn is_master(&self) -> bool {
        false
    }
}

impl<
        const E: usize,
        const I: usize,
        const T: usize,
        const R: usize,
        const B: usize,
        const M: bool,
    > Runtime for Node<'_, E, I, T, R, B, M>
{
    fn poll(&mut self, now: Micros, can: &mut dyn CanController) {
        Node::poll(self, now, can);
    }
    fn slot_tick(&mut self, now: Micros, can: &mut dyn CanController) {
        Node::slot_tick(self, now, can);
    }
    fn next_slot_at(&self, now: Micros) -> Micros {
        Node::next_slot_at(self, now)
    }
    fn wakes_on_transmit(&self) -> bool {
        Node::wakes_on_transmit(self)
    }
    fn releases_waiting(&self) -> usize {
        Node::releases_waiting(self)
    }
    fn top_up(&mut self, now: Micros, can: &mut dyn CanController) {
        Node::top_up(self, now, can);
    }
    fn is_master(&self) -> bool {
        Node::role(self) == rtcan::failover::Role::Master
    }
}

impl<R: Runtime + ?Sized> Runtime for Box<R> {
    fn poll(&mut self, now: Micros, can: &mut dyn CanController) {
        (**self).poll(now, can);
    }
    fn slot_tick(&mut self, now: Micros, can: &mut dyn CanController) {
        (**self).slot_tick(now, can);
    }
    fn next_slot_at(&self, now: Micros) -> Micros {
        (**self).next_slot_at(now)
    }
    fn wakes_on_transmit(&self) -> bool {
        (**self).wakes_on_transmit()
    }
    fn releases_waiting(&self) -> usize {
        (**self).releases_waiting()
    }
    fn top_up(&mut self, now: Micros, can: &mut dyn CanController) {
        (**self).top_up(now, can);
    }
    fn is_master(&self) -> bool {
        (**self).is_master()
    }
}

/// Something between a board's node and its port, as the gateway's bus tap is on the MCU
/// (`r2p_app_gateway::BusTap`): each call of the node runtime goes through it.
pub trait PortTap {
    /// Calls `node` (one `slot_tick` or `poll`) at `now` on `port` as the tap presents it.
    fn run(
        &mut self,
        now: Micros,
        port: &mut dyn CanController,
        node: &mut dyn FnMut(&mut dyn CanController),
    );
}

/// How boards drive their nodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// TDMA: `slot_tick` at every slot boundary the node asks for.
    Tdma,
    /// Unslotted: `poll` every `period_us`.
    Poll {
        /// Poll period in µs.
        period_us: Micros,
    },
}

/// A board's application step: called every millisecond of virtual time with the time (µs) and
/// the board's node (before the node's own tick at that time).
pub type App<'a, N> = Box<dyn FnMut(Micros, &mut N) + 'a>;

/// A port of the vbus as a board's controller sees it: a bxCAN in time-triggered mode and its
/// driver ([`r2p_vbus::BxCanPort`]). Received frames carry the start of frame the firmware
/// computes from the controller's counter capture and its receive-interrupt stamp.
pub type SimPort = r2p_vbus::BxCanPort;

/// µs from an F103 module's clock read to its frame's mailbox request: its slot path from the
/// compare interrupt ([`r2p_node::CORTEX_M3_SLOT_PATH`], 1 724–1 824 instructions, 23.9–25.3 µs
/// at 72 MHz and one cycle per instruction), the longest rounded up. Every emulated frame of a
/// board added with [`Sim::add_board`] reaches its mailbox this much after the node's tick; the
/// boards' firmware ticks [`r2p_node::MODULE_SLOT_LEAD_US`] (the shortest path) before each
/// boundary. Boards on another MCU (the F407 gateway) take theirs: [`Sim::add_board_on`].
pub const SLOT_PATH_US: u64 = r2p_node::CORTEX_M3_SLOT_PATH.longest_us(72_000_000) as u64;

/// CPU time a board's firmware lost since the last call, ns: what its flash took (on the
/// F103 the CPU stalls while a page is erased or a half-word programmed).
pub type StallSource<'a> = Box<dyn FnMut() -> u64 + 'a>;

/// A board's next boot after a reset its firmware asked for (a REBOOT request, a watchdog).
pub struct Reset<'a, N> {
    /// The new firmware's node.
    pub node: N,
    /// Its application step.
    pub app: Option<App<'a, N>>,
    /// Its port tap, if the board has one.
    pub tap: Option<Box<dyn PortTap + 'a>>,
    /// How long the board is off the bus first (the bootloader's work, e.g. a swap), ns.
    pub down_ns: u64,
}

/// Called after every step for each board: `Some` when the board reset (its firmware asked),
/// with its next boot.
pub type Resetter<'a, N> = Box<dyn FnMut(usize, Micros) -> Option<Reset<'a, N>> + 'a>;

/// One emulated board.
struct Board<'a, N> {
    node: N,
    port: SimPort,
    app: Option<App<'a, N>>,
    /// Between the node and its port, if the board has one.
    tap: Option<Box<dyn PortTap + 'a>>,
    /// Where its flash's CPU time comes from.
    stall: Option<StallSource<'a>>,
    /// In its bootloader until then (port off), after a reset.
    down_until_ns: Option<u64>,
    /// Next slot tick / poll, ns.
    wake_ns: u64,
    /// Next short path ([`Runtime::top_up`]: a transmit-complete or a publish), ns; `u64::MAX`:
    /// none. A slot tick due by then runs instead.
    event_ns: u64,
    /// Its MCU: how long each of its firmware's paths takes from a clock read to the mailbox
    /// request (`Mcu::slot_path_us`, `Mcu::top_up_path_us`, `Mcu::sync_path_us`,
    /// `Mcu::framed_paths_us`).
    mcu: Mcu,
    /// Next application step, ns.
    app_ns: u64,
    powered: bool,
    /// Frames in its mailboxes when the sim last looked: one fewer is its transmit-complete
    /// interrupt ([`Runtime::wakes_on_transmit`]).
    mailboxes: usize,
    /// That interrupt's mask: it waits for the end of the call it woke.
    transmit_irq: TransmitIrq,
    /// Released messages waiting after its last slot tick: more is a publish that wakes it.
    releases: usize,
    /// Ticks in a row whose node asked for its next tick at or before the tick's µs
    /// ([`STUCK_TICKS`]).
    stuck_ticks: u32,
}

/// Ticks in a row at which a board's slot timer may ask for no later µs than its tick's before
/// the sim stops with a panic: firmware whose timer does not move on busy-loops its MCU's
/// timer interrupt, which the sim would crawl through a nanosecond at a time (a tick that ran
/// late, after a stall, may ask for its own µs once or twice).
pub const STUCK_TICKS: u32 = 1_000;

impl<N> Board<'_, N> {
    /// Holds the firmware for the CPU time its flash just took.
    fn hold(&mut self, t: u64) {
        let ns = self.stall.as_mut().map_or(0, |stall| stall());
        self.hold_for(t, ns);
    }

    /// Holds the firmware for `ns` of stalls from `t` on.
    fn hold_for(&mut self, t: u64, ns: u64) {
        if ns > 0 {
            self.wake_ns = self.wake_ns.max(t + ns);
            self.app_ns = self.app_ns.max(t + ns);
            if self.event_ns != u64::MAX {
                self.event_ns = self.event_ns.max(t + ns);
            }
        }
    }
}

/// Counters of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SimStats {
    /// Distinct instants the sim stopped at.
    pub steps: u64,
    /// Slot ticks or polls run.
    pub ticks: u64,
    /// Application steps run.
    pub app_steps: u64,
    /// Frames the boards' transmit interrupts loaded of those their nodes staged (staged
    /// reloads: `r2p_vbus::BxCanPort::load_staged`).
    pub staged_loads: u64,
    /// Transmit interrupts that waited for the end of the bus task's call (the interrupt
    /// masks itself until then): a frame of the node's ended while it ran.
    pub deferred_transmit_irqs: u64,
}

/// The world's step: called every millisecond of virtual time with the time (µs), before the
/// boards' application steps at that time (so they sample the world as it is then).
pub type WorldStep<'a> = Box<dyn FnMut(Micros) + 'a>;

/// Several boards on one virtual bus, in virtual time. See the crate documentation.
pub struct Sim<'a, N: Runtime> {
    bus: Bus,
    mode: Mode,
    boards: Vec<Board<'a, N>>,
    world: Option<WorldStep<'a>>,
    /// Next world step, ns.
    world_ns: u64,
    now_ns: u64,
    stats: SimStats,
    resetter: Option<Resetter<'a, N>>,
}

impl<'a, N: Runtime> Sim<'a, N> {
    /// A sim on a new bus with `ports` ports (boards take some of them; the others are free for
    /// babblers or bridges) and bus configuration `config` (its seed drives every fault).
    pub fn new(ports: usize, config: Config, mode: Mode) -> Self {
        Self {
            bus: Bus::new(ports, config),
            mode,
            boards: Vec::new(),
            world: None,
            world_ns: 0,
            now_ns: 0,
            stats: SimStats::default(),
            resetter: None,
        }
    }

    /// Holds board `i`'s firmware for the CPU time `stall` reports after each of its steps.
    pub fn set_stall(&mut self, i: usize, stall: StallSource<'a>) {
        self.boards[i].stall = Some(stall);
    }

    /// Lets boards reset themselves: `resetter` is asked after each step (see [`Resetter`]).
    pub fn set_resetter(&mut self, resetter: Resetter<'a, N>) {
        self.resetter = Some(resetter);
    }

    /// Adds an F103 board: `node` on port `port`, with application step `app` (if any). Returns
    /// the board's index. Its first tick is at the current time.
    pub fn add_board(&mut self, node: N, port: usize, app: Option<App<'a, N>>) -> usize {
        self.add_board_on(node, port, app, Mcu::F103)
    }

    /// Adds a board on `mcu`, whose slot path and short path take their time on it from a
    /// call to its frame's mailbox request (`Mcu::slot_path_us`, `Mcu::top_up_path_us`; a
    /// master's sync `Mcu::sync_path_us`; on frame-sized reservations a slot tick's HRT frame
    /// and sync `Mcu::framed_paths_us`).
    pub fn add_board_on(
        &mut self,
        node: N,
        port: usize,
        app: Option<App<'a, N>>,
        mcu: Mcu,
    ) -> usize {
        assert!(self.boards.iter().all(|b| b.port.port().index() != port), "port {port} taken");
        let bit_rate = self.bus.config().bit_rate;
        self.boards.push(Board {
            node,
            port: SimPort::new(self.bus.port(port), bit_rate).with_load_latency(mcu.slot_path_us()),
            app,
            tap: None,
            stall: None,
            down_until_ns: None,
            wake_ns: self.now_ns,
            event_ns: u64::MAX,
            mcu,
            app_ns: self.now_ns,
            powered: true,
            mailboxes: 0,
            transmit_irq: TransmitIrq::default(),
            releases: 0,
            stuck_ticks: 0,
        });
        self.boards.len() - 1
    }

    /// Steps `world` every millisecond from now on, before the boards' applications.
    pub fn set_world(&mut self, world: WorldStep<'a>) {
        self.world = Some(world);
        self.world_ns = self.now_ns;
    }

    /// Reboots board `i` with a new `node` and application (the firmware starts again from
    /// reset: RAM state is gone, whatever the builder keeps, such as flash, stays). Its
    /// controller is reset as by a power cycle.
    pub fn reboot(&mut self, i: usize, node: N, app: Option<App<'a, N>>) {
        let port = self.boards[i].port.port().index();
        self.bus.power(port, false);
        self.bus.power(port, true);
        let b = &mut self.boards[i];
        b.node = node;
        b.app = app;
        b.powered = true;
        b.wake_ns = self.now_ns;
        b.event_ns = u64::MAX;
        b.app_ns = self.now_ns;
    }

    /// Puts `tap` between board `i`'s node and its port (replacing any; `None` removes it).
    /// A reboot keeps it: set the new firmware's after [`Sim::reboot`].
    pub fn set_tap(&mut self, i: usize, tap: Option<Box<dyn PortTap + 'a>>) {
        self.boards[i].tap = tap;
    }

    /// Whether board `i` is powered.
    pub fn is_powered(&self, i: usize) -> bool {
        self.boards[i].powered
    }

    /// The bus (faults, babblers, partitions, the trace).
    pub fn bus(&self) -> &Bus {
        &self.bus
    }

    /// Number of boards.
    pub fn boards(&self) -> usize {
        self.boards.len()
    }

    /// Board `i`'s node.
    pub fn node(&self, i: usize) -> &N {
        &self.boards[i].node
    }

    /// Board `i`'s node, mutably.
    pub fn node_mut(&mut self, i: usize) -> &mut N {
        &mut self.boards[i].node
    }

    /// Board `i`'s bus port index.
    pub fn port_of(&self, i: usize) -> usize {
        self.boards[i].port.port().index()
    }

    /// Current virtual time, ns.
    pub fn now_ns(&self) -> u64 {
        self.now_ns
    }

    /// Current virtual time, µs.
    pub fn now_us(&self) -> Micros {
        self.now_ns / NS_PER_US
    }

    /// Counters so far.
    pub fn stats(&self) -> SimStats {
        self.stats
    }

    /// Powers board `i` off (its port too: a frame on the wire is cut short, its controller
    /// reset) or on again. A board powered on resumes with the node state it had (a reboot
    /// would need a new node: not modelled).
    pub fn power(&mut self, i: usize, on: bool) {
        let b = &mut self.boards[i];
        self.bus.power(b.port.port().index(), on);
        b.powered = on;
        b.wake_ns = b.wake_ns.max(self.now_ns);
        if !on {
            b.event_ns = u64::MAX; // its interrupts went with its power
            b.transmit_irq = TransmitIrq::default();
        }
        b.app_ns = b.app_ns.max(self.now_ns);
    }

    /// The next instant something is due, capped at `limit_ns`.
    fn next_due(&self, limit_ns: u64) -> u64 {
        let bus = self.bus.next_event().map_or(u64::MAX, |t| t.max(self.now_ns));
        self.boards
            .iter()
            .filter(|b| b.powered)
            .flat_map(|b| {
                let app = if b.app.is_some() { b.app_ns } else { u64::MAX };
                [b.wake_ns.min(b.event_ns), app, b.transmit_irq.due_ns().unwrap_or(u64::MAX)]
            })
            .fold(bus, u64::min)
            .min(if self.world.is_some() { self.world_ns } else { u64::MAX })
            .min(limit_ns)
    }

    /// Runs until virtual time `t_ns` (everything due at or before it runs).
    pub fn run_until(&mut self, t_ns: u64) {
        loop {
            let t = self.next_due(t_ns).max(self.now_ns);
            self.bus.advance_to(t);
            self.now_ns = t;
            self.stats.steps += 1;
            let now_us = t / NS_PER_US;
            let mode = self.mode;
            if let Some(world) = &mut self.world {
                if self.world_ns <= t {
                    world(now_us);
                    self.world_ns += NS_PER_MS;
                }
            }
            for b in self.boards.iter_mut().filter(|b| b.powered) {
                match b.down_until_ns {
                    Some(d) if d > t => continue,
                    Some(_) => {
                        self.bus.power(b.port.port().index(), true);
                        b.down_until_ns = None;
                    }
                    None => {}
                }
                if let Some(app) = &mut b.app {
                    if b.app_ns <= t {
                        app(now_us, &mut b.node);
                        b.app_ns += NS_PER_MS;
                        self.stats.app_steps += 1;
                        // A publish to a remote subscriber runs the short path of a board
                        // that asks for it (once the application's own CPU time is over).
                        if mode == Mode::Tdma && b.node.wakes_on_transmit() {
                            let waiting = b.node.releases_waiting();
                            if waiting > b.releases {
                                b.event_ns = b.event_ns.min(t);
                            }
                            b.releases = waiting;
                        }
                        b.hold(t);
                    }
                }
            }
            let boards = self.boards.iter_mut().enumerate();
            for (i, b) in boards.filter(|(_, b)| b.powered && b.down_until_ns.is_none()) {
                // A frame of its own left a mailbox (sent, or lost a one-shot arbitration):
                // its transmit-complete interrupt runs the short path now, or at the end of
                // the call it last woke (it masks itself until then).
                let pending = b.port.port().pending();
                let wakes = mode == Mode::Tdma && b.node.wakes_on_transmit();
                let deferred = b.transmit_irq.deferred;
                if wakes && b.transmit_irq.fires(t, pending < b.mailboxes) {
                    self.stats.deferred_transmit_irqs += b.transmit_irq.deferred - deferred;
                    b.event_ns = b.event_ns.min(t);
                    // With staged reloads, the interrupt first runs the firmware's staged
                    // loads: if the controller is empty, the frames the node staged reach
                    // their mailboxes `STAGED_LOAD_US` later, if they may still go then.
                    if b.port.has_staged() {
                        b.port.set_load_latency(STAGED_LOAD_US);
                        let n = b.port.load_staged(now_us + STAGED_LOAD_US);
                        self.stats.staged_loads += n as u64;
                    }
                }
                b.mailboxes = pending;
                if b.wake_ns.min(b.event_ns) > t {
                    continue;
                }
                self.stats.ticks += 1;
                // The slot timer's tick, or else the short path of a transmit-complete or a
                // publish; each with its own time to the mailboxes.
                let short = b.wake_ns > t;
                b.event_ns = u64::MAX;
                let (mcu, slot_path_us) = (b.mcu, b.mcu.slot_path_us());
                let path_us = if short { mcu.top_up_path_us() } else { slot_path_us };
                b.port.set_load_latency(path_us);
                b.transmit_irq.on_call(t, path_us * NS_PER_US);
                // A slot tick loads a master's sync first, on a path of its own, and on
                // frame-sized reservations an HRT frame at its reservation's start too. A node
                // that takes over in the tick loads its first sync at the tick's end.
                let sync_us = |first| if b.node.is_master() { first } else { slot_path_us };
                b.port.set_reserved_latency(match (mode, short, b.node.wakes_on_transmit()) {
                    (Mode::Tdma, false, true) => {
                        let (hrt, sync) = mcu.framed_paths_us();
                        Some((hrt, sync_us(sync)))
                    }
                    (Mode::Tdma, false, false) => Some((slot_path_us, sync_us(mcu.sync_path_us()))),
                    _ => None,
                });
                let node = &mut b.node;
                let mut port = StalledPort::new(&mut b.port, b.stall.as_mut());
                let mut call = |c: &mut dyn CanController| match mode {
                    Mode::Tdma if short => node.top_up(now_us, c),
                    Mode::Tdma => node.slot_tick(now_us, c),
                    Mode::Poll { .. } => node.poll(now_us, c),
                };
                match &mut b.tap {
                    Some(tap) => tap.run(now_us, &mut port, &mut call),
                    None => call(&mut port),
                }
                let stalled_ns = port.stalled_ns();
                b.mailboxes = b.port.port().pending();
                if b.node.wakes_on_transmit() {
                    b.releases = b.node.releases_waiting();
                }
                b.wake_ns = match mode {
                    Mode::Tdma => {
                        let next_us = b.node.next_slot_at(now_us);
                        b.stuck_ticks = if next_us > now_us { 0 } else { b.stuck_ticks + 1 };
                        assert!(
                            b.stuck_ticks < STUCK_TICKS,
                            "board {i}: its slot timer asked {STUCK_TICKS} times in a row for \
                             {next_us} µs at {now_us} µs, no later than its tick: the node's \
                             `next_slot_at` does not move on (its MCU would busy-loop)"
                        );
                        (next_us * NS_PER_US).max(t + 1)
                    }
                    Mode::Poll { period_us } => t + period_us.max(1) * NS_PER_US,
                };
                b.hold_for(t, stalled_ns);
            }
            if let Some(resetter) = &mut self.resetter {
                for (i, b) in self.boards.iter_mut().enumerate() {
                    if let Some(r) = resetter(i, now_us) {
                        let port = b.port.port().index();
                        self.bus.power(port, false);
                        b.node = r.node;
                        b.app = r.app;
                        b.tap = r.tap;
                        let up = t + r.down_ns.max(1);
                        (b.down_until_ns, b.wake_ns, b.app_ns) = (Some(up), up, up);
                        b.event_ns = u64::MAX;
                        b.transmit_irq = TransmitIrq::default();
                    }
                }
            }
            if t >= t_ns {
                // Let frames loaded at the limit start, so a later run continues identically.
                break;
            }
        }
    }

    /// Runs for `dt_ns` more.
    pub fn run_for(&mut self, dt_ns: u64) {
        self.run_until(self.now_ns + dt_ns);
    }

    /// Runs in slices of `slice_ns` until `done(self)` or the time passes `limit_ns`; returns
    /// whether `done` held.
    pub fn run_while(
        &mut self,
        slice_ns: u64,
        limit_ns: u64,
        mut done: impl FnMut(&Self) -> bool,
    ) -> bool {
        while !done(self) {
            if self.now_ns >= limit_ns {
                return false;
            }
            self.run_for(slice_ns);
        }
        true
    }

    /// Writes the frames that went out on the bus as a candump log on `channel`; a frame's
    /// time is `epoch` plus its end of frame in virtual time (µs resolution in the file).
    pub fn write_candump<W: Write>(&self, out: W, channel: &str, epoch: Duration) -> io::Result<W> {
        write_candump(&self.bus, out, channel, epoch)
    }
}

/// The frames `bus` carried as canlink frames: (end of frame ns, sender port, frame).
pub fn bus_frames(bus: &Bus) -> Vec<(u64, usize, CanFrame)> {
    bus.frames()
        .map(|(t, p, f)| {
            let frame =
                CanFrame::extended(f.id().to_raw(), f.payload()).expect("29-bit, ≤ 8 bytes");
            (t, p, frame)
        })
        .collect()
}

/// The syncs that went out on `bus`: (start of frame ns, sender port), in order.
pub fn sync_starts(bus: &Bus) -> Vec<(u64, usize)> {
    bus.trace()
        .into_iter()
        .filter_map(|e| match e.kind {
            r2p_vbus::EventKind::Sent { start_ns, frame, .. }
                if rtcan::SyncFrame::from_frame(&frame).is_ok() =>
            {
                Some((start_ns, e.port))
            }
            _ => None,
        })
        .collect()
}

/// Writes `bus`'s frames as a candump log (see [`Sim::write_candump`]).
pub fn write_candump<W: Write>(bus: &Bus, out: W, channel: &str, epoch: Duration) -> io::Result<W> {
    let mut w = LogWriter::new(out, channel);
    for (t, _, frame) in bus_frames(bus) {
        w.write(&Stamped { time: epoch + Duration::from_nanos(t), frame })?;
    }
    w.flush()?;
    Ok(w.into_inner())
}

#[cfg(test)]
mod stuck_timer_tests {
    use super::*;

    /// A slot timer that asks for its own tick's µs again until `stuck_from_us`, then one µs on.
    struct Timer {
        stuck_from_us: Micros,
    }

    impl Runtime for Timer {
        fn poll(&mut self, _: Micros, _: &mut dyn CanController) {}
        fn slot_tick(&mut self, _: Micros, _: &mut dyn CanController) {}
        fn next_slot_at(&self, now: Micros) -> Micros {
            if now >= self.stuck_from_us {
                now
            } else {
                now + 1
            }
        }
    }

    #[test]
    fn a_slot_timer_that_never_moves_on_stops_the_sim_with_its_board() {
        let run = |stuck_from_us| {
            let mut sim = Sim::new(2, r2p_vbus::Config::default(), Mode::Tdma);
            sim.add_board(Timer { stuck_from_us: u64::MAX }, 0, None);
            sim.add_board(Timer { stuck_from_us }, 1, None);
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| sim.run_until(1_000_000)))
        };
        // A tick every µs is slow, not stuck.
        assert!(run(u64::MAX).is_ok());
        let err = run(500).expect_err("stuck from 500 µs");
        let msg = err.downcast_ref::<String>().expect("a formatted message");
        assert!(msg.starts_with("board 1: its slot timer asked 1000 times in a row"), "{msg}");
        assert!(msg.contains("`next_slot_at` does not move on"), "{msg}");
    }
}
