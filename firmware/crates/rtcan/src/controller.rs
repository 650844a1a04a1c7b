//! The CAN controller as RTCAN needs it: the contract between the protocol and the hardware.
//!
//! Implemented by embassy-stm32's bxCAN on the modules (F103, F407) and by the emulated bus on a
//! host. Every method is non-blocking, so the slot timer can call [`CanController::try_transmit`]
//! from its interrupt handler to put a frame on the wire at the start of its slot.
//!
//! The TDMA cycle needs two things of a controller beyond "send this frame": a frame that did
//! not get the bus in its slot must not go out later, in someone else's slot, so a slotted node
//! transmits [one-shot](TxMode::OneShot) (bxCAN `NART`, as the original R2P and TTCAN's
//! exclusive windows do); and the node must learn what became of each frame it loaded
//! ([`CanController::take_tx_result`]) to keep a frame that did not go out in its queue.

use crate::frame::Frame;
use crate::id::FrameId;

/// When a frame was received, in microseconds of the receiver's clock.
pub type Micros = u64;

/// A received frame and its reception time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Received {
    /// The frame.
    pub frame: Frame,
    /// Reception time (hardware timestamp where the controller has one).
    pub at: Micros,
}

/// Why a frame was not loaded into a transmit mailbox.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TxError {
    /// Every mailbox is busy: retry later (SRT/NRT) or report the slot as missed (HRT).
    MailboxesFull,
    /// The controller is bus-off and sends nothing until it recovers.
    BusOff,
}

/// How the controller treats a frame whose transmission attempt fails.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TxMode {
    /// CAN's default: a frame that loses arbitration or ends in an error frame is tried again
    /// at the next bus idle, until it is sent or aborted.
    #[default]
    Retransmit,
    /// One attempt per frame (bxCAN `NART` = 1): a frame that loses arbitration or ends in an
    /// error frame is withdrawn and reported. A frame loaded while the bus is busy still waits
    /// for the bus to go idle and makes its attempt then.
    OneShot,
}

/// What became of a frame handed to [`CanController::try_transmit`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TxOutcome {
    /// It went out: sent and acknowledged.
    Sent,
    /// One-shot: another node won the arbitration; the frame was withdrawn.
    LostArbitration,
    /// One-shot, or aborted while on the wire: its transmission ended in an error frame and it
    /// was withdrawn.
    Error,
    /// [`CanController::abort_pending`] withdrew it before it went out. (With automatic
    /// retransmission, a frame aborted after failed attempts may be reported with the cause
    /// of its last attempt instead.)
    Aborted,
}

/// A finished frame: which one and what became of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TxResult {
    /// The frame's identifier.
    pub id: FrameId,
    /// Sent, or why not.
    pub outcome: TxOutcome,
    /// A sent frame's start of frame in the node's µs, where the controller captures it (bxCAN
    /// in time-triggered mode: `CAN_TDTxR.TIME`); `None` otherwise. The master anchors its
    /// cycle at its sync's start of frame, as the slaves do, rather than at the instant it
    /// loaded the sync (the code from its clock read to the mailbox request takes ~20 µs on a
    /// 72 MHz Cortex-M3).
    pub start_of_frame: Option<Micros>,
}

impl TxResult {
    /// A result without a start-of-frame stamp.
    pub const fn new(id: FrameId, outcome: TxOutcome) -> Self {
        Self { id, outcome, start_of_frame: None }
    }

    /// True if the frame went out.
    pub const fn sent(&self) -> bool {
        matches!(self.outcome, TxOutcome::Sent)
    }
}

/// Results a controller keeps until they are taken ([`CanController::take_tx_result`]): one per
/// bxCAN transmit mailbox. Older untaken results are dropped.
pub const TX_RESULTS: usize = 3;

/// A frame handed to the controller's transmit interrupt to load by itself
/// ([`CanController::stage`]): the node could not load it because frames of its own were still
/// in the controller, and its own next call would come too late for the arbitration that
/// follows them (issue 22's staged reloads, docs/rtcan.md "Where the fast reaction gains").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StagedFrame {
    /// The frame.
    pub frame: Frame,
    /// Its latest start in the node's µs: after it, the frame no longer fits its window.
    pub latest: Micros,
}

impl StagedFrame {
    /// True if the interrupt at `now` may still load it: before its latest start.
    pub const fn may_load(&self, now: Micros) -> bool {
        now < self.latest
    }
}

/// A hardware acceptance filter: pass frames whose `id & mask == value & mask`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Filter {
    /// Identifier bits to match.
    pub value: u32,
    /// Which identifier bits must match (1 = must match).
    pub mask: u32,
}

impl Filter {
    /// Passes every frame.
    pub const ACCEPT_ALL: Filter = Filter { value: 0, mask: 0 };

    /// True if `raw_id` passes this filter.
    pub const fn accepts(&self, raw_id: u32) -> bool {
        raw_id & self.mask == self.value & self.mask
    }
}

