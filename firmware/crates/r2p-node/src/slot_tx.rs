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
//!
//! In a merged window the node loads the next [`QUEUED_MAX`] frames of its queue at once (the
//! controller sends its mailboxes in load order), so a multi-frame message goes out back to
//! back as on plain CAN instead of one fragment per slot boundary; the guard withdraws every
//! one that has not started.
//!
//! With the feature `fitted-windows` (issue 22's frame-sized reservations, measured by
//! `r2p-loadbench`'s `rtcan_framed`; no image turns it on), `SlotTx::fitted` makes each
//! loaded frame's latest start its own — the window's end less its own worst case — and lets a
//! window take the most urgent frames that still fit rather than stop at a worst-case frame's
//! guard.
//!
//! A fitted window may also *stage* frames for the transmit interrupt ([`SlotTx::staging`],
//! feature `staged-reloads`): when the node cannot load because frames of its own are still in
//! the controller (withdrawn and on the wire, or loaded for the window before), it hands the
//! frames it would load to the controller (`CanController::stage`), whose transmit interrupt
//! loads them as soon as the controller is empty, inside CAN's 3-bit intermission, where the
//! node's short path would come ~27 µs later and lose the arbitration that follows
//! (docs/rtcan.md, "Where the fast reaction gains", "Staged reloads on the module").

use rtcan::controller::{TxMode, TxOutcome};
use rtcan::cycle::SlotPosition;
#[cfg(feature = "staged-reloads")]
use rtcan::StagedFrame;
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
    /// carries frames back to back; a node keeps its next [`QUEUED_MAX`] frames loaded and tops
    /// them up at each slot boundary.
    #[default]
    Merged,
}

/// A frame [`SlotTx`] stages for the transmit interrupt (module documentation), in load order.
#[cfg(feature = "staged-reloads")]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Staged {
    /// Its entry in the transmit queue.
    pub ticket: Ticket,
    /// The frame, its laxity code as of the call that staged it.
    pub frame: Frame,
    /// Its latest start: the window's end less its own worst case.
    pub latest: Micros,
}

#[cfg(feature = "staged-reloads")]
impl Staged {
    /// True if the transmit interrupt at `now` may still load it: before its latest start (the
    /// node's timer withdraws it there if the bus is busy, [`SlotTx::next_wake`]).
    pub fn may_load(&self, now: Micros) -> bool {
        StagedFrame::from(*self).may_load(now)
    }
}

