//! Runs one protocol over a load point's traffic on a fresh virtual bus, in virtual time.

use r2p_emu::SimPort;
use r2p_node::{FreeSlots, NodeConfig};
use r2p_vbus::{Bus, Config, Event, EventKind};

use crate::fixed_node::FixedNode;
use crate::record::{Counters, Sent};
use crate::rtcan_node::RtcanNode;
use crate::setup::Setup;
use crate::traffic::{Kind, Traffic};

/// How the nodes get frames onto the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Policy {
    /// RTCAN as the node runtime runs it by default (`NodeConfig::new(..).free_slots`).
    Rtcan,
    /// RTCAN, one one-shot frame per free slot (`FreeSlots::Single`).
    RtcanOneShot,
    /// RTCAN, free slots merged into windows with retransmission (`FreeSlots::Merged`).
    RtcanMerged,
    /// What-if (issue 22's capacity): reservations as long as their frames, laid out in blocks
    /// (`rtcan::layout`); between them merged windows (`rtcan::framed_cycle`, the node
    /// runtime's rule), in which each node loads the most urgent frames that still fit
    /// (`SlotTx::fitted`), at release and whenever one of its frames ends, not only at slot
    /// boundaries.
    RtcanFramed,
    /// Plain fixed-priority CAN, rate-monotonic identifiers: the baseline.
    Fixed,
}

impl Policy {
    /// Every policy, in report order.
    pub const ALL: [Policy; 5] = [
        Policy::Rtcan,
        Policy::RtcanOneShot,
        Policy::RtcanMerged,
        Policy::RtcanFramed,
        Policy::Fixed,
    ];

    /// The sweep's default: the node runtime's default, its other free-slot policy, the
    /// frame-sized what-if and the baseline (the policy equal to the default is left out: it
    /// would repeat `rtcan`).
    pub fn defaults() -> Vec<Policy> {
        let repeats = |p: Policy| {
            p != Policy::Rtcan
                && p != Policy::RtcanFramed
                && p.free_slots() == Some(DEFAULT_FREE_SLOTS)
        };
        Self::ALL.into_iter().filter(|&p| !repeats(p)).collect()
    }

    /// Its name in reports.
    pub const fn name(self) -> &'static str {
        match self {
            Policy::Rtcan => "rtcan",
            Policy::RtcanOneShot => "rtcan_oneshot",
            Policy::RtcanMerged => "rtcan_merged",
            Policy::RtcanFramed => "rtcan_framed",
            Policy::Fixed => "fixed",
        }
    }

    /// The policy called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// The RTCAN nodes' free-slot policy (`None`: fixed priority).
    pub const fn free_slots(self) -> Option<FreeSlots> {
        match self {
            Policy::Rtcan => Some(DEFAULT_FREE_SLOTS),
            Policy::RtcanOneShot => Some(FreeSlots::Single),
            Policy::RtcanMerged | Policy::RtcanFramed => Some(FreeSlots::Merged),
            Policy::Fixed => None,
        }
    }
}

/// The node runtime's default free-slot policy.
const DEFAULT_FREE_SLOTS: FreeSlots = NodeConfig::new([0; 12], "").free_slots;

/// What a run produced: the bus's event log and each node's account of it.
pub struct Run {
    /// The policy.
    pub policy: Policy,
    /// The bus's event log.
    pub trace: Vec<Event>,
    /// Per node: the frames its port sent, in order (matches the log's `Sent` events).
    pub sent: Vec<Vec<Sent>>,
    /// The nodes' counters, summed.
    pub counters: Counters,
    /// Simulation events: node activations, frames on the bus (start and end), releases.
    pub events: u64,
    /// Frame-sized reservations ([`Policy::RtcanFramed`]): per message, its HRT reservation's
    /// start and end, µs (where its frame is due; 0s for other messages). Otherwise HRT
    /// frames are due at their release, their grid slot's start.
    pub reservations: Option<Vec<(u64, u64)>>,
}

/// Runs `policy` over `traffic`.
pub fn run(setup: &Setup, traffic: &Traffic, policy: Policy) -> Run {
    let config = Config { bit_rate: setup.cycle.bit_rate, rx_depth: 8, seed: setup.seed };
    let bus = Bus::new(setup.nodes, config);
    let stop_ns = setup.stop_us() * 1_000;
    let (sent, counters): (Vec<Vec<Sent>>, Vec<Counters>) = match policy.free_slots() {
        Some(free_slots) => {
            let framed = policy == Policy::RtcanFramed;
            let mut nodes: Vec<RtcanNode> = (0..setup.nodes)
                .map(|i| {
                    let port = SimPort::new(bus.port(i), setup.cycle.bit_rate);
                    RtcanNode::new(traffic, setup, i, port, free_slots, framed)
                })
                .collect();
            loop {
                // The nodes' slot timers (slot boundaries, latest starts); the bus runs
                // everything due up to then. Framed: also every frame's start and end on the
                // bus, which each node's interrupt reacts to (`RtcanNode::on_bus_event`).
                let timers = nodes.iter().map(|n| n.next_wake() * 1_000).min().expect("nodes");
                let bus_event = if framed { bus.next_event() } else { None };
                let t = bus_event.map_or(timers, |b| b.min(timers));
                if t > stop_ns {
                    break;
                }
                bus.advance_to(t);
                for node in nodes.iter_mut() {
                    if bus_event == Some(t) {
                        node.on_bus_event(t / 1_000);
                    }
                    if node.next_wake() * 1_000 <= t {
                        node.wake(t / 1_000);
                    }
                }
            }
            nodes.into_iter().map(|n| (n.sent, n.counters)).unzip()
        }
        None => {
            let mut nodes: Vec<FixedNode> =
                (0..setup.nodes).map(|i| FixedNode::new(traffic, setup, i, bus.port(i))).collect();
            let mut releases = traffic.messages.iter().map(|m| m.release_us * 1_000).peekable();
            loop {
                while releases.next_if(|&r| r < bus.now()).is_some() {}
                let next_release = releases.peek().copied().unwrap_or(u64::MAX);
                let t = bus.next_event().map_or(next_release, |b| b.min(next_release));
                if t > stop_ns {
                    break;
                }
                bus.advance_to(t);
                while releases.next_if(|&r| r <= t).is_some() {}
                nodes.iter_mut().for_each(|n| n.service(t));
                if bus.next_event() == Some(t) {
                    bus.advance_to(t); // frames loaded now start now
                }
            }
            nodes.into_iter().map(|n| (n.sent, n.counters)).unzip()
        }
    };
    let trace = bus.trace();
    let mut total = Counters::default();
    counters.into_iter().for_each(|c| total += c);
    let frames = trace.iter().filter(|e| matches!(e.kind, EventKind::Sent { .. })).count() as u64;
    let events = total.activations + 2 * frames + traffic.messages.len() as u64;
    let reservations = (policy == Policy::RtcanFramed).then(|| {
        let cycle_us = u64::from(setup.cycle.cycle_us);
        traffic
            .messages
            .iter()
            .map(|m| {
                let Kind::Hrt { framed, .. } = traffic.streams[usize::from(m.stream)].kind else {
                    return (0, 0);
                };
                let cycle = traffic.framed_cycle(m).expect("an HRT message");
                let r = traffic.layout.span(framed.slot).expect("its slot is placed");
                let c0 = u64::from(cycle) * cycle_us;
                (c0 + u64::from(r.start_us), c0 + u64::from(r.end_us()))
            })
            .collect()
    });
    Run { policy, trace, sent, counters: total, events, reservations }
}