/// Fault confinement state (ISO 11898-1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusState {
    /// Error counters below 128: sends active error frames.
    ErrorActive,
    /// An error counter at 128 or above: sends passive error frames.
    ErrorPassive,
    /// Transmit error counter above 255: off the bus.
    BusOff,
}

/// Transmit and receive error counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ErrorCounters {
    /// Transmit error counter (TEC).
    pub tx: u8,
    /// Receive error counter (REC).
    pub rx: u8,
}

/// A CAN controller RTCAN can drive.
pub trait CanController {
    /// Loads `frame` into a free transmit mailbox now; never waits. Callable from an interrupt.
    /// It is sent as the [transmit mode](Self::set_tx_mode) says; what became of it comes from
    /// [`take_tx_result`](Self::take_tx_result). Frames in several mailboxes go out in the
    /// order they were loaded (transmit FIFO priority: bxCAN's `TXFP`), not lowest identifier
    /// first, so a node may load the next frames of its queue at once and keep its order.
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError>;

    /// Sets how frames are sent from now on: [`TxMode::Retransmit`] (the mode after reset) or
    /// [`TxMode::OneShot`]. The mode is one setting for all transmit mailboxes (bxCAN's `NART`
    /// bit), frames already loaded included: change it when none is pending.
    fn set_tx_mode(&mut self, mode: TxMode);

    /// Takes the result of the oldest frame that finished — went out, or was withdrawn (lost
    /// arbitration or an error in one-shot mode, aborted) — since the last call, if any. A
    /// frame still waiting or on the wire has no result yet. The controller keeps the last
    /// [`TX_RESULTS`] results; older untaken ones are dropped, so a caller that takes them
    /// before loading more frames than that loses none.
    fn take_tx_result(&mut self) -> Option<TxResult>;

    /// Takes the oldest received frame, if any; never waits.
    fn try_receive(&mut self) -> Option<Received>;

    /// Replaces the acceptance filters. Controllers with fewer filter banks than `filters.len()`
    /// widen them (accept more) rather than drop traffic; RTCAN filters again in software.
    fn set_filters(&mut self, filters: &[Filter]);

    /// Withdraws every frame still waiting in a transmit mailbox (a frame that missed its
    /// window must not go out in someone else's slot) and returns how many. A frame already on
    /// the wire cannot be stopped: it is not counted, it ends as it ends and, if it fails, is
    /// not tried again. Each frame's fate is reported by [`take_tx_result`](Self::take_tx_result)
    /// (a withdrawn one as [`TxOutcome::Aborted`]). Never waits.
    fn abort_pending(&mut self) -> usize;

    /// The fault confinement state.
    fn bus_state(&self) -> BusState;

    /// The error counters.
    fn error_counters(&self) -> ErrorCounters;

    /// Hands the transmit interrupt `frames` to load, in order, once the node's frames still in
    /// the controller are gone and the last of them was sent: each into a mailbox whose result
    /// was taken, while it [may](StagedFrame::may_load) still go. It loads them at most once;
    /// each call replaces what the last one staged (none: nothing to load). A controller
    /// without such an interrupt ignores them (the default): the node's next call loads them.
    fn stage(&mut self, frames: &[StagedFrame]) {
        let _ = frames;
    }

    /// How many of the frames last [staged](Self::stage) the interrupt loaded since, the first
    /// ones in their order: they are in the controller now, as if the node had loaded them,
    /// and their results come as any frame's. Never more than once per staging (0 after). The
    /// node asks first in each call: an interrupt it found loading loads nothing more.
    fn staged_loaded(&mut self) -> usize {
        0
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;
    use crate::{Laxity, MessageId};

    /// A controller with the contract's required methods only: no transmit interrupt.
    struct NoInterrupt;

    impl CanController for NoInterrupt {
        fn try_transmit(&mut self, _: &Frame) -> Result<(), TxError> {
            Err(TxError::MailboxesFull)
        }
        fn set_tx_mode(&mut self, _: TxMode) {}
        fn take_tx_result(&mut self) -> Option<TxResult> {
            None
        }
        fn try_receive(&mut self) -> Option<Received> {
            None
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

    r2p_testkit::suite! {
        fn a_controller_without_a_transmit_interrupt_loads_nothing_it_is_handed() {
            // The node then loads its staged frames itself at its next call: a controller that
            // claimed loads would make it count frames that never went into a mailbox.
            let id = FrameId::new(Laxity::NRT, MessageId(0x100), 0).unwrap();
            let frame = Frame::new(id, &[1]).unwrap();
            let mut can = NoInterrupt;
            can.stage(&[StagedFrame { frame, latest: 100 }]);
            assert_eq!(can.staged_loaded(), 0);
            let staged = StagedFrame { frame, latest: 100 };
            assert!(staged.may_load(99) && !staged.may_load(100));
        }
    }
}