/// What the controller's transmit interrupt is handed ([`CanController::stage`]).
#[cfg(feature = "staged-reloads")]
impl From<Staged> for StagedFrame {
    fn from(s: Staged) -> Self {
        StagedFrame { frame: s.frame, latest: s.latest }
    }
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
        /// Its start of frame, if it was sent and the controller stamps transmissions.
        start_of_frame: Option<Micros>,
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
        /// It missed its window because the bus was busy at its latest start: withdrawn there,
        /// or at the window's end after losing an arbitration it was in at the latest start.
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

/// Queued frames a node keeps in its controller in a merged window: bxCAN's three mailboxes.
pub const QUEUED_MAX: usize = 3;

/// Slotted frames a node keeps in its controller: this slot's, and the previous slot's while
/// it is still on the wire — the slot timer runs its path ahead of the boundary
/// (`NodeConfig::slot_lead_us`), so a frame that fills its slot (a sync, a worst-case HRT
/// frame) may not have ended when the next slot's frame is loaded; it ends before that frame's
/// mailbox request, which the transmit FIFO orders behind it anyway.
pub const SLOTTED_MAX: usize = 2;

/// What [`SlotTx::settle`] returns: the slotted frames' and every queued frame's fate.
pub type Settled<T> = [Option<Done<T>>; SLOTTED_MAX + QUEUED_MAX];

/// The node's transmit state in slotted mode: at most [`SLOTTED_MAX`] slotted (sync/HRT) frames or up to
/// [`QUEUED_MAX`] queued frames (one with [`FreeSlots::Single`]) in the controller, in load
/// order, their window, and the controller's transmit mode.
#[derive(Clone, Debug)]
pub struct SlotTx<T> {
    policy: FreeSlots,
    slots: u8,
    frame_us: Micros,
    /// Fitted windows ([`SlotTx::fitted`]): a bit's time in ns (rounded up), to time each
    /// frame by its length.
    #[cfg(feature = "fitted-windows")]
    fitted: Option<u32>,
    /// Laxity code steps a loaded frame may lag behind its code now and stay loaded
    /// ([`SlotTx::laxity_drift`]).
    #[cfg(feature = "fitted-windows")]
    laxity_drift: u8,
    /// Stages frames for the transmit interrupt ([`SlotTx::staging`]).
    #[cfg(feature = "staged-reloads")]
    stages: bool,
    /// The frames staged, in load order ([`SlotTx::staged`]).
    #[cfg(feature = "staged-reloads")]
    staged: [Option<Staged>; QUEUED_MAX],
    /// The end of the window they were staged for.
    #[cfg(feature = "staged-reloads")]
    staged_end: Micros,
    /// How many of them the interrupt loaded ([`SlotTx::staged_went_in`]), not yet taken in.
    #[cfg(feature = "staged-reloads")]
    staged_in: usize,
    /// The slotted frames loaded are not withdrawn before this ([`SlotTx::hold_slotted`]).
    #[cfg(feature = "fitted-windows")]
    slotted_until: Micros,
    slotted: [Option<(Slotted<T>, FrameId)>; SLOTTED_MAX],
    queued: [Option<(Ticket, FrameId)>; QUEUED_MAX],
    window: Option<Window>,
    /// The guard of the loaded window has run: what is withdrawn from now on is late.
    late: bool,
    /// Withdrawn but still in the controller (on the wire or losing an arbitration): whether
    /// they go out is not known yet, so nothing is loaded behind them.
    draining: bool,
    mode: Option<TxMode>,
}

impl<T: Copy> SlotTx<T> {
    /// Nothing loaded, for cycle `cycle` (validated) and free-slot policy `policy`.
    pub const fn new(cycle: &CycleConfig, policy: FreeSlots) -> Self {
        Self {
            policy,
            slots: cycle.slots,
            frame_us: cycle.frame_us() as Micros,
            #[cfg(feature = "fitted-windows")]
            fitted: None,
            #[cfg(feature = "fitted-windows")]
            laxity_drift: 0,
            #[cfg(feature = "staged-reloads")]
            stages: false,
            #[cfg(feature = "staged-reloads")]
            staged: [None; QUEUED_MAX],
            #[cfg(feature = "staged-reloads")]
            staged_end: 0,
            #[cfg(feature = "staged-reloads")]
            staged_in: 0,
            #[cfg(feature = "fitted-windows")]
            slotted_until: 0,
            slotted: [None; SLOTTED_MAX],
            queued: [None; QUEUED_MAX],
            window: None,
            late: false,
            draining: false,
            mode: None,
        }
    }

    /// Merged windows take the queue's most urgent frames that still fit in what remains of
    /// the window, each withdrawn at its own latest start (feature `fitted-windows`).
    #[cfg(feature = "fitted-windows")]
    pub const fn fitted(mut self, cycle: &CycleConfig) -> Self {
        self.fitted = Some(1_000_000_000u32.div_ceil(cycle.bit_rate));
        self
    }

    /// What-if (`r2p-loadbench --laxity-drift`, docs/rtcan.md "What the median goal would
    /// take"): a loaded frame whose laxity code moved on by at most `steps` since it was loaded
    /// stays in its mailbox at the slot timer's `settle` instead of being withdrawn and loaded
    /// again with its new code. The reload waits until the frame on the wire has ended
    /// (`draining`), ~27 µs, past CAN's 3-bit intermission, so the node loses the arbitration
    /// after it. Kept, the frame competes one code less urgent than it is. Measured, 16 seeds:
    /// the median SRT latency against fixed priority's falls from 1.42–1.53 to 1.35–1.45 at
    /// 80 % offered load, but the share carried at 95 % falls by up to 0.07 points (seed 3:
    /// 92.01 → 91.95 %, under issue 22's 92 %), so it stays off (0) in the node runtime.
    #[cfg(feature = "fitted-windows")]
    pub const fn laxity_drift(mut self, steps: u8) -> Self {
        self.laxity_drift = steps;
        self
    }

