//! The TDMA cycle (docs/middleware.md, "The TDMA cycle and HRT streams"): the slot timer's
//! path, which follows the master's syncs (or sends them as master), settles what the
//! controller did with the last slot's frame, and loads the next slot's. A node that only polls
//! (`node.rs`) links none of it.

use rtcan::controller::TxOutcome;
use rtcan::cycle::{ClockState, SYNC_SLOT};
use rtcan::failover::{sync_timeout_us, Actions, Role};
use rtcan::schedule::occurs;
use rtcan::{CanController, Micros, Phase, SlotClock, SyncFrame};

use super::stats::bump;
use super::{HrtState, Node};
use crate::slot_tx::{Done, Slotted};
#[cfg(doc)]
use crate::{FreeSlots, NodeConfig};

/// The slot of a cycle from which a standby counts the cycle's sync as missing: the sync
/// starts the cycle and takes at most 160 bit times, so it has arrived by the second slot's end
/// whatever the node's slot lead.
pub const CONTINUE_AFTER_SLOT: u8 = 2;

/// The cycle this node runs as master.
#[derive(Clone, Copy)]
pub(super) struct MasterCycle {
    pub(super) cycle: u32,
    pub(super) next_sync: Micros,
    pub(super) epoch: bool,
}

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
    /// This node's role in the cycle (master, standby candidate or slave).
    pub fn role(&self) -> Role {
        self.failover.role()
    }

    /// The node's view of the cycle.
    pub fn clock(&self) -> &SlotClock {
        &self.clock
    }

    /// The slot timer: call at every slot boundary and at the latest start of a loaded frame's
    /// window, both as [`next_slot_at`](Self::next_slot_at) says, with `now` that time.
    ///
    /// At a loaded frame's latest start, it only withdraws the frame if it has not started. At
    /// a slot boundary, in order:
    ///
    /// 1. the controller's results: an SRT/NRT frame that went out leaves the queue, one that
    ///    did not stays in it with its deadline (and is loaded again with its laxity for then);
    ///    an HRT frame that did not go out is a missed occurrence;
    /// 2. as master, at a cycle's start: send the sync with the next cycle's reservations, on
    ///    a short path of steady length with a lead of its own ([`NodeConfig::sync_lead_us`]),
    ///    and load nothing else in this tick; else, on frame-sized reservations, this node's
    ///    HRT frame if its reservation starts now (step 5's, brought forward: `framed_tx.rs`);
    ///    take received frames (syncs feed the [`SlotClock`] and the failover state machine);
    /// 3. the protocol's timers ([`tick`](Self::tick)), master takeover, HRT registrations;
    /// 4. as a master that took over in step 3: its first sync, as in step 2;
    /// 5. load this slot's frame: in slot 0 nothing (the sync's); in a reserved slot this
    ///    node's HRT frame if the slot is its stream's, else nothing; in a free slot the most
    ///    urgent SRT/NRT frame for the window the slot opens ([`FreeSlots`]). Without a cycle
    ///    (no sync heard for `sync_timeout_us`, or none since boot for that long) every slot
    ///    is free and a window of its own.
    ///
    /// `now` is the time the timer fired; the node acts for `now` + [`NodeConfig::slot_lead_us`],
    /// the time its frames reach the controller (for a master's sync + its own lead,
    /// [`NodeConfig::sync_lead_us`]; on frame-sized reservations the leads of the frame it
    /// loads first, [`NodeConfig::framed_leads`]).
    pub fn slot_tick<C: CanController + ?Sized>(&mut self, now: Micros, can: &mut C) {
        #[cfg(feature = "staged-reloads")]
        self.take_staged_loads(can);
        let (now, sync_at) = self.tick_time(now);
        self.start(now);
        self.program_filters(can);
        if self.slot_tx.at_guard(now) {
            self.slot_tx.on_guard(can);
            if !self.at_boundary(now) {
                return;
            }
        }
        for done in self.slot_tx.settle(now, can, &self.tx).into_iter().flatten() {
            self.on_done(done);
        }
        let synced = self.send_sync(now, sync_at, can);
        if !synced {
            self.framed_first(now, can);
        }
        while let Some(r) = can.try_receive() {
            self.receive::<true>(&r);
        }
        self.errors = can.error_counters();
        self.tick(now);
        let a = self.failover.poll(now);
        self.apply(a);
        self.register_hrt(now);

        if synced || self.send_sync(now, sync_at, can) {
            return;
        }

        let state = self.clock.state(now);
        self.continue_cycle(state);
        if self.framed_load(now, state, can) {
            return;
        }
        match state {
            ClockState::Running(p) if p.slot == SYNC_SLOT => {}
            ClockState::Running(p) if self.clock.mask(p.cycle) & (1 << p.slot) != 0 => {
                if let Some((i, frame)) = self.hrt_frame_in(p.cycle, p.slot) {
                    self.send_hrt(i, frame, can);
                }
            }
            ClockState::Running(p) => {
                if let Some(end) = self.slot_tx.window_end(&self.clock, p) {
                    self.send_queued(now, end, can);
                }
            }
            ClockState::Unsynced | ClockState::Lost => {
                let quiet = now.saturating_sub(self.last_sync);
                if quiet >= sync_timeout_us(self.config.cycle.cycle_us) {
                    // No cycle on the bus: every slot is free.
                    let slot_us = Micros::from(self.config.cycle.slot_us());
                    self.send_queued(now, now + slot_us, can);
                }
            }
        }
    }

    /// The time a slot tick that fired at `fired` acts for, and the time a sync it loads would
    /// reach its mailbox. A master's sync has a path and a lead of its own (`next_slot_at`,
    /// [`NodeConfig::sync_lead_us`], on frame-sized reservations
    /// [`FramedLeads::sync_us`](crate::FramedLeads)): the tick that fired for it acts for
    /// `fired` + that lead, so that the cycle starts where the master times it. Every other
    /// tick acts for `fired` + the slot lead ([`NodeConfig::slot_lead_us`], on frame-sized
    /// reservations [`FramedLeads::slot_us`](crate::FramedLeads)).
    #[inline(always)]
    fn tick_time(&self, fired: Micros) -> (Micros, Micros) {
        let now = fired + Micros::from(self.lead_us());
        match self.master_sync() {
            Some((next_sync, lead)) if fired + lead >= next_sync => (fired + lead, fired + lead),
            Some((_, lead)) => (now, fired + lead),
            None => (now, now),
        }
    }

    /// The slot timer's lead (µs): the grid's or, on frame-sized reservations, theirs.
    pub(super) fn lead_us(&self) -> u32 {
        #[cfg(feature = "framed-reservations")]
        if self.layout.is_some() {
            return self.config.framed_leads.slot_us;
        }
        self.config.slot_lead_us
    }

    /// A master's next sync and the sync's own lead ([`NodeConfig::sync_lead_us`], on
    /// frame-sized reservations `FramedLeads::sync_us`); `None` for a node that is not master.
    #[inline(always)]
    fn master_sync(&self) -> Option<(Micros, Micros)> {
        let m = self.master.filter(|_| MASTER)?;
        #[cfg(feature = "framed-reservations")]
        if self.layout.is_some() {
            return Some((m.next_sync, Micros::from(self.config.framed_leads.sync_us)));
        }
        Some((m.next_sync, Micros::from(self.config.sync_lead_us)))
    }

    /// Steps 2 and 4 of [`slot_tick`](Self::slot_tick): as master, if its sync is due by
    /// `sync_at` (`tick_time`), loads it with the next cycle's reservations and starts the cycle at `now`
    /// (the slaves start it at the sync's start of frame, the master too once the controller
    /// reports it). True if the sync was loaded: the tick loads nothing else. The check is
    /// inlined, the loading not: a slave's slot path pays two compares for it.
    #[inline(always)]
    pub(super) fn send_sync<C: CanController + ?Sized>(
        &mut self,
        now: Micros,
        sync_at: Micros,
        can: &mut C,
    ) -> bool {
        match self.master.filter(|m| MASTER && sync_at >= m.next_sync) {
            Some(m) => self.load_sync(now, m, can),
            None => false,
        }
    }

    /// [`send_sync`](Self::send_sync)'s sync of cycle `m.cycle`, due.
    #[inline(never)]
    fn load_sync<C: CanController + ?Sized>(
        &mut self,
        now: Micros,
        mut m: MasterCycle,
        can: &mut C,
    ) -> bool {
        let rank = self.failover.rank().map_or(0, |r| r.get());
        let next = self.scheduler.mask(m.cycle.wrapping_add(1));
        let sync = SyncFrame::new(m.cycle, next, m.epoch).from_rank(rank);
        let ok = self.slot_tx.load_slotted(can, Slotted::Sync, &sync.to_frame());
        if ok {
            self.hold_slotted(now, SYNC_SLOT);
            self.clock.on_sync(now, &sync);
            self.last_sync = now;
            // Its outcome comes from the controller (`on_done`); `syncs_sent` and the
            // failover count it then.
            self.sync_loaded = Some((now, sync));
        }
        let cycle_us = Micros::from(self.config.cycle.cycle_us);
        m.cycle = m.cycle.wrapping_add(1);
        m.next_sync += cycle_us;
        if m.next_sync <= now {
            m.next_sync = now + cycle_us; // the timer was late by a cycle: restart
        }
        self.master = Some(m);
        if !ok {
            // Not even loaded (mailboxes full, bus-off): a failed sync.
            let a = self.failover.on_sync_sent(now, &sync, false);
            self.apply(a);
        }
        ok
    }

    /// The export whose HRT frame goes in slot `slot` of cycle `cycle`, and which of its
    /// message's frames.
    pub(super) fn hrt_frame_in(&self, cycle: u32, slot: u8) -> Option<(usize, u8)> {
        self.exports.iter().enumerate().find_map(|(i, e)| match e.hrt?.state {
            HrtState::Granted { slots }
                if occurs(e.hrt?.period, Phase { offset: slots.offset, slot: 0 }, cycle) =>
            {
                Some((i, slots.frame_in(slot)?))
            }
            _ => None,
        })
    }

    /// True if `now` is a slot boundary (a slot's start as the clock sees it, or the master's
    /// next sync), not only a loaded frame's latest start (they meet when a slot is exactly
    /// one worst-case frame long). With frame-sized reservations every call is one: the
    /// window after a latest start may still take a shorter frame.
    fn at_boundary(&self, now: Micros) -> bool {
        if self.framed_running(now) {
            return true;
        }
        let slot_start = match self.clock.state(now) {
            ClockState::Running(p) => self.clock.slot_start(p.cycle, p.slot),
            _ => None,
        };
        slot_start == Some(now) || self.master.is_some_and(|m| now >= m.next_sync)
    }

    /// A loaded frame's fate (step 1 of [`slot_tick`](Self::slot_tick)).
    pub(super) fn on_done(&mut self, done: Done<usize>) {
        if done.is_retry(self.slot_tx.policy()) {
            bump(&mut self.stats.slot_retries);
        }
        match done {
            Done::Slotted { what: Slotted::Hrt(_), outcome: TxOutcome::Sent, .. } => {
                bump(&mut self.stats.hrt_sent)
            }
            Done::Slotted { what: Slotted::Hrt(i), .. } => self.hrt_miss(i),
            Done::Slotted { what: Slotted::Sync, outcome, start_of_frame, .. } => {
                // The controller's result of the sync loaded at `at`: sent (TXOK), or it lost
                // arbitration, ended in an error frame (no ACK, bit error) or was withdrawn.
                // More than L failures in a row make the master step down (docs/rtcan.md,
                // "Master failover").
                if let Some((at, sync)) = self.sync_loaded.take() {
                    let sent = outcome == TxOutcome::Sent;
                    if sent {
                        bump(&mut self.stats.syncs_sent);
                    }
                    // The cycle starts at the sync's start of frame, for the master as for
                    // the slaves that stamp it on reception.
                    if let (true, Some(sof)) = (sent, start_of_frame) {
                        if self.master.is_some() {
                            self.clock.restamp_last_sync(sync.cycle, sof);
                            self.last_sync = self.last_sync.max(sof);
                        }
                    }
                    let a = self.failover.on_sync_sent(at, &sync, sent);
                    self.apply(a);
                }
            }
            Done::Queued { ticket, outcome: TxOutcome::Sent, .. } => {
                self.tx.remove(ticket);
                bump(&mut self.stats.frames_sent);
            }
            Done::Queued { late, .. } => {
                if late {
                    bump(&mut self.stats.late_withdrawals);
                }
            }
        }
    }

    /// When the slot timer should call [`slot_tick`](Self::slot_tick) next: the next slot
    /// boundary of the cycle as this node's clock sees it (as master: of its own cycle), or one
    /// nominal slot later while no cycle runs — or before it, the latest start of the window
    /// of a frame the node has loaded; [`NodeConfig::slot_lead_us`] early (a master's sync
    /// [`NodeConfig::sync_lead_us`]; on frame-sized reservations [`NodeConfig::framed_leads`]).
    pub fn next_slot_at(&self, now: Micros) -> Micros {
        let lead = Micros::from(self.lead_us());
        let at = self.next_boundary(now + lead);
        match self.master_sync() {
            Some((next_sync, sync_lead)) if at >= next_sync => {
                next_sync.saturating_sub(sync_lead).max(now)
            }
            _ => at.saturating_sub(lead).max(now),
        }
    }

    /// The next boundary (or guard) after `now`, in the time the node acts for.
    fn next_boundary(&self, now: Micros) -> Micros {
        let slot_us = Micros::from(self.config.cycle.slot_us().max(1));
        // No cycle: a nominal slot after this tick. Ticks without a cycle are boundaries, or
        // guards of a loaded window, after which `next_wake` returns the window's end.
        let by_clock = match self.clock.state(now) {
            ClockState::Running(p) => {
                self.framed_next(now, p).or_else(|| self.clock.slot_start(p.cycle, p.slot + 1))
            }
            _ => None,
        }
        .unwrap_or(now + slot_us);
        let boundary = match self.master {
            Some(m) => by_clock.min(m.next_sync.max(now)),
            None => by_clock,
        };
        self.slot_tx.next_wake(now, boundary)
    }

    /// A sync heard: ignored if out of turn (a babbler's, docs/rtcan.md "Babblers") or, while
    /// not synced, until a sync in sequence with it confirms it; counted when not followed
    /// (the decision is `rtcan`'s [`Failover::on_sync`](rtcan::failover::Failover)); else it
    /// feeds the clock and the failover state machine.
    pub(super) fn on_sync(&mut self, at: Micros, sync: &SyncFrame) {
        let a = self.failover.on_sync(at, sync);
        if a.out_of_turn {
            bump(&mut self.stats.syncs_out_of_turn);
        }
        if a.ignored {
            if !self.failover.synced() {
                // Held: a cycle may run, which the node follows at the next sync; until then
                // it sends nothing outside one (no frame into that cycle's slots).
                self.last_sync = at;
            }
            return;
        }
        let info = self.clock.on_sync(at, sync);
        self.last_sync = at;
        if a.re_register {
            // The positions it heard belong to a calendar it may no longer follow (a new one,
            // or one it lost track of): it hears them again in the grants of the registrations
            // that follow and in the master's beacon.
            self.calendar_cleared();
        }
        self.apply(a);
        self.follow_sync(sync, info, a.new_calendar);
    }

    /// A standby that knows the calendar and heard no sync at the start of this cycle sends
    /// the next cycle's sync itself, at the instant its clock gives (docs/rtcan.md, "Master
    /// failover"): by slot [`CONTINUE_AFTER_SLOT`] the master's sync would have arrived.
    fn continue_cycle(&mut self, state: ClockState) {
        if !MASTER || self.master.is_some() || !self.knows_calendar() {
            return;
        }
        let ClockState::Running(p) = state else { return };
        if p.free_run != 1 || p.slot < CONTINUE_AFTER_SLOT {
            return;
        }
        let next = p.cycle.wrapping_add(1);
        if let Some(at) = self.clock.slot_start(next, SYNC_SLOT) {
            let a = self.failover.continue_cycle(at, next);
            self.apply(a);
        }
    }

    fn apply(&mut self, a: Actions) {
        if let Some(s) = a.start_syncing.filter(|_| MASTER) {
            self.master = Some(MasterCycle { cycle: s.cycle, next_sync: s.at, epoch: s.epoch });
            if !s.continuing {
                self.scheduler.clear();
                self.calendar_cleared();
                self.owners.clear();
                self.clock.reset();
            }
        }
        if a.stop_syncing {
            self.master = None;
            if !a.re_register {
                // Another master continues this calendar: the one this node holds.
                self.calendar_agree = rtcan::schedule::MAX_PERIOD_CYCLES as u16;
            }
        }
        if a.re_register {
            self.re_register();
        }
    }

    /// Loads the most urgent SRT/NRT frame for the window ending at `end` (one at a time).
    fn send_queued<C: CanController + ?Sized>(&mut self, now: Micros, end: Micros, can: &mut C) {
        self.slot_tx.load_queued(now, end, can, &self.tx);
    }
}
