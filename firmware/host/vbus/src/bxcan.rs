//! A port as an STM32 bxCAN in time-triggered mode hands received frames to its driver, and
//! the driver's start-of-frame correction on top ([`BxCanPort`]).
//!
//! The hardware half is a model: the bus knows each frame's start of frame; bxCAN captures its
//! 16-bit bit-time counter there (`CAN_RDTxR.TIME`), the counter having started at an
//! arbitrary phase; the receive interrupt stamps the node's clock when the frame becomes valid
//! (one bit before the end of EOF) plus an interrupt latency drawn per frame: none for three
//! frames in four, 1 … [`MAX_RX_LATENCY_US`] µs for the others. Transmitted frames are
//! captured at their start of frame too (`CAN_TDTxR.TIME`), and a frame reaches its mailbox
//! [`BxCanPort::with_load_latency`] after the firmware read its clock (the code of the slot
//! path between the two). The driver half is firmware: [`rtcan::time_counter::TimeCounter`],
//! the same code `rtcan-bxcan` runs on the modules, turns a capture into the node's µs.
//! Nothing here subtracts a frame's length from a timestamp on the firmware's behalf.

use core::cell::RefCell;

use critical_section::Mutex;
use rtcan::controller::{
    BusState, ErrorCounters, Filter, Received, StagedFrame, TxError, TxMode, TxOutcome, TxResult,
};
use rtcan::time_counter::{TimeCounter, TIME_COUNTER_MODULUS};
use rtcan::{CanController, Frame, Laxity, Micros, SyncFrame};
use rtcan_bxcan::mailboxes::MailboxStatus;
use rtcan_bxcan::staged_loads::{self, StagedLoads};

use crate::Port;

/// From the transmit-mailbox-empty interrupt's request (the bus's intermission begins) to its
/// first staged frame's mailbox request ([`BxCanPort::load_staged`]), µs: an estimate, ~60
/// instructions at 72 MHz (12 cycles of entry, `CAN_TSR` read, the staged frame's checks and
/// four mailbox registers; rtcan-bxcan's `TransmitWake` with `staged-reloads`), under CAN's
/// 3-bit intermission at 1 Mbit/s.
pub const STAGED_LOAD_US: Micros = 2;

/// Longest receive-interrupt latency the model draws, µs: the message-pending interrupt
/// waiting behind the slot timer's (higher-priority) handler and a critical section.
pub const MAX_RX_LATENCY_US: u64 = 5;

/// A vbus port seen through a bxCAN in time-triggered mode and its driver: received frames
/// carry their start of frame in the node's µs, computed by the firmware from the counter.
pub struct BxCanPort {
    port: Port,
    bit_ns: u64,
    /// The counter's value at bus time 0 (it runs from the controller's start, at a phase
    /// unrelated to the node's clock).
    phase: u64,
    counter: TimeCounter,
    /// From the caller's clock read to the mailbox request (ns).
    load_latency_ns: u64,
    /// The same for the frames a slot tick loads first, each on a path of its own: (an HRT
    /// frame's, a sync's), ns.
    reserved_latency_ns: Option<(u64, u64)>,
    /// What the node handed the transmit interrupt ([`CanController::stage`]) and what the
    /// interrupt loaded of it, as the firmware's driver keeps them (`rtcan-bxcan`'s
    /// `TransmitWake`).
    staged: Mutex<RefCell<StagedLoads>>,
}

impl BxCanPort {
    /// Wraps `port` of a bus running at `bit_rate` bit/s.
    ///
    /// # Panics
    /// If a bit time at `bit_rate` is not a whole number of µs (the firmware's counter
    /// extension supports those only).
    pub fn new(port: Port, bit_rate: u32) -> Self {
        let phase =
            (port.index() as u64).wrapping_mul(40_503).wrapping_add(1_234) % TIME_COUNTER_MODULUS;
        let counter = TimeCounter::new(bit_rate).expect("a bit rate with a whole-µs bit time");
        let bit_ns = 1_000_000_000 / u64::from(bit_rate);
        Self {
            port,
            bit_ns,
            phase,
            counter,
            load_latency_ns: 0,
            reserved_latency_ns: None,
            staged: Mutex::new(RefCell::new(StagedLoads::new())),
        }
    }