    /// Staged reloads (module documentation; the node turns them on with frame-sized
    /// reservations, `r2p-loadbench --staged` measures them): in a fitted window, when frames
    /// of the node's are still in the controller, stage the frames it would load for the
    /// transmit interrupt ([`staged`](Self::staged)), handed to the controller as they are
    /// staged and taken back when dropped. Measured, 16 seeds: the median SRT latency against
    /// fixed priority's 1.32–1.42 at 80 % offered load (1.42–1.53 without), the share carried
    /// at 95 % 92.03–93.30 %.
    #[cfg(feature = "staged-reloads")]
    pub const fn staging(mut self, on: bool) -> Self {
        self.stages = on;
        self
    }

    /// The frames staged for the transmit interrupt, in load order: what the node handed the
    /// controller (`CanController::stage`), replacing what it handed before. The interrupt loads them
    /// once the controller holds none of the node's frames and the last one that left was
    /// sent (a fragment of its message may be among them), each while
    /// [`may_load`](Staged::may_load), then tells [`staged_went_in`](Self::staged_went_in).
    #[cfg(feature = "staged-reloads")]
    pub fn staged(&self) -> impl Iterator<Item = Staged> + '_ {
        self.staged.iter().map_while(|s| *s).filter(|_| self.staged_in == 0)
    }

    /// The transmit interrupt loaded `n` more of the staged frames, the first ones (in all at
    /// most as many as [`staged`](Self::staged) gave it): the next
    /// [`settle`](Self::settle) takes them among the queued frames, and their results as theirs.
    /// A call that ends before its `settle` (at a guard) keeps them for the next call's, which
    /// finds no new loads (`n` = 0: the interrupt loads once per staging).
    #[cfg(feature = "staged-reloads")]
    pub fn staged_went_in(&mut self, n: usize) {
        self.staged_in += n;
    }

    /// The free-slot policy.
    pub const fn policy(&self) -> FreeSlots {
        self.policy
    }

    /// True if a call of the slot timer at `now` is the loaded queued frame's guard (its
    /// window's latest start), not a slot boundary.
    pub fn at_guard(&self, now: Micros) -> bool {
        #[cfg(feature = "staged-reloads")]
        if self.staged_in > 0 && self.staged_due(now) {
            return true;
        }
        self.has_queued() && self.window.is_some_and(|w| now >= w.guard && now < w.end)
    }

    fn has_slotted(&self) -> bool {
        self.slotted.iter().any(Option::is_some)
    }

    fn has_queued(&self) -> bool {
        self.queued[0].is_some()
    }

