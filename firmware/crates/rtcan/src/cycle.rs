//! The communication cycle: configuration, slot timing, the sync frame and the slave's clock.
//!
//! The master sends a sync frame at the start of every cycle; the cycle is cut into `slots`
//! equal slots (slot 0 carries the sync). The sync's payload is the reservation mask of the
//! *next* cycle: bit k set = slot k is reserved for an HRT frame. Every node re-phases its
//! [`SlotClock`] on each sync it receives, and free-runs on its period estimate for at most
//! [`FREE_RUN_CYCLES`] cycles when syncs are missing (docs/rtcan.md, "Communication cycle").
//!
//! # Slot length
//! A slot must hold the longest frame RTCAN sends — a CAN 2.0B extended data frame with 8 data
//! bytes and worst-case bit stuffing — plus the interframe space:
//!
//! ```text
//! stuffable SOF..CRC : 1 SOF + 11 base ID + 1 SRR + 1 IDE + 18 ext ID + 1 RTR + 2 r1,r0
//!                      + 4 DLC + 64 data + 15 CRC                         = 118 bits
//! stuff bits         : first after 5 equal bits, then (worst case) every 4: ⌊(118−1)/4⌋ = 29
//! fixed tail         : 1 CRC delimiter + 2 ACK slot/delimiter + 7 EOF        = 10 bits
//! interframe space   : 3 bits                                              =  3 bits
//! total              : 118 + 29 + 10 + 3                                   = 160 bit times
//! ```
//! Slot boundaries fall on whole microseconds: slot k starts ⌈k·cycle/slots⌉ µs after the
//! cycle's start, so the shortest slot lasts ⌊cycle/slots⌋ µs; a configuration is valid only if
//! that is at least [`WORST_CASE_FRAME_BITS`] bit times.

use crate::controller::Micros;
use crate::frame::Frame;
use crate::id::FrameId;

/// Default bit rate: 1 Mbit/s.
pub const DEFAULT_BIT_RATE: u32 = 1_000_000;
/// Highest bit rate of classic CAN.
pub const MAX_BIT_RATE: u32 = 1_000_000;
/// Default cycle length: 10 ms (100 Hz syncs).
pub const DEFAULT_CYCLE_US: u32 = 10_000;
/// Default slot count: 60 slots of 166–167 µs (the most that fit 160 bit times in 10 ms at 1 Mbit/s
/// with a round number).
pub const DEFAULT_SLOTS: u8 = 60;
/// Most slots per cycle: one reservation bit per slot in the 8-byte sync payload.
pub const MAX_SLOTS: u8 = 64;
/// Fewest slots per cycle: the sync slot and one more.
pub const MIN_SLOTS: u8 = 2;
/// The slot that carries the sync frame; it is always reserved.
pub const SYNC_SLOT: u8 = 0;

/// Bits of an 8-byte extended data frame exposed to bit stuffing (SOF up to the CRC sequence).
pub const STUFFABLE_BITS: u32 = 1 + 11 + 1 + 1 + 18 + 1 + 2 + 4 + 64 + 15;
/// Worst-case stuff bits in [`STUFFABLE_BITS`]: ⌊(118 − 1) / 4⌋.
pub const MAX_STUFF_BITS: u32 = (STUFFABLE_BITS - 1) / 4;
/// Unstuffed tail of a frame: CRC delimiter, ACK slot and delimiter, end of frame.
pub const FRAME_TAIL_BITS: u32 = 1 + 2 + 7;
/// Interframe space (intermission) before the next frame may start.
pub const INTERFRAME_BITS: u32 = 3;
/// Worst-case bit times of one 8-byte extended data frame plus interframe space: 160.
pub const WORST_CASE_FRAME_BITS: u32 =
    STUFFABLE_BITS + MAX_STUFF_BITS + FRAME_TAIL_BITS + INTERFRAME_BITS;

/// Worst-case bit times of an extended data frame with `len` data bytes plus interframe space:
/// its stuffable bits, ⌊(stuffable − 1)/4⌋ stuff bits, the tail and the intermission.
/// `frame_bits(8)` is [`WORST_CASE_FRAME_BITS`].
pub const fn frame_bits(len: usize) -> u32 {
    let stuffable = STUFFABLE_BITS - 64 + 8 * len as u32;
    stuffable + (stuffable - 1) / 4 + FRAME_TAIL_BITS + INTERFRAME_BITS
}

/// Bits of an extended data frame from SOF to the DLC, the part its identifier and length fix:
/// SOF, base ID 11, SRR, IDE, extended ID 18, RTR, r1, r0, DLC 4.
pub const HEADER_BITS: u32 = 1 + 11 + 1 + 1 + 18 + 1 + 2 + 4;

