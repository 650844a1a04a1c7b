//! RTCAN: a real-time protocol on classic CAN 2.0B (docs/rtcan.md is the specification).
//!
//! Hard-real-time (HRT) messages go in TDMA slots reserved by the bus master; soft-real-time
//! (SRT) messages carry their laxity in the identifier's most significant bits, so CAN's own
//! bitwise arbitration sends the most urgent one first; non-real-time (NRT) messages use the
//! lowest priority and are never promoted.
//!
//! `no_std`, no heap: it runs on an STM32F103 beside a module's application and on the host
//! for emulation and tools.
#![no_std]
#![warn(missing_docs)]

// Host tests (vectors, property tests) use std; the library itself never does.
#[cfg(test)]
extern crate std;

pub mod controller;
pub mod cycle;
pub mod failover;
pub mod filter_banks;
pub mod fragment;
pub mod frame;
pub mod framed_cycle;
pub mod id;
pub mod laxity;
pub mod layout;
pub mod schedule;
pub mod srt;
pub mod time_counter;
pub mod transfer_crc;
pub mod wire_bits;

pub use controller::{CanController, Micros, StagedFrame, TxMode, TxOutcome, TxResult};
pub use cycle::{CycleConfig, SlotClock, SyncFrame};
pub use failover::Failover;
pub use fragment::{fragments, Expect, Reassembler, ReassemblyStats};
pub use frame::Frame;
pub use id::{FrameId, IdError, MessageId};
pub use laxity::{FrameClass, Laxity, LaxityEncoding};
pub use schedule::{next_reserved, Period, Phase, Scheduler, StreamSlots};
pub use srt::{Missed, Ticket, TxQueue, Urgency};

/// The crate's test suite, compiled in for bare-metal runners (feature `selftest`).
#[cfg(any(test, feature = "selftest"))]
pub mod selftest {
    /// Every suite of the crate, in the order a runner should run them.
    pub const ALL: &[&[r2p_testkit::Case]] = &[
        crate::id::tests::SUITE,
        crate::laxity::tests::SUITE,
        crate::frame::tests::SUITE,
        crate::transfer_crc::tests::SUITE,
        crate::fragment::tests::SUITE,
        crate::srt::tests::SUITE,
        crate::cycle::tests::SUITE,
        crate::schedule::tests::SUITE,
        crate::layout::tests::SUITE,
        crate::framed_cycle::tests::SUITE,
        crate::failover::tests::SUITE,
        crate::filter_banks::tests::SUITE,
        crate::wire_bits::tests::SUITE,
        crate::time_counter::tests::SUITE,
        crate::controller::tests::SUITE,
    ];
}
