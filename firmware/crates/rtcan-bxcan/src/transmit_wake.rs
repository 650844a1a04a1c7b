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
//!
//! With `staged-reloads` it first loads the frames the node staged
//! ([`crate::staged_loads`]: once the controller is empty and the node's newest frame was
//! sent). The bus task (TIM2, priority 0) preempts this interrupt (priority 1) and must not
//! find a mailbox half written or a load not booked: each frame goes in within a critical
//! section of its own, whose length is what it can add to the start of a reservation's frame
//! (docs/rtcan.md, "Staged reloads on the module").

use core::cell::Cell;

use critical_section::Mutex;
use embassy_stm32::interrupt::typelevel::{Handler, Interrupt};

use crate::rx_stamp;
#[cfg(feature = "staged-reloads")]
use crate::staged_loads::StagedLoads;

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
            #[cfg(feature = "staged-reloads")]
            load_staged(regs);
        }
        if let Some(wake) = critical_section::with(|cs| WAKE.borrow(cs).get()) {
            wake();
        }
    }
}

/// The frames the node staged, between the bus task and the interrupt.
#[cfg(feature = "staged-reloads")]
static STAGED: Mutex<core::cell::RefCell<StagedLoads>> =
    Mutex::new(core::cell::RefCell::new(StagedLoads::new()));

/// Replaces the staged frames (`BxCan::stage`); `newest`: the mailbox of the node's newest frame.
#[cfg(feature = "staged-reloads")]
pub(crate) fn stage(frames: &[rtcan::StagedFrame], newest: Option<usize>) {
    critical_section::with(|cs| STAGED.borrow_ref_mut(cs).stage(frames, newest));
}

/// Books what the interrupt loaded since the last call: `book(mailbox, identifier)` in load
/// order (`BxCan`'s collect, before it reads the mailboxes); with `stop`, an interrupt under
/// way stops too (the node's call begins: `StagedLoads::take_loaded`).
#[cfg(feature = "staged-reloads")]
pub(crate) fn take_staged_loads(stop: bool, mut book: impl FnMut(usize, rtcan::FrameId)) {
    critical_section::with(|cs| {
        STAGED.borrow_ref_mut(cs).take_loaded(stop).for_each(|(i, id)| book(i, id));
    });
}

/// The interrupt's loads ([`crate::staged_loads::load_staged`]: short critical sections, the
/// bus task waits for one frame's four register writes at most).
#[cfg(feature = "staged-reloads")]
fn load_staged(regs: embassy_stm32::pac::can::Can) {
    use crate::driver::MailboxRegisters;
    let tsr = regs.tsr().read();
    let status = crate::driver::status_of(tsr);
    let waiting = core::array::from_fn(|i| tsr.rqcp(i));
    crate::staged_loads::load_staged(
        &STAGED,
        &status,
        &waiting,
        || embassy_time::Instant::now().as_micros(),
        MailboxRegisters::of,
        |i, registers: &MailboxRegisters| registers.write(regs, i),
    );
}
