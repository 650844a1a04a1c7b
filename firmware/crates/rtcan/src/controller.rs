//! The CAN controller as RTCAN needs it: the contract between the protocol and the hardware.
//!
//! Implemented by embassy-stm32's bxCAN on the modules (F103, F407) and by the emulated bus on a
//! host. Every method is non-blocking, so the slot timer can call [`CanController::try_transmit`]
//! from its interrupt handler to put a frame on the wire at the start of its slot.

use crate::frame::Frame;

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
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError>;

    /// Takes the oldest received frame, if any; never waits.
    fn try_receive(&mut self) -> Option<Received>;

    /// Replaces the acceptance filters. Controllers with fewer filter banks than `filters.len()`
    /// widen them (accept more) rather than drop traffic; RTCAN filters again in software.
    fn set_filters(&mut self, filters: &[Filter]);

    /// Aborts frames still waiting in transmit mailboxes (an HRT frame that missed its slot
    /// must not go out in someone else's) and returns how many it aborted: 0 means every frame
    /// loaded since the last call went out, which is how the slot timer learns whether its
    /// SRT/NRT frame won arbitration or must be retried in a later free slot.
    fn abort_pending(&mut self) -> usize;

    /// The fault confinement state.
    fn bus_state(&self) -> BusState;

    /// The error counters.
    fn error_counters(&self) -> ErrorCounters;
}
