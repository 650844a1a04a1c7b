//! The handler of the bxCAN interrupts the driver does not use: the status change (error)
//! interrupt, and the transmit interrupt unless the crate's feature `transmit-wake` makes it
//! [`crate::TransmitWake`]'s.
//!
//! embassy-stm32's `Can::new` enables all four of the bxCAN's interrupts, and asks for its own
//! handlers bound to them. The transmit one acknowledges `RQCP`, which clears the
//! `TXOK`/`ALST`/`TERR` bits [`crate::BxCan`] reads as each frame's result; `BxCan::new` masks
//! it (`TMEIE`) before the first frame is sent, so it never fires. The status change one masks
//! its own source (`ERRIE`) at the first bus error and wakes the waker of embassy's `read` or
//! `write`, which the driver never calls (it reads the error counters from `ESR` itself).
//! [`UnusedIrq`] is what images bind instead (`bind_bxcan_interrupts!`; 420 and 80 B of the
//! PSU's flash): when its interrupt fires it turns it off in the NVIC, so it fires at most once,
//! as embassy's error handler, and never touches the mailboxes' status.

use embassy_stm32::interrupt::typelevel::{Handler, Interrupt};

/// Binds a bxCAN interrupt the driver does not use, in place of embassy-stm32's handler (see
/// the module documentation).
pub struct UnusedIrq;

impl<I: Interrupt> Handler<I> for UnusedIrq {
    unsafe fn on_interrupt() {
        I::disable();
    }
}
