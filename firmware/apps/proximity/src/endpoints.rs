//! The proximity module's topics, their publishers, and the proxies that put them on the bus.
//!
//! | topic | type | class |
//! |---|---|---|
//! | `proximity/ranges` | `Proximity` | NRT, at `rate_hz` |
//! | `proximity/obstacle` | `Obstacle` | SRT, deadline `obstacle_deadline_ms` (Listing 1) |
//!
//! Topic names depend on the `instance` parameter and a publisher's class on a parameter, so the
//! objects are made at boot from the parameters, in a [`Storage`] of `StaticCell`s: a `static`
//! one on the MCU, a leaked one per emulated board on the host ([`Endpoints::leak`]).

use r2p_middleware::{pool_size, Class, Publisher, Topic};
use r2p_msgs::{Obstacle, Proximity};
use r2p_node::{ParamStore, RemoteSubscriber};
use static_cell::StaticCell;

use crate::params::{INSTANCE, OBSTACLE_DEADLINE_MS};

/// A module's name and its topics' names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Names {
    /// Node name (heartbeats).
    pub node: &'static str,
    /// The four distances.
    pub ranges: &'static str,
    /// Obstacle events.
    pub obstacle: &'static str,
}

/// Names by `instance` parameter.
pub const NAMES: [Names; 4] = [
    Names { node: "proximity", ranges: "proximity/ranges", obstacle: "proximity/obstacle" },
    Names { node: "proximity1", ranges: "proximity1/ranges", obstacle: "proximity1/obstacle" },
    Names { node: "proximity2", ranges: "proximity2/ranges", obstacle: "proximity2/obstacle" },
    Names { node: "proximity3", ranges: "proximity3/ranges", obstacle: "proximity3/obstacle" },
];

/// The names the parameters select.
pub fn names(params: &dyn ParamStore) -> &'static Names {
    let i = crate::params::typed(params).u32(INSTANCE) as usize;
    &NAMES[i.min(NAMES.len() - 1)]
}

/// Queue each remote subscriber may ask for.
pub const REMOTE_QUEUE: usize = 4;
/// Room left on every topic for one more local subscriber with this queue (a user's node on
/// the module, such as Listing 2's obstacle avoidance, or a test).
pub const SPARE_QUEUE: usize = 4;

const POOL: usize = pool_size(&[REMOTE_QUEUE, SPARE_QUEUE], 1);

/// `ranges` topic.
pub type RangesTopic<'a> = Topic<'a, Proximity, POOL, 2>;
/// `obstacle` topic.
pub type ObstacleTopic<'a> = Topic<'a, Obstacle, POOL, 2>;

/// Everything the application and the node use, by reference.
#[derive(Clone, Copy)]
pub struct Endpoints<'a> {
    /// The names in use.
    pub names: &'static Names,
    /// `ranges` topic (subscribe here to read it on the module).
    pub ranges: &'a RangesTopic<'a>,
    /// Its publisher (NRT).
    pub ranges_pub: &'a Publisher<'a, Proximity>,
    /// Its remote subscriber (exported).
    pub ranges_out: &'a RemoteSubscriber<'a, Proximity, REMOTE_QUEUE>,
    /// `obstacle` topic.
    pub obstacle: &'a ObstacleTopic<'a>,
    /// Its publisher (SRT).
    pub obstacle_pub: &'a Publisher<'a, Obstacle>,
    /// Its remote subscriber (exported).
    pub obstacle_out: &'a RemoteSubscriber<'a, Obstacle, REMOTE_QUEUE>,
}

/// Room for one set of endpoints: declare it `static` on the MCU, then [`Storage::build`] once.
pub struct Storage {
    ranges: StaticCell<RangesTopic<'static>>,
    ranges_pub: StaticCell<Publisher<'static, Proximity>>,
    ranges_out: StaticCell<RemoteSubscriber<'static, Proximity, REMOTE_QUEUE>>,
    obstacle: StaticCell<ObstacleTopic<'static>>,
    obstacle_pub: StaticCell<Publisher<'static, Obstacle>>,
    obstacle_out: StaticCell<RemoteSubscriber<'static, Obstacle, REMOTE_QUEUE>>,
}

impl Default for Storage {
    fn default() -> Self {
        Self::new()
    }
}

impl Storage {
    /// Empty storage.
    pub const fn new() -> Self {
        Self {
            ranges: StaticCell::new(),
            ranges_pub: StaticCell::new(),
            ranges_out: StaticCell::new(),
            obstacle: StaticCell::new(),
            obstacle_pub: StaticCell::new(),
            obstacle_out: StaticCell::new(),
        }
    }

    /// Makes and wires the endpoints with the names and obstacle deadline `params` give.
    ///
    /// # Panics
    /// If called twice on one storage (each `StaticCell` is initialised once).
    pub fn build(&'static self, params: &dyn ParamStore) -> Endpoints<'static> {
        let names = names(params);
        let deadline_us = crate::params::typed(params).u32(OBSTACLE_DEADLINE_MS) * 1000;
        let empty = Proximity { distance: [f32::NAN; 4], status: [3; 4], supply_fault: false };

        let ranges = &*self.ranges.init(Topic::new(names.ranges, empty));
        let ranges_pub = &*self.ranges_pub.init(Publisher::new(ranges, Class::NonRealTime));
        let ranges_out = &*self.ranges_out.init(RemoteSubscriber::new(ranges_pub));
        let obstacle = &*self.obstacle.init(Topic::new(names.obstacle, Obstacle::default()));
        let class = Class::AsyncRealTime { deadline_us };
        let obstacle_pub = &*self.obstacle_pub.init(Publisher::new(obstacle, class));
        let obstacle_out = &*self.obstacle_out.init(RemoteSubscriber::new(obstacle_pub));

        // Sized by `pool_size` for exactly these: cannot fail.
        let wired = (|| {
            ranges.advertise(ranges_pub)?;
            ranges.subscribe(ranges_out)?;
            obstacle.advertise(obstacle_pub)?;
            obstacle.subscribe(obstacle_out)
        })();
        wired.expect("proximity topics are sized for their endpoints");

        Endpoints { names, ranges, ranges_pub, ranges_out, obstacle, obstacle_pub, obstacle_out }
    }
}

#[cfg(any(test, feature = "std"))]
impl Endpoints<'static> {
    /// A fresh set of endpoints on the host (its storage is leaked: one per emulated board).
    pub fn leak(params: &dyn ParamStore) -> Self {
        std::boxed::Box::leak(std::boxed::Box::new(Storage::new())).build(params)
    }
}
