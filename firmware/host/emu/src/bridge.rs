//! Real-time mode: an emulated bus that real CAN tools can join.
//!
//! A [`Bridge`] paces a [`Sim`] against the wall clock (virtual time follows the real time
//! elapsed since the start, advanced in steps of about 1 ms) and connects the virtual bus to an
//! [`r2p_canlink::Hub`] (e.g. a [`r2p_canlink::BroadcastHub`] with a socketcand
//! [`r2p_canlink::Server`] on it) as one participant:
//!
//! - **Virtual bus → hub.** The bridge owns a spare port of the virtual bus, a listening node
//!   like a CAN adapter on a real bus (it acknowledges frames, and it misses a frame that
//!   fault injection drops for it or every receiver, or that another bus segment carries). Every
//!   frame it receives is sent to the hub as an extended (29-bit) frame. The port's receive
//!   FIFO is drained after every sub-step short enough that it cannot overflow at full bus load
//!   (overflows would still be counted). (The bus's event log, [`Bus::trace`], is not used:
//!   it is copied whole on every call, which grows without bound in a long real-time run.)
//! - **Hub → virtual bus.** Frames from the hub's other participants (socketcand clients) are
//!   queued (at most [`BACKLOG`]) and loaded into the bridge port's own mailboxes
//!   (`try_transmit`) at the current virtual time, so they arbitrate with the boards' frames.
//!   Frames that find the backlog full are counted in [`BridgeStats::not_queued`]. The bridge
//!   port does not receive its own frames, so they are not echoed back to the hub (the hub has
//!   delivered them to the other clients already).
//! - **Standard identifiers.** The virtual bus, like RTCAN, carries extended (29-bit) frames
//!   only: standard-ID (11-bit) frames from tools are counted in
//!   [`BridgeStats::standard_dropped`] and dropped, not injected.
//!
//! If the host cannot keep up, virtual time falls behind and catches up at the next step (the
//! largest lag is in [`BridgeStats::max_lag_us`]); virtual time never runs ahead of real time.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};

use r2p_canlink::{CanFrame, Hub, ParticipantId, Subscription};
use r2p_vbus::bits::FrameBits;
use r2p_vbus::{Bus, Port};
use rtcan::{CanController, Frame};

use crate::{Runtime, Sim};

/// Frames from the hub waiting for a free mailbox of the bridge port.
pub const BACKLOG: usize = 256;
/// Real-time pacing step.
pub const STEP: Duration = Duration::from_millis(1);

/// The frame a tool sees for an RTCAN frame (29-bit extended identifier).
pub fn to_canlink(frame: &Frame) -> CanFrame {
    CanFrame::extended(frame.id().to_raw(), frame.payload()).expect("29-bit, ≤ 8 bytes")
}

/// The RTCAN frame for a tool's frame; `None` for a standard (11-bit) identifier, which the
/// virtual bus does not carry.
pub fn from_canlink(frame: &CanFrame) -> Option<Frame> {
    if !frame.is_extended() {
        return None;
    }
    Frame::from_raw(frame.id(), frame.data()).ok()
}

/// Counters of a bridge.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BridgeStats {
    /// Frames of the virtual bus sent to the hub.
    pub to_hub: u64,
    /// Frames from the hub loaded into the bridge port's mailboxes.
    pub injected: u64,
    /// Standard-ID frames from the hub, dropped.
    pub standard_dropped: u64,
    /// Frames from the hub dropped because the backlog was full (or the port was bus-off).
    pub not_queued: u64,
    /// Largest lag of virtual time behind real time seen after a step, µs.
    pub max_lag_us: u64,
}

/// Connects a [`Sim`]'s virtual bus to a [`Hub`] through a spare port. See the module
/// documentation.
pub struct Bridge {
    bus: Bus,
    port: Port,
    hub: Arc<dyn Hub>,
    me: ParticipantId,
    sub: Subscription,
    backlog: VecDeque<Frame>,
    /// Longest sub-step (ns) after which the port's FIFO is drained.
    tap_ns: u64,
    stats: BridgeStats,
}

impl Bridge {
    /// A bridge between `sim`'s bus, through port `port` (no board may use it), and `hub`,
    /// receiving through a hub queue of `queue` frames.
    pub fn new<N: Runtime>(sim: &Sim<'_, N>, port: usize, hub: Arc<dyn Hub>, queue: usize) -> Self {
        assert!((0..sim.boards()).all(|i| sim.port_of(i) != port), "port {port} has a board");
        let bus = sim.bus().clone();
        let config = bus.config();
        // At most `rx_depth - 1` shortest frames (74 bits) end within one sub-step.
        let bit_ns = 1_000_000_000 / u64::from(config.bit_rate);
        let shortest = u64::from(FrameBits::of(&Frame::from_raw(0, &[]).expect("empty")).total());
        let tap_ns =
            (config.rx_depth.saturating_sub(1).max(1) as u64 * shortest * bit_ns).min(1_000_000);
        let me = hub.join();
        let sub = hub.subscribe(me, queue);
        Self {
            port: bus.port(port),
            bus,
            hub,
            me,
            sub,
            backlog: VecDeque::new(),
            tap_ns,
            stats: BridgeStats::default(),
        }
    }

