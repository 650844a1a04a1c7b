//! Master failover: any node with a rank can stand by for the master and take over when syncs
//! stop (docs/rtcan.md, "Master failover").
//!
//! States: **Slave** (a master is heard), **Candidate** (a standby that has heard no sync for
//! [`sync_timeout_us`] and waits for its takeover time), **Master** (sends the syncs).
//!
//! * A standby of rank r takes over [`takeover_delay_us`] = (`TAKEOVER_BASE_CYCLES` +
//!   r·`RANK_STEP_CYCLES`) cycles after the last sync it heard (rank 0 first). Its first sync
//!   restarts the cycle counter at 0 and flips the epoch bit (bit 0 of the sync payload) relative
//!   to the last sync it heard; its calendar starts empty.
//! * A master that receives a sync steps down (sync frames carry no rank; both masters of a
//!   start-up race step down and the rank-ordered delays then elect one). A master whose sync
//!   failed to go out more than [`MAX_SYNC_LOSS`] times in a row steps down too, before anyone
//!   could take over from it.
//! * Every node re-registers its HRT streams on the first sync after losing sync, on a sync
//!   whose epoch bit differs from the previous one, and on a sync that does not continue the
//!   previous one's counter (a new master's restarted counter).
//!
//! Under the fault hypothesis (a node misses at most [`MAX_SYNC_LOSS`] = L consecutive syncs of a
//! live master): a live master is never suspected, since syncs are heard at least every (L+1)
//! cycles < `TAKEOVER_BASE_CYCLES` = L+2; two standbys' last-heard syncs differ by at most L
//! cycles, so the next-ranked standby's takeover time is at least `RANK_STEP_CYCLES` − L = L+1
//! cycles after the first one's, during which it hears one of the new master's syncs and stays
//! slave. Hence after the master's last sync, exactly one master — the lowest-ranked live
//! standby r — syncs within (`TAKEOVER_BASE_CYCLES` + r·`RANK_STEP_CYCLES`) cycles, and no
//! two masters ever sync in the same cycle.

use crate::controller::Micros;
use crate::cycle::{SyncFrame, MAX_SYNC_LOSS};

/// Cycles of silence before the rank-0 standby takes over: L + 2.
pub const TAKEOVER_BASE_CYCLES: u32 = MAX_SYNC_LOSS + 2;
/// Extra cycles of silence per rank step: 2L + 1.
pub const RANK_STEP_CYCLES: u32 = 2 * MAX_SYNC_LOSS + 1;
/// Highest rank; ranks on a bus are unique.
pub const MAX_RANK: u8 = 15;
/// Worst-case takeover time in cycles after the master's last sync (only rank 15 alive).
pub const MAX_TAKEOVER_CYCLES: u32 = TAKEOVER_BASE_CYCLES + MAX_RANK as u32 * RANK_STEP_CYCLES;

/// A standby's priority for taking over: 0 first. Unique on a bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Rank(u8);

impl Rank {
    /// The rank `r`, if at most [`MAX_RANK`].
    pub const fn new(r: u8) -> Option<Self> {
        if r <= MAX_RANK {
            Some(Rank(r))
        } else {
            None
        }
    }

    /// The number.
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// Silence after which a node considers the master lost: (L + 1.5) cycles.
pub const fn sync_timeout_us(cycle_us: u32) -> Micros {
    (MAX_SYNC_LOSS as Micros + 1) * cycle_us as Micros + cycle_us as Micros / 2
}

/// Silence after which a standby of rank `rank` takes over.
pub const fn takeover_delay_us(rank: Rank, cycle_us: u32) -> Micros {
    (TAKEOVER_BASE_CYCLES + rank.0 as u32 * RANK_STEP_CYCLES) as Micros * cycle_us as Micros
}

/// The node's role.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Follows a master's syncs (or, without a rank, waits for one).
    Slave,
    /// A standby that hears no master and will take over at its time.
    Candidate,
    /// Sends the syncs.
    Master,
}

/// How a new master starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StartSyncing {
    /// Send the first sync now: the start of cycle 0.
    pub at: Micros,
    /// Its cycle counter (0).
    pub cycle: u32,
    /// The epoch bit of every sync of this mastership.
    pub epoch: bool,
}

/// What the node must do after an input.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Actions {
    /// Become master: clear the calendar and start sending syncs.
    pub start_syncing: Option<StartSyncing>,
    /// Stop sending syncs.
    pub stop_syncing: bool,
    /// Register every HRT stream of this node again (the calendar that held them is gone).
    pub re_register: bool,
}

