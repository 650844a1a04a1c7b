//! The IMU module's topic, its publisher, and the proxy that puts it on the bus.
//!
//! | topic | type | class |
//! |---|---|---|
//! | `imu` | `Imu` | NRT, at `rate_hz` |
//!
//! The topic's name depends on the `instance` parameter, so the objects are made at boot from
//! the parameters, in a [`Storage`] of `StaticCell`s: a `static` one on the MCU, a leaked one
//! per emulated board on the host ([`Endpoints::leak`]).

use r2p_middleware::{pool_size, Class, Publisher, Topic};
use r2p_msgs::Imu;
use r2p_node::{ParamStore, RemoteSubscriber};
use static_cell::StaticCell;

use crate::params::INSTANCE;

/// A module's node name and its topic's name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Names {
    /// Node name (heartbeats).
    pub node: &'static str,
    /// The `Imu` topic.
    pub imu: &'static str,
}

/// Names by `instance` parameter.
pub const NAMES: [Names; 4] = [
    Names { node: "imu", imu: "imu" },
    Names { node: "imu1", imu: "imu1" },
    Names { node: "imu2", imu: "imu2" },
    Names { node: "imu3", imu: "imu3" },
];

/// The names the parameters select.
pub fn names(params: &dyn ParamStore) -> &'static Names {
    let i = crate::params::typed(params).u32(INSTANCE) as usize;
    &NAMES[i.min(NAMES.len() - 1)]
}

/// Queue the remote subscriber may ask for.
pub const REMOTE_QUEUE: usize = 4;
/// Room left on the topic for one more local subscriber with this queue (a user's node on the
/// module, or a test).
pub const SPARE_QUEUE: usize = 4;

const POOL: usize = pool_size(&[REMOTE_QUEUE, SPARE_QUEUE], 1);

/// The `imu` topic.
pub type ImuTopic<'a> = Topic<'a, Imu, POOL, 2>;

/// Everything the application and the node use, by reference.
#[derive(Clone, Copy)]
pub struct Endpoints<'a> {
    /// The names in use.
    pub names: &'static Names,
    /// The topic (subscribe here to read it on the module).
    pub imu: &'a ImuTopic<'a>,
    /// Its publisher (NRT).
    pub imu_pub: &'a Publisher<'a, Imu>,
    /// Its remote subscriber (exported).
    pub imu_out: &'a RemoteSubscriber<'a, Imu, REMOTE_QUEUE>,
}

/// Room for one set of endpoints: declare it `static` on the MCU, then [`Storage::build`] once.
pub struct Storage {
    imu: StaticCell<ImuTopic<'static>>,
    imu_pub: StaticCell<Publisher<'static, Imu>>,
    imu_out: StaticCell<RemoteSubscriber<'static, Imu, REMOTE_QUEUE>>,
}

impl Default for Storage {
    fn default() -> Self {
        Self::new()
    }
}

impl Storage {
    /// Empty storage.
    pub const fn new() -> Self {
        Self { imu: StaticCell::new(), imu_pub: StaticCell::new(), imu_out: StaticCell::new() }
    }

    /// Makes and wires the endpoints with the names `params` give.
    ///
    /// # Panics
    /// If called twice on one storage (each `StaticCell` is initialised once).
    pub fn build(&'static self, params: &dyn ParamStore) -> Endpoints<'static> {
        let names = names(params);
        let empty = Imu { status: crate::app::STATUS_NO_DATA, ..Imu::default() };
        let imu = &*self.imu.init(Topic::new(names.imu, empty));
        let imu_pub = &*self.imu_pub.init(Publisher::new(imu, Class::NonRealTime));
        let imu_out = &*self.imu_out.init(RemoteSubscriber::new(imu_pub));
        // Sized by `pool_size` for exactly these: cannot fail.
        let wired = imu.advertise(imu_pub).and_then(|()| imu.subscribe(imu_out));
        wired.expect("the imu topic is sized for its endpoints");
        Endpoints { names, imu, imu_pub, imu_out }
    }
}

#[cfg(any(test, feature = "std"))]
impl Endpoints<'static> {
    /// A fresh set of endpoints on the host (its storage is leaked: one per emulated board).
    pub fn leak(params: &dyn ParamStore) -> Self {
        std::boxed::Box::leak(std::boxed::Box::new(Storage::new())).build(params)
    }
}