/// Worst-case bit times of a frame with identifier `raw_id` (29 bits) and `len` data bytes,
/// intermission included, for a sender that knows the identifier: the header's stuff bits
/// exactly, then the worst case for the data and CRC after the header's last run of `r` equal
/// bits — a stuff bit after 5 − `r` more, then one every 4. At most [`frame_bits`]`(len)`.
pub const fn frame_bits_of(raw_id: u32, len: usize) -> u32 {
    // The header, first bit at the top: SOF 0, base ID, SRR 1, IDE 1, extended ID, RTR 0,
    // r1 0, r0 0, DLC (disjoint fields, so a sum).
    let header: u64 = ((raw_id as u64 >> 18 & 0x7ff) << 27)
        + (0b11 << 25)
        + ((raw_id as u64 & 0x3ffff) << 7)
        + (len as u64 & 0xf);
    // Ten nibbles, left-aligned: a recessive idle bit, then the 39 header bits. The idle bit
    // leaves the state the bus had before SOF (SOF starts a run whatever came before), and
    // makes the header a whole number of nibbles. A constant shift per nibble (a variable
    // 64-bit shift is a dozen Cortex-M3 instructions): 66 instructions a call on a Cortex-M3
    // (QEMU), 363 bit by bit.
    let mut window = ((1 << HEADER_BITS) | header) << (64 - HEADER_BITS - 1);
    let (mut state, mut stuff, mut i) = (STUFF_IDLE, 0u32, 0);
    while i < (HEADER_BITS + 1) / 4 {
        let step = NIBBLE_STUFFING[((state as usize) << 4) | (window >> 60) as usize];
        window <<= 4;
        stuff += (step >> 3) as u32;
        state = step & 7;
        i += 1;
    }
    let run = (state & 3) as u32 + 1;
    // Data and CRC: 1 + ⌊(rest − (5 − run))/4⌋ stuff bits at most (rest ≥ 15 > 5 − run).
    let rest = 8 * len as u32 + 15;
    let rest_stuff = (rest + run - 1) / 4;
    HEADER_BITS + rest + stuff + rest_stuff + FRAME_TAIL_BITS + INTERFRAME_BITS
}

/// The bit stuffer's state: the level of the current run (bit 2) and its length less one
/// (bits 0–1: a run of 5 is stuffed, so 1 to 4).
type StuffState = u8;

/// The stuffer's state on an idle (recessive) bus.
const STUFF_IDLE: StuffState = 0b100;

/// One bit through the stuffer from `state`: the new state and whether a stuff bit followed
/// it (after 5 equal bits, a bit of the other level, which starts the next run).
const fn stuff_bit(state: StuffState, bit: u8) -> (StuffState, bool) {
    let (level, run) = (state >> 2, (state & 3) + 1);
    if bit != level {
        return (bit << 2, false);
    }
    if run == 4 {
        return ((bit ^ 1) << 2, true);
    }
    (state + 1, false)
}

/// The stuffer over four bits at once, indexed by state × 16 + nibble (first bit at the top):
/// the new state (bits 0–2) and the stuff bits inserted (bit 3; at most one in four bits, as
/// a run after a stuff bit needs four more). Built from [`stuff_bit`] at compile time.
const NIBBLE_STUFFING: [u8; 128] = {
    let mut table = [0u8; 128];
    let mut k = 0;
    while k < 128 {
        let (mut state, mut stuffed, mut b) = ((k >> 4) as StuffState, 0u8, 0);
        while b < 4 {
            let (next, s) = stuff_bit(state, (k >> (3 - b)) as u8 & 1);
            state = next;
            stuffed += s as u8;
            b += 1;
        }
        assert!(stuffed <= 1);
        table[k] = state | stuffed << 3;
        k += 1;
    }
    table
};

/// Consecutive syncs a node may miss while the master is alive (fault hypothesis). A node
/// free-runs through that many missing syncs and keeps sending HRT frames.
pub const MAX_SYNC_LOSS: u32 = 2;
/// Cycles a [`SlotClock`] free-runs after the last received sync before it stops HRT
/// transmission (equal to [`MAX_SYNC_LOSS`]).
pub const FREE_RUN_CYCLES: u32 = MAX_SYNC_LOSS;
/// Syncs over which a [`SlotClock`] measures the master's period.
pub const PERIOD_WINDOW: usize = 8;
/// A sync more than this far (parts per million of a cycle) from where the clock expected it is
/// a discontinuity (a new master or a restarted cycle): the clock re-phases and restarts its
/// period estimate.
pub const SYNC_TOLERANCE_PPM: u64 = 5_000;
/// Sync payload bit that carries the master's epoch bit instead of a reservation (slot 0 is the
/// sync slot and always reserved, so its reservation bit needs no transmission).
pub const EPOCH_BIT: u64 = 1 << SYNC_SLOT;
/// The mask of a cycle whose reservations a node does not know: every slot reserved.
pub const UNKNOWN_MASK: u64 = u64::MAX;
/// Sync payload length.
pub const SYNC_PAYLOAD_LEN: usize = 8;

/// Why a cycle configuration cannot be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfigError {
    /// Bit rate 0 or above [`MAX_BIT_RATE`].
    BitRate(u32),
    /// Slot count outside [`MIN_SLOTS`]..=[`MAX_SLOTS`].
    SlotCount(u8),
    /// The shortest slot cannot hold a worst-case frame.
    SlotTooShort {
        /// Bit times in the shortest slot.
        slot_bits: u32,
        /// Bit times needed: [`WORST_CASE_FRAME_BITS`].
        needed: u32,
    },
}

/// The communication cycle's parameters; every node of a bus uses the same.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CycleConfig {
    /// Bus bit rate in bit/s.
    pub bit_rate: u32,
    /// Nominal cycle length (sync period) in µs.
    pub cycle_us: u32,
    /// Slots per cycle, slot 0 being the sync slot.
    pub slots: u8,
}

impl Default for CycleConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl CycleConfig {
    /// 1 Mbit/s, 10 ms, 60 slots.
    pub const DEFAULT: Self =
        Self { bit_rate: DEFAULT_BIT_RATE, cycle_us: DEFAULT_CYCLE_US, slots: DEFAULT_SLOTS };

