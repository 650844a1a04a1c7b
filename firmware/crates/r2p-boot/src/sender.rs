//! The sending side of a [`crate::transfer`]: what `r2p update` runs. Sans-IO: the caller sends
//! what [`Sender::poll`] returns, passes every status it hears to [`Sender::on_status`], and
//! calls `poll` again as time passes.

use crate::transfer::{Msg, State, Status, BLOCK_MAX};
use crate::Refusal;

/// Blocks in flight by default: one. A module writes each block as it arrives, and an F103's
/// CPU stops while its flash programs (1.3 ms for a block) or erases (20–40 ms for a page): the
/// frames of a second block in flight (8 or 9) arrive then and overflow its receive FIFOs
/// (2 × 3 frames), the block is lost whole and the sender waits out its timeout. Measured on the emulated Triskar2
/// (`make bench`, a 52 KB image): 7.7 KiB/s with one block in flight, 0.15 with two, 1.4 with
/// eight (most blocks sent twice or more).
pub const DEFAULT_WINDOW: u32 = 1;

/// Where a transfer stands on the sender.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Asking the receiver to begin.
    Beginning,
    /// Sending blocks.
    Sending,
    /// Every byte acknowledged; asking for the check.
    Ending,
    /// The module holds the image, verified.
    Done,
    /// The module refused it.
    Refused(Refusal),
}

/// The sender.
pub struct Sender<'a> {
    image: &'a [u8],
    id: u16,
    window: u32,
    timeout_ms: u64,
    phase: Phase,
    /// Bytes the receiver has acknowledged (in order).
    acked: u32,
    /// The next byte to send.
    next: u32,
    /// When the last message went out while nothing was outstanding, or progress was last heard.
    last_progress_ms: u64,
    /// When the last control message (begin, end) or go-back happened.
    last_sent_ms: Option<u64>,
    /// Times the sender went back for want of an answer.
    pub timeouts: u32,
    /// Times it went back because the receiver said it still waits for a block.
    pub fast_goes_back: u32,
    repeats: u32,
    went_back_at: Option<u32>,
    /// Times the receiver had lost its place and the transfer began again.
    pub restarts: u32,
}

impl<'a> Sender<'a> {
    /// Sends `image` (a signed image: image then trailer) as transfer `id`, with up to `window`
    /// blocks unacknowledged, going back after `timeout_ms` without progress.
    pub fn new(image: &'a [u8], id: u16, window: u32, timeout_ms: u64) -> Self {
        Self {
            image,
            id,
            window: window.max(1),
            timeout_ms,
            phase: Phase::Beginning,
            acked: 0,
            next: 0,
            last_progress_ms: 0,
            last_sent_ms: None,
            timeouts: 0,
            fast_goes_back: 0,
            repeats: 0,
            went_back_at: None,
            restarts: 0,
        }
    }

    /// Where the transfer stands.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Bytes acknowledged and in all: the progress bar's numbers.
    pub fn progress(&self) -> (u32, u32) {
        (self.acked, self.image.len() as u32)
    }

    /// The next message to send at `now_ms`, if any.
    pub fn poll(&mut self, now_ms: u64) -> Option<Msg<'a>> {
        let stale = |since: Option<u64>| since.is_none_or(|t| now_ms >= t + self.timeout_ms);
        match self.phase {
            Phase::Beginning if stale(self.last_sent_ms) => {
                self.count_timeout();
                self.last_sent_ms = Some(now_ms);
                Some(Msg::Begin { id: self.id, len: self.image.len() as u32 })
            }
            Phase::Sending => {
                if self.next > self.acked && now_ms >= self.last_progress_ms + self.timeout_ms {
                    self.timeouts += 1;
                    self.next = self.acked; // go back
                    self.last_progress_ms = now_ms;
                }
                let in_flight = (self.next - self.acked).div_ceil(BLOCK_MAX as u32);
                if in_flight >= self.window || self.next as usize >= self.image.len() {
                    return None;
                }
                if self.next == self.acked {
                    self.last_progress_ms = now_ms;
                }
                let start = self.next as usize;
                let end = (start + BLOCK_MAX).min(self.image.len());
                self.next = end as u32;
                Some(Msg::Block {
                    id: self.id,
                    offset: start as u32,
                    data: &self.image[start..end],
                })
            }
            Phase::Ending if stale(self.last_sent_ms) => {
                self.count_timeout();
                self.last_sent_ms = Some(now_ms);
                Some(Msg::End { id: self.id })
            }
            _ => None,
        }
    }

    fn count_timeout(&mut self) {
        if self.last_sent_ms.is_some() {
            self.timeouts += 1;
        }
    }

    /// A status heard from the receiver at `now_ms`.
    pub fn on_status(&mut self, s: &Status, now_ms: u64) {
        if matches!(self.phase, Phase::Done | Phase::Refused(_)) {
            return;
        }
        if s.id != self.id || s.state == State::Idle {
            // Another transfer's, or a receiver that forgot ours (it rebooted): begin again.
            if self.phase != Phase::Beginning && s.state == State::Idle {
                self.restart();
            }
            return;
        }
        match s.state {
            State::Refused(r) => self.phase = Phase::Refused(r),
            State::Verified => self.phase = Phase::Done,
            State::Receiving => {
                if self.phase == Phase::Beginning && s.received == 0 {
                    self.phase = Phase::Sending;
                    self.acked = 0;
                    self.next = 0;
                    self.last_progress_ms = now_ms;
                } else if self.phase == Phase::Sending
                    && s.received == self.acked
                    && self.next > self.acked
                {
                    // The receiver is waiting for the block at `acked`: it was lost. Go back at
                    // the second such answer (the first may be the answer to a block sent just
                    // before the status), once per gap, rather than waiting for the timeout.
                    self.repeats += 1;
                    if self.repeats == 2 && self.went_back_at != Some(self.acked) {
                        self.went_back_at = Some(self.acked);
                        self.next = self.acked;
                        self.fast_goes_back += 1;
                    }
                } else if self.phase == Phase::Sending && s.received > self.acked {
                    self.repeats = 0;
                    self.acked = s.received.min(self.image.len() as u32);
                    self.next = self.next.max(self.acked);
                    self.last_progress_ms = now_ms;
                    if self.acked as usize == self.image.len() {
                        self.phase = Phase::Ending;
                        self.last_sent_ms = None;
                    }
                }
                // A count below what was acknowledged is an older status arriving late: ignored.
            }
            State::Idle => {}
        }
    }

    fn restart(&mut self) {
        self.restarts += 1;
        // A new transfer ID: statuses still in flight from the old one are then ignored.
        self.id = self.id.wrapping_add(1).max(1);
        self.phase = Phase::Beginning;
        self.acked = 0;
        self.next = 0;
        self.last_sent_ms = None;
        self.repeats = 0;
        self.went_back_at = None;
    }
}
