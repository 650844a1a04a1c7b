//! [`BxCan`]: the driver, on the peripheral's registers and embassy-stm32's `Can`.

use embassy_stm32::can::filter::{BankConfig, Mask32};
use embassy_stm32::can::{self, ExtendedId, Fifo};
use embassy_stm32::pac;
use embassy_stm32::pac::can::vals::{Ide, Rtr};
use rtcan::controller::{BusState, ErrorCounters, Filter, Received, TxError, TxMode, TxResult};
use rtcan::time_counter::TimeCounter;
use rtcan::{CanController, Frame};

use crate::filter_plan::{bank_plan, RxFifo};
use crate::mailboxes::{withdrawn, MailboxStatus, Mailboxes, MAILBOXES};
use crate::results::Results;
use crate::rx_stamp;
use crate::stamps::received_start_of_frame;

/// `CAN_TSR` reads after an abort request before the driver stops waiting for the mailboxes
/// that were not on the wire to empty (RM0008 §24.7.1: a pending or scheduled mailbox is
/// aborted at once; one in transmit state empties when its frame ends, which is not waited for).
const ABORT_POLLS: u32 = 64;

/// Polls of `CAN_MSR.INAK` before giving up on entering or leaving initialisation mode (leaving
/// waits for 11 recessive bits on the bus).
const INIT_POLLS: u32 = 100_000;

/// An enabled bxCAN peripheral driven by RTCAN.
pub struct BxCan<'d> {
    can: can::Can<'d>,
    regs: pac::can::Can,
    mailboxes: Mailboxes,
    results: Results,
    /// Frames dropped on receive because they were not RTCAN frames (standard IDs, remote frames).
    pub foreign_frames: u32,
    /// Relates the time-triggered counter to the node's clock (none at a bit rate whose bit
    /// time is not a whole number of µs).
    counter: Option<TimeCounter>,
    bit_rate: u32,
    /// Staged frames the transmit interrupt loaded, booked and not yet told to the node
    /// ([`CanController::staged_loaded`]).
    #[cfg(feature = "staged-reloads")]
    staged_in: usize,
}

/// `CAN_TSR` as each mailbox's status.
fn mailbox_status(regs: pac::can::Can) -> [MailboxStatus; MAILBOXES] {
    status_of(regs.tsr().read())
}

/// Each mailbox's status in a `CAN_TSR` value.
#[inline(always)]
pub(crate) fn status_of(tsr: pac::can::regs::Tsr) -> [MailboxStatus; MAILBOXES] {
    core::array::from_fn(|i| MailboxStatus {
        empty: tsr.tme(i),
        txok: tsr.txok(i),
        alst: tsr.alst(i),
        terr: tsr.terr(i),
    })
}

impl<'d> BxCan<'d> {
    /// Takes an enabled `Can` and its register block (`pac::CAN` on the F103, `pac::CAN1` on
    /// the F407), switches the transmit mailboxes to FIFO order and automatic retransmission,
    /// and accepts every frame.
    ///
    /// It also masks the transmit-mailbox-empty interrupt: embassy-stm32's handler for it
    /// acknowledges `RQCP`, which clears the `TXOK`/`ALST`/`TERR` bits this driver reads to
    /// report each frame's result. (Images bind [`crate::TransmitWake`] to it instead, which
    /// only runs once [`arm_transmit_wake`](Self::arm_transmit_wake) unmasks it.)
    ///
    /// Received frames reach the driver through [`crate::RxStamp`], which the image binds to
    /// the receive interrupts before embassy's handlers. `bit_rate` is the bus's (bit/s): the
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
            mailboxes: Mailboxes::new(),
            results: Results::new(),
            foreign_frames: 0,
            counter: TimeCounter::new(bit_rate),
            bit_rate: bit_rate.max(1),
            #[cfg(feature = "staged-reloads")]
            staged_in: 0,
        };
        this.set_filters(&[Filter::ACCEPT_ALL]);
        this
    }

    /// Calls `wake` from the transmit interrupt when a frame leaves its mailbox, once per
    /// [`arm_transmit_wake`](Self::arm_transmit_wake) ([`crate::TransmitWake`]).
    #[cfg(feature = "transmit-wake")]
    pub fn on_transmit(&mut self, wake: fn()) {
        crate::transmit_wake::set(wake);
    }

    /// Unmasks the transmit-mailbox-empty interrupt (`TMEIE`) until it next fires: at once if
    /// a mailbox finished since its result was last taken.
    #[cfg(feature = "transmit-wake")]
    pub fn arm_transmit_wake(&mut self) {
        self.regs.ier().modify(|w| w.set_tmeie(true));
    }

    /// Received frames lost because the driver did not take them from the receive
    /// interrupt's ring in time.
    pub fn rx_overruns(&self) -> u32 {
        rx_stamp::overruns()
    }

    /// Books the frames the transmit interrupt loaded since the last look as loaded, after
    /// every frame booked before (they went in after those: into an empty controller); with
    /// `stop`, an interrupt under way stops (`CanController::staged_loaded`).
    #[cfg(feature = "staged-reloads")]
    fn book_staged_loads(&mut self, stop: bool) {
        crate::transmit_wake::take_staged_loads(stop, |i, id| {
            self.mailboxes.load(i, id);
            self.staged_in += 1;
        });
    }

    /// Moves the results of mailboxes that emptied since the last look into `results`, in
    /// the order their frames were loaded, and acknowledges them (`RQCP`). A sent frame's
    /// start of frame is its `CAN_TDTxR.TIME`, extended by the counter.
    fn collect(&mut self) {
        #[cfg(feature = "staged-reloads")]
        self.book_staged_loads(false);
        let status = mailbox_status(self.regs);
        let (done, n) = self.mailboxes.take_finished(&status);
        for &(i, id) in &done[..n] {
            let mut r = TxResult::new(id, status[i].outcome());
            if let (true, Some(tc)) = (r.sent(), &self.counter) {
                let capture = self.regs.tx(i).tdtr().read().time();
                let now = embassy_time::Instant::now().as_micros();
                r.start_of_frame = tc.start_of_frame(capture, now);
            }
            self.regs.tsr().write(|w| w.set_rqcp(i, true));
            self.results.push(r);
        }
    }
}