    /// Length of the shortest slot in µs: ⌊cycle_us / slots⌋.
    pub const fn slot_us(&self) -> u32 {
        if self.slots == 0 {
            0
        } else {
            self.cycle_us / self.slots as u32
        }
    }

    /// Bit times in the shortest slot: ⌊slot_us · bit_rate / 10⁶⌋.
    pub const fn slot_bits(&self) -> u32 {
        (self.slot_us() as u64 * self.bit_rate as u64 / 1_000_000) as u32
    }

    /// Start of slot `slot` relative to the cycle's start, in µs: ⌈slot · cycle_us / slots⌉.
    /// `slot == slots` gives the cycle length.
    pub const fn slot_offset_us(&self, slot: u8) -> u32 {
        let n = self.slots as u64;
        (slot as u64 * self.cycle_us as u64).div_ceil(n) as u32
    }

    /// Time one worst-case frame occupies the bus, in whole µs (rounded up).
    pub const fn frame_us(&self) -> u32 {
        let b = self.bit_rate as u64;
        (WORST_CASE_FRAME_BITS as u64 * 1_000_000).div_ceil(b) as u32
    }

    /// Checks the configuration; every other method assumes it passed.
    pub const fn validate(&self) -> Result<(), ConfigError> {
        if self.bit_rate == 0 || self.bit_rate > MAX_BIT_RATE {
            return Err(ConfigError::BitRate(self.bit_rate));
        }
        if self.slots < MIN_SLOTS || self.slots > MAX_SLOTS {
            return Err(ConfigError::SlotCount(self.slots));
        }
        let slot_bits = self.slot_bits();
        if slot_bits < WORST_CASE_FRAME_BITS {
            return Err(ConfigError::SlotTooShort { slot_bits, needed: WORST_CASE_FRAME_BITS });
        }
        Ok(())
    }

    /// The mask with one bit for every slot of the cycle.
    pub const fn all_slots(&self) -> u64 {
        if self.slots >= 64 {
            u64::MAX
        } else {
            (1u64 << self.slots) - 1
        }
    }
}

/// Why a frame is not a sync frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SyncError {
    /// The identifier is not a sync identifier.
    NotSync,
    /// A sync frame's payload is not 8 bytes.
    Length(usize),
}

/// The content of a sync frame.
///
/// Identifier: [`FrameId::sync_from`] the cycle counter (its low byte) and the sender's master
/// rank. Payload: 8 bytes, the
/// 64-bit word `(reservations & !EPOCH_BIT) | epoch` in **little-endian** order, so byte j bit b
/// is slot 8·j + b: byte 0 bit 1 = slot 1, byte 7 bit 7 = slot 63. Bit 0 would be the sync
/// slot's reservation, which is implicit; it carries the master's epoch bit instead.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyncFrame {
    /// Cycle counter (low byte of the master's cycle number) of the cycle this sync starts.
    pub cycle: u8,
    /// Reservations of the next cycle; bit 0 (the sync slot) always reads as reserved.
    pub reservations: u64,
    /// The master's epoch bit: it flips when a new master starts a new calendar (a takeover
    /// that continues the cycle and the calendar keeps it).
    pub epoch: bool,
    /// The sender's master rank (the identifier's fragment field).
    pub sender: u8,
}

impl SyncFrame {
    /// The sync of cycle `cycle` (only the low byte is sent) announcing `reservations`.
    pub const fn new(cycle: u32, reservations: u64, epoch: bool) -> Self {
        Self { cycle: cycle as u8, reservations: reservations | EPOCH_BIT, epoch, sender: 0 }
    }

    /// The same sync sent by the master of rank `sender`.
    pub const fn from_rank(self, sender: u8) -> Self {
        Self { sender, ..self }
    }

    /// The 8-byte payload.
    pub const fn payload(&self) -> [u8; SYNC_PAYLOAD_LEN] {
        ((self.reservations & !EPOCH_BIT) | self.epoch as u64).to_le_bytes()
    }

    /// The frame the master sends.
    pub fn to_frame(&self) -> Frame {
        match Frame::new(FrameId::sync_from(self.cycle as u32, self.sender), &self.payload()) {
            Ok(f) => f,
            Err(_) => unreachable!(),
        }
    }

    /// Decodes a received frame; `Err(NotSync)` for every other frame.
    pub fn from_frame(frame: &Frame) -> Result<Self, SyncError> {
        let Some(cycle) = frame.id().sync_cycle() else {
            return Err(SyncError::NotSync);
        };
        let p = frame.payload();
        if p.len() != SYNC_PAYLOAD_LEN {
            return Err(SyncError::Length(p.len()));
        }
        let mut b = [0u8; SYNC_PAYLOAD_LEN];
        b.copy_from_slice(p);
        let word = u64::from_le_bytes(b);
        let (reservations, epoch) = (word | EPOCH_BIT, word & EPOCH_BIT != 0);
        Ok(Self { cycle, reservations, epoch, sender: frame.id().fragment })
    }
}

/// Where a node stands in the cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockState {
    /// No sync received yet (or the clock was reset).
    Unsynced,
    /// Within the cycle announced by the last sync or at most [`FREE_RUN_CYCLES`] after it.
    Running(SlotPosition),
    /// More than [`FREE_RUN_CYCLES`] cycles without a sync: no HRT transmission.
    Lost,
}

