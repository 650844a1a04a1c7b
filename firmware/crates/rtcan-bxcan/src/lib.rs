//! [`rtcan::CanController`] for the STM32 bxCAN peripheral (F103 modules, F407 gateway).
//!
//! Wraps embassy-stm32's `Can` driver for reception and filters; transmission goes through the
//! PAC, because RTCAN needs what embassy-stm32 0.6 does not give: the result of every frame
//! (the `TXOK`/`ALST`/`TERR` bits of `CAN_TSR`), one-shot transmission (`NART` in `CAN_MCR`;
//! embassy's `set_automatic_retransmit` writes the bit inverted) and an abort that does not
//! wait for a frame on the wire to end. Transmit mailboxes are scheduled first-in first-out
//! (`TXFP`) so RTCAN's own queue decides the order (the hardware's lowest-ID-first scheduling
//! could swap a frame into a mailbox behind RTCAN's back). Error counters and bus-off come from
//! the `ESR` register.
//!
//! Received frames are stamped at their start of frame: time-triggered mode's counter captured
//! by the hardware, related to the node's clock by the receive interrupt ([`RxStamp`],
//! `rtcan::time_counter`).
#![no_std]
#![warn(missing_docs)]

mod rx_stamp;
pub use rx_stamp::RxStamp;

use embassy_stm32::can::filter::{BankConfig, Mask32};
use embassy_stm32::can::{self, ExtendedId, Fifo};
use embassy_stm32::pac;
use embassy_stm32::pac::can::vals::{Ide, Rtr};
use rtcan::controller::{
    BusState, ErrorCounters, Filter, Received, TxError, TxMode, TxOutcome, TxResult, TX_RESULTS,
};
use rtcan::time_counter::{valid_at_bits, TimeCounter};
use rtcan::{CanController, Frame, FrameId};

/// Filter banks RTCAN uses: all of the F103's, and CAN1's share on the F407 (split at 14).
pub const FILTER_BANKS: usize = 14;

/// Transmit mailboxes of a bxCAN.
const MAILBOXES: usize = 3;

/// `CAN_TSR` reads after an abort request before the driver stops waiting for the mailboxes
/// that were not on the wire to empty (RM0008 §24.7.1: a pending or scheduled mailbox is
/// aborted at once; one in transmit state empties when its frame ends, which is not waited for).
const ABORT_POLLS: u32 = 64;

/// Finished frames' results not taken yet, oldest first.
struct Results {
    buf: [Option<TxResult>; TX_RESULTS],
    head: usize,
    len: usize,
}

impl Results {
    const fn new() -> Self {
        Self { buf: [None; TX_RESULTS], head: 0, len: 0 }
    }

    /// Adds `r`, dropping the oldest result if full.
    fn push(&mut self, r: TxResult) {
        if self.len == TX_RESULTS {
            self.head = (self.head + 1) % TX_RESULTS;
            self.len -= 1;
        }
        self.buf[(self.head + self.len) % TX_RESULTS] = Some(r);
        self.len += 1;
    }

    fn pop(&mut self) -> Option<TxResult> {
        if self.len == 0 {
            return None;
        }
        let r = self.buf[self.head].take();
        self.head = (self.head + 1) % TX_RESULTS;
        self.len -= 1;
        r
    }
}

/// An enabled bxCAN peripheral driven by RTCAN.
pub struct BxCan<'d> {
    can: can::Can<'d>,
    regs: pac::can::Can,
    /// What each transmit mailbox was loaded with (identifier, load order) until its result is
    /// collected from `CAN_TSR`.
    loaded: [Option<(FrameId, u32)>; MAILBOXES],
    seq: u32,
    results: Results,
    /// Frames dropped on receive because they were not RTCAN frames (standard IDs, remote frames).
    pub foreign_frames: u32,
    /// Relates the time-triggered counter to the node's clock (none at a bit rate whose bit
    /// time is not a whole number of µs).
    counter: Option<TimeCounter>,
    bit_rate: u32,
}

