//! The experiment's parameters: one load point of the sweep.

use rtcan::layout::Layout;
use rtcan::{CycleConfig, LaxityEncoding};

/// Frames a node's transmit queue holds (the demo boards' `TxQueue<32>`); the loaded frame
/// counts until it is confirmed.
pub const TX_QUEUE: usize = 32;

/// How the offered load is split between the classes (NRT fills the rest exactly).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mix {
    /// Share of HRT traffic (periodic control streams), 0–1.
    pub hrt: f64,
    /// Share of SRT traffic (events with deadlines), 0–1; NRT gets `1 − hrt − srt`.
    pub srt: f64,
}

/// One load point: the bus, the nodes and the traffic to offer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setup {
    /// Offered load as a fraction of the bit rate (bits on the wire, stuffing and
    /// intermission included), e.g. 0.9.
    pub load: f64,
    /// Seed of the traffic generator (streams, arrivals, deadlines, payloads).
    pub seed: u64,
    /// Nodes on the bus; node 0 is the RTCAN master.
    pub nodes: usize,
    /// The RTCAN cycle (also fixes the bit rate of both protocols).
    pub cycle: CycleConfig,
    /// Slots the master may reserve for HRT streams (`rtcan::Scheduler` lays them out).
    pub hrt_slots: u8,
    /// `rtcan_framed` (what-if): blocks the frame-sized reservations are laid out in, evenly
    /// spaced over the cycle ([`rtcan::layout`]; 1 … [`rtcan::layout::MAX_BLOCKS`]).
    pub hrt_blocks: u8,
    /// SRT laxity encoding (the node runtime's default: logarithmic, 100 µs ticks).
    pub laxity: LaxityEncoding,
    /// `rtcan_framed` (what-if): laxity code steps a loaded frame may lag and stay loaded
    /// (`r2p_node::SlotTx::laxity_drift`; the node runtime's: 0).
    pub laxity_drift: u8,
    /// `rtcan_framed` (what-if): µs from one of a node's frames leaving its mailbox, and from
    /// a message's release, to the node's short path loading its next frames (the node
    /// runtime's as measured: [`crate::rtcan_node::TRANSMIT_REACTION_US`] and
    /// [`crate::rtcan_node::RELEASE_REACTION_US`]).
    pub reactions_us: (u64, u64),
    /// What-if for both protocols' traffic: HRT payloads that need no stuff bits (0x55 …) and
    /// frame-sized reservations as long as those frames exactly, so no reservation has slack
    /// after its frame: the bound a layout that let HRT frames follow each other as their
    /// lengths allow (jitter up to the stuff bits of the frames before) would approach.
    pub hrt_exact: bool,
    /// `rtcan_framed` with staged reloads (r2p-node's and rtcan-bxcan's `staged-reloads`): the
    /// transmit interrupt loads the frames the node staged (`r2p_node::SlotTx::staging`)
    /// [`crate::rtcan_node::STAGED_LOAD_US`] after the controller empties
    /// (`r2p_vbus::BxCanPort::load_staged`).
    pub staged: bool,
    /// `rtcan_framed` what-if: HRT frames follow each other as their actual lengths allow. A
    /// node whose HRT reservation starts where another's ends loads its frame
    /// [`rtcan::framed_cycle::FOLLOW_US`] after that one's start, when that frame is on the
    /// wire: it goes at that frame's actual end, early by the stuff bits the frames before it
    /// in the run did not need (a bounded start jitter), and still ends by its own
    /// reservation's end.
    pub hrt_follow: bool,
    /// Class shares of the offered load.
    pub mix: Mix,
    /// SRT streams per node.
    pub srt_streams_per_node: usize,
    /// SRT relative deadlines are drawn uniformly from this range (µs), one per stream.
    pub srt_deadline_us: (u32, u32),
    /// Messages a stream's publisher queue holds before publishing fails (a middleware remote
    /// subscriber's queue); the message is then lost.
    pub backlog: usize,
    /// Warm-up before traffic starts (the slaves lock on the master's syncs), µs.
    pub warmup_us: u64,
    /// Length of the measured window in which traffic is released, µs.
    pub duration_us: u64,
    /// Time after the window for the last messages to complete (longer than any deadline), µs.
    pub drain_us: u64,
}

