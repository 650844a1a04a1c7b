//! The transmit-mailbox-empty interrupt as a wake for the node (issue 22, frame-sized
//! reservations: `r2p_node::Node::wakes_on_transmit`). When one of its frames leaves a mailbox
//! (sent, lost a one-shot arbitration, aborted), the node loads the next ones at once
//! (`Node::top_up`) instead of at its next slot timer.
//!
//! The interrupt is level-triggered on `RQCP`, which stays set until the driver takes the
//! mailbox's result (`BxCan::collect` acknowledges it), so the handler masks it (`TMEIE`) and
//! calls the wake the image gave [`crate::BxCan::on_transmit`]; the bus task unmasks it again
//! after its call ([`crate::BxCan::arm_transmit_wake`]). A mailbox that finished in between
//! interrupts at once then. Until an image arms it, `TMEIE` stays masked (`BxCan::new`). Without
//! the crate's feature `transmit-wake` (images on the slot grid) `TransmitWake` is
//! [`crate::UnusedIrq`].

use core::cell::Cell;

use critical_section::Mutex;
use embassy_stm32::interrupt::typelevel::{Handler, Interrupt};

use crate::rx_stamp;

/// What the transmit interrupt calls: the bus task's wake.
type Wake = fn();

/// What the transmit interrupt calls.
static WAKE: Mutex<Cell<Option<Wake>>> = Mutex::new(Cell::new(None));

/// Sets what the transmit interrupt calls ([`crate::BxCan::on_transmit`]).
pub(crate) fn set(wake: Wake) {
    critical_section::with(|cs| WAKE.borrow(cs).set(Some(wake)));
}

/// The transmit interrupt's handler (`bind_bxcan_interrupts!` binds it; module
/// documentation).
pub struct TransmitWake;

impl<I: Interrupt> Handler<I> for TransmitWake {
    unsafe fn on_interrupt() {
        if let Some(regs) = rx_stamp::regs() {
            regs.ier().modify(|w| w.set_tmeie(false));
        }
        if let Some(wake) = critical_section::with(|cs| WAKE.borrow(cs).get()) {
            wake();
        }
    }
}
