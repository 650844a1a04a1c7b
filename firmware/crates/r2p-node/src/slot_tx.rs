//! The sender side of the TDMA cycle: which frame a node has in its controller, for which
//! window, and when it takes it back (docs/rtcan.md, "Node slot policy").
//!
//! A frame loaded for a window must not go out after it: the next slot may be reserved for
//! another node's HRT stream, or be the next cycle's sync slot. Two rules keep every frame
//! inside its window:
//!
//! - **no late start**: a queued (SRT/NRT) frame that has not started one worst-case frame
//!   before its window's end (its *latest start*, the *guard*) is withdrawn then
//!   ([`SlotTx::on_guard`]) — it was waiting for a bus someone else's frame kept busy;
//! - **no late retry**: in a one-slot window, or in a reserved slot, frames go one-shot
//!   (`TxMode::OneShot`): one that loses arbitration or fails is withdrawn by the controller
//!   at once. In a merged window (several free slots) they may retry inside the window
//!   (`TxMode::Retransmit`); what has not started by the guard is withdrawn there.
//!
//! A frame that did not go out stays in the node's transmit queue ([`TxQueue::peek_ticket`])
//! with its deadline, to be loaded again with its laxity recomputed. The node learns each
//! frame's fate from the controller's results (`CanController::take_tx_result`).

use rtcan::controller::{TxMode, TxOutcome};
use rtcan::cycle::SlotPosition;
use rtcan::{CanController, CycleConfig, Frame, FrameId, Micros, SlotClock, Ticket, TxQueue};

/// How a node uses the free slots of the cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum FreeSlots {
    /// Every free slot is a window for at most one frame per node, sent one-shot: a frame that
    /// loses the slot's arbitration waits for the next free slot. At most one frame per free
    /// slot goes out.
    Single,
    /// Consecutive free slots, up to the next reserved slot or sync, are one window (as TTCAN
    /// merges arbitrating windows): frames are sent with automatic retransmission, so the bus
    /// carries frames back to back, and a node loads its next frame at each slot boundary.
    #[default]
    Merged,
}

/// A frame a node loads in a slot of its own: the sync (master) or one of its HRT streams.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slotted<T> {
    /// The master's sync frame.
    Sync,
    /// An HRT frame of the stream `T` names.
    Hrt(T),
}

/// What became of a frame [`SlotTx`] had loaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Done<T> {
    /// A sync or HRT frame.
    Slotted {
        /// Which.
        what: Slotted<T>,
        /// Its identifier.
        id: FrameId,
        /// Its outcome.
        outcome: TxOutcome,
    },
    /// A queued (SRT/NRT) frame: if it went out, remove `ticket` from the queue; otherwise it
    /// stays there.
    Queued {
        /// The frame in the transmit queue.
        ticket: Ticket,
        /// Its identifier as loaded (laxity of that time).
        id: FrameId,
        /// Its outcome.
        outcome: TxOutcome,
        /// It was withdrawn at its window's latest start (the bus was busy until then).
        late: bool,
    },
}