impl Actions {
    /// True if nothing is to be done.
    pub fn is_empty(&self) -> bool {
        *self == Actions::default()
    }
}

/// The failover state machine of one node.
#[derive(Clone, Debug)]
pub struct Failover {
    rank: Option<Rank>,
    cycle_us: u32,
    role: Role,
    /// Last sync heard (or, as master, sent): time, counter, epoch bit.
    last: Micros,
    last_cycle: u8,
    epoch: Option<bool>,
    synced: bool,
    tx_failures: u32,
}

impl Failover {
    /// A node booting at `now` as a slave; `rank` is `None` for nodes that never become master.
    pub const fn new(rank: Option<Rank>, cycle_us: u32, now: Micros) -> Self {
        Self {
            rank,
            cycle_us,
            role: Role::Slave,
            last: now,
            last_cycle: 0,
            epoch: None,
            synced: false,
            tx_failures: 0,
        }
    }

    /// The current role.
    pub const fn role(&self) -> Role {
        self.role
    }

    /// The node's rank.
    pub const fn rank(&self) -> Option<Rank> {
        self.rank
    }

    /// True while a master is heard within [`sync_timeout_us`] (or this node is master).
    pub const fn synced(&self) -> bool {
        self.synced
    }

    /// The epoch bit of the current master, if one was heard.
    pub const fn epoch(&self) -> Option<bool> {
        self.epoch
    }

    /// When this node will take over if it hears nothing until then.
    pub fn takeover_at(&self) -> Option<Micros> {
        match self.role {
            Role::Master => None,
            _ => self.rank.map(|r| self.last + takeover_delay_us(r, self.cycle_us)),
        }
    }

    /// Time passes: call at least every millisecond or so (a sync slot's timer will do).
    pub fn poll(&mut self, now: Micros) -> Actions {
        let mut a = Actions::default();
        if self.role == Role::Master {
            return a;
        }
        if self.synced && now.saturating_sub(self.last) >= sync_timeout_us(self.cycle_us) {
            self.synced = false;
        }
        if !self.synced && self.rank.is_some() {
            self.role = Role::Candidate;
        }
        if let Some(at) = self.takeover_at() {
            if now >= at {
                let epoch = !self.epoch.unwrap_or(true);
                self.role = Role::Master;
                self.synced = true;
                self.epoch = Some(epoch);
                self.last = now;
                self.last_cycle = 0;
                self.tx_failures = 0;
                a.start_syncing = Some(StartSyncing { at: now, cycle: 0, epoch });
                a.re_register = true;
            }
        }
        a
    }

    /// A sync frame from another node was received at `now`.
    pub fn on_sync(&mut self, now: Micros, sync: &SyncFrame) -> Actions {
        let mut a = Actions::default();
        if self.role == Role::Master {
            a.stop_syncing = true;
            a.re_register = true;
        } else {
            // Continuity: the counter advanced by the number of elapsed cycles (1..=L+1).
            let t = self.cycle_us as Micros;
            let n = (now.saturating_sub(self.last) + t / 2) / t;
            let continuous = (1..=MAX_SYNC_LOSS as Micros + 1).contains(&n)
                && self.last_cycle.wrapping_add(n as u8) == sync.cycle;
            a.re_register = !self.synced || self.epoch != Some(sync.epoch) || !continuous;
        }
        self.role = Role::Slave;
        self.synced = true;
        self.last = now;
        self.last_cycle = sync.cycle;
        self.epoch = Some(sync.epoch);
        a
    }