    /// The bridge's vbus port index.
    pub fn port(&self) -> usize {
        self.port.index()
    }

    /// Counters so far.
    pub fn stats(&self) -> BridgeStats {
        self.stats
    }

    /// Frames the bridge port lost to a full receive FIFO (not expected; see the module docs).
    pub fn overflows(&self) -> u64 {
        self.bus.overflows(self.port.index())
    }

    /// Takes the hub's frames and loads as many as the port's mailboxes hold.
    fn inject(&mut self) {
        while let Ok(s) = self.sub.try_recv() {
            match from_canlink(&s.frame) {
                None => self.stats.standard_dropped += 1,
                Some(_) if self.backlog.len() >= BACKLOG => self.stats.not_queued += 1,
                Some(f) => self.backlog.push_back(f),
            }
        }
        // The port sends its mailboxes in load order (`TxOrder::Loaded`), so a message's
        // fragments leave in order, as a SocketCAN interface sends a socket's frames.
        while let Some(f) = self.backlog.front() {
            match self.port.try_transmit(f) {
                Ok(()) => {
                    self.backlog.pop_front();
                    self.stats.injected += 1;
                }
                Err(rtcan::controller::TxError::MailboxesFull) => break,
                Err(_) => {
                    // Bus-off or powered off: the frame cannot be queued.
                    self.backlog.pop_front();
                    self.stats.not_queued += 1;
                }
            }
        }
    }

    /// Sends the frames the port received to the hub.
    fn forward(&mut self) {
        while let Some(r) = self.port.try_receive() {
            self.hub.send(self.me, to_canlink(&r.frame));
            self.stats.to_hub += 1;
        }
    }

    /// Runs `sim` until virtual time `t_ns`, exchanging frames with the hub along the way.
    pub fn run_until<N: Runtime>(&mut self, sim: &mut Sim<'_, N>, t_ns: u64) {
        loop {
            self.inject();
            let next = (sim.now_ns() + self.tap_ns).min(t_ns);
            sim.run_until(next);
            self.forward();
            if sim.now_ns() >= t_ns {
                break;
            }
        }
    }

    /// Runs `sim` in real time from `start` (virtual time 0 = `start`) until `stop()` returns
    /// true (checked every step) or `limit` of real time has passed (then virtual time ends at
    /// exactly `limit`).
    pub fn run_realtime<N: Runtime>(
        &mut self,
        sim: &mut Sim<'_, N>,
        start: Instant,
        limit: Option<Duration>,
        stop: impl FnMut() -> bool,
    ) {
        self.run_realtime_with(sim, start, limit, &[], stop);
    }

