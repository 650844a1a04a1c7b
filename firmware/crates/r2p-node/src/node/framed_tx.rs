//! The slot path on frame-sized reservations (issue 22; docs/rtcan.md "Frame-sized
//! reservations"): with [`NodeConfig::hrt_blocks`](super::NodeConfig) > 0 the node sends in the
//! cycle as the master laid it out (`framed.rs`, `rtcan::framed_cycle`) instead of on the slot
//! grid: each HRT frame at its reservation's start, free frames in the windows between the
//! reservations, each fitted to what remains of its window (`SlotTx::fitted`). Its timer fires
//! where what it may load changes (a reservation's start, a window's opening), at a loaded
//! frame's latest start, and at the grid's slot boundaries as before: there it tops the window
//! up (its last frames may have gone) and a standby checks for a missing sync
//! (`CONTINUE_AFTER_SLOT`). A transmit-complete interrupt or a publish runs the short path
//! (`Node::top_up`), which tops the window up sooner.
//!
//! Without the feature `framed-reservations` these are constant and compile to nothing.

#[cfg(feature = "framed-reservations")]
use rtcan::cycle::SYNC_SLOT;
use rtcan::cycle::{ClockState, SlotPosition};
#[cfg(feature = "framed-reservations")]
use rtcan::framed_cycle::{FramedCycle, Moment};
use rtcan::{CanController, Micros};

#[cfg(feature = "framed-reservations")]
use super::HrtState;
use super::Node;