impl Setup {
    /// The sweep's defaults at offered load `load`: 8 nodes, 1 Mbit/s, 5 ms cycles of 30 slots
    /// (166 µs, the same slot length as the 10 ms / 60-slot default, so that 200 Hz control
    /// loops fit a 1-cycle period), up to 15 HRT slots, logarithmic laxity with 100 µs ticks,
    /// 30 % HRT / 50 % SRT / 20 % NRT, 4 SRT streams per node with deadlines of 2–20 ms, 10 s.
    pub fn new(load: f64, seed: u64) -> Self {
        Self {
            load,
            seed,
            nodes: 8,
            cycle: CycleConfig { bit_rate: 1_000_000, cycle_us: 5_000, slots: 30 },
            hrt_slots: 15,
            hrt_blocks: 2,
            laxity: LaxityEncoding::Logarithmic { tick_us: 100 },
            laxity_drift: 0,
            reactions_us: (
                crate::rtcan_node::TRANSMIT_REACTION_US,
                crate::rtcan_node::RELEASE_REACTION_US,
            ),
            hrt_exact: false,
            staged: false,
            hrt_follow: false,
            mix: Mix { hrt: 0.3, srt: 0.5 },
            srt_streams_per_node: 4,
            srt_deadline_us: (2_000, 20_000),
            backlog: 16,
            warmup_us: 20_000,
            duration_us: 10_000_000,
            drain_us: 40_000,
        }
    }

    /// Checks what the generator and the simulation rely on.
    pub fn validate(&self) -> Result<(), SetupError> {
        if !(self.load > 0.0 && self.load <= 1.0) {
            return Err(SetupError::Load(self.load));
        }
        if self.nodes < 2 {
            return Err(SetupError::Nodes(self.nodes));
        }
        self.cycle.validate().map_err(SetupError::Cycle)?;
        if self.hrt_slots == 0 || self.hrt_slots >= self.cycle.slots {
            return Err(SetupError::HrtSlots(self.hrt_slots));
        }
        self.layout()?;
        let m = self.mix;
        if !(m.hrt >= 0.0 && m.srt > 0.0 && m.hrt + m.srt <= 1.0) {
            return Err(SetupError::Mix(m));
        }
        let (lo, hi) = self.srt_deadline_us;
        if lo == 0 || lo > hi || u64::from(hi) >= self.drain_us {
            return Err(SetupError::Deadlines(self.srt_deadline_us));
        }
        if self.srt_streams_per_node == 0 || self.backlog == 0 || self.duration_us == 0 {
            return Err(SetupError::Empty);
        }
        Ok(())
    }

    /// The frame-sized calendar's empty layout: `hrt_blocks` blocks which together may hold
    /// as much time as `hrt_slots` grid slots.
    pub fn layout(&self) -> Result<Layout, SetupError> {
        Layout::for_hrt_slots(self.cycle, self.hrt_blocks, self.hrt_slots)
            .map_err(|_| SetupError::HrtBlocks(self.hrt_blocks))
    }

    /// Bit time in ns.
    pub fn bit_ns(&self) -> u64 {
        1_000_000_000 / u64::from(self.cycle.bit_rate)
    }

    /// First µs of the measured window.
    pub fn start_us(&self) -> u64 {
        self.warmup_us
    }

    /// End (exclusive) of the measured window, µs.
    pub fn end_us(&self) -> u64 {
        self.warmup_us + self.duration_us
    }

    /// When the simulation stops, µs.
    pub fn stop_us(&self) -> u64 {
        self.end_us() + self.drain_us
    }

    /// Bit times in the measured window: the denominator of every load figure.
    pub fn capacity_bits(&self) -> f64 {
        self.duration_us as f64 * f64::from(self.cycle.bit_rate) / 1e6
    }
}

/// Why a [`Setup`] cannot be run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SetupError {
    /// The offered load must be in (0, 1].
    Load(f64),
    /// At least two nodes (one to send, one to acknowledge).
    Nodes(usize),
    /// The RTCAN cycle is invalid.
    Cycle(rtcan::cycle::ConfigError),
    /// HRT slots must be 1 … slots − 1.
    HrtSlots(u8),
    /// HRT blocks must be 1 … `rtcan::layout::MAX_BLOCKS`, each with room for its share.
    HrtBlocks(u8),
    /// Class shares must be non-negative, SRT positive, summing to at most 1.
    Mix(Mix),
    /// The deadline range must be positive, ordered and shorter than the drain time.
    Deadlines((u32, u32)),
    /// No SRT streams, no backlog or no time.
    Empty,
}

impl core::fmt::Display for SetupError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Load(l) => {
                write!(f, "offered load {l} is outside (0, 1]: pass a fraction like 0.9")
            }
            Self::Nodes(n) => write!(f, "{n} node(s): the bus needs at least 2"),
            Self::Cycle(e) => write!(f, "invalid RTCAN cycle: {e:?}"),
            Self::HrtSlots(s) => {
                write!(f, "hrt_slots = {s}: use 1 … slots − 1")
            }
            Self::HrtBlocks(b) => write!(
                f,
                "hrt_blocks = {b}: use 1 … {} (each block must hold its share of hrt_slots' time)",
                rtcan::layout::MAX_BLOCKS
            ),
            Self::Mix(m) => write!(f, "class mix {m:?}: shares must be ≥ 0, SRT > 0, sum ≤ 1"),
            Self::Deadlines(d) => {
                write!(f, "SRT deadlines {d:?} µs: need 0 < low ≤ high < drain time")
            }
            Self::Empty => write!(f, "no SRT streams, no backlog or no duration"),
        }
    }
}