    /// As master: the sync of the current cycle was sent (`ok`) or could not be sent.
    pub fn on_sync_sent(&mut self, now: Micros, sync: &SyncFrame, ok: bool) -> Actions {
        let mut a = Actions::default();
        if self.role != Role::Master {
            return a;
        }
        if ok {
            self.tx_failures = 0;
            self.last = now;
            self.last_cycle = sync.cycle;
            return a;
        }
        self.tx_failures += 1;
        if self.tx_failures > MAX_SYNC_LOSS {
            // Others may be counting silence since our last good sync: compete from there.
            self.role = Role::Slave;
            self.synced = false;
            a.stop_syncing = true;
            a.re_register = true;
        }
        a
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    const T: u32 = 10_000;

    fn rank(r: u8) -> Option<Rank> {
        Rank::new(r)
    }

    r2p_testkit::suite! {
        fn constants_follow_the_loss_bound() {
            assert_eq!(TAKEOVER_BASE_CYCLES, 4);
            assert_eq!(RANK_STEP_CYCLES, 5);
            assert_eq!(MAX_TAKEOVER_CYCLES, 79);
            assert_eq!(sync_timeout_us(T), 35_000);
            assert_eq!(takeover_delay_us(Rank::new(2).unwrap(), T), 140_000);
            assert_eq!(Rank::new(16), None);
            // A live master is heard at least every L + 1 cycles: never suspected.
            assert!(((MAX_SYNC_LOSS + 1) * T) as Micros + T as Micros / 2 <= sync_timeout_us(T));
            assert!(sync_timeout_us(T) < takeover_delay_us(Rank::new(0).unwrap(), T));
        }

        fn lone_standby_takes_over_at_its_time() {
            let mut f = Failover::new(rank(1), T, 0);
            assert_eq!(f.takeover_at(), Some(90_000));
            assert!(f.poll(50_000).is_empty());
            assert_eq!(f.role(), Role::Candidate);
            let a = f.poll(90_000);
            assert_eq!(a.start_syncing, Some(StartSyncing { at: 90_000, cycle: 0, epoch: false }));
            assert!(a.re_register);
            assert_eq!(f.role(), Role::Master);
            assert!(f.poll(10_000_000).is_empty());
        }

        fn nodes_without_rank_never_take_over() {
            let mut f = Failover::new(None, T, 0);
            assert!(f.poll(100_000_000).is_empty());
            assert_eq!(f.role(), Role::Slave);
            assert!(!f.synced());
        }

        fn syncs_keep_a_standby_slave_and_losses_are_tolerated() {
            let mut f = Failover::new(rank(0), T, 0);
            let a = f.on_sync(1_000, &SyncFrame::new(7, 0, true));
            assert!(a.re_register, "first sync: register");
            assert!(f.on_sync(11_000, &SyncFrame::new(8, 0, true)).is_empty());
            // Two syncs lost, the third arrives: still the same master.
            assert!(f.poll(40_999).is_empty());
            assert_eq!(f.role(), Role::Slave);
            // Even polled right before the third sync is handled, rank 0 does not take over.
            assert!(f.poll(41_000).is_empty());
            assert!(f.on_sync(41_000, &SyncFrame::new(11, 0, true)).is_empty());
            assert_eq!(f.takeover_at(), Some(81_000));
        }

        fn epoch_flip_or_counter_restart_means_re_register() {
            let mut f = Failover::new(None, T, 0);
            f.on_sync(0, &SyncFrame::new(200, 0, false));
            assert!(f.on_sync(10_000, &SyncFrame::new(201, 0, true)).re_register);
            assert!(!f.on_sync(20_000, &SyncFrame::new(202, 0, true)).re_register);
            assert!(f.on_sync(30_000, &SyncFrame::new(0, 0, true)).re_register);
            // Lost for longer than the timeout: re-register even with the same epoch.
            f.poll(66_000);
            assert!(!f.synced());
            assert!(f.on_sync(70_000, &SyncFrame::new(4, 0, true)).re_register);
        }

        fn master_steps_down_on_a_foreign_sync() {
            let mut f = Failover::new(rank(3), T, 0);
            assert!(f.poll(190_000).start_syncing.is_some());
            let a = f.on_sync(195_000, &SyncFrame::new(9, 0, true));
            assert!(a.stop_syncing && a.re_register);
            assert_eq!(f.role(), Role::Slave);
            assert_eq!(f.takeover_at(), Some(195_000 + 190_000));
        }

        fn master_steps_down_after_failed_syncs() {
            let mut f = Failover::new(rank(0), T, 0);
            let s = f.poll(40_000).start_syncing.unwrap();
            let sync = SyncFrame::new(s.cycle, 0, s.epoch);
            assert!(f.on_sync_sent(40_000, &sync, true).is_empty());
            for k in 1..=MAX_SYNC_LOSS as u64 {
                assert!(f.on_sync_sent(40_000 + k * 10_000, &sync, false).is_empty());
            }
            let a = f.on_sync_sent(70_000, &sync, false);
            assert!(a.stop_syncing);
            assert_eq!(f.role(), Role::Slave);
            // Competes again from its last good sync; keeps its epoch bit.
            assert_eq!(f.takeover_at(), Some(80_000));
            let a = f.poll(80_000);
            assert_eq!(a.start_syncing.map(|s| s.epoch), Some(!s.epoch));
        }

        fn a_sent_sync_resets_the_failure_count() {
            // "More than L failures in a row": L failures, a success, L failures again keep
            // the node master; only the (L + 1)-th consecutive one makes it step down.
            let mut f = Failover::new(rank(0), T, 0);
            let s = f.poll(40_000).start_syncing.unwrap();
            let sync = SyncFrame::new(s.cycle, 0, s.epoch);
            let mut t = 40_000;
            for _ in 0..3 {
                for _ in 0..MAX_SYNC_LOSS {
                    t += 10_000;
                    assert!(f.on_sync_sent(t, &sync, false).is_empty());
                }
                t += 10_000;
                assert!(f.on_sync_sent(t, &sync, true).is_empty());
                assert_eq!(f.role(), Role::Master);
            }
            for _ in 0..MAX_SYNC_LOSS {
                t += 10_000;
                assert!(f.on_sync_sent(t, &sync, false).is_empty());
            }
            assert!(f.on_sync_sent(t + 10_000, &sync, false).stop_syncing);
            assert_eq!(f.role(), Role::Slave);
        }

        fn adjacent_ranks_with_worst_case_losses_never_both_master() {
            // The master syncs every T up to cycle 9 (at 90 000) and dies. A (rank 0) hears
            // every sync; B (rank 1) misses the last L of them and the first L of A's.
            let mut a = Failover::new(rank(0), T, 0);
            let mut b = Failover::new(rank(1), T, 0);
            for c in 0..10u32 {
                let at = c as Micros * 10_000;
                a.on_sync(at, &SyncFrame::new(c, 0, false));
                if c < 10 - MAX_SYNC_LOSS {
                    b.on_sync(at, &SyncFrame::new(c, 0, false));
                }
            }
            let mut t = 90_000;
            let mut a_syncs = 0;
            while t <= 300_000 {
                let ra = a.poll(t);
                let rb = b.poll(t);
                assert!(rb.start_syncing.is_none(), "B took over at {} while A is master", t);
                if ra.start_syncing.is_some() {
                    assert_eq!(t, 130_000);
                }
                if a.role() == Role::Master && (t - 130_000) % 10_000 == 0 {
                    a_syncs += 1;
                    if a_syncs > MAX_SYNC_LOSS {
                        b.on_sync(t, &SyncFrame::new(a_syncs - 1, 0, true));
                    }
                }
                t += 1_000;
            }
            assert_eq!(b.role(), Role::Slave);
        }

        fn epoch_flip_catches_a_takeover_the_counter_hides() {
            // The old master's last sync has counter 254 at 1 000 000; the new master (which
            // missed the last L syncs) starts L cycles later with counter 0 = 254 + 2 mod 256.
            let mut n = Failover::new(None, T, 0);
            let mut a = Failover::new(rank(0), T, 0);
            for c in 240..=254u32 {
                let at = 1_000_000 - (254 - c as Micros) * 10_000;
                n.on_sync(at, &SyncFrame::new(c, 0, true));
                if c <= 254 - MAX_SYNC_LOSS {
                    a.on_sync(at, &SyncFrame::new(c, 0, true));
                }
            }
            let start = a.poll(1_020_000).start_syncing.unwrap();
            assert_eq!((start.cycle, start.epoch), (0, false));
            let r = n.on_sync(1_020_000, &SyncFrame::new(start.cycle, 0, start.epoch));
            assert!(r.re_register);
        }

        fn lower_rank_wins_a_common_silence() {
            let mut a = Failover::new(rank(0), T, 0);
            let mut b = Failover::new(rank(1), T, 0);
            for f in [&mut a, &mut b] {
                f.on_sync(5_000, &SyncFrame::new(1, 0, false));
            }
            assert!(a.poll(45_000).start_syncing.is_some());
            // b hears a's first sync before its own time (95 000) and stays slave.
            assert!(b.poll(45_000).is_empty());
            let r = b.on_sync(45_000, &SyncFrame::new(0, 0, true));
            assert!(r.re_register);
            assert_eq!(b.role(), Role::Slave);
            assert!(b.poll(94_999).is_empty());
        }
    }
}

#[cfg(test)]
mod proptests {
    extern crate std;
    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    const T: u32 = 10_000;
    const STEP: Micros = 500;

