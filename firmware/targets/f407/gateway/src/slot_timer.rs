//! The TDMA slot timer on the gateway: module-core's (firmware/targets/f103/module-core/src/
//! slot_timer.rs) on the F407's TIM5. Slot boundaries come from a compare of TIM5, whose
//! interrupt runs the bus executor at once, so the path from the boundary to the mailbox
//! request is one interrupt and the node's `slot_tick` — not embassy's timer queue and a second
//! interrupt to pend the executor: the base controller's HRT setpoints leave in their slots as
//! a module's HRT frames do (docs/rtcan.md "The slot timer on a module").
//!
//! TIM5 counts the time driver's 1 MHz ticks (TIM2, same APB1 timer clock and prescaler), so a
//! slot boundary in the node's µs is a compare value less a constant offset, measured once at
//! start; both counters are 32-bit here. The two prescalers run at a fixed phase to each other:
//! the offset may be one tick off, a constant bias below 1 µs, not jitter.

use core::future::poll_fn;
use core::task::Poll;

use embassy_stm32::interrupt;
use embassy_stm32::pac;
use embassy_stm32::peripherals::TIM5;
use embassy_stm32::time::Hertz;
use embassy_stm32::timer::low_level::Timer;
use embassy_stm32::Peri;
use embassy_sync::waitqueue::AtomicWaker;
use embassy_time::{Instant, TICK_HZ};

use crate::BUS_EXECUTOR;

const _: () = assert!(TICK_HZ == 1_000_000, "the slot timer counts the time driver's µs ticks");

/// Furthest ahead a compare is set: three quarters of the 32-bit counter, so that a target is
/// never mistaken for one a wrap earlier.
const MAX_AHEAD_TICKS: u64 = 0xC000_0000;

/// The bus task waiting for the compare.
static SLOT_WAKER: AtomicWaker = AtomicWaker::new();

#[path = "../../../shared/bus_wake.rs"]
mod bus_wake;
#[cfg(feature = "framed-reservations")]
pub use bus_wake::Woken;

/// Wakes the bus task before its time (frame-sized reservations: the transmit interrupt's and
/// the node's release wake, `Node::wakes_on_transmit`, `Node::wake_on_release`).
#[cfg(feature = "framed-reservations")]
pub fn wake_bus() {
    bus_wake::raise();
    SLOT_WAKER.wake();
}

/// TIM5's compare on channel 1 as the bus's slot timer.
pub struct SlotTimer {
    /// Owns TIM5 (and keeps its clock enabled).
    _tim: Timer<'static, TIM5>,
    /// (time driver ticks − TIM5 count) mod 2³².
    offset: u32,
    /// What ended the last [`wait_until`](Self::wait_until)`::<true>`.
    #[cfg(feature = "framed-reservations")]
    woken: Woken,
}

impl SlotTimer {
    /// Starts TIM5 at the time driver's tick rate, free-running over 32 bits, and relates it
    /// to the node's clock.
    pub fn new(tim: Peri<'static, TIM5>) -> Self {
        let mut t = Timer::new(tim);
        t.set_tick_freq(Hertz(TICK_HZ as u32));
        let r = pac::TIM5;
        r.arr().write_value(u32::MAX);
        r.dier().write(|w| w.set_ccie(0, false));
        t.start();
        Self {
            _tim: t,
            offset: relate(),
            #[cfg(feature = "framed-reservations")]
            woken: Woken::Timer,
        }
    }

    /// Returns at the node's time `at` (µs), woken by the compare interrupt (at once if `at`
    /// has passed); with `OR_EVENT`, sooner on [`wake_bus`] (at once if it came since the last
    /// return), which [`woken`](Self::woken) then tells. (Without, the body is the slot
    /// timer's alone: the bus task's future and poll are those of a wait for the compare.)
    pub async fn wait_until<const OR_EVENT: bool>(&mut self, at: u64) {
        #[cfg(feature = "framed-reservations")]
        {
            self.woken = Woken::Timer;
        }
        let r = pac::TIM5;
        loop {
            if OR_EVENT && bus_wake::take() {
                self.note_event();
                return;
            }
            let now = Instant::now().as_ticks();
            if at <= now {
                return;
            }
            let target = at.min(now + MAX_AHEAD_TICKS);
            r.ccr(0).write_value((target as u32).wrapping_sub(self.offset));
            r.sr().write(|w| {
                w.0 = !0;
                w.set_ccif(0, false);
            });
            r.dier().modify(|w| w.set_ccie(0, true));
            // The counter may have passed the compare value while it was written.
            if Instant::now().as_ticks() >= target {
                r.dier().modify(|w| w.set_ccie(0, false));
                continue;
            }
            poll_fn(|cx| {
                SLOT_WAKER.register(cx.waker());
                if r.dier().read().ccie(0) && !(OR_EVENT && bus_wake::pending()) {
                    Poll::Pending
                } else {
                    Poll::Ready(())
                }
            })
            .await;
            if OR_EVENT && bus_wake::take() {
                self.note_event();
                return;
            }
            if target == at {
                return;
            }
        }
    }
}

impl SlotTimer {
    /// What ended the last [`wait_until`](Self::wait_until)`::<true>`.
    #[cfg(feature = "framed-reservations")]
    pub fn woken(&self) -> Woken {
        self.woken
    }

    /// Notes that [`wake_bus`] ended the wait.
    #[inline(always)]
    fn note_event(&mut self) {
        #[cfg(feature = "framed-reservations")]
        {
            self.woken = Woken::Event;
        }
    }
}

/// (time driver ticks − TIM5 count) mod 2³², read between two equal readings of the clock.
fn relate() -> u32 {
    loop {
        let before = Instant::now().as_ticks();
        let cnt = pac::TIM5.cnt().read();
        if Instant::now().as_ticks() == before {
            return (before as u32).wrapping_sub(cnt);
        }
    }
}

/// The compare: wakes the bus task and runs the bus executor in this interrupt. (The executor
/// also pends this interrupt when the task is woken; that second entry finds no compare and
/// nothing to run.)
#[interrupt]
unsafe fn TIM5() {
    let r = pac::TIM5;
    if r.sr().read().ccif(0) && r.dier().read().ccie(0) {
        r.dier().modify(|w| w.set_ccie(0, false));
        r.sr().write(|w| {
            w.0 = !0;
            w.set_ccif(0, false);
        });
        SLOT_WAKER.wake();
    }
    // SAFETY: the interrupt is reserved for the bus executor (started in `main`).
    unsafe { BUS_EXECUTOR.on_interrupt() }
}