impl<
        'a,
        const EXPORTS: usize,
        const IMPORTS: usize,
        const TXQ: usize,
        const RX: usize,
        const BUF: usize,
        const MASTER: bool,
    > Node<'a, EXPORTS, IMPORTS, TXQ, RX, BUF, MASTER>
{
    /// True if the node sends on frame-sized reservations at `now`: it has a layout and the
    /// cycle runs (without a cycle every slot is free, as on the grid).
    #[inline(always)]
    pub(super) fn framed_running(&self, now: Micros) -> bool {
        #[cfg(feature = "framed-reservations")]
        if self.layout.is_some() {
            return matches!(self.clock.state(now), ClockState::Running(_));
        }
        let _ = now;
        false
    }

    /// True if the slot timer should also run [`top_up`](Self::top_up) when one of the
    /// node's frames leaves its mailbox (the controller's transmit-complete interrupt): on
    /// frame-sized reservations a window is then topped up as its frames go, not at the next
    /// grid boundary (`r2p-loadbench`: the mailboxes refilled at once carry 0.05–0.6 points
    /// more at 95 % load and cut the median SRT latency by ~6 %). On the grid: never needed.
    pub fn wakes_on_transmit(&self) -> bool {
        #[cfg(feature = "framed-reservations")]
        if self.layout.is_some() {
            return true;
        }
        false
    }

    /// Messages the application released on the node's SRT/NRT exports that are not yet in
    /// its transmit queue. On frame-sized reservations, a slot timer that also runs
    /// [`top_up`](Self::top_up) when this grows (a publish to a remote subscriber) sends
    /// them in the window at once instead of at the next grid boundary (`r2p-loadbench`: the
    /// median SRT latency at 10–75 % load falls by 6–20 %).
    pub fn releases_waiting(&self) -> usize {
        let waiting = self.exports.iter().filter(|e| e.hrt.is_none());
        waiting.map(|e| e.export.pending()).sum()
    }

    /// Calls `wake` from the publisher's context whenever the application publishes a message
    /// for the bus on one of the node's exports, those to come included: the board's wake for
    /// [`top_up`](Self::top_up), as [`releases_waiting`](Self::releases_waiting) asks of it
    /// (module-core's bus task). Only with the feature `framed-reservations`.
    #[cfg(feature = "framed-reservations")]
    pub fn wake_on_release(&mut self, wake: fn()) {
        self.release_wake = Some(wake);
        self.exports.iter().for_each(|e| e.export.wake_on_release(wake));
    }

    /// The short path for the two wakes above (a transmit-complete, a publish), instead of
    /// [`slot_tick`](Self::slot_tick): takes the controller's results, queues the released
    /// messages and, in a free window, loads the frames that still fit; at one of this node's
    /// reservations' start, its HRT frame. Received frames, the protocol's timers and the
    /// master's sync wait for the slot timer, which fires at every grid boundary anyway; the
    /// frames still loaded are not re-checked (`SlotTx::settle_sent`). The frames reach the
    /// controller sooner: QEMU, Cortex-M3 (`slot-path --features framed`), the window's first
    /// frame is requested after 1 699–3 923 instructions, where a whole slot tick takes
    /// 2 429–3 418 (`CORTEX_M3_TOP_UP_PATH`, docs/rtcan.md). `now` is the interrupt's
    /// time; the node acts for `now` + [`FramedLeads::slot_us`](crate::FramedLeads) as
    /// `slot_tick` does. On the slot grid (or before a cycle runs) it does nothing.
    pub fn top_up<C: CanController + ?Sized>(&mut self, now: Micros, can: &mut C) {
        #[cfg(feature = "framed-reservations")]
        if self.layout.is_some() {
            #[cfg(feature = "staged-reloads")]
            self.take_staged_loads(can);
            let now = now + Micros::from(self.lead_us());
            let ClockState::Running(p) = self.clock.state(now) else { return };
            for done in self.slot_tx.settle_sent(now, can).into_iter().flatten() {
                self.on_done(done);
            }
            self.drain_exports(now);
            self.framed_step(now, p, can, true);
        }
        let _ = (now, can);
    }

    /// Staged reloads (feature `staged-reloads`), before a call looks at the frames it loaded:
    /// the frames the controller's transmit interrupt loaded since the last call, of those
    /// `SlotTx` staged for it (`CanController::stage`), are the node's loaded frames now.
    #[cfg(feature = "staged-reloads")]
    #[inline(always)]
    pub(super) fn take_staged_loads<C: CanController + ?Sized>(&mut self, can: &mut C) {
        if self.layout.is_some() {
            let n = can.staged_loaded();
            if n > 0 {
                self.slot_tx.staged_went_in(n);
            }
        }
    }

    /// Step 5 of `slot_tick` on frame-sized reservations: loads this node's HRT frame at its
    /// reservation's start (once), or the queue's frames for the free window `now` is in.
    /// False if the node is on the slot grid or no cycle runs: the grid's step 5 applies.
    #[inline(always)]
    pub(super) fn framed_load<C: CanController + ?Sized>(
        &mut self,
        now: Micros,
        state: ClockState,
        can: &mut C,
    ) -> bool {
        #[cfg(feature = "framed-reservations")]
        if let (true, ClockState::Running(p)) = (self.layout.is_some(), state) {
            self.framed_step(now, p, can, true);
            return true;
        }
        let _ = (now, state, can);
        false
    }

    /// Step 2 of `slot_tick` on frame-sized reservations, when no sync went: this node's HRT
    /// frame, if `now` is the start of one of its reservations, goes to its mailbox before the
    /// node takes the frames it received and runs the protocol's timers (the clock and the mask
    /// come from syncs taken at earlier calls), as the master's sync does. It then has a short
    /// path of steady length, which its lead ([`FramedLeads`](crate::FramedLeads)) matches: a
    /// master's heartbeat taken in the same call (every 20 ms) would start it ~370
    /// instructions late (QEMU, Cortex-M3), more than the reservation's guard bits.
    #[inline(always)]
    pub(super) fn framed_first<C: CanController + ?Sized>(&mut self, now: Micros, can: &mut C) {
        #[cfg(feature = "framed-reservations")]
        if let (true, ClockState::Running(p)) = (self.layout.is_some(), self.clock.state(now)) {
            self.framed_step(now, p, can, false);
        }
        let _ = (now, can);
    }

    /// Loads what cycle position `p` allows at `now`: this node's HRT frame at its
    /// reservation's start (once), and in a free window (if `free`) the queue's frames.
    #[cfg(feature = "framed-reservations")]
    fn framed_step<C: CanController + ?Sized>(
        &mut self,
        now: Micros,
        p: SlotPosition,
        can: &mut C,
        free: bool,
    ) {
        let (Some(layout), Some((c0, c1))) = (self.layout.as_ref(), self.cycle_bounds(p)) else {
            return;
        };
        let cycle = FramedCycle::new(layout, self.clock.mask(p.cycle));
        match cycle.at(now.saturating_sub(c0) as u32) {
            Moment::Reserved { slot: Some(slot), start_us } if slot != SYNC_SLOT => {
                let start = c0 + Micros::from(start_us);
                if self.hrt_loaded_for != start {
                    if let Some((i, frame)) = self.framed_frame_in(p.cycle, slot) {
                        self.hrt_loaded_for = start;
                        self.send_hrt(i, frame, can);
                        self.hold_slotted(start, slot);
                    }
                }
            }
            Moment::Reserved { .. } => {}
            Moment::Free { end_us } if free => {
                let end = (c0 + Micros::from(end_us)).min(c1);
                self.slot_tx.load_queued(now, end, can, &self.tx);
            }
            Moment::Free { .. } => {}
        }
    }

    /// On frame-sized reservations: the next time after `now` the slot timer must fire in
    /// cycle position `p` (module documentation); `None` on the slot grid.
    #[inline(always)]
    pub(super) fn framed_next(&self, now: Micros, p: SlotPosition) -> Option<Micros> {
        #[cfg(feature = "framed-reservations")]
        if let Some(layout) = self.layout.as_ref() {
            let (c0, c1) = self.cycle_bounds(p)?;
            let cycle = FramedCycle::new(layout, self.clock.mask(p.cycle));
            let edge = c0 + Micros::from(cycle.next_edge(now.saturating_sub(c0) as u32));
            // The layout's cycle is nominal, the clock's as long as the master's runs (a µs
            // more, say): past the layout's end, its last edge is behind and the cycle's end next
            // (else the timer would ask for `now` again until the clock's cycle ends).
            let edge = if edge > now { edge.min(c1) } else { c1 };
            let grid = self.clock.slot_start(p.cycle, p.slot + 1).filter(|&t| t > now);
            return Some(grid.map_or(edge, |t| t.min(edge)));
        }
        let _ = (now, p);
        None
    }

    /// A sync or HRT frame loaded for `slot`'s reservation starting at `start`: free frames
    /// loaded behind it while it is on the wire must not withdraw it before its worst-case end.
    #[inline(always)]
    pub(super) fn hold_slotted(&mut self, start: Micros, slot: u8) {
        #[cfg(feature = "framed-reservations")]
        if let Some(span) = self.layout.as_ref().and_then(|l| l.span(slot)) {
            self.slot_tx.hold_slotted(start + Micros::from(span.len_us));
        }
        let _ = (start, slot);
    }

    /// The export whose HRT frame goes in slot `slot` of cycle `cycle`, and which of its
    /// message's frames: a message's frames go in its slots in the order the reservations lie
    /// in the cycle, which is not the slots' order (the master places each slot where it ends
    /// earliest).
    #[cfg(feature = "framed-reservations")]
    fn framed_frame_in(&self, cycle: u32, slot: u8) -> Option<(usize, u8)> {
        let (i, _) = self.hrt_frame_in(cycle, slot)?;
        let HrtState::Granted { slots } = self.exports[i].hrt?.state else { return None };
        let layout = self.layout.as_ref()?;
        let at = layout.span(slot)?.start_us;
        // The stream's slots whose reservations start earlier.
        let mut earlier = 0;
        for s in slots.iter() {
            earlier += u8::from(layout.span(s).is_some_and(|o| o.start_us < at));
        }
        Some((i, earlier))
    }

    /// Where cycle `p.cycle` starts and ends as the clock sees it.
    #[cfg(feature = "framed-reservations")]
    fn cycle_bounds(&self, p: SlotPosition) -> Option<(Micros, Micros)> {
        let slots = self.config.cycle.slots;
        Some((self.clock.slot_start(p.cycle, SYNC_SLOT)?, self.clock.slot_start(p.cycle, slots)?))
    }
}
