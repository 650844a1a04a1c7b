//! [`bind_bxcan_interrupts!`](crate::bind_bxcan_interrupts): an image's interrupt bindings with
//! the bxCAN's four written once, for every MCU (the F103's and the F407's interrupts have other
//! names).
//!
//! The receive FIFOs go to [`RxStamp`](crate::RxStamp) alone: it stamps each frame's start of
//! frame and empties the FIFOs. embassy-stm32's receive handler after it would mask the FIFO's
//! interrupt (`FMPIE`), which only embassy's `read` unmasks — the driver never calls it — so an
//! image would stop hearing frames after each FIFO's first interrupt. The transmit interrupt goes
//! to [`TransmitWake`](crate::TransmitWake): masked unless a node on frame-sized reservations
//! arms it (crate feature `transmit-wake`; without it, [`UnusedIrq`](crate::UnusedIrq)). The
//! status change interrupt goes to [`UnusedIrq`](crate::UnusedIrq) (the driver reads the error
//! counters itself). embassy-stm32's `Can::new` still asks for its four handlers' bindings: the
//! macro declares them, since none of them is needed.

/// Binds an image's interrupts, as `embassy_stm32::bind_interrupts!` does, with the bxCAN's four
/// named once (module documentation). Any others the image needs follow the `;`:
///
/// ```ignore
/// rtcan_bxcan::bind_bxcan_interrupts!(struct Irqs {
///     can: CAN1, rx0: CAN1_RX0, rx1: CAN1_RX1, sce: CAN1_SCE, tx: CAN1_TX;
///     ETH => eth::InterruptHandler;
/// });
/// ```
#[macro_export]
macro_rules! bind_bxcan_interrupts {
    (struct $name:ident {
        can: $can:ident, rx0: $rx0:ident, rx1: $rx1:ident, sce: $sce:ident, tx: $tx:ident;
        $($others:tt)*
    }) => {
        $crate::__private::embassy_stm32::bind_interrupts!(struct $name {
            $rx0 => $crate::RxStamp;
            $rx1 => $crate::RxStamp;
            $sce => $crate::UnusedIrq;
            $tx => $crate::TransmitWake;
            $($others)*
        });
        $crate::__bxcan_bindings!($name, $can,
            $rx0 => Rx0InterruptHandler, $rx1 => Rx1InterruptHandler,
            $tx => TxInterruptHandler, $sce => SceInterruptHandler);
    };
}

/// The bindings embassy-stm32's `Can::new` asks for, one per interrupt (not an API).
#[doc(hidden)]
#[macro_export]
macro_rules! __bxcan_bindings {
    ($name:ident, $can:ident, $($irq:ident => $handler:ident),*) => {
        $(
            // SAFETY: embassy-stm32's `Can::new` asks for its handlers; the driver needs none
            // of them (module documentation of `rtcan_bxcan::bind`).
            unsafe impl $crate::__private::embassy_stm32::interrupt::typelevel::Binding<
                $crate::__private::embassy_stm32::interrupt::typelevel::$irq,
                $crate::__private::embassy_stm32::can::$handler<$crate::__private::embassy_stm32::peripherals::$can>,
            > for $name {}
        )*
    };
}

/// What [`bind_bxcan_interrupts!`](crate::bind_bxcan_interrupts) names from the image's point
/// of view (not an API).
#[doc(hidden)]
pub mod __private {
    pub use embassy_stm32;
}
