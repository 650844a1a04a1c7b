//! A standby's copy of the master's calendar (issue 22; docs/rtcan.md, "Master failover"): a
//! node that may become master admits every grant it hears into its own scheduler and checks
//! each sync's mask against it, so that when the master dies it can continue the cycle with the
//! same reservations: no node registers again and HRT frames keep their slots.
//!
//! The copy is trusted for a takeover only after it predicted the master's masks for a whole
//! hyperperiod ([`MAX_PERIOD_CYCLES`] syncs in a row), or when the node heard the calendar
//! start (a new epoch: empty, every grant to come). A reservation the master's mask no longer
//! shows is removed (the master released it); one the copy lacks (a grant missed) makes it
//! untrusted until it agrees again. Master-side only, like `liveness.rs`.

use r2p_management::NodeId;
use rtcan::cycle::SyncInfo;
use rtcan::schedule::{occurs, Reservation, MAX_PERIOD_CYCLES};
use rtcan::{MessageId, Micros, Period, Phase, SyncFrame};

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
    /// True if this node's copy of the calendar may carry the bus: as master, or as a standby
    /// whose copy predicted the master's masks for a hyperperiod.
    pub fn knows_calendar(&self) -> bool {
        MASTER
            && (self.master.is_some()
                || u32::from(self.calendar_agree) >= MAX_PERIOD_CYCLES && self.positions_known())
    }

    /// The master granted `stream` of `owner` (this node's or another's) `period_cycles` at
    /// `phase`: a standby takes it into its copy.
    pub(super) fn follow_grant(
        &mut self,
        owner: NodeId,
        stream: MessageId,
        period_cycles: u16,
        phase: Phase,
        now: Micros,
    ) {
        if !MASTER || self.master.is_some() || self.failover.rank().is_none() {
            return;
        }
        let Ok(period) = Period::from_cycles(u32::from(period_cycles)) else { return };
        if phase.slot >= self.config.cycle.slots {
            return; // no slot of this bus's cycle
        }
        if self.scheduler.admit(Reservation { stream, period, phase }).is_err() {
            self.calendar_agree = 0; // a grant it cannot hold: the copy is incomplete
        }
        self.owner_granted(owner, now);
    }

    /// A sync heard as a standby: the calendar starts anew on a new epoch; otherwise the mask
    /// it announces for the next cycle is checked against the copy.
    pub(super) fn follow_sync(&mut self, sync: &SyncFrame, info: SyncInfo, new_calendar: bool) {
        if !MASTER || self.master.is_some() || self.failover.rank().is_none() {
            return;
        }
        if new_calendar {
            self.scheduler.clear(); // the layout too (`Node::on_sync`)
            self.owners.clear();
            self.calendar_agree = MAX_PERIOD_CYCLES as u16;
            return;
        }
        let next = info.cycle.wrapping_add(1);
        // A reservation of the next cycle the master's mask no longer shows: released by the
        // master (a node that left or rebooted), so here.
        let mask = sync.reservations;
        self.scheduler
            .retain(|r| !occurs(r.period, r.phase, next) || mask & 1 << r.phase.slot != 0);
        self.calendar_released();
        let agrees = info.continuous && self.scheduler.mask(next) == mask;
        self.calendar_agree = if agrees {
            self.calendar_agree.saturating_add(1).min(MAX_PERIOD_CYCLES as u16)
        } else {
            0
        };
    }
}