    /// [`Bridge::run_realtime`], powering board `i` off at virtual time `t` for each `(t, i)`
    /// of `power_off` (fault injection while tools watch: a module that dies on the bus).
    pub fn run_realtime_with<N: Runtime>(
        &mut self,
        sim: &mut Sim<'_, N>,
        start: Instant,
        limit: Option<Duration>,
        power_off: &[(Duration, usize)],
        mut stop: impl FnMut() -> bool,
    ) {
        let limit_ns = limit.map_or(u64::MAX, |l| l.as_nanos() as u64);
        let mut offs: Vec<(u64, usize)> =
            power_off.iter().map(|(t, i)| (t.as_nanos() as u64, *i)).collect();
        offs.sort_unstable();
        let mut offs = offs.into_iter().peekable();
        loop {
            let target = (start.elapsed().as_nanos() as u64).min(limit_ns);
            if target > sim.now_ns() {
                while let Some((t, i)) = offs.next_if(|(t, _)| *t <= target) {
                    if t > sim.now_ns() {
                        self.run_until(sim, t);
                    }
                    sim.power(i, false);
                }
                if target > sim.now_ns() {
                    self.run_until(sim, target);
                }
            }
            let lag =
                (start.elapsed().as_nanos() as u64).min(limit_ns).saturating_sub(sim.now_ns());
            self.stats.max_lag_us = self.stats.max_lag_us.max(lag / 1_000);
            if sim.now_ns() >= limit_ns || stop() {
                break;
            }
            // Sleep to the next step boundary of real time.
            let elapsed = start.elapsed();
            let step = STEP.as_nanos() as u64;
            let next = Duration::from_nanos((elapsed.as_nanos() as u64 / step + 1) * step);
            std::thread::sleep(next.saturating_sub(elapsed));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Mode;
    use r2p_canlink::BroadcastHub;
    use r2p_vbus::Config;
    use rtcan::Micros;

    /// Sends one frame per poll, counts what it receives.
    struct Talker {
        sent: u32,
        got: Vec<Frame>,
    }

    impl Runtime for Talker {
        fn poll(&mut self, _: Micros, can: &mut dyn CanController) {
            while let Some(r) = can.try_receive() {
                self.got.push(r.frame);
            }
            if can
                .try_transmit(&Frame::from_raw(0x1234_5678, &self.sent.to_be_bytes()).unwrap())
                .is_ok()
            {
                self.sent += 1;
            }
        }
        fn slot_tick(&mut self, _: Micros, _: &mut dyn CanController) {}
        fn next_slot_at(&self, now: Micros) -> Micros {
            now + 1
        }
    }

    #[test]
    fn frames_cross_both_ways_and_standard_ids_are_dropped() {
        let mut sim = Sim::new(2, Config::default(), Mode::Poll { period_us: 1_000 });
        sim.add_board(Talker { sent: 0, got: Vec::new() }, 0, None);
        let hub = Arc::new(BroadcastHub::new());
        let mut bridge = Bridge::new(&sim, 1, hub.clone(), 64);
        let tool = hub.join();
        let rx = hub.subscribe(tool, 1024);
        hub.send(tool, CanFrame::extended(0x1ABC_0000, &[7]).unwrap());
        hub.send(tool, CanFrame::standard(0x123, &[1]).unwrap());
        bridge.run_until(&mut sim, 10_000_000);

        let got: Vec<_> = std::iter::from_fn(|| rx.try_recv().ok()).collect();
        assert_eq!(got.len(), 10, "one frame per ms");
        assert!(got.iter().all(|s| s.frame.is_extended() && s.frame.id() == 0x1234_5678));
        assert_eq!(got[3].frame.data(), &3u32.to_be_bytes());
        let s = bridge.stats();
        assert_eq!((s.to_hub, s.injected, s.standard_dropped, s.not_queued), (10, 1, 1, 0));
        assert_eq!(sim.node(0).got, vec![Frame::from_raw(0x1ABC_0000, &[7]).unwrap()]);
        assert_eq!(bridge.overflows(), 0);
    }

    #[test]
    fn a_tools_fragments_reach_the_bus_in_the_order_sent() {
        // A message's fragments count down: later fragments have lower identifiers and would
        // win arbitration against earlier ones if loaded together.
        let mut sim = Sim::new(2, Config::default(), Mode::Poll { period_us: 1_000 });
        sim.add_board(Talker { sent: 0, got: Vec::new() }, 0, None);
        let hub = Arc::new(BroadcastHub::new());
        let mut bridge = Bridge::new(&sim, 1, hub.clone(), 64);
        let tool = hub.join();
        let ids = [0x1FA8_0003u32, 0x1FA8_0002, 0x1FA8_0001, 0x1FA8_0000];
        for id in ids {
            hub.send(tool, CanFrame::extended(id, &[1, 2]).unwrap());
        }
        bridge.run_until(&mut sim, 10_000_000);
        let from_tool: Vec<u32> =
            sim.bus().frames().filter(|f| f.1 == 1).map(|f| f.2.id().to_raw()).collect();
        assert_eq!(from_tool, ids);
    }

    #[test]
    fn conversions() {
        let f = Frame::from_raw(0x1FA8_0003, &[0x11, 0]).unwrap();
        let c = to_canlink(&f);
        assert!(c.is_extended());
        assert_eq!((c.id(), c.data()), (0x1FA8_0003, &[0x11, 0][..]));
        assert_eq!(from_canlink(&c), Some(f));
        assert_eq!(from_canlink(&CanFrame::standard(0x7FF, &[]).unwrap()), None);
    }

    #[test]
    fn realtime_follows_the_wall_clock() {
        let mut sim = Sim::new(2, Config::default(), Mode::Poll { period_us: 1_000 });
        sim.add_board(Talker { sent: 0, got: Vec::new() }, 0, None);
        let mut bridge = Bridge::new(&sim, 1, Arc::new(BroadcastHub::new()), 64);
        let start = Instant::now();
        bridge.run_realtime(&mut sim, start, Some(Duration::from_millis(100)), || false);
        let wall = start.elapsed();
        assert_eq!(sim.now_ns(), 100_000_000);
        assert!(wall >= Duration::from_millis(100), "{wall:?}");
        assert_eq!(bridge.stats().to_hub, 100);
    }

    #[test]
    fn a_board_powered_off_at_a_time_says_nothing_after_it() {
        let mut sim = Sim::new(2, Config::default(), Mode::Poll { period_us: 1_000 });
        sim.add_board(Talker { sent: 0, got: Vec::new() }, 0, None);
        let mut bridge = Bridge::new(&sim, 1, Arc::new(BroadcastHub::new()), 64);
        let off = [(Duration::from_millis(30), 0)];
        bridge.run_realtime_with(
            &mut sim,
            Instant::now(),
            Some(Duration::from_millis(60)),
            &off,
            || false,
        );
        assert_eq!(sim.now_ns(), 60_000_000);
        let sent = bridge.stats().to_hub;
        assert!((29..=31).contains(&sent), "one frame a millisecond for 30 ms: {sent}");
    }
}
