//! Which of this client's published key expressions have subscribers behind the router, from
//! the router's answers to one interest per key ([`Net::declare_interest`]).
//!
//! Why subscriber declarations and not rmw_zenoh's liveliness tokens (`@ros2_lv/…/MS/…`): a
//! token says a ROS 2 subscription exists, but the users of an R2P kit may also subscribe with
//! plain Zenoh (zenoh-python, a Zenoh-Foxglove bridge, `z_sub`), which declares a subscriber
//! and no token. The router's subscriber declarations are what decides where a put goes, so
//! they are exactly "someone would receive this": every subscriber whose key expression
//! matches, with wildcards (`0/**` matches `/odom`'s key), ROS or not. It is also what Zenoh's
//! own publishers use for their matching status and zenoh-pico for its write filter.
//!
//! Conventions: `keys[i]` is this client's key expression declared as expression id `i + 1`,
//! and its interest is interest id `i + 1` ([`interest_id`]). The router's subscriber ids name
//! key expressions (one per key expression, whoever holds it): each is kept with the keys it
//! matches until it is undeclared.
//!
//! Failing safe: a declaration this table cannot follow (the table is full, the router named
//! the key by a prefix the session no longer remembers, the key is too long to match) makes
//! every key count as matched until the session starts over: publishing to nobody is waste,
//! not publishing to someone is a fault.
//!
//! [`Net::declare_interest`]: crate::session::Net::declare_interest

use heapless::{String, Vec};

use crate::keyexpr;
use crate::session::{Declared, Event, MAX_KEY};

/// Most keys one table follows (a bit each).
pub const MAX_KEYS: usize = 32;

/// The interest id for `keys[i]`.
pub const fn interest_id(i: usize) -> u32 {
    i as u32 + 1
}

/// Counters (they only grow).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MatchingStats {
    /// Subscriber declarations kept (they match at least one key).
    pub declared: u32,
    /// Subscriber declarations that match none of the keys: not kept.
    pub unmatched: u32,
    /// Subscribers undeclared.
    pub undeclared: u32,
    /// Declarations that could not be followed: every key counts as matched since.
    pub unresolved: u32,
}

/// The router's subscribers that match this client's keys; `SUBS` of them at most.
#[derive(Clone, Debug)]
pub struct Matching<const SUBS: usize> {
    /// The router's subscriber id and the keys it matches (a bit each).
    subs: Vec<(u32, u32), SUBS>,
    /// Keys whose interest's current subscribers are all declared (DECLARE FINAL came).
    complete: u32,
    /// A declaration could not be followed: everything counts as matched.
    saturated: bool,
    stats: MatchingStats,
}

impl<const SUBS: usize> Default for Matching<SUBS> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const SUBS: usize> Matching<SUBS> {
    /// Nothing known yet.
    pub const fn new() -> Self {
        Self { subs: Vec::new(), complete: 0, saturated: false, stats: zero_stats() }
    }

    /// A new session: the router's ids and this client's interests start over (the counters
    /// go on).
    pub fn reset(&mut self) {
        self.subs.clear();
        self.complete = 0;
        self.saturated = false;
    }

    /// Takes in one event of the session (the others are ignored).
    pub fn on_event(&mut self, event: &Event<'_>, keys: &[&str]) {
        match *event {
            Event::Subscriber { id, key } => self.declared(id, key, keys),
            Event::SubscriberGone { id } => {
                let before = self.subs.len();
                self.subs.retain(|&(s, _)| s != id);
                if self.subs.len() != before {
                    self.stats.undeclared = self.stats.undeclared.wrapping_add(1);
                }
            }
            Event::InterestFinal { id } => {
                if let Some(i) = (0..keys.len().min(MAX_KEYS)).find(|&i| interest_id(i) == id) {
                    self.complete |= 1 << i;
                }
            }
            Event::Opened | Event::Sample { .. } => {}
        }
    }

    fn declared(&mut self, id: u32, key: Declared<'_>, keys: &[&str]) {
        let mut pattern: String<MAX_KEY> = String::new();
        let (prefix, suffix) = match key {
            Declared::Full(k) => (Some(k.prefix), k.suffix),
            Declared::Own { expr_id, suffix } => {
                (keys.get(usize::from(expr_id).wrapping_sub(1)).copied(), suffix)
            }
            Declared::Unknown => (None, ""),
        };
        let whole =
            prefix.is_some_and(|p| pattern.push_str(p).is_ok() && pattern.push_str(suffix).is_ok());
        if !whole {
            return self.saturate();
        }
        let mask = keys
            .iter()
            .take(MAX_KEYS)
            .enumerate()
            .filter(|(_, k)| keyexpr::matches(&pattern, k))
            .fold(0u32, |m, (i, _)| m | 1 << i);
        self.subs.retain(|&(s, _)| s != id);
        if mask == 0 {
            self.stats.unmatched = self.stats.unmatched.wrapping_add(1);
            return;
        }
        if self.subs.push((id, mask)).is_err() {
            return self.saturate();
        }
        self.stats.declared = self.stats.declared.wrapping_add(1);
    }

    fn saturate(&mut self) {
        self.saturated = true;
        self.stats.unresolved = self.stats.unresolved.wrapping_add(1);
    }

    /// Subscriber key expressions that match `keys[i]` now.
    pub fn count(&self, i: usize) -> usize {
        self.subs.iter().filter(|&&(_, m)| i < MAX_KEYS && m & (1 << i) != 0).count()
    }

    /// Whether `keys[i]` has a subscriber: `None` while its interest's answer is not complete
    /// and none came yet; `Some(true)` for any key after a declaration that could not be
    /// followed.
    pub fn matched(&self, i: usize) -> Option<bool> {
        if self.saturated || self.count(i) > 0 {
            Some(true)
        } else if i < MAX_KEYS && self.complete & (1 << i) != 0 {
            Some(false)
        } else {
            None
        }
    }

    /// The write filter: whether a sample on `keys[i]` should go to the router. Only a key
    /// known to have no subscriber (its interest answered, none declared since, nothing that
    /// could not be followed) is held back; anything unknown sends, as zenoh-pico's write
    /// filter does, since publishing to nobody is waste and not publishing to someone a fault.
    pub fn sends(&self, i: usize) -> bool {
        self.matched(i) != Some(false)
    }

    /// The counters.
    pub fn stats(&self) -> MatchingStats {
        self.stats
    }
}

const fn zero_stats() -> MatchingStats {
    MatchingStats { declared: 0, unmatched: 0, undeclared: 0, unresolved: 0 }
}