    struct Node {
        f: Failover,
        /// Boots at this time (0, or later while a master is live: a late joiner).
        boot_at: Micros,
        booted: bool,
        alive: bool,
        /// Consecutive syncs this node missed (the loss model keeps it ≤ MAX_SYNC_LOSS).
        misses: u32,
        /// As master: when the next sync goes out, its counter and epoch, and the mastership.
        next_sync: Option<(Micros, u32, bool, u32)>,
        /// The mastership this node's streams are registered with.
        registered_with: Option<u32>,
    }

    /// A node: rank (None = never master) and boot time.
    type Spec = (Option<u8>, Micros);

    /// Deterministic bus of `specs` nodes: sync loss with probability `loss_pct` bounded by
    /// MAX_SYNC_LOSS consecutive — for all receivers at once (`global`, CAN's consistent
    /// broadcast) or for each receiver on its own — and the master killed `kills[j]` µs after
    /// the j-th takeover. Within the fault hypothesis (module documentation): with
    /// per-receiver loss a master lives at least MAX_SYNC_LOSS + 1 syncs; late joiners boot
    /// while a master is live, and it lives until they heard it.
    fn simulate(specs: &[Spec], global: bool, loss_pct: u64, seed: u64, kills: &[Micros]) {
        let min_life = if global { 0 } else { MAX_SYNC_LOSS as Micros * T as Micros + STEP };
        let mut rng = seed | 1;
        let mut rand = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng
        };
        let mut nodes: Vec<Node> = specs
            .iter()
            .map(|&(r, boot_at)| Node {
                f: Failover::new(r.map(|r| Rank::new(r).unwrap()), T, 0),
                boot_at,
                booted: false,
                alive: false,
                misses: 0,
                next_sync: None,
                registered_with: None,
            })
            .collect();
        let mut last_sync_at: Micros = 0; // boot is the common reference
        let mut last_sender: Option<usize> = None;
        let mut masterships = 0u32;
        let mut takeover_at: Option<Micros> = None;
        let mut kills_done = 0;
        let mut global_misses = 0;
        let mut t: Micros = 0;
        let end_margin = (MAX_TAKEOVER_CYCLES as Micros + 10) * T as Micros;
        let mut quiet_since_last_kill: Micros = 0;
        while quiet_since_last_kill < end_margin {
            let live_master = nodes.iter().any(|n| n.alive && n.f.role() == Role::Master);
            // Boot: everyone at 0; late joiners only while a master is live.
            for n in nodes.iter_mut().filter(|n| !n.booted && t >= n.boot_at) {
                if n.boot_at == 0 || live_master {
                    n.f = Failover::new(n.f.rank(), T, t);
                    n.booted = true;
                    n.alive = true;
                }
            }
            // Kill the master when its turn comes (not before every joiner heard it).
            let joiners_heard = nodes.iter().all(|n| !n.alive || n.boot_at == 0 || n.f.synced());
            let standbys_alive = nodes.iter().filter(|n| n.alive && n.f.rank().is_some()).count();
            if let Some(d) = takeover_at {
                if kills_done < kills.len()
                    && t >= d + kills[kills_done].max(min_life)
                    && joiners_heard
                    && standbys_alive >= 2
                {
                    let m = nodes.iter().position(|n| n.alive && n.f.role() == Role::Master);
                    if let Some(m) = m {
                        nodes[m].alive = false;
                        kills_done += 1;
                        takeover_at = None;
                    }
                }
            }
            if kills_done == kills.len() {
                quiet_since_last_kill += STEP;
            }
            // Time passes.
            let best = nodes.iter().filter(|n| n.alive).filter_map(|n| n.f.rank()).min();
            for n in nodes.iter_mut().filter(|n| n.alive) {
                let a = n.f.poll(t);
                if let Some(s) = a.start_syncing {
                    assert_eq!(s.at, t);
                    assert_eq!(n.f.rank(), best, "the best live standby takes over");
                    masterships += 1;
                    n.next_sync = Some((t, s.cycle, s.epoch, masterships));
                    takeover_at = Some(t);
                }
                if a.re_register {
                    assert!(a.start_syncing.is_some(), "poll re-registers only on takeover");
                    n.registered_with = Some(masterships);
                }
            }
            let alive_masters: Vec<usize> = (0..nodes.len())
                .filter(|&i| nodes[i].alive && nodes[i].f.role() == Role::Master)
                .collect();
            assert!(alive_masters.len() <= 1, "two masters at {t}: {alive_masters:?}");
            // Bound: with no live master, one must appear within the rank's takeover time.
            if alive_masters.is_empty() {
                if let Some(r) = best {
                    let bound = last_sync_at + takeover_delay_us(r, T);
                    assert!(t < bound, "no master at {t}, bound {bound} (rank {r:?})");
                }
            }
            // Syncs.
            for m in alive_masters {
                let Some((at, cycle, epoch, ship)) = nodes[m].next_sync else { continue };
                if at > t {
                    continue;
                }
                if last_sender.is_some_and(|s| s != m) {
                    assert!(t >= last_sync_at + T as Micros, "two masters' syncs within a cycle");
                }
                let sync = SyncFrame::new(cycle, 0, epoch);
                assert!(nodes[m].f.on_sync_sent(t, &sync, true).is_empty());
                last_sync_at = t;
                last_sender = Some(m);
                nodes[m].next_sync = Some((at + T as Micros, cycle + 1, epoch, ship));
                let lost_by_all = global_misses < MAX_SYNC_LOSS && rand() % 100 < loss_pct;
                global_misses = if lost_by_all { global_misses + 1 } else { 0 };
                for (i, n) in nodes.iter_mut().enumerate() {
                    if i == m || !n.alive {
                        continue;
                    }
                    let lost = if global {
                        lost_by_all
                    } else {
                        n.misses < MAX_SYNC_LOSS && rand() % 100 < loss_pct
                    };
                    if lost {
                        n.misses += 1;
                        continue;
                    }
                    n.misses = 0;
                    let a = n.f.on_sync(t, &sync);
                    assert!(a.start_syncing.is_none() && !a.stop_syncing, "{a:?}");
                    if a.re_register {
                        n.registered_with = Some(ship);
                    }
                    assert_eq!(
                        n.registered_with,
                        Some(ship),
                        "node {i} thinks it is registered with another master"
                    );
                }
            }
            t += STEP;
            if t > 30_000_000 {
                break; // every standby that boots late may be needed; stop planning kills
            }
        }
        assert!(kills_done >= 1, "the first master was killed");
    }

