//! The transmit interrupt's handler: the driver never needs the interrupt.
//!
//! embassy-stm32's `Can::new` enables the bxCAN's transmit-mailbox-empty interrupt, and its
//! handler acknowledges `RQCP`, which clears the `TXOK`/`ALST`/`TERR` bits [`crate::BxCan`]
//! reads as each frame's result; `BxCan::new` masks it (`TMEIE`) before the first frame is
//! sent, so it never fires. [`TxQuiet`] is what the image binds instead of embassy's handler
//! (420 B of the PSU image's flash, never run): should the interrupt ever fire, it
//! turns the interrupt off in the NVIC rather than touch the mailboxes' status.

use embassy_stm32::interrupt::typelevel::{Handler, Interrupt};

/// Binds the bxCAN's transmit interrupt in place of embassy-stm32's `TxInterruptHandler`
/// (see the module documentation).
pub struct TxQuiet;

impl<I: Interrupt> Handler<I> for TxQuiet {
    unsafe fn on_interrupt() {
        I::disable();
    }
}
