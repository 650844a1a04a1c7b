//! Reception with start-of-frame stamps: bxCAN's time-triggered counter captured at each
//! frame's start of frame (`CAN_RDTxR.TIME`, with `CAN_MCR.TTCM` set) and the node's clock read
//! first thing in the receive interrupt.
//!
//! embassy-stm32 0.6 with a time driver keeps only its own `Instant::now()` of a received
//! frame and drops `TIME`, so [`RxStamp`] is bound to the receive interrupts in place of
//! embassy's handlers (module-core's `bind_can_interrupts!`): it empties both FIFOs into a ring
//! with both stamps. embassy's handler must not follow it: in its non-buffered mode it masks
//! the FIFO's interrupt (`FMPIE`) on every call, and only its `read`, which the driver never
//! calls, unmasks it, so reception would stop after a FIFO's first interrupt. [`crate::BxCan`]
//! turns the pair into the start of frame with [`rtcan::time_counter::TimeCounter`].
//!
//! Until [`crate::BxCan::new`] attaches the registers the handler has nothing to drain; no
//! frame arrives before then: `BxCan::new` attaches them before it programs the first filter
//! (a bxCAN out of reset has no filter active and accepts nothing).

use core::cell::RefCell;

use critical_section::Mutex;
use embassy_stm32::interrupt::typelevel::{Handler, Interrupt};
use embassy_stm32::pac;
use embassy_stm32::pac::can::vals::{Ide, Rtr};

use crate::rx_ring::{Captured, RxRing};

struct Rx {
    regs: Option<pac::can::Can>,
    ring: RxRing,
}

static RX: Mutex<RefCell<Rx>> = Mutex::new(RefCell::new(Rx { regs: None, ring: RxRing::new() }));

/// Points the interrupt handler at `regs` and empties the ring.
pub(crate) fn attach(regs: pac::can::Can) {
    critical_section::with(|cs| {
        let mut r = RX.borrow_ref_mut(cs);
        r.regs = Some(regs);
        r.ring.clear();
    });
}

/// The controller's registers, once [`attach`]ed.
#[cfg(feature = "transmit-wake")]
pub(crate) fn regs() -> Option<pac::can::Can> {
    critical_section::with(|cs| RX.borrow_ref(cs).regs)
}

/// The oldest captured frame.
pub(crate) fn take() -> Option<Captured> {
    critical_section::with(|cs| RX.borrow_ref_mut(cs).ring.take())
}

/// Frames dropped because the ring was full.
pub(crate) fn overruns() -> u32 {
    critical_section::with(|cs| RX.borrow_ref(cs).ring.overruns())
}

/// The receive interrupts' handler (bind it to RX0 and RX1, before embassy's).
pub struct RxStamp;

impl<I: Interrupt> Handler<I> for RxStamp {
    unsafe fn on_interrupt() {
        drain();
    }
}

/// Empties both FIFOs into the ring (one copy for both interrupts). The FIFOs are this
/// interrupt's alone; only the ring is shared with the driver, so each frame's push is its
/// own short critical section, and the slot timer's interrupt (above this one) is held back
/// by one push at most, never by a whole drain.
#[inline(never)]
fn drain() {
    // First: this instant is the frame's valid point plus the interrupt's latency.
    let now = embassy_time::Instant::now().as_micros();
    let Some(regs) = critical_section::with(|cs| RX.borrow_ref(cs).regs) else { return };
    for fifo in 0..2 {
        while regs.rfr(fifo).read().fmp() != 0 {
            let mb = regs.rx(fifo);
            let rir = mb.rir().read();
            let rdtr = mb.rdtr().read();
            let lo = mb.rdlr().read().0.to_le_bytes();
            let hi = mb.rdhr().read().0.to_le_bytes();
            regs.rfr(fifo).modify(|w| w.set_rfom(true));
            let raw_id = (rir.ide() == Ide::EXTENDED && rir.rtr() == Rtr::DATA)
                .then(|| (u32::from(rir.stid()) & 0x7ff) << 18 | (rir.exid() & 0x3_ffff));
            let c = Captured {
                raw_id,
                len: rdtr.dlc().min(8),
                data: [lo[0], lo[1], lo[2], lo[3], hi[0], hi[1], hi[2], hi[3]],
                time: rdtr.time(),
                stamped_at: now,
            };
            critical_section::with(|cs| RX.borrow_ref_mut(cs).ring.push(c));
        }
    }
}