/// A frame as a transmit mailbox's registers, made before they are written (the transmit
/// interrupt makes them outside its critical sections).
#[derive(Clone, Copy)]
pub(crate) struct MailboxRegisters {
    tdtr: pac::can::regs::Tdtr,
    tdlr: u32,
    tdhr: u32,
    tir: pac::can::regs::Tir,
}

impl MailboxRegisters {
    /// `frame`'s registers, its transmission requested (`TXRQ`).
    #[inline(always)]
    pub(crate) fn of(frame: &Frame) -> Self {
        let raw = frame.id().to_raw();
        let mut data = [0u8; 8];
        data[..frame.payload().len()].copy_from_slice(frame.payload());
        let mut tdtr = pac::can::regs::Tdtr(0);
        tdtr.set_dlc(frame.payload().len() as u8);
        let mut tir = pac::can::regs::Tir(0);
        tir.set_stid((raw >> 18) as u16);
        tir.set_exid(raw & 0x3_ffff);
        tir.set_ide(Ide::EXTENDED);
        tir.set_rtr(Rtr::DATA);
        tir.set_txrq(true);
        Self {
            tdtr,
            tdlr: u32::from_le_bytes([data[0], data[1], data[2], data[3]]),
            tdhr: u32::from_le_bytes([data[4], data[5], data[6], data[7]]),
            tir,
        }
    }

    /// Writes them into mailbox `i`, the transmission request last.
    #[inline(always)]
    pub(crate) fn write(&self, regs: pac::can::Can, i: usize) {
        let mb = regs.tx(i);
        mb.tdtr().write_value(self.tdtr);
        mb.tdlr().write(|w| w.0 = self.tdlr);
        mb.tdhr().write(|w| w.0 = self.tdhr);
        mb.tir().write_value(self.tir);
    }
}

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
    let id = ExtendedId::new(f.value).unwrap_or(ExtendedId::ZERO);
    let mask = ExtendedId::new(f.mask).unwrap_or(ExtendedId::ZERO);
    Mask32::frames_with_ext_id(id, mask).into()
}

impl CanController for BxCan<'_> {
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        if self.bus_state() == BusState::BusOff {
            return Err(TxError::BusOff);
        }
        self.collect();
        let Some(i) = self.mailboxes.free(&mailbox_status(self.regs)) else {
            return Err(TxError::MailboxesFull);
        };
        MailboxRegisters::of(frame).write(self.regs, i);
        self.mailboxes.load(i, frame.id());
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
            let at = received_start_of_frame(
                self.counter.as_mut(),
                &frame,
                c.time,
                c.stamped_at,
                now,
                self.bit_rate,
            );
            return Some(Received { frame, at });
        }
        None
    }

    fn set_filters(&mut self, filters: &[Filter]) {
        let mut banks = self.can.modify_filters();
        banks.clear();
        for b in bank_plan(filters) {
            let fifo = match b.fifo {
                RxFifo::Fifo0 => Fifo::Fifo0,
                RxFifo::Fifo1 => Fifo::Fifo1,
            };
            banks.enable_bank(b.index, fifo, bank(&b.filter));
        }
    }

    /// Requests the abort of every loaded mailbox (`ABRQ`) and waits only for those not on the
    /// wire, which empty at once; the one in transmit state (`CAN_MSR.TXM`) ends on its own and
    /// its result is collected later.
    fn abort_pending(&mut self) -> usize {
        self.collect();
        let asked = self.mailboxes.pending(&mailbox_status(self.regs));
        if !asked.contains(&true) {
            return 0;
        }
        self.regs.tsr().write(|w| (0..MAILBOXES).for_each(|i| w.set_abrq(i, asked[i])));
        let mut status = mailbox_status(self.regs);
        for _ in 0..ABORT_POLLS {
            let waiting = (0..MAILBOXES).filter(|&i| asked[i] && !status[i].empty).count();
            if waiting == 0 || (waiting == 1 && self.regs.msr().read().txm()) {
                break;
            }
            status = mailbox_status(self.regs);
        }
        let aborted = withdrawn(&asked, &status);
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

    /// For [`crate::TransmitWake`] to load (`staged_loads`): with the mailbox of the node's
    /// newest frame, whose result says whether the last frame to leave was sent. It takes no
    /// result: one that came since the node's last look keeps `RQCP` set, so the interrupt
    /// fires when the bus task arms it.
    #[cfg(feature = "staged-reloads")]
    fn stage(&mut self, frames: &[rtcan::StagedFrame]) {
        crate::transmit_wake::stage(frames, self.mailboxes.newest());
    }

    /// Books the interrupt's loads without reading the mailboxes, and stops an interrupt under
    /// way: the node's call runs this first, before its reservation's frame (the results
    /// follow in its `settle`), and an interrupt it preempted must load nothing after.
    #[cfg(feature = "staged-reloads")]
    fn staged_loaded(&mut self) -> usize {
        self.book_staged_loads(true);
        core::mem::take(&mut self.staged_in)
    }
}