impl<T> Done<T> {
    /// A queued frame that did not go out in its window and went back to the queue: it lost a
    /// one-shot arbitration, ended in an error or was withdrawn at its latest start — not one
    /// withdrawn at a boundary inside a merged window to be loaded again at once.
    pub fn is_retry(&self, policy: FreeSlots) -> bool {
        match *self {
            Done::Queued { outcome: TxOutcome::Sent, .. } | Done::Slotted { .. } => false,
            Done::Queued { outcome: TxOutcome::Aborted, late: false, .. } => {
                policy == FreeSlots::Single
            }
            Done::Queued { .. } => true,
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Window {
    /// Start of the first slot the window does not include.
    end: Micros,
    /// Latest start of a frame in the window (`end` once the guard has run).
    guard: Micros,
}

/// The node's transmit state in slotted mode: at most one slotted (sync/HRT) and one queued
/// frame in the controller, the queued one's window, and the controller's transmit mode.
#[derive(Clone, Debug)]
pub struct SlotTx<T> {
    policy: FreeSlots,
    slots: u8,
    frame_us: Micros,
    slotted: Option<(Slotted<T>, FrameId)>,
    queued: Option<(Ticket, FrameId)>,
    window: Option<Window>,
    late: bool,
    mode: Option<TxMode>,
}

impl<T: Copy> SlotTx<T> {
    /// Nothing loaded, for cycle `cycle` (validated) and free-slot policy `policy`.
    pub const fn new(cycle: &CycleConfig, policy: FreeSlots) -> Self {
        Self {
            policy,
            slots: cycle.slots,
            frame_us: cycle.frame_us() as Micros,
            slotted: None,
            queued: None,
            window: None,
            late: false,
            mode: None,
        }
    }

    /// The free-slot policy.
    pub const fn policy(&self) -> FreeSlots {
        self.policy
    }

    /// True if a call of the slot timer at `now` is the loaded queued frame's guard (its
    /// window's latest start), not a slot boundary.
    pub fn at_guard(&self, now: Micros) -> bool {
        self.queued.is_some() && self.window.is_some_and(|w| now >= w.guard && now < w.end)
    }

    /// At the guard: withdraws the queued frame if it has not started (one on the wire ends
    /// within the window).
    pub fn on_guard<C: CanController + ?Sized>(&mut self, can: &mut C) {
        // Only the queued frame can be waiting: nothing else is loaded in a free slot.
        self.late = can.abort_pending() > 0;
        if let Some(w) = &mut self.window {
            w.guard = w.end;
        }
    }

    /// At slot boundary `now`: withdraws what has not started and takes the controller's
    /// results. Returns what became of the loaded frames, in the order they finished; a frame
    /// on the wire stays loaded. Inside a merged window, a queued frame that is still the
    /// queue's head with the same laxity code is left loaded (withdrawing it while it is in an
    /// arbitration would cost it its retry); otherwise it is withdrawn, to be loaded again
    /// with the more urgent frame or code.
    pub fn settle<C: CanController + ?Sized, const N: usize>(
        &mut self,
        now: Micros,
        can: &mut C,
        tx: &TxQueue<N>,
    ) -> [Option<Done<T>>; 2] {
        let mut done = [None, None];
        if self.slotted.is_none() && self.queued.is_none() {
            return done;
        }
        let inside = self.policy == FreeSlots::Merged && self.window.is_some_and(|w| now < w.end);
        let head = if inside { tx.peek_ticket(now) } else { None };
        let current = matches!((self.queued, head), (Some(q), Some((t, f))) if q == (t, f.id()));
        if !current || self.slotted.is_some() {
            can.abort_pending();
        }
        let mut n = 0;
        while let Some(r) = can.take_tx_result() {
            let d = match (self.slotted, self.queued) {
                (Some((what, id)), _) if id == r.id => {
                    self.slotted = None;
                    Done::Slotted { what, id, outcome: r.outcome }
                }
                (_, Some((ticket, id))) if id == r.id => {
                    self.queued = None;
                    let late = self.late && r.outcome == TxOutcome::Aborted;
                    Done::Queued { ticket, id, outcome: r.outcome, late }
                }
                _ => continue, // a frame of an earlier mode of use (unslotted): nothing to do
            };
            done[n] = Some(d);
            n += 1;
        }
        if self.queued.is_none() {
            self.window = None;
            self.late = false;
        }
        done
    }

    /// Switches the controller to `mode` if it is not there yet.
    pub fn set_mode<C: CanController + ?Sized>(&mut self, can: &mut C, mode: TxMode) {
        if self.mode != Some(mode) {
            can.set_tx_mode(mode);
            self.mode = Some(mode);
        }
    }

    /// Loads the sync or an HRT frame for the slot starting now, one-shot: it is the slot's
    /// only frame, and a failed one must not go out late. False if it could not be loaded.
    pub fn load_slotted<C: CanController + ?Sized>(
        &mut self,
        can: &mut C,
        what: Slotted<T>,
        frame: &Frame,
    ) -> bool {
        if self.slotted.is_some() {
            return false;
        }
        self.set_mode(can, TxMode::OneShot);
        if can.try_transmit(frame).is_err() {
            return false;
        }
        self.slotted = Some((what, frame.id()));
        true
    }

    /// The end of the window a free slot at `p` opens: the start of the next slot (`Single`),
    /// or of the next reserved slot or the next cycle's sync slot (`Merged`) as the clock's
    /// reservations for this cycle say.
    pub fn window_end(&self, clock: &SlotClock, p: SlotPosition) -> Option<Micros> {
        let next = match self.policy {
            FreeSlots::Single => p.slot + 1,
            FreeSlots::Merged => {
                let mask = clock.mask(p.cycle);
                (p.slot + 1..self.slots).find(|&j| mask & (1 << j) != 0).unwrap_or(self.slots)
            }
        };
        clock.slot_start(p.cycle, next)
    }

    /// Loads the queue's most urgent frame at `now` for the window ending at `end`, if its
    /// latest start is still ahead; one-shot in a one-slot window, with retransmission in a
    /// merged one. False if nothing was loaded.
    pub fn load_queued<C: CanController + ?Sized, const N: usize>(
        &mut self,
        now: Micros,
        end: Micros,
        can: &mut C,
        tx: &TxQueue<N>,
    ) -> bool {
        let guard = end.saturating_sub(self.frame_us);
        if self.queued.is_some() || now >= guard {
            return false;
        }
        let Some((ticket, frame)) = tx.peek_ticket(now) else { return false };
        let mode = match self.policy {
            FreeSlots::Single => TxMode::OneShot,
            FreeSlots::Merged => TxMode::Retransmit,
        };
        self.set_mode(can, mode);
        if can.try_transmit(&frame).is_err() {
            return false;
        }
        self.queued = Some((ticket, frame.id()));
        self.window = Some(Window { end, guard });
        self.late = false;
        true
    }

    /// The end of the loaded queued frame's window, if one is loaded.
    pub fn window_end_loaded(&self) -> Option<Micros> {
        self.window.map(|w| w.end)
    }

    /// When the slot timer must fire next: `boundary`, or before it the loaded frame's guard
    /// if that is still ahead.
    pub fn next_wake(&self, now: Micros, boundary: Micros) -> Micros {
        match self.window {
            Some(w) if self.queued.is_some() && now < w.guard && w.guard < boundary => w.guard,
            _ => boundary,
        }
    }
}
