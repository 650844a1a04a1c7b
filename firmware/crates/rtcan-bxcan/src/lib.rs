//! [`rtcan::CanController`] for the STM32 bxCAN peripheral (F103 modules, F407 gateway).
//!
//! Wraps embassy-stm32's `Can` driver. Transmit mailboxes are scheduled first-in first-out so
//! RTCAN's own queue decides the order (the hardware's lowest-ID-first scheduling could swap a
//! frame into a mailbox behind RTCAN's back). Error counters and bus-off come from the ESR
//! register through the PAC, which embassy-stm32 0.6 does not expose otherwise.
#![no_std]
#![warn(missing_docs)]

use embassy_stm32::can::enums::TryReadError;
use embassy_stm32::can::filter::{BankConfig, Mask32};
use embassy_stm32::can::{self, ExtendedId, Fifo, Id, TryWriteError};
use embassy_stm32::pac;
use rtcan::controller::{BusState, ErrorCounters, Filter, Received, TxError};
use rtcan::{CanController, Frame};

/// Filter banks RTCAN uses: all of the F103's, and CAN1's share on the F407 (split at 14).
pub const FILTER_BANKS: usize = 14;

/// An enabled bxCAN peripheral driven by RTCAN.
pub struct BxCan<'d> {
    can: can::Can<'d>,
    regs: pac::can::Can,
    /// Frames dropped on receive because they were not RTCAN frames (standard IDs, remote frames).
    pub foreign_frames: u32,
}

impl<'d> BxCan<'d> {
    /// Takes an enabled `Can` and its register block (`pac::CAN` on the F103, `pac::CAN1` on
    /// the F407), switches the transmit mailboxes to FIFO order and accepts every frame.
    pub fn new(mut can: can::Can<'d>, regs: pac::can::Can) -> Self {
        can.set_tx_fifo_scheduling(true);
        let mut this = Self { can, regs, foreign_frames: 0 };
        this.set_filters(&[Filter::ACCEPT_ALL]);
        this
    }
}

fn bank(f: &Filter) -> BankConfig {
    let id = ExtendedId::new(f.value & ExtendedId::MAX.as_raw()).unwrap_or(ExtendedId::ZERO);
    let mask = ExtendedId::new(f.mask & ExtendedId::MAX.as_raw()).unwrap_or(ExtendedId::ZERO);
    Mask32::frames_with_ext_id(id, mask).into()
}

impl CanController for BxCan<'_> {
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        if self.bus_state() == BusState::BusOff {
            return Err(TxError::BusOff);
        }
        let Ok(hw) = can::Frame::new_extended(frame.id().to_raw(), frame.payload()) else {
            // Unreachable: Frame guarantees a 29-bit ID and at most 8 bytes.
            return Err(TxError::MailboxesFull);
        };
        match self.can.try_write(&hw) {
            Ok(_) => Ok(()),
            Err(TryWriteError::Full) => Err(TxError::MailboxesFull),
        }
    }

    fn try_receive(&mut self) -> Option<Received> {
        loop {
            match self.can.try_read() {
                Ok(env) => {
                    let raw = match env.frame.id() {
                        Id::Extended(id) if !env.frame.header().rtr() => id.as_raw(),
                        _ => {
                            self.foreign_frames = self.foreign_frames.wrapping_add(1);
                            continue;
                        }
                    };
                    match Frame::from_raw(raw, env.frame.data()) {
                        Ok(frame) => return Some(Received { frame, at: env.ts.as_micros() }),
                        Err(_) => self.foreign_frames = self.foreign_frames.wrapping_add(1),
                    }
                }
                Err(TryReadError::Empty) => return None,
                // A bus error is reflected in the error counters; keep reading.
                Err(TryReadError::BusError(_)) => continue,
            }
        }
    }

    fn set_filters(&mut self, filters: &[Filter]) {
        let mut banks = self.can.modify_filters();
        banks.clear();
        if filters.len() > FILTER_BANKS {
            // Too many to express: widen to everything; RTCAN filters again in software.
            banks.enable_bank(0, Fifo::Fifo0, bank(&Filter::ACCEPT_ALL));
            return;
        }
        for (i, f) in filters.iter().enumerate() {
            let fifo = if i % 2 == 0 { Fifo::Fifo0 } else { Fifo::Fifo1 };
            banks.enable_bank(i as u8, fifo, bank(f));
        }
    }

    fn abort_pending(&mut self) -> usize {
        [can::Mailbox::Mailbox0, can::Mailbox::Mailbox1, can::Mailbox::Mailbox2]
            .into_iter()
            .filter(|&mb| self.can.abort(mb))
            .count()
    }

    fn bus_state(&self) -> BusState {
        let esr = self.regs.esr().read();
        if esr.boff() {
            BusState::BusOff
        } else if esr.epvf() {
            BusState::ErrorPassive
        } else {
            BusState::ErrorActive
        }
    }

    fn error_counters(&self) -> ErrorCounters {
        let esr = self.regs.esr().read();
        ErrorCounters { tx: esr.tec(), rx: esr.rec() }
    }
}