/// A cycle and a slot in it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotPosition {
    /// Cycle number (the node's extension of the 8-bit counter; its low byte is the counter).
    pub cycle: u32,
    /// Slot index, 0..slots.
    pub slot: u8,
    /// Cycles since the last received sync: 0 when synced, 1..=[`FREE_RUN_CYCLES`] free-running.
    pub free_run: u32,
}

/// What a received sync told the clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyncInfo {
    /// The cycle this sync starts (extended cycle number; low byte = the sync's counter).
    pub cycle: u32,
    /// False if the sync was not where the clock expected it (first sync, after the clock was
    /// lost, a counter jump or a phase jump): the period estimate restarted.
    pub continuous: bool,
    /// Syncs missed since the previous one (0 when none).
    pub missed: u32,
}

/// The slave's view of the cycle, re-phased on every sync (the master feeds it its own syncs).
///
/// Time arithmetic uses the period in 1/256 µs (`Q8`): the start of slot j of the k-th cycle
/// after the last sync at `t` is `t + ⌈(k·P + ⌊j·P/slots⌋) / 256⌉` µs, where P is the estimated
/// period — for the nominal period exactly `t + k·cycle_us + slot_offset_us(j)`.
#[derive(Clone, Debug)]
pub struct SlotClock {
    config: CycleConfig,
    nominal_q8: u64,
    period_q8: u64,
    last: Option<(Micros, u32)>,
    hist_at: [Micros; PERIOD_WINDOW],
    hist_cycle: [u32; PERIOD_WINDOW],
    hist_len: usize,
    hist_head: usize,
    current: (u32, u64),
    next: (u32, u64),
}

impl SlotClock {
    /// A clock for a validated configuration, not yet synced.
    pub const fn new(config: CycleConfig) -> Self {
        let nominal_q8 = (config.cycle_us as u64) << 8;
        Self {
            config,
            nominal_q8,
            period_q8: nominal_q8,
            last: None,
            hist_at: [0; PERIOD_WINDOW],
            hist_cycle: [0; PERIOD_WINDOW],
            hist_len: 0,
            hist_head: 0,
            current: (0, UNKNOWN_MASK),
            next: (0, UNKNOWN_MASK),
        }
    }

    /// The configuration.
    pub const fn config(&self) -> &CycleConfig {
        &self.config
    }

    /// The estimated master period in 1/256 µs (the nominal period until two syncs were seen).
    pub const fn period_q8(&self) -> u64 {
        self.period_q8
    }

    /// Forgets every sync (after a master change): the next sync starts a fresh estimate.
    pub fn reset(&mut self) {
        *self = Self::new(self.config);
    }

    /// Feeds a sync received (or, on the master, sent) with its start-of-frame time `at`.
    ///
    /// The sync's start of frame is the start of its cycle: drivers timestamp syncs at SOF
    /// (bxCAN's time-triggered mode does) or subtract the frame's length.
    pub fn on_sync(&mut self, at: Micros, sync: &SyncFrame) -> SyncInfo {
        let counter = sync.cycle;
        let mut info = SyncInfo { cycle: counter as u32, continuous: false, missed: 0 };
        if let Some((t0, c0)) = self.last {
            let dt_q8 = at.saturating_sub(t0) << 8;
            // Elapsed cycles, rounded to nearest.
            let n = (dt_q8 + self.period_q8 / 2) / self.period_q8;
            let expected = c0.wrapping_add(n as u32);
            let err = dt_q8.abs_diff(n * self.period_q8);
            // Multiply first: dividing the period by 10⁶ first truncated 0.5 % of 10 ms to 39 µs.
            let tolerance = n * self.period_q8 * SYNC_TOLERANCE_PPM / 1_000_000;
            let in_free_run = n >= 1 && n <= FREE_RUN_CYCLES as u64 + 1;
            if in_free_run && expected as u8 == counter && err <= tolerance {
                info = SyncInfo { cycle: expected, continuous: true, missed: n as u32 - 1 };
            } else {
                // Keep the extended number monotonic, with the counter as its low byte.
                let step = match counter.wrapping_sub(c0 as u8) {
                    0 => 256,
                    d => d as u32,
                };
                info.cycle = c0.wrapping_add(step);
            }
        }
        if !info.continuous {
            self.hist_len = 0;
            self.hist_head = 0;
            self.period_q8 = self.nominal_q8;
        }
        self.push_history(at, info.cycle);
        self.last = Some((at, info.cycle));
        self.current = if self.next.0 == info.cycle && info.continuous && info.missed == 0 {
            self.next
        } else {
            (info.cycle, UNKNOWN_MASK)
        };
        self.next = (info.cycle.wrapping_add(1), sync.reservations | EPOCH_BIT);
        info
    }

    /// The master's own sync of `cycle` (its counter byte) went out with its start of frame at
    /// `at`, as the controller reports it: re-anchors the cycle there, where the slaves anchor
    /// it. ([`Self::on_sync`] was fed the instant the sync was loaded, earlier by the code and
    /// the controller's latency up to the mailbox request.) Ignored unless that sync is the
    /// last one fed and `at` lies in its slot, after the instant it was fed.
    pub fn restamp_last_sync(&mut self, cycle: u8, at: Micros) {
        let Some((t0, c0)) = self.last else { return };
        let in_its_slot = at >= t0 && at - t0 < Micros::from(self.config.slot_us());
        if c0 as u8 != cycle || !in_its_slot {
            return;
        }
        let newest = (self.hist_head + PERIOD_WINDOW - 1) % PERIOD_WINDOW;
        self.last = Some((at, c0));
        self.hist_at[newest] = at;
        self.estimate_period();
    }