    /// Frames reach their mailbox `us` after [`CanController::try_transmit`] is called: the
    /// time the firmware's code takes from reading its clock (the instant it decided to send)
    /// to the transmit request. On a module that is the slot path, ~1 600 instructions
    /// (`make bench`, QEMU slot-path bench), about 22 µs at 72 MHz.
    pub fn with_load_latency(mut self, us: u64) -> Self {
        self.load_latency_ns = us * 1_000;
        self
    }

    /// Changes the load latency ([`with_load_latency`](Self::with_load_latency)): firmware with
    /// more than one path to the mailboxes takes each one's.
    pub fn set_load_latency(&mut self, us: u64) {
        self.load_latency_ns = us * 1_000;
    }

    /// Gives HRT frames and syncs latencies of their own, `(hrt_us, sync_us)` (`None`: the load
    /// latency, as other frames): the firmware's slot tick requests a master's sync (and on
    /// frame-sized reservations an HRT frame) first, on a shorter path than its other frames,
    /// each matched by its own slot lead.
    pub fn set_reserved_latency(&mut self, us: Option<(u64, u64)>) {
        self.reserved_latency_ns = us.map(|(hrt, sync)| (hrt * 1_000, sync * 1_000));
    }

    /// From the caller's clock read to `frame`'s mailbox request (ns).
    fn latency_of(&self, frame: &Frame) -> u64 {
        match self.reserved_latency_ns {
            Some((_, sync)) if SyncFrame::from_frame(frame).is_ok() => sync,
            Some((hrt, _)) if frame.id().laxity == Laxity::HRT => hrt,
            _ => self.load_latency_ns,
        }
    }

    /// [`CanController::try_transmit`] for firmware whose CPU stalled `stalled_ns` since its
    /// clock read (its flash, on an F103): the request reaches the mailbox that much later.
    pub fn transmit_after_stall(&mut self, frame: &Frame, stalled_ns: u64) -> Result<(), TxError> {
        self.port.transmit_after(frame, self.latency_of(frame) + stalled_ns)
    }

    /// The counter's value at bus time `t_ns` (what bxCAN captures at a start of frame then).
    fn capture_at(&self, t_ns: u64) -> u16 {
        ((t_ns / self.bit_ns + self.phase) % TIME_COUNTER_MODULUS) as u16
    }

    /// True if the node handed the transmit interrupt frames that no interrupt has run on yet
    /// ([`load_staged`](Self::load_staged) loads them if the controller is empty, and drops
    /// them either way).
    pub fn has_staged(&self) -> bool {
        critical_section::with(|cs| self.staged.borrow_ref(cs).any())
    }

    /// The transmit interrupt at `now` (the node's µs) with `staged-reloads`: the firmware's
    /// own rule and steps (`rtcan_bxcan::staged_loads::load_staged`, as `TransmitWake` runs
    /// them) on this port's mailboxes read as `CAN_TSR`. The staged frames are gone after,
    /// loaded or not. Returns how many it loaded.
    pub fn load_staged(&mut self, now: Micros) -> usize {
        let (status, waiting) = self.transmit_status();
        let port = &self.port;
        let write = |i, frame: &Frame| {
            // The rule loads empty mailboxes only; a write into a pending one would be lost.
            let loaded = port.load_mailbox(i, frame, self.latency_of(frame));
            debug_assert!(loaded, "mailbox {i} was empty when the interrupt decided");
        };
        staged_loads::load_staged(&self.staged, &status, &waiting, || now, |f| *f, write)
    }

