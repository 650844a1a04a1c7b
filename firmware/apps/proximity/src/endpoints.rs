//! The proximity module's topics, their publishers, and the proxies that put them on the bus.
//!
//! | topic | type | class |
//! |---|---|---|
//! | `proximity/ranges` | `Proximity` | NRT, at `rate_hz` |
//! | `proximity/obstacle` | `Obstacle` | SRT, deadline `obstacle_deadline_ms` (Listing 1) |
//!
//! Topic names depend on the `instance` parameter and a publisher's class on a parameter, so the
//! objects are made at boot from the parameters, in a [`Storage`] of cells (`r2p_module`'s
//! [`Outbound`], each topic written once): a `static` one on the MCU, a leaked one per emulated
//! board on the host ([`Endpoints::leak`]).

use r2p_middleware::{pool_size, Class, Error};
use r2p_module::{Outbound, OutboundCell};
use r2p_msgs::{Obstacle, Proximity};
use r2p_node::ParamStore;

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

/// Everything the application and the node use, by reference: one field a topic.
#[derive(Clone, Copy)]
pub struct Endpoints<'a> {
    /// The names in use.
    pub names: &'static Names,
    /// The four distances: published (NRT) and exported.
    pub ranges: Outbound<'a, Proximity, POOL, 2, REMOTE_QUEUE>,
    /// Obstacle events: published (SRT) and exported.
    pub obstacle: Outbound<'a, Obstacle, POOL, 2, REMOTE_QUEUE>,
}

/// Room for one set of endpoints: declare it `static` on the MCU, then [`Storage::build`] once.
#[derive(Default)]
pub struct Storage {
    ranges: OutboundCell<Proximity, POOL, 2, REMOTE_QUEUE>,
    obstacle: OutboundCell<Obstacle, POOL, 2, REMOTE_QUEUE>,
}

impl Storage {
    /// Empty storage.
    pub const fn new() -> Self {
        Self { ranges: OutboundCell::new(), obstacle: OutboundCell::new() }
    }

    /// Makes and wires the endpoints with the names and obstacle deadline `params` give.
    ///
    /// # Panics
    /// If called twice on one storage (each cell is initialised once).
    pub fn build(&'static self, params: &dyn ParamStore) -> Endpoints<'static> {
        let names = names(params);
        let deadline_us = crate::params::typed(params).u32(OBSTACLE_DEADLINE_MS) * 1000;
        let (nrt, srt) = (Class::NonRealTime, Class::AsyncRealTime { deadline_us });
        let empty = Proximity { distance: [f32::NAN; 4], status: [3; 4], supply_fault: false };
        // Sized by `pool_size` for exactly these: cannot fail.
        let built = (|| -> Result<_, Error> {
            Ok(Endpoints {
                names,
                ranges: self.ranges.build(names.ranges, empty, nrt)?,
                obstacle: self.obstacle.build(names.obstacle, Obstacle::default(), srt)?,
            })
        })();
        built.expect("proximity topics are sized for their endpoints")
    }
}

#[cfg(any(test, feature = "std"))]
impl Endpoints<'static> {
    /// A fresh set of endpoints on the host (its storage is leaked: one per emulated board).
    pub fn leak(params: &dyn ParamStore) -> Self {
        std::boxed::Box::leak(std::boxed::Box::new(Storage::new())).build(params)
    }
}