    fn scenario() -> impl Strategy<Value = (Vec<Spec>, u64, u64, Vec<Micros>)> {
        (2usize..=6, 0usize..=2)
            .prop_flat_map(|(standbys, plain)| {
                // Dense ranks (often adjacent, often including 0) are the hard cases.
                let ranks = (0u8..=MAX_RANK - 8).prop_flat_map(move |base| {
                    let top = (base + standbys as u8 + 2).min(MAX_RANK);
                    proptest::sample::subsequence((base..=top).collect::<Vec<u8>>(), standbys)
                        .prop_shuffle()
                });
                // Most boot at 0; some join later (in ms).
                let boots = proptest::collection::vec(
                    prop_oneof![3 => Just(0u64), 1 => 1u64..=1_500],
                    standbys + plain,
                );
                let kills = proptest::collection::vec(0u64..=600_000, 1..standbys);
                (ranks, Just(plain), boots, 0u64..=95, any::<u64>(), kills)
            })
            .prop_map(|(ranks, plain, boots, loss, seed, kills)| {
                let mut r: Vec<Option<u8>> = ranks.into_iter().map(Some).collect();
                r.extend(core::iter::repeat_n(None, plain));
                // The first node always boots at 0 so that a master appears.
                let specs = r
                    .into_iter()
                    .zip(boots)
                    .enumerate()
                    .map(|(i, (r, b))| (r, if i == 0 { 0 } else { b * 1_000 }))
                    .collect();
                (specs, loss, seed, kills)
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]
        #[test]
        fn one_master_within_the_bound(
            (specs, loss, seed, kills) in scenario(),
            global in any::<bool>(),
        ) {
            simulate(&specs, global, loss, seed, &kills);
        }

        #[test]
        fn quick_successive_deaths((specs, loss, seed, _k) in scenario(), d in 0u64..=40_000) {
            // Each new master dies again within a few cycles, possibly before anyone heard it.
            let standbys = specs.iter().filter(|s| s.0.is_some()).count();
            let kills: Vec<Micros> = (1..standbys).map(|_| d).collect();
            simulate(&specs, true, loss, seed, &kills);
        }
    }
}