    /// The port's mailboxes as bxCAN's `CAN_TSR` shows them: each one's `TME`,
    /// `TXOK`/`ALST`/`TERR`, and `RQCP` (a result not taken).
    pub fn transmit_status(&self) -> ([MailboxStatus; crate::MAILBOXES], [bool; crate::MAILBOXES]) {
        let boxes = self.port.mailboxes();
        let status = boxes.map(|(held, last)| MailboxStatus {
            empty: !held,
            txok: last == Some(TxOutcome::Sent),
            alst: last == Some(TxOutcome::LostArbitration),
            terr: last == Some(TxOutcome::Error),
        });
        (status, boxes.map(|(_, last)| last.is_some()))
    }

    /// The wrapped port.
    pub fn port(&self) -> &Port {
        &self.port
    }

    /// The driver's relation of the counter to the node's clock.
    pub fn time_counter(&self) -> &TimeCounter {
        &self.counter
    }

    /// What the hardware hands the driver for the oldest received frame: the frame, the
    /// counter captured at its start of frame and the node's time (µs) the receive interrupt
    /// stamped, never after `now_us` (the interrupt ran before the frame is read).
    pub fn receive_captured(&mut self, now_us: Micros) -> Option<(Frame, u16, Micros)> {
        let (r, bits) = self.port.try_receive_with_bits()?;
        let end_ns = r.at * 1_000;
        let capture = self.capture_at(end_ns - u64::from(bits) * self.bit_ns);
        let valid_us = (end_ns - self.bit_ns) / 1_000;
        let h = (r.at ^ (self.port.index() as u64) << 48).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        // Mostly prompt (the core idle or in a task); one frame in four waits 1 … max µs
        // behind a higher-priority handler.
        let latency = if h >> 62 == 0 { 1 + (h >> 40) % MAX_RX_LATENCY_US } else { 0 };
        Some((r.frame, capture, (valid_us + latency).min(now_us)))
    }
}

impl CanController for BxCanPort {
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        self.port.transmit_after(frame, self.latency_of(frame))
    }
    fn set_tx_mode(&mut self, mode: TxMode) {
        self.port.set_tx_mode(mode);
    }
    /// A sent frame's start of frame: its `TIME` capture extended by the firmware's counter
    /// (none until a received frame related the counter to the node's clock).
    fn take_tx_result(&mut self) -> Option<TxResult> {
        let (mut r, sof_ns) = self.port.take_tx_result_with_start()?;
        if let Some(sof_ns) = sof_ns {
            let now = self.port.now_ns() / 1_000;
            r.start_of_frame = self.counter.start_of_frame(self.capture_at(sof_ns), now);
        }
        Some(r)
    }
    /// The firmware's path: the counter capture extended to the node's µs.
    fn try_receive(&mut self) -> Option<Received> {
        let now = self.port.now_ns() / 1_000;
        let (frame, capture, stamped) = self.receive_captured(now)?;
        let at = self.counter.stamp_received(&frame, capture, stamped, now);
        Some(Received { frame, at })
    }
    fn set_filters(&mut self, filters: &[Filter]) {
        self.port.set_filters(filters);
    }
    fn abort_pending(&mut self) -> usize {
        self.port.abort_pending()
    }
    fn bus_state(&self) -> BusState {
        self.port.bus_state()
    }
    fn error_counters(&self) -> ErrorCounters {
        self.port.error_counters()
    }
    /// Kept for [`BxCanPort::load_staged`], which the sim calls when its interrupt would run,
    /// with the mailbox of the node's newest frame (as the driver's `BxCan::stage`).
    fn stage(&mut self, frames: &[StagedFrame]) {
        let newest = self.port.newest_held();
        critical_section::with(|cs| self.staged.borrow_ref_mut(cs).stage(frames, newest));
    }
    /// As the driver's: the interrupt's loads, and an interrupt under way stops.
    fn staged_loaded(&mut self) -> usize {
        critical_section::with(|cs| self.staged.borrow_ref_mut(cs).take_loaded(true).count())
    }
}
