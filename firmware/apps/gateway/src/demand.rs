//! The gateway's bus imports follow the ROS side (issue 22): an import only ROS 2 wants is
//! unsubscribed on the bus (`Node::unsubscribe`) when the last Zenoh subscriber of the ROS
//! topics it feeds has been gone for [`HOLD_OFF_US`], and subscribed again (`resubscribe`)
//! as soon as one comes back; its publisher's stream stops when no other node wants it, and
//! its frames leave the bus.
//!
//! Two halves, because the MCU runs them in two tasks: [`Demand`] decides, in the ROS task,
//! from the Zenoh session's [`Matching`](r2p_zenoh::matching::Matching) (who subscribes to
//! each published key); it hands a mask of the imports it wants to [`Follower`], which
//! subscribes and unsubscribes them on the node in the bus task. Both take the same list of
//! [`Feed`]s, in the same order: bit `k` of the mask is `feeds[k]`.
//!
//! What stays subscribed: every import not in the feeds — the base controller's when it runs
//! on the gateway (it needs them whether ROS listens or not; the gateway's own `odom` and
//! ranges imports exist only when it runs elsewhere), and everything while the ROS side knows
//! nothing (no router, a session not yet answered: no change is made on no information).

use heapless::Vec;
use r2p_node::{Node, NodeError};

use crate::endpoints::{BARO_TOPIC, BATTERY_TOPIC, GNSS_TOPIC, IMU_TOPIC, MAG_TOPIC, MIRRORED};
use crate::ros::topic;

/// How long an import stays subscribed after the last Zenoh subscriber of its ROS topics
/// left: 5 s. A ROS 2 node that restarts (a crash and its launch file's respawn, a
/// `ros2 topic echo` run again) undeclares its subscriber and declares it again a few seconds
/// later; each unsubscription and subscription costs the bus a request and an answer and the
/// subscriber a stream that restarts from its next message, while 5 s more of a topic nobody
/// reads costs at most 5 s of its frames. A figure chosen for that, not measured on a robot.
pub const HOLD_OFF_US: u64 = 5_000_000;

/// Most feeds one gateway follows: the gateway's 10 and a remote base's 2 (the F407 image's
/// static RAM is within ~300 B of its budget: no room kept for more).
pub const MAX_FEEDS: usize = 12;

/// A gateway's feeds, in the order of [`Demand::wanted`]'s bits.
pub type Feeds<'a> = Vec<Feed<'a>, MAX_FEEDS>;

/// An import only the ROS side wants, and the ROS topics it feeds (bits of
/// [`crate::ros::topic`] indices).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Feed<'a> {
    /// The imported R2P topic.
    pub topic: &'a str,
    /// The ROS publishers it feeds, a bit each.
    pub ros: u32,
}

const fn one(i: usize) -> u32 {
    1 << i
}

/// The gateway's own imports ([`crate::App::register`]): each feeds one ROS topic.
pub const GATEWAY_FEEDS: [Feed<'static>; 10] = [
    Feed { topic: BATTERY_TOPIC, ros: one(topic::BATTERY) },
    Feed { topic: IMU_TOPIC, ros: one(topic::IMU) },
    Feed { topic: MAG_TOPIC, ros: one(topic::MAG) },
    Feed { topic: BARO_TOPIC, ros: one(topic::PRESSURE) },
    Feed { topic: GNSS_TOPIC, ros: one(topic::GNSS) },
    Feed { topic: MIRRORED[0].0, ros: one(topic::MIRRORED0) },
    Feed { topic: MIRRORED[1].0, ros: one(topic::MIRRORED0 + 1) },
    Feed { topic: MIRRORED[2].0, ros: one(topic::MIRRORED0 + 2) },
    Feed { topic: MIRRORED[3].0, ros: one(topic::MIRRORED0 + 3) },
    Feed { topic: MIRRORED[4].0, ros: one(topic::MIRRORED0 + 4) },
];

/// Counters (they only grow).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DemandStats {
    /// Imports given up (their last subscriber gone for the hold-off).
    pub unsubscribes: u32,
    /// Imports wanted again.
    pub resubscribes: u32,
}

/// Which imports the ROS side wants, with the hold-off.
#[derive(Clone, Debug)]
pub struct Demand {
    /// Each feed's ROS topics.
    ros: Vec<u32, MAX_FEEDS>,
    /// Since when each has had no subscriber (while still wanted); [`NOT_IDLE`] if it has one.
    idle_since: [u64; MAX_FEEDS],
    /// Bit `k`: feed `k` is wanted.
    wanted: u32,
    stats: DemandStats,
}

/// An `idle_since` that is no time (half the size of an `Option<u64>`).
const NOT_IDLE: u64 = u64::MAX;

impl Default for Demand {
    fn default() -> Self {
        Self::new(&[])
    }
}