    fn push_history(&mut self, at: Micros, cycle: u32) {
        self.hist_at[self.hist_head] = at;
        self.hist_cycle[self.hist_head] = cycle;
        self.hist_head = (self.hist_head + 1) % PERIOD_WINDOW;
        if self.hist_len < PERIOD_WINDOW {
            self.hist_len += 1;
        }
        self.estimate_period();
    }

    /// The period over the syncs in the history window.
    fn estimate_period(&mut self) {
        if self.hist_len >= 2 {
            let newest = (self.hist_head + PERIOD_WINDOW - 1) % PERIOD_WINDOW;
            let (at, cycle) = (self.hist_at[newest], self.hist_cycle[newest]);
            let oldest = (self.hist_head + PERIOD_WINDOW - self.hist_len) % PERIOD_WINDOW;
            let cycles = cycle.wrapping_sub(self.hist_cycle[oldest]) as u64;
            let dt = at - self.hist_at[oldest];
            if let Some(p) = (dt << 8).checked_div(cycles) {
                self.period_q8 = p;
            }
        }
    }

    /// The cycle and slot at time `now`.
    pub fn state(&self, now: Micros) -> ClockState {
        let Some((t0, c0)) = self.last else { return ClockState::Unsynced };
        let x = now.saturating_sub(t0) << 8;
        let k = x / self.period_q8;
        if k > FREE_RUN_CYCLES as u64 {
            return ClockState::Lost;
        }
        let r = x - k * self.period_q8;
        let n = self.config.slots as u64;
        // Largest j with ⌊j·P/n⌋ ≤ r.
        let slot = ((n * (r + 1) - 1) / self.period_q8).min(n - 1) as u8;
        ClockState::Running(SlotPosition {
            cycle: c0.wrapping_add(k as u32),
            slot,
            free_run: k as u32,
        })
    }

    /// Start time of slot `slot` of cycle `cycle`; `None` unless that cycle is the last synced
    /// one or one of the [`FREE_RUN_CYCLES`] after it. `slot == slots` gives the cycle's end.
    pub fn slot_start(&self, cycle: u32, slot: u8) -> Option<Micros> {
        let (t0, c0) = self.last?;
        let k = cycle.wrapping_sub(c0) as u64;
        if k > FREE_RUN_CYCLES as u64 || slot > self.config.slots {
            return None;
        }
        let t = k * self.period_q8 + slot as u64 * self.period_q8 / self.config.slots as u64;
        Some(t0 + t.div_ceil(256) as Micros)
    }

    /// True if HRT frames may be sent at `now`: synced or free-running.
    pub fn hrt_allowed(&self, now: Micros) -> bool {
        matches!(self.state(now), ClockState::Running(_))
    }