impl<'d> BxCan<'d> {
    /// Takes an enabled `Can` and its register block (`pac::CAN` on the F103, `pac::CAN1` on
    /// the F407), switches the transmit mailboxes to FIFO order and automatic retransmission,
    /// and accepts every frame.
    ///
    /// It also masks the transmit-mailbox-empty interrupt: embassy-stm32's handler for it
    /// acknowledges `RQCP`, which clears the `TXOK`/`ALST`/`TERR` bits this driver reads to
    /// report each frame's result. (The handler stays bound; it no longer fires.)
    ///
    /// Received frames reach the driver through [`RxStamp`], which the image binds to the
    /// receive interrupts before embassy's handlers. `bit_rate` is the bus's (bit/s): the
    /// time-triggered counter counts its bit times.
    pub fn new(mut can: can::Can<'d>, regs: pac::can::Can, bit_rate: u32) -> Self {
        can.set_tx_fifo_scheduling(true);
        enable_time_triggered_mode(regs);
        rx_stamp::attach(regs);
        regs.ier().modify(|w| w.set_tmeie(false));
        regs.mcr().modify(|w| w.set_nart(false));
        regs.tsr().write(|w| (0..MAILBOXES).for_each(|i| w.set_rqcp(i, true)));
        let mut this = Self {
            can,
            regs,
            loaded: [None; MAILBOXES],
            seq: 0,
            results: Results::new(),
            foreign_frames: 0,
            counter: TimeCounter::new(bit_rate),
            bit_rate: bit_rate.max(1),
        };
        this.set_filters(&[Filter::ACCEPT_ALL]);
        this
    }

    /// Received frames lost because the driver did not take them from the receive
    /// interrupt's ring in time.
    pub fn rx_overruns(&self) -> u32 {
        rx_stamp::overruns()
    }

    /// Moves the results of mailboxes that emptied since the last look into `results`, in
    /// the order their frames were loaded, and acknowledges them (`RQCP`).
    fn collect(&mut self) {
        let tsr = self.regs.tsr().read();
        let mut done = [(u32::MAX, 0usize); MAILBOXES];
        let mut n = 0;
        for (i, l) in self.loaded.iter().enumerate() {
            if let (Some((_, seq)), true) = (l, tsr.tme(i)) {
                done[n] = (*seq, i);
                n += 1;
            }
        }
        let done = &mut done[..n];
        done.sort_unstable();
        for &(_, i) in done.iter() {
            let Some((id, _)) = self.loaded[i].take() else { continue };
            let outcome = if tsr.txok(i) {
                TxOutcome::Sent
            } else if tsr.alst(i) {
                TxOutcome::LostArbitration
            } else if tsr.terr(i) {
                TxOutcome::Error
            } else {
                TxOutcome::Aborted
            };
            self.regs.tsr().write(|w| w.set_rqcp(i, true));
            self.results.push(TxResult { id, outcome });
        }
    }
}

/// Polls of `CAN_MSR.INAK` before giving up on entering or leaving initialisation mode (leaving
/// waits for 11 recessive bits on the bus).
const INIT_POLLS: u32 = 100_000;