    /// The queued frames in the controller, in load order (their tickets and identifiers).
    pub fn queued(&self) -> impl Iterator<Item = (Ticket, FrameId)> + '_ {
        self.queued.iter().map_while(|q| *q)
    }

    /// At the guard: withdraws the queued frames that have not started (one on the wire ends
    /// within the window).
    pub fn on_guard<C: CanController + ?Sized>(&mut self, can: &mut C) {
        // Only queued frames can be waiting: nothing else is loaded in a free slot.
        can.abort_pending();
        // What is withdrawn from now on in this window missed it because the bus was busy: the
        // frames taken back now, and one that was in an arbitration here (it cannot be taken
        // back) and lost it, withdrawn at the window's end.
        self.late = true;
        self.draining = true;
        if let Some(w) = &mut self.window {
            w.guard = w.end;
        }
    }

    /// At slot boundary `now`: withdraws what has not started and takes the controller's
    /// results. Returns what became of the loaded frames, in the order they finished; a frame
    /// on the wire stays loaded. Inside a merged window, queued frames that are still the
    /// queue's next frames, in order and with the same laxity codes, are left loaded
    /// (withdrawing one while it is in an arbitration would cost it its retry); otherwise they
    /// are withdrawn, to be loaded again behind the more urgent frame or code.
    pub fn settle<C: CanController + ?Sized, const N: usize>(
        &mut self,
        now: Micros,
        can: &mut C,
        tx: &TxQueue<N>,
    ) -> Settled<T> {
        self.settle_with(now, can, |me, done| {
            let inside = me.policy == FreeSlots::Merged && me.window.is_some_and(|w| now < w.end);
            inside && me.still_next(now, tx, done)
        })
    }

    /// [`settle`](Self::settle) after one of the node's frames left its mailbox (its
    /// transmit-complete interrupt, `Node::top_up`): takes the controller's results, and
    /// withdraws only a slotted frame held past its reservation. The queued frames still
    /// loaded stay as they are until the slot timer's next `settle`: checking that they are
    /// still the queue's next frames with the same laxity codes (and withdrawing them to load
    /// them again when a code moved on) is ~1 100 instructions on a Cortex-M3, a third of the
    /// path to the next frame, and a frame's place in the queue changes at a release only.
    #[cfg(feature = "fitted-windows")]
    pub fn settle_sent<C: CanController + ?Sized>(
        &mut self,
        now: Micros,
        can: &mut C,
    ) -> Settled<T> {
        self.settle_with(now, can, |me, _| {
            me.policy == FreeSlots::Merged && me.window.is_some_and(|w| now < w.end)
        })
    }

    /// Takes the controller's results, and withdraws the loaded frames unless `keep` says the
    /// queued ones may stay (and no slotted one is held past its reservation).
    #[cfg_attr(not(feature = "fitted-windows"), allow(unused_variables))] // `now`
    fn settle_with<C: CanController + ?Sized>(
        &mut self,
        now: Micros,
        can: &mut C,
        keep: impl FnOnce(&Self, &Settled<T>) -> bool,
    ) -> Settled<T> {
        let mut done: Settled<T> = [None; SLOTTED_MAX + QUEUED_MAX];
        // The staged frames the interrupt loaded are queued frames now, behind those whose
        // results wait (there is room: it loads only mailboxes whose results were taken).
        #[cfg(feature = "staged-reloads")]
        let staged_in = self.staged_in > 0;
        #[cfg(feature = "staged-reloads")]
        if staged_in {
            self.queue_staged();
        } else if self.stages && self.staged[0].is_some() {
            self.staged = [None; QUEUED_MAX]; // each call stages afresh
            can.stage(&[]);
        }
        if !self.has_slotted() && !self.has_queued() {
            return done;
        }
        let n = self.take_results(can, &mut done, 0);
        #[cfg(feature = "staged-reloads")]
        if staged_in {
            self.open_staged_window();
        }
        #[cfg(not(feature = "fitted-windows"))]
        let withdraw = !keep(self, &done) || self.has_slotted();
        #[cfg(feature = "fitted-windows")]
        let withdraw = (self.has_queued() && !keep(self, &done))
            || (self.has_slotted() && now >= self.slotted_until);
        if withdraw {
            can.abort_pending();
            self.take_results(can, &mut done, n);
            self.draining = true;
        }
        if !self.has_queued() {
            self.window = None;
            self.late = false;
            self.draining = false;
        }
        done
    }

    /// True if the frames still loaded are the queue's next frames at `now`, in order and with
    /// the same identifiers (those `done` reports sent aside: the node removes them after
    /// `settle`). Else a frame that lost or was withdrawn would go out behind the ones loaded
    /// after it. A loaded frame's laxity code may lag behind its code now by
    /// [`laxity_drift`](Self::laxity_drift) steps.
    fn still_next<const N: usize>(&self, now: Micros, tx: &TxQueue<N>, done: &Settled<T>) -> bool {
        let sent = |t: Ticket| {
            done.iter().flatten().any(
                |d| matches!(d, Done::Queued { ticket, outcome: TxOutcome::Sent, .. } if *ticket == t),
            )
        };
        #[cfg(feature = "fitted-windows")]
        let end = self.window.map_or(now, |w| w.end);
        #[cfg(feature = "fitted-windows")]
        let mut blocked = Blocked::default();
        #[cfg(feature = "fitted-windows")]
        let mut next = tx
            .upcoming(now)
            .filter(|&(t, _)| !sent(t))
            .filter(|(_, f)| blocked.admits(f, self.fits(now, end, f)));
        #[cfg(not(feature = "fitted-windows"))]
        let mut next = tx.upcoming(now).filter(|&(t, _)| !sent(t));
        #[cfg(not(feature = "fitted-windows"))]
        return self.queued().all(|q| next.next().is_some_and(|(t, f)| q == (t, f.id())));
        #[cfg(feature = "fitted-windows")]
        self.queued().all(|q| next.next().is_some_and(|(t, f)| q.0 == t && self.stays(q.1, f.id())))
    }

    /// True if a loaded frame whose identifier was `loaded` may stay in its mailbox where the
    /// queue now gives the same frame (its ticket: the same message and fragment) the
    /// identifier `now`: its laxity code at most [`laxity_drift`](Self::laxity_drift) steps
    /// behind.
    #[cfg(feature = "fitted-windows")]
    fn stays(&self, loaded: FrameId, now: FrameId) -> bool {
        loaded.laxity.code().abs_diff(now.laxity.code()) <= self.laxity_drift
    }

    /// A frame's own worst-case time on the bus, intermission included (µs, rounded up);
    /// a worst-case frame's unless the windows are fitted.
    #[cfg(feature = "fitted-windows")]
    fn frame_time(&self, frame: &Frame) -> Micros {
        let Some(bit_ns) = self.fitted else { return self.frame_us };
        let bits = rtcan::cycle::frame_bits_of(frame.id().to_raw(), frame.payload().len());
        // In 32 bits (a 160-bit frame at 8 µs a bit is 1.3 ms): the Cortex-M3 divides them in
        // hardware, a 64-bit division is a library call of ~100 instructions.
        Micros::from((bits * bit_ns).div_ceil(1_000))
    }

    /// True if `frame` may be loaded at `now` for a window ending at `end`: its latest start is
    /// still ahead, so the guard's timer can withdraw it if the bus stays busy until then
    /// (always, unless the windows are fitted: the window's guard decides).
    #[cfg(feature = "fitted-windows")]
    fn fits(&self, now: Micros, end: Micros, frame: &Frame) -> bool {
        self.fitted.is_none() || now + self.frame_time(frame) < end
    }

    /// Takes the controller's results into `done` from index `n`; returns the next index.
    fn take_results<C: CanController + ?Sized>(
        &mut self,
        can: &mut C,
        done: &mut Settled<T>,
        mut n: usize,
    ) -> usize {
        while let Some(r) = can.take_tx_result() {
            let mine = self.slotted.iter_mut().find(|s| s.is_some_and(|(_, id)| id == r.id));
            let d = if let Some((what, _)) = mine.and_then(|s| s.take()) {
                Done::Slotted {
                    what,
                    id: r.id,
                    outcome: r.outcome,
                    start_of_frame: r.start_of_frame,
                }
            } else if let Some(j) = self.queued.iter().position(|q| q.is_some_and(|q| q.1 == r.id))
            {
                // Loaded frames have distinct identifiers (`load_queued`).
                let (ticket, id) = self.queued[j].take().expect("found above");
                // Close the gap, keeping load order (element by element: a slice rotation
                // would link memmove into the image, 1.5 KiB on the F103).
                for i in j..QUEUED_MAX - 1 {
                    self.queued[i] = self.queued[i + 1];
                }
                self.queued[QUEUED_MAX - 1] = None;
                let late = self.late && r.outcome == TxOutcome::Aborted;
                Done::Queued { ticket, id, outcome: r.outcome, late }
            } else {
                continue; // a frame of an earlier mode of use (unslotted): nothing to do
            };
            if let Some(slot) = done.get_mut(n) {
                *slot = Some(d);
                n += 1;
            }
        }
        n
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
        let Some(free) = self.slotted.iter().position(|s| s.is_none()) else { return false };
        self.set_mode(can, TxMode::OneShot);
        if can.try_transmit(frame).is_err() {
            return false;
        }
        self.slotted[free] = Some((what, frame.id()));
        true
    }

    /// Keeps the slotted frames loaded until `until`, their reservation's worst-case end:
    /// frame-sized reservations load free frames behind a slotted frame while it is on the
    /// wire (`rtcan::framed_cycle::FOLLOW_US`), which must not withdraw it — on the grid the
    /// next call is the next slot's boundary, where a slotted frame not yet sent is late.
    #[cfg(feature = "fitted-windows")]
    pub fn hold_slotted(&mut self, until: Micros) {
        self.slotted_until = until;
    }

    /// Stages the frames `load_queued` would load at `now` for the window ending at `end` if the
    /// controller held none of the node's frames: those that fit, in order, with identifiers
    /// distinct from each other's and from the frames still loaded (results name a frame by
    /// its identifier).
    #[cfg(feature = "staged-reloads")]
    #[inline(never)]
    fn stage<C: CanController + ?Sized, const N: usize>(
        &mut self,
        now: Micros,
        end: Micros,
        can: &mut C,
        tx: &TxQueue<N>,
    ) {
        self.staged = [None; QUEUED_MAX];
        let mut blocked = Blocked::default();
        let mut k = 0;
        for (ticket, frame) in tx.upcoming(now) {
            if k == QUEUED_MAX {
                break;
            }
            if self.queued().any(|(t, _)| t == ticket) {
                continue; // still loaded: it goes first, or went
            }
            if !blocked.admits(&frame, self.fits(now, end, &frame)) {
                continue;
            }
            let id = frame.id();
            let taken = |s: &Option<Staged>| s.is_some_and(|s| s.frame.id() == id);
            if self.staged.iter().any(taken) || self.queued().any(|(_, q)| q == id) {
                break;
            }
            self.staged[k] = Some(Staged { ticket, frame, latest: end - self.frame_time(&frame) });
            k += 1;
        }
        self.staged_end = end;
        let handed: heapless::Vec<StagedFrame, QUEUED_MAX> =
            self.staged.iter().flatten().map(|&s| s.into()).collect();
        can.stage(&handed);
    }

    /// True if a staged frame the interrupt loaded, not yet taken in by `settle`, is at or past
    /// its latest start at `now` (out of line, as the other staging steps: the slot path of a
    /// node that does not stage pays a compare for each).
    #[cfg(feature = "staged-reloads")]
    #[inline(never)]
    fn staged_due(&self, now: Micros) -> bool {
        let mut went_in = self.staged.iter().take(self.staged_in).flatten();
        went_in.any(|s| now >= s.latest && now < self.staged_end)
    }

    /// `boundary`, or before it the earliest staged frame's latest start still ahead.
    #[cfg(feature = "staged-reloads")]
    #[inline(never)]
    fn staged_wake(&self, now: Micros, boundary: Micros) -> Micros {
        self.staged().map(|s| s.latest).filter(|&l| l > now).fold(boundary, Micros::min)
    }

    /// Queues the staged frames the interrupt loaded behind the frames still loaded, whose
    /// results wait (their window's state follows once those are taken,
    /// [`open_staged_window`](Self::open_staged_window)).
    #[cfg(feature = "staged-reloads")]
    #[inline(never)]
    fn queue_staged(&mut self) {
        let went_in = self.staged.iter().take(self.staged_in).flatten();
        for (free, s) in self.queued.iter_mut().filter(|q| q.is_none()).zip(went_in) {
            *free = Some((s.ticket, s.frame.id()));
        }
    }

    /// The window the staged frames the interrupt loaded were staged for is the node's now:
    /// the interrupt loaded them into an empty controller, so every frame of the window before
    /// has ended. A guard that ran for them since withdrew those not on the wire (their
    /// results came in `settle`); one on the wire ends inside the window, and its guard, past,
    /// lets nothing load behind it.
    #[cfg(feature = "staged-reloads")]
    #[inline(never)]
    fn open_staged_window(&mut self) {
        let n = core::mem::take(&mut self.staged_in);
        let staged = core::mem::replace(&mut self.staged, [None; QUEUED_MAX]);
        let guard =
            staged.iter().take(n).flatten().map(|s| s.latest).fold(self.staged_end, Micros::min);
        (self.late, self.draining) = (false, false);
        self.window = self.has_queued().then_some(Window { end: self.staged_end, guard });
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

    /// Loads the queue's most urgent frames at `now` for the window ending at `end`, if its
    /// latest start is still ahead: one, one-shot, in a one-slot window ([`FreeSlots::Single`]);
    /// up to [`QUEUED_MAX`] with retransmission in a merged one, topping up what is still
    /// loaded for the same window. False if nothing was loaded.
    pub fn load_queued<C: CanController + ?Sized, const N: usize>(
        &mut self,
        now: Micros,
        end: Micros,
        can: &mut C,
        tx: &TxQueue<N>,
    ) -> bool {
        #[cfg(not(feature = "fitted-windows"))]
        let guard = end.saturating_sub(self.frame_us);
        // Each frame's own latest start; the window's guard is the earliest of those loaded (a
        // window is kept only while frames are loaded: `settle` drops it).
        #[cfg(feature = "fitted-windows")]
        let mut guard = match (self.fitted, self.window) {
            (None, _) => end.saturating_sub(self.frame_us),
            (Some(_), Some(w)) => w.guard,
            (Some(_), None) => end,
        };
        #[cfg(feature = "fitted-windows")]
        let mut blocked = Blocked::default();
        let other_window = self.window.is_some_and(|w| w.end != end);
        if now >= guard || (self.has_queued() && (other_window || self.draining)) {
            // Frames of the node's are still in the controller: what would go next is staged.
            #[cfg(feature = "staged-reloads")]
            if self.stages && self.has_queued() && (other_window || self.draining) {
                self.stage(now, end, can, tx);
            }
            return false;
        }
        let (mode, depth) = match self.policy {
            FreeSlots::Single => (TxMode::OneShot, 1),
            FreeSlots::Merged => (TxMode::Retransmit, QUEUED_MAX),
        };
        let mut loaded = self.queued().count();
        let first = loaded;
        // What is still loaded is the queue's next frames, in order (`settle` withdrew it
        // otherwise, and `draining` waits for the fate of what it could not take back): the
        // frames after it go in behind it.
        for (ticket, frame) in tx.upcoming(now) {
            if loaded == depth {
                break;
            }
            // Still loaded (before timing it: it went in when it fitted, and frames behind
            // it may follow it).
            if self.queued().any(|(t, _)| t == ticket) {
                continue;
            }
            #[cfg(feature = "fitted-windows")]
            if !blocked.admits(&frame, self.fits(now, end, &frame)) {
                continue;
            }
            if self.queued().any(|(_, id)| id == frame.id()) {
                // Results name a frame by identifier: two loaded frames must not share one
                // (two messages of one stream can, fragment and laxity code alike).
                break;
            }
            self.set_mode(can, mode);
            if can.try_transmit(&frame).is_err() {
                break;
            }
            self.queued[loaded] = Some((ticket, frame.id()));
            loaded += 1;
            #[cfg(feature = "fitted-windows")]
            if self.fitted.is_some() {
                guard = guard.min(end - self.frame_time(&frame));
            }
        }
        if loaded == first {
            return false;
        }
        if first == 0 {
            self.window = Some(Window { end, guard });
            self.late = false;
        }
        #[cfg(feature = "fitted-windows")]
        if let Some(w) = &mut self.window {
            w.guard = guard;
        }
        true
    }

    /// When the slot timer must fire next: `boundary`, or before it the loaded frame's guard
    /// if that is still ahead.
    pub fn next_wake(&self, now: Micros, boundary: Micros) -> Micros {
        // A staged frame the interrupt may load must be withdrawn at its latest start.
        #[cfg(feature = "staged-reloads")]
        let boundary = if self.stages { self.staged_wake(now, boundary) } else { boundary };
        match self.window {
            Some(w) if self.has_queued() && now < w.guard && w.guard < boundary => w.guard,
            _ => boundary,
        }
    }
}

/// The messages a fitted window passes over: a frame that does not fit holds back the frames
/// of its message behind it (fragments go in order), and a node holding back more messages
/// than this loads nothing further.
#[cfg(feature = "fitted-windows")]
#[derive(Default)]
struct Blocked {
    messages: [Option<rtcan::MessageId>; 4],
    full: bool,
}

#[cfg(feature = "fitted-windows")]
impl Blocked {
    /// True if `frame` may be loaded: it fits, and no frame of its message was passed over.
    fn admits(&mut self, frame: &Frame, fits: bool) -> bool {
        let message = frame.id().message;
        if self.full || self.messages.contains(&Some(message)) {
            return false;
        }
        if !fits {
            match self.messages.iter_mut().find(|m| m.is_none()) {
                Some(free) => *free = Some(message),
                None => self.full = true,
            }
        }
        fits
    }
}