    /// Reservations of cycle `cycle` as far as this node knows: the mask the previous cycle's
    /// sync announced, or [`UNKNOWN_MASK`] (everything reserved) if that sync was missed.
    pub fn mask(&self, cycle: u32) -> u64 {
        if self.current.0 == cycle {
            self.current.1
        } else if self.next.0 == cycle {
            self.next.1
        } else {
            UNKNOWN_MASK
        }
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    fn cfg(bit_rate: u32, cycle_us: u32, slots: u8) -> CycleConfig {
        CycleConfig { bit_rate, cycle_us, slots }
    }

    r2p_testkit::suite! {
        fn worst_case_frame_is_160_bits() {
            assert_eq!(STUFFABLE_BITS, 118);
            assert_eq!(MAX_STUFF_BITS, 29);
            assert_eq!(WORST_CASE_FRAME_BITS, 160);
        }

        #[allow(clippy::needless_range_loop)]
        fn stuffing_bound_is_reached_and_never_exceeded() {
            // CAN stuffing: after 5 equal bits the sender inserts the complement, which starts
            // the next run. Dynamic programming over (level, run length) finds the most stuff
            // bits any 118-bit string can need.
            const NONE: i32 = -1;
            let mut best = [[NONE; 6]; 2]; // best[level][run] = max stuff bits so far
            best[0][1] = 0; // SOF is dominant (0)
            for _ in 1..STUFFABLE_BITS {
                let mut next = [[NONE; 6]; 2];
                for level in 0..2 {
                    for run in 1..6 {
                        let v = best[level][run];
                        if v == NONE { continue; }
                        for bit in 0..2 {
                            let (mut l, mut r, mut c) =
                                if bit == level { (level, run + 1, v) } else { (bit, 1, v) };
                            if r == 5 { l = 1 - l; r = 1; c += 1; }
                            if c > next[l][r] { next[l][r] = c; }
                        }
                    }
                }
                best = next;
            }
            let max = best.iter().flatten().copied().max().unwrap();
            assert_eq!(max as u32, MAX_STUFF_BITS);
        }

        fn nibble_stuffing_is_the_bit_by_bit_stuffer() {
            // The header's stuff bits and last run, bit by bit as a CAN controller stuffs.
            fn bitwise(raw_id: u32, len: usize) -> u32 {
                let header: u64 = ((u64::from(raw_id) >> 18 & 0x7ff) << 27)
                    + (0b11 << 25)
                    + ((u64::from(raw_id) & 0x3ffff) << 7)
                    + (len as u64 & 0xf);
                let (mut level, mut run, mut stuff) = (2u64, 0u32, 0u32);
                for i in (0..HEADER_BITS).rev() {
                    let bit = header >> i & 1;
                    run = if bit == level { run + 1 } else { 1 };
                    level = bit;
                    if run == 5 {
                        (stuff, level, run) = (stuff + 1, bit ^ 1, 1);
                    }
                }
                let rest = 8 * len as u32 + 15;
                HEADER_BITS + rest + stuff + (rest + run - 1) / 4 + FRAME_TAIL_BITS + INTERFRAME_BITS
            }
            let mut x = 0x2545_f491u32;
            for k in 0..4_000u32 {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                // Random identifiers, and long runs of either level (where stuffing happens).
                let raw = match k % 4 {
                    0 => x & 0x1fff_ffff,
                    1 => (x & 0x1fff_ffff) | 0x0fff_f000,
                    2 => x & 0x1e00_001f,
                    _ => 0x1fff_ffff >> (k / 4 % 30),
                };
                let len = (x >> 29) as usize + (k as usize & 1);
                assert_eq!(frame_bits_of(raw, len), bitwise(raw, len), "id {raw:#x}, {len} bytes");
            }
        }

        fn default_config_is_valid() {
            let c = CycleConfig::default();
            assert_eq!(c.validate(), Ok(()));
            assert_eq!(c.slot_us(), 166);
            assert_eq!(c.slot_bits(), 166);
            assert_eq!(c.frame_us(), 160);
            assert_eq!(frame_bits(8), WORST_CASE_FRAME_BITS);
            assert_eq!(frame_bits(0), 80); // 54 stuffable, 13 stuff bits, tail, intermission
            // Identifier 0, 8 bytes: the header's runs of zeros take 6 stuff bits (not the 9 of
            // the worst header) and end in a run of 3, so data and CRC take at most 20.
            assert_eq!(frame_bits_of(0, 8), HEADER_BITS + 79 + 6 + 20 + 10 + 3);
            assert!(frame_bits_of(0x1555_5555, 8) < frame_bits_of(0, 8)); // alternating: none
            // Identifier 0x1fff_ffff, no data: SOF then 11 ones (2 stuff bits), SRR and IDE
            // (run of 3 ones after the second), 18 ones (4 more), RTR r1 r0 0 and DLC 0000: 7
            // zeros (1 more, a run of 2 left); the CRC's 15 bits take at most 4.
            assert_eq!(frame_bits_of(0x1fff_ffff, 0), HEADER_BITS + 15 + 7 + 4 + 10 + 3);
            assert_eq!(c.slot_offset_us(1), 167);
            assert_eq!(c.slot_offset_us(60), 10_000);
        }

        fn rejects_short_slots_and_bad_counts() {
            assert_eq!(
                cfg(1_000_000, 10_000, 64).validate(),
                Err(ConfigError::SlotTooShort { slot_bits: 156, needed: 160 })
            );
            assert_eq!(cfg(1_000_000, 10_240, 64).validate(), Ok(()));
            assert_eq!(cfg(500_000, 10_000, 31).validate(), Ok(()));
            assert!(matches!(cfg(500_000, 10_000, 32).validate(), Err(ConfigError::SlotTooShort { .. })));
            assert_eq!(cfg(1_000_000, 10_000, 65).validate(), Err(ConfigError::SlotCount(65)));
            assert_eq!(cfg(1_000_000, 10_000, 1).validate(), Err(ConfigError::SlotCount(1)));
            assert_eq!(cfg(0, 10_000, 8).validate(), Err(ConfigError::BitRate(0)));
            assert_eq!(cfg(2_000_000, 10_000, 8).validate(), Err(ConfigError::BitRate(2_000_000)));
        }

        fn slots_never_shorter_than_slot_us() {
            let c = cfg(1_000_000, 10_000, 60);
            for k in 0..c.slots {
                let len = c.slot_offset_us(k + 1) - c.slot_offset_us(k);
                assert!(len >= c.slot_us() && len <= c.slot_us() + 1);
            }
        }

        fn sync_frame_roundtrips() {
            let s = SyncFrame::new(0x1_2345, (1 << 1) | (1 << 63), true);
            let f = s.to_frame();
            assert_eq!(f.id().to_raw(), 0x45 << 7);
            assert_eq!(f.payload(), &[0x03, 0, 0, 0, 0, 0, 0, 0x80]);
            let d = SyncFrame::from_frame(&f).unwrap();
            assert_eq!(d, s);
            assert_eq!(d.reservations, (1 << 0) | (1 << 1) | (1 << 63));
            let e = SyncFrame::new(7, 0, false);
            assert_eq!(e.payload(), [0; 8]);
            assert_eq!(SyncFrame::from_frame(&e.to_frame()).unwrap().reservations, 1);
        }

        fn non_sync_frames_are_rejected() {
            let data = FrameId::from_raw(0x100 << 7).unwrap();
            assert_eq!(SyncFrame::from_frame(&Frame::new(data, &[0; 8]).unwrap()), Err(SyncError::NotSync));
            let short = Frame::new(FrameId::sync(3), &[0; 4]).unwrap();
            assert_eq!(SyncFrame::from_frame(&short), Err(SyncError::Length(4)));
        }

        fn clock_follows_syncs() {
            let c = CycleConfig::DEFAULT;
            let mut clk = SlotClock::new(c);
            assert_eq!(clk.state(0), ClockState::Unsynced);
            let t0 = 1_000_000;
            let info = clk.on_sync(t0, &SyncFrame::new(10, 0b110, false));
            assert!(!info.continuous);
            assert_eq!(info.cycle, 10);
            let pos = |clk: &SlotClock, t| match clk.state(t) {
                ClockState::Running(p) => (p.cycle, p.slot, p.free_run),
                s => panic!("{:?}", s),
            };
            assert_eq!(pos(&clk, t0), (10, 0, 0));
            assert_eq!(pos(&clk, t0 + 166), (10, 0, 0));
            assert_eq!(pos(&clk, t0 + 167), (10, 1, 0));
            assert_eq!(pos(&clk, t0 + 9_999), (10, 59, 0));
            assert_eq!(pos(&clk, t0 + 10_000), (11, 0, 1));
            assert_eq!(clk.slot_start(10, 1), Some(t0 + 167));
            assert_eq!(clk.slot_start(11, 2), Some(t0 + 10_334));
            assert_eq!(clk.mask(10), UNKNOWN_MASK);
            assert_eq!(clk.mask(11), 0b111);
            let info = clk.on_sync(t0 + 10_000, &SyncFrame::new(11, 0b1000, false));
            assert!(info.continuous);
            assert_eq!((info.cycle, info.missed), (11, 0));
            assert_eq!(clk.mask(11), 0b111);
            assert_eq!(clk.mask(12), 0b1001);
        }

        fn clock_estimates_period_and_rephases() {
            // The master runs 0.1 % slow: 10 010 µs cycles.
            let mut clk = SlotClock::new(CycleConfig::DEFAULT);
            let mut t = 5_000;
            for c in 0..20u32 {
                let info = clk.on_sync(t, &SyncFrame::new(250 + c, 0, false));
                assert_eq!(info.cycle, 250 + c);
                assert_eq!(info.continuous, c > 0);
                t += 10_010;
            }
            assert_eq!(clk.period_q8(), 10_010 << 8);
            // Free-running with the estimate: slot 30 of the next cycle.
            let last = t - 10_010;
            assert_eq!(clk.slot_start(270, 30), Some(last + 10_010 + 5_005));
            // Re-phase: the next sync arrives 3 µs late; slot times follow it.
            clk.on_sync(last + 10_013, &SyncFrame::new(270, 0, false));
            assert_eq!(clk.slot_start(270, 0), Some(last + 10_013));
        }

        fn a_sent_syncs_start_of_frame_re_anchors_the_masters_cycle() {
            // The master feeds its syncs as it loads them; each starts 22 µs later on the wire.
            let mut clk = SlotClock::new(CycleConfig::DEFAULT);
            for c in 0..4u32 {
                let loaded = 1_000 + u64::from(c) * 10_000;
                clk.on_sync(loaded, &SyncFrame::new(c, 0, false));
                assert_eq!(clk.slot_start(c, 0), Some(loaded));
                clk.restamp_last_sync(c as u8, loaded + 22);
                assert_eq!(clk.slot_start(c, 0), Some(loaded + 22));
                assert_eq!(clk.slot_start(c, 1), Some(loaded + 22 + 167));
            }
            assert_eq!(clk.period_q8(), 10_000 << 8, "a constant latency leaves the period");
            // Not the last sync, before its anchor, or past its slot: ignored.
            let last = 30_000 + 1_022;
            for (cycle, at) in [(2u8, last + 5), (3, last - 1), (3, last + 166)] {
                let mut c = clk.clone();
                c.restamp_last_sync(cycle, at);
                assert_eq!(c.slot_start(3, 0), Some(last), "{cycle} {at}");
            }
            let mut c = clk.clone();
            c.restamp_last_sync(3, last + 165);
            assert_eq!(c.slot_start(3, 0), Some(last + 165), "the slot's last µs");
            // Before any sync: nothing to re-anchor.
            let mut fresh = SlotClock::new(CycleConfig::DEFAULT);
            fresh.restamp_last_sync(0, 5);
            assert_eq!(fresh.state(5), ClockState::Unsynced);
        }

        fn the_period_is_estimated_from_the_restamped_starts_of_frame() {
            // Latencies that vary from sync to sync: the estimate spans the window's oldest and
            // newest starts of frame, not the instants the syncs were loaded.
            let mut clk = SlotClock::new(CycleConfig::DEFAULT);
            let sof = |c: u64| c * 10_000 + 20 + (c * 7) % 11;
            let cycles = 3 * PERIOD_WINDOW as u64;
            for c in 0..cycles {
                clk.on_sync(c * 10_000, &SyncFrame::new(c as u32, 0, false));
                clk.restamp_last_sync(c as u8, sof(c));
            }
            let (newest, oldest) = (cycles - 1, cycles - PERIOD_WINDOW as u64);
            let span = sof(newest) - sof(oldest);
            assert_eq!(clk.period_q8(), (span << 8) / (newest - oldest));
            assert_eq!(clk.slot_start(newest as u32, 0), Some(sof(newest)));
        }

        fn a_reset_clock_forgets_the_old_masters_cycle() {
            // After a master change the node resets its clock: the old cycle's grid, period
            // estimate and reservations must not carry over to the new master's syncs.
            let mut clk = SlotClock::new(CycleConfig::DEFAULT);
            for c in 0..4u32 {
                clk.on_sync(u64::from(c) * 10_010, &SyncFrame::new(c, 0b110, false));
            }
            assert_eq!(clk.period_q8(), 10_010 << 8);
            clk.reset();
            assert_eq!(clk.state(40_040), ClockState::Unsynced);
            assert_eq!(clk.period_q8(), 10_000 << 8, "back to the nominal period");
            let info = clk.on_sync(40_040, &SyncFrame::new(4, 0, true));
            assert!(!info.continuous, "the first sync of a new master starts afresh");
            assert_eq!(clk.mask(4), UNKNOWN_MASK);
        }

        fn clock_free_runs_then_stops() {
            let c = CycleConfig::DEFAULT;
            let mut clk = SlotClock::new(c);
            clk.on_sync(0, &SyncFrame::new(0, 0, false));
            clk.on_sync(10_000, &SyncFrame::new(1, 0, false));
            // Syncs 2 and 3 lost: free-running.
            assert!(clk.hrt_allowed(29_999));
            assert!(matches!(clk.state(25_000), ClockState::Running(SlotPosition { cycle: 2, free_run: 1, .. })));
            assert!(matches!(clk.state(39_999), ClockState::Running(SlotPosition { cycle: 3, free_run: 2, .. })));
            assert_eq!(clk.state(40_000), ClockState::Lost);
            assert!(!clk.hrt_allowed(40_000));
            assert_eq!(clk.slot_start(4, 0), None);
            // A sync after FREE_RUN_CYCLES missed ones is still continuous; after more it is not.
            let mut clk2 = clk.clone();
            let info = clk2.on_sync(40_000, &SyncFrame::new(4, 0, false));
            assert_eq!((info.cycle, info.continuous, info.missed), (4, true, 2));
            let mut clk3 = clk.clone();
            let info = clk3.on_sync(50_000, &SyncFrame::new(5, 0, false));
            assert!(!info.continuous);
            assert_eq!(info.cycle, 5);
            assert_eq!(clk3.period_q8(), 10_000 << 8);
            let info = clk.on_sync(30_000, &SyncFrame::new(3, 0b10, false));
            assert_eq!((info.cycle, info.continuous, info.missed), (3, true, 1));
            assert_eq!(clk.mask(3), UNKNOWN_MASK);
            assert_eq!(clk.mask(4), 0b11);
        }

        fn counter_jump_is_a_discontinuity() {
            let mut clk = SlotClock::new(CycleConfig::DEFAULT);
            clk.on_sync(0, &SyncFrame::new(5, 0, false));
            clk.on_sync(10_000, &SyncFrame::new(6, 0, false));
            let info = clk.on_sync(20_000, &SyncFrame::new(100, 0, true));
            assert!(!info.continuous);
            assert_eq!(info.cycle, 100);
            // Phase jump: right counter, 2 ms early.
            let info = clk.on_sync(28_000, &SyncFrame::new(101, 0, true));
            assert!(!info.continuous);
            assert_eq!(info.cycle, 101);
            assert_eq!(clk.slot_start(101, 0), Some(28_000));
        }
    }
}

#[cfg(test)]
mod vectors {
    extern crate std;
    use super::*;
    use serde::Deserialize;
    use std::{string::String, vec::Vec};