/// Sets `CAN_MCR.TTCM` (its counter then captures every frame's start of frame) in
/// initialisation mode, then returns to normal mode.
fn enable_time_triggered_mode(regs: pac::can::Can) {
    regs.mcr().modify(|w| w.set_inrq(true));
    for _ in 0..INIT_POLLS {
        if regs.msr().read().inak() {
            break;
        }
    }
    regs.mcr().modify(|w| w.set_ttcm(true));
    regs.mcr().modify(|w| w.set_inrq(false));
    for _ in 0..INIT_POLLS {
        if !regs.msr().read().inak() {
            break;
        }
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
        self.collect();
        // An empty mailbox whose result was collected: loading one with an uncollected result
        // would clear it (`RQCP` is cleared when `TXRQ` is set).
        let tsr = self.regs.tsr().read();
        let free = (0..MAILBOXES).find(|&i| tsr.tme(i) && self.loaded[i].is_none());
        let Some(i) = free else { return Err(TxError::MailboxesFull) };
        let raw = frame.id().to_raw();
        let mut data = [0u8; 8];
        data[..frame.payload().len()].copy_from_slice(frame.payload());
        let mb = self.regs.tx(i);
        mb.tdtr().write(|w| w.set_dlc(frame.payload().len() as u8));
        mb.tdlr().write(|w| w.0 = u32::from_le_bytes([data[0], data[1], data[2], data[3]]));
        mb.tdhr().write(|w| w.0 = u32::from_le_bytes([data[4], data[5], data[6], data[7]]));
        mb.tir().write(|w| {
            w.set_stid((raw >> 18) as u16);
            w.set_exid(raw & 0x3_ffff);
            w.set_ide(Ide::EXTENDED);
            w.set_rtr(Rtr::DATA);
            w.set_txrq(true);
        });
        self.loaded[i] = Some((frame.id(), self.seq));
        self.seq = self.seq.wrapping_add(1);
        Ok(())
    }

    /// Writes `NART` (RM0008 §24.9.2; it names no mode restriction for this bit, as it does for
    /// `CAN_BTR`). The node changes the mode only with its mailboxes empty.
    fn set_tx_mode(&mut self, mode: TxMode) {
        self.regs.mcr().modify(|w| w.set_nart(mode == TxMode::OneShot));
    }

    fn take_tx_result(&mut self) -> Option<TxResult> {
        self.collect();
        self.results.pop()
    }

    /// The oldest frame the receive interrupt captured, stamped at its start of frame.
    fn try_receive(&mut self) -> Option<Received> {
        while let Some(c) = rx_stamp::take() {
            let Some(Ok(frame)) =
                c.raw_id.map(|id| Frame::from_raw(id, &c.data[..usize::from(c.len)]))
            else {
                self.foreign_frames = self.foreign_frames.wrapping_add(1);
                continue;
            };
            let now = embassy_time::Instant::now().as_micros();
            let at = match &mut self.counter {
                Some(tc) => tc.stamp_received(&frame, c.time, c.stamped_at, now),
                // No whole-µs bit time: the interrupt's stamp less the frame's length (late by
                // the interrupt's latency).
                None => c
                    .stamped_at
                    .saturating_sub(u64::from(valid_at_bits(&frame) * (1_000_000 / self.bit_rate))),
            };
            return Some(Received { frame, at });
        }
        None
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

    /// Requests the abort of every loaded mailbox (`ABRQ`) and waits only for those not on the
    /// wire, which empty at once; the one in transmit state (`CAN_MSR.TXM`) ends on its own and
    /// its result is collected later.
    fn abort_pending(&mut self) -> usize {
        self.collect();
        let tsr = self.regs.tsr().read();
        let asked: [bool; MAILBOXES] =
            core::array::from_fn(|i| self.loaded[i].is_some() && !tsr.tme(i));
        if !asked.contains(&true) {
            return 0;
        }
        self.regs.tsr().write(|w| (0..MAILBOXES).for_each(|i| w.set_abrq(i, asked[i])));
        let mut tsr = self.regs.tsr().read();
        for _ in 0..ABORT_POLLS {
            let waiting = (0..MAILBOXES).filter(|&i| asked[i] && !tsr.tme(i)).count();
            if waiting == 0 || (waiting == 1 && self.regs.msr().read().txm()) {
                break;
            }
            tsr = self.regs.tsr().read();
        }
        let aborted = (0..MAILBOXES).filter(|&i| asked[i] && tsr.tme(i) && !tsr.txok(i)).count();
        self.collect();
        aborted
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
