//! The gateway's CAN controller as its node sees it, with the bus copied to the network.
//!
//! [`BusTap::run`] wraps the controller for one call of the node runtime (`slot_tick`/`poll`)
//! and then loads a waiting client frame:
//!
//! - every frame the controller receives goes to the node and to the clients ([`BusLink`]);
//! - every frame the node sends goes to the clients once the controller reports it sent;
//! - a client's frame is loaded only when the node has nothing in the mailboxes, one at a time,
//!   so a client never takes a mailbox the node's next slot needs; once sent it goes to the
//!   other clients and is looped back to the node (a bxCAN does not receive its own frames:
//!   without this, `r2p param gateway …` through the gateway would never reach it). A client
//!   frame that loses arbitration or is withdrawn (the node's slot windows are one-shot) is
//!   tried again until it goes out, for up to [`CLIENT_PATIENCE_US`]: a host's controller
//!   would keep trying it, and the lowest-priority NRT frame of a tool loses to every frame of
//!   a burst after the sync (a fixed count of tries lost fragments of the tools' messages, and
//!   so whole advertisements and subscription answers). One that ends in an error frame is
//!   tried [`CLIENT_TRIES`] times in all;
//! - the acceptance filters stay open: the clients see every frame, the node filters again in
//!   software as RTCAN always does.
//!
//! The node's transmit results are its own: results of client frames never reach it.

use heapless::Deque;
use rtcan::controller::{
    BusState, CanController, ErrorCounters, Filter, Received, StagedFrame, TxError, TxMode,
    TxOutcome, TxResult,
};
use rtcan::{Frame, Micros};

use crate::link::{BusLink, LinkFrame, LinkStats, Source, BUS};
use r2p_socketcand::CanFrame;

/// Attempts at sending one client frame that end in an error frame before it is counted lost.
pub const CLIENT_TRIES: u8 = 3;
/// How long a client frame that keeps losing arbitration, or being withdrawn for the node's
/// slots, is tried again (from its first try) before it is counted lost: a busy bus delays an
/// NRT frame by milliseconds; a frame still waiting after this long waits for a bus that is
/// full, and the tools re-send their requests (every 300 ms) rather than wait for it.
pub const CLIENT_PATIENCE_US: Micros = 100_000;
/// Frames loaded and not yet reported, at most (bxCAN has 3 mailboxes; results untaken for
/// longer are dropped by the controller, and so here).
const IN_FLIGHT: usize = 6;
/// A loaded frame with no result after this long never gets one (the controller was reset,
/// went bus-off, or dropped the result): forgotten, so that client frames are loaded again.
pub const STALE_US: Micros = 100_000;

/// A frame loaded into a mailbox: whose, and the frame (the result carries only its ID).
#[derive(Clone, Copy, Debug)]
struct Loaded {
    frame: Frame,
    owner: Option<Source>,
    /// Tries that ended in an error frame.
    tries: u8,
    /// When it was loaded last, and first (a client frame's patience runs from its first try).
    at: Micros,
    first: Micros,
}

/// The state the tap keeps between the node's calls. See the module documentation.
pub struct BusTap<'l> {
    link: &'l BusLink,
    in_flight: Deque<Loaded, IN_FLIGHT>,
    node_results: Deque<TxResult, { rtcan::controller::TX_RESULTS }>,
    loopback: Deque<Received, 4>,
    retry: Option<Loaded>,
    /// What the node last handed the transmit interrupt (`CanController::stage`): those it
    /// loads are the node's frames in flight.
    staged: heapless::Vec<Frame, { rtcan::controller::TX_RESULTS }>,
}

/// The controller during one call of the node: [`CanController`] for the node.
pub struct Tapped<'t, 'l, C: CanController + ?Sized> {
    tap: &'t mut BusTap<'l>,
    can: &'t mut C,
    now: Micros,
}

fn to_link(frame: &Frame, at_us: Micros, from: Source) -> LinkFrame {
    let frame = CanFrame::extended(frame.id().to_raw(), frame.payload())
        .expect("an RTCAN frame has a 29-bit identifier and at most 8 bytes");
    LinkFrame { frame, at_us, from }
}

impl<'l> BusTap<'l> {
    /// A tap feeding `link`.
    pub const fn new(link: &'l BusLink) -> Self {
        Self {
            link,
            in_flight: Deque::new(),
            node_results: Deque::new(),
            loopback: Deque::new(),
            retry: None,
            staged: heapless::Vec::new(),
        }
    }

    /// Runs `node` (a call of the node runtime) on `can` as tapped at time `now`, then takes
    /// the controller's results and loads a client frame if the mailboxes are the clients' to
    /// use.
    pub fn run<C: CanController + ?Sized, R>(
        &mut self,
        now: Micros,
        can: &mut C,
        node: impl FnOnce(&mut Tapped<'_, 'l, C>) -> R,
    ) -> R {
        let mut t = Tapped { tap: self, can, now };
        let r = node(&mut t);
        t.collect();
        t.load_client_frame();
        r
    }
}

impl<C: CanController + ?Sized> Tapped<'_, '_, C> {
    fn stats(&self) -> &LinkStats {
        &self.tap.link.stats
    }