impl Demand {
    /// Following `feeds` (the first [`MAX_FEEDS`]), all wanted.
    pub fn new(feeds: &[Feed<'_>]) -> Self {
        let ros = feeds.iter().take(MAX_FEEDS).map(|f| f.ros).collect();
        let idle_since = [NOT_IDLE; MAX_FEEDS];
        Self { ros, idle_since, wanted: u32::MAX, stats: DemandStats::default() }
    }

    /// The state at `now_us`, given whether each ROS topic has a subscriber (`None`: not known).
    /// A feed is wanted while any of its topics has one; given up when all of them have had
    /// none for [`HOLD_OFF_US`]; left as it is while any is not known.
    pub fn update(&mut self, now_us: u64, matched: impl Fn(usize) -> Option<bool>) {
        for (k, &ros) in self.ros.iter().enumerate() {
            let (mut any, mut unknown) = (false, false);
            for i in (0..32).filter(|i| ros & (1 << i) != 0) {
                match matched(i) {
                    Some(true) => any = true,
                    Some(false) => {}
                    None => unknown = true,
                }
            }
            let bit = 1 << k;
            let wanted = self.wanted & bit != 0;
            if any {
                self.idle_since[k] = NOT_IDLE;
                if !wanted {
                    self.wanted |= bit;
                    self.stats.resubscribes = self.stats.resubscribes.wrapping_add(1);
                }
            } else if unknown {
                self.idle_since[k] = NOT_IDLE;
            } else if wanted {
                if self.idle_since[k] == NOT_IDLE {
                    self.idle_since[k] = now_us;
                }
                if now_us.saturating_sub(self.idle_since[k]) >= HOLD_OFF_US {
                    self.wanted &= !bit;
                    self.idle_since[k] = NOT_IDLE;
                    self.stats.unsubscribes = self.stats.unsubscribes.wrapping_add(1);
                }
            }
        }
    }

    /// Bit `k`: feed `k` is wanted (bits past the feeds are set).
    pub fn wanted(&self) -> u32 {
        self.wanted
    }

    /// The counters.
    pub fn stats(&self) -> DemandStats {
        self.stats
    }
}

/// What following the demand needs of the node (the gateway's `Node`, with r2p-node's
/// `unsubscribe` feature).
pub trait Imports {
    /// The index of the import of `topic`.
    fn import_index(&self, topic: &str) -> Option<usize>;
    /// Stops import `import` ([`Node::unsubscribe`]).
    fn unsubscribe(&mut self, import: usize) -> Result<(), NodeError>;
    /// Wants it again ([`Node::resubscribe`]).
    fn resubscribe(&mut self, import: usize) -> Result<(), NodeError>;
}

impl<
        'a,
        const E: usize,
        const I: usize,
        const T: usize,
        const R: usize,
        const B: usize,
        const M: bool,
    > Imports for Node<'a, E, I, T, R, B, M>
{
    fn import_index(&self, topic: &str) -> Option<usize> {
        Node::import_index(self, topic)
    }
    fn unsubscribe(&mut self, import: usize) -> Result<(), NodeError> {
        Node::unsubscribe(self, import)
    }
    fn resubscribe(&mut self, import: usize) -> Result<(), NodeError> {
        Node::resubscribe(self, import)
    }
}

/// The node's side: applies the wanted mask to the imports the feeds name.
#[derive(Clone, Debug)]
pub struct Follower {
    /// Each feed's import on the node ([`NO_IMPORT`]: the node does not import it; a node has
    /// fewer than 255 imports).
    index: [u8; MAX_FEEDS],
    /// Bit `k`: feed `k` is subscribed, as last applied.
    applied: u32,
}

/// A feed the node does not import.
const NO_IMPORT: u8 = u8::MAX;

impl Follower {
    /// The feeds' imports on `node` (registered before), all subscribed.
    pub fn bind(feeds: &[Feed<'_>], node: &impl Imports) -> Self {
        let mut index = [NO_IMPORT; MAX_FEEDS];
        for (slot, f) in index.iter_mut().zip(feeds) {
            let i = node.import_index(f.topic).and_then(|i| u8::try_from(i).ok());
            *slot = i.unwrap_or(NO_IMPORT);
        }
        Self { index, applied: u32::MAX }
    }

    /// Unsubscribes the feeds `wanted` no longer has, resubscribes those it has again.
    pub fn apply(&mut self, wanted: u32, node: &mut impl Imports) {
        let changed = wanted ^ self.applied;
        if changed == 0 {
            return;
        }
        for (k, import) in self.index.iter().enumerate() {
            let bit = 1 << k;
            if *import == NO_IMPORT || changed & bit == 0 {
                continue;
            }
            let i = usize::from(*import);
            // The index came from the node: neither call can fail.
            let _ = match wanted & bit {
                0 => node.unsubscribe(i),
                _ => node.resubscribe(i),
            };
        }
        self.applied = wanted;
    }
}
