//! [`rtcan::CanController`] for the STM32 bxCAN peripheral (F103 modules, F407 gateway).
//!
//! With the `stm32` feature (the MCU workspaces) the crate is the driver, [`BxCan`]: it wraps
//! embassy-stm32's `Can` driver for reception and filters; transmission goes through the PAC,
//! because RTCAN needs what embassy-stm32 0.6 does not give: the result of every frame (the
//! `TXOK`/`ALST`/`TERR` bits of `CAN_TSR`), one-shot transmission (`NART` in `CAN_MCR`;
//! embassy's `set_automatic_retransmit` writes the bit inverted) and an abort that does not
//! wait for a frame on the wire to end. Transmit mailboxes are scheduled first-in first-out
//! (`TXFP`) so RTCAN's own queue decides the order (the hardware's lowest-ID-first scheduling
//! could swap a frame into a mailbox behind RTCAN's back). Error counters and bus-off come from
//! the `ESR` register.
//!
//! Frames are stamped at their start of frame, received and sent: time-triggered mode's
//! counter captured by the hardware, related to the node's clock by the receive interrupt
//! ([`RxStamp`], `rtcan::time_counter`).
//!
//! Without the feature it is the driver's logic that needs no peripheral — mailbox
//! bookkeeping, the receive ring, the filter-bank plan, the stamps — tested on the host.
#![no_std]
#![warn(missing_docs)]

pub mod filter_plan;
pub mod mailboxes;
pub mod results;
pub mod rx_ring;
pub mod staged_loads;
pub mod stamps;

#[cfg(feature = "stm32")]
#[doc(hidden)]
pub mod bind;
#[cfg(feature = "stm32")]
mod driver;
#[cfg(feature = "stm32")]
mod rx_stamp;
#[cfg(feature = "transmit-wake")]
mod transmit_wake;
#[cfg(feature = "stm32")]
mod unused_irq;

#[cfg(feature = "stm32")]
#[doc(hidden)]
pub use bind::__private;
#[cfg(feature = "stm32")]
pub use driver::BxCan;
pub use filter_plan::FILTER_BANKS;
#[cfg(feature = "stm32")]
pub use rx_stamp::RxStamp;
#[cfg(feature = "transmit-wake")]
pub use transmit_wake::TransmitWake;
/// The transmit interrupt's handler: without the feature `transmit-wake` the interrupt stays
/// masked, and [`UnusedIrq`] stands in.
#[cfg(all(feature = "stm32", not(feature = "transmit-wake")))]
pub type TransmitWake = UnusedIrq;
#[cfg(feature = "stm32")]
pub use unused_irq::UnusedIrq;