    /// Takes the controller's results: the node's are kept for it, client frames are
    /// forwarded and looped back when sent, tried again when not.
    fn collect(&mut self) {
        while let Some(r) = self.can.take_tx_result() {
            let tap = &mut *self.tap;
            let found = tap.in_flight.iter().position(|l| l.frame.id() == r.id);
            let loaded = found.and_then(|i| remove(&mut tap.in_flight, i));
            match loaded {
                Some(Loaded { frame, owner: Some(client), .. }) if r.sent() => {
                    let at = r.start_of_frame.unwrap_or(self.now);
                    tap.link.publish(to_link(&frame, at, client));
                    if tap.loopback.is_full() {
                        tap.loopback.pop_front();
                    }
                    let _ = tap.loopback.push_back(Received { frame, at });
                    LinkStats::add(&tap.link.stats.frames_from_clients, 1);
                }
                Some(Loaded { frame, owner: Some(client), tries, first, .. }) => {
                    let withdrawn =
                        matches!(r.outcome, TxOutcome::LostArbitration | TxOutcome::Aborted);
                    let errors = tries + u8::from(!withdrawn);
                    let again = if withdrawn {
                        self.now.saturating_sub(first) < CLIENT_PATIENCE_US
                    } else {
                        errors < CLIENT_TRIES
                    };
                    if again {
                        let owner = Some(client);
                        tap.retry = Some(Loaded { frame, owner, tries: errors, at: 0, first });
                    } else {
                        LinkStats::add(&tap.link.stats.lost, 1);
                    }
                }
                other => {
                    if let (true, Some(l)) = (r.sent(), other) {
                        let at = r.start_of_frame.unwrap_or(self.now);
                        tap.link.publish(to_link(&l.frame, at, BUS));
                    }
                    if tap.node_results.is_full() {
                        tap.node_results.pop_front();
                    }
                    let _ = tap.node_results.push_back(r);
                }
            }
        }
    }

    /// Loads the next client frame if nothing is in the mailboxes.
    fn load_client_frame(&mut self) {
        let now = self.now;
        while self.tap.in_flight.front().is_some_and(|l| now.saturating_sub(l.at) > STALE_US) {
            if let Some(Loaded { owner: Some(_), .. }) = self.tap.in_flight.pop_front() {
                LinkStats::add(&self.stats().lost, 1);
            }
        }
        if !self.tap.in_flight.is_empty() {
            return;
        }
        let next = self.tap.retry.take().or_else(|| {
            let f = self.tap.link.next_for_bus()?;
            match Frame::from_raw(f.frame.id(), f.frame.data()) {
                Ok(frame) => {
                    Some(Loaded { frame, owner: Some(f.from), tries: 0, at: 0, first: self.now })
                }
                Err(_) => {
                    // `BusLink::send` lets extended frames only: cannot happen; count it.
                    LinkStats::add(&self.stats().lost, 1);
                    None
                }
            }
        });
        let Some(mut l) = next else { return };
        match self.can.try_transmit(&l.frame) {
            Ok(()) => {
                l.at = self.now;
                let _ = self.tap.in_flight.push_back(l);
            }
            Err(TxError::MailboxesFull) => self.tap.retry = Some(l),
            Err(TxError::BusOff) => LinkStats::add(&self.stats().lost, 1),
        }
    }
}

fn remove<T: Copy, const N: usize>(q: &mut Deque<T, N>, i: usize) -> Option<T> {
    let mut kept: Deque<T, N> = Deque::new();
    let mut out = None;
    let mut n = 0;
    while let Some(x) = q.pop_front() {
        if n == i {
            out = Some(x);
        } else {
            let _ = kept.push_back(x);
        }
        n += 1;
    }
    *q = kept;
    out
}

impl<C: CanController + ?Sized> CanController for Tapped<'_, '_, C> {
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        self.can.try_transmit(frame)?;
        let tap = &mut *self.tap;
        if tap.in_flight.is_full() {
            tap.in_flight.pop_front();
        }
        let at = self.now;
        let _ =
            tap.in_flight.push_back(Loaded { frame: *frame, owner: None, tries: 0, at, first: at });
        Ok(())
    }

    fn set_tx_mode(&mut self, mode: TxMode) {
        self.can.set_tx_mode(mode);
    }

    fn take_tx_result(&mut self) -> Option<TxResult> {
        self.collect();
        self.tap.node_results.pop_front()
    }

    fn try_receive(&mut self) -> Option<Received> {
        if let Some(r) = self.tap.loopback.pop_front() {
            return Some(r);
        }
        let r = self.can.try_receive()?;
        self.tap.link.publish(to_link(&r.frame, r.at, BUS));
        Some(r)
    }

    fn set_filters(&mut self, _filters: &[Filter]) {
        self.can.set_filters(&[Filter::ACCEPT_ALL]);
    }

    fn abort_pending(&mut self) -> usize {
        self.can.abort_pending()
    }

    fn bus_state(&self) -> BusState {
        self.can.bus_state()
    }

    fn error_counters(&self) -> ErrorCounters {
        self.can.error_counters()
    }

    fn stage(&mut self, frames: &[StagedFrame]) {
        self.can.stage(frames);
        self.tap.staged =
            frames.iter().map(|s| s.frame).take(rtcan::controller::TX_RESULTS).collect();
    }

    /// The frames the interrupt loaded are the node's in flight, loaded at the call's time.
    fn staged_loaded(&mut self) -> usize {
        let n = self.can.staged_loaded();
        let tap = &mut *self.tap;
        for &frame in tap.staged.iter().take(n) {
            if tap.in_flight.is_full() {
                tap.in_flight.pop_front();
            }
            let at = self.now;
            let _ = tap.in_flight.push_back(Loaded { frame, owner: None, tries: 0, at, first: at });
        }
        tap.staged.clear();
        n
    }
}