    #[derive(Deserialize)]
    struct File {
        #[allow(dead_code)]
        description: String,
        configs: Vec<ConfigCase>,
        syncs: Vec<SyncCase>,
    }

    #[derive(Deserialize)]
    struct ConfigCase {
        bit_rate: u32,
        cycle_us: u32,
        slots: u8,
        slot_us: u32,
        slot_bits: u32,
        /// "ok", "bit_rate", "slot_count" or "slot_too_short".
        result: String,
    }

    #[derive(Deserialize)]
    struct SyncCase {
        cycle: u32,
        reservations: String,
        epoch: bool,
        id: String,
        data: String,
    }

    fn hex(s: &str) -> u64 {
        u64::from_str_radix(s.trim_start_matches("0x").replace('_', "").as_str(), 16).unwrap()
    }

    #[test]
    fn cycle_vectors() {
        let f: File =
            serde_json::from_str(include_str!("../../../../tests/vectors/rtcan/cycle.json"))
                .unwrap();
        assert!(!f.configs.is_empty() && !f.syncs.is_empty());
        for c in &f.configs {
            let cfg = CycleConfig { bit_rate: c.bit_rate, cycle_us: c.cycle_us, slots: c.slots };
            let got = match cfg.validate() {
                Ok(()) => "ok",
                Err(ConfigError::BitRate(_)) => "bit_rate",
                Err(ConfigError::SlotCount(_)) => "slot_count",
                Err(ConfigError::SlotTooShort { .. }) => "slot_too_short",
            };
            assert_eq!(got, c.result, "{}/{}/{}", c.bit_rate, c.cycle_us, c.slots);
            if c.result != "slot_count" {
                assert_eq!(cfg.slot_us(), c.slot_us, "{}/{}/{}", c.bit_rate, c.cycle_us, c.slots);
                assert_eq!(cfg.slot_bits(), c.slot_bits);
            }
        }
        for s in &f.syncs {
            let sync = SyncFrame::new(s.cycle, hex(&s.reservations), s.epoch);
            let frame = sync.to_frame();
            assert_eq!(frame.id().to_raw() as u64, hex(&s.id), "cycle {}", s.cycle);
            let data: [u8; 8] = hex(&s.data).to_be_bytes();
            assert_eq!(frame.payload(), &data, "cycle {}", s.cycle);
            assert_eq!(
                SyncFrame::from_frame(&Frame::from_raw(hex(&s.id) as u32, &data).unwrap()),
                Ok(sync)
            );
        }
    }
}
