//! The gateway's topic, its publisher, and the proxy that puts it on the bus.
//!
//! | topic | type | class |
//! |---|---|---|
//! | `gateway/status` | `GatewayStatus` | NRT, 1 Hz |
//!
//! The objects are made at boot in a [`Storage`] of `StaticCell`s: a `static` one on the MCU,
//! a leaked one per emulated board on the host ([`Endpoints::leak`]).

use r2p_middleware::{pool_size, Class, Publisher, Topic};
use r2p_msgs::GatewayStatus;
use r2p_node::RemoteSubscriber;
use static_cell::StaticCell;

/// The topic's name.
pub const STATUS_TOPIC: &str = "gateway/status";

/// Queue each remote subscriber may ask for.
pub const REMOTE_QUEUE: usize = 2;
/// Room left on the topic for one more local subscriber with this queue (a user's node, a
/// test).
pub const SPARE_QUEUE: usize = 2;

const POOL: usize = pool_size(&[REMOTE_QUEUE, SPARE_QUEUE], 1);

/// `gateway/status` topic.
pub type StatusTopic<'a> = Topic<'a, GatewayStatus, POOL, 2>;

/// Everything the application and the node use, by reference.
#[derive(Clone, Copy)]
pub struct Endpoints<'a> {
    /// `gateway/status` topic (subscribe here to read it on the gateway).
    pub status: &'a StatusTopic<'a>,
    /// Its publisher (NRT).
    pub status_pub: &'a Publisher<'a, GatewayStatus>,
    /// Its remote subscriber (exported).
    pub status_out: &'a RemoteSubscriber<'a, GatewayStatus, REMOTE_QUEUE>,
}

/// Room for one set of endpoints: declare it `static` on the MCU, then [`Storage::build`] once.
pub struct Storage {
    status: StaticCell<StatusTopic<'static>>,
    status_pub: StaticCell<Publisher<'static, GatewayStatus>>,
    status_out: StaticCell<RemoteSubscriber<'static, GatewayStatus, REMOTE_QUEUE>>,
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
            status: StaticCell::new(),
            status_pub: StaticCell::new(),
            status_out: StaticCell::new(),
        }
    }

    /// Makes and wires the endpoints.
    ///
    /// # Panics
    /// If called twice on one storage (each `StaticCell` is initialised once).
    pub fn build(&'static self) -> Endpoints<'static> {
        let status = &*self.status.init(Topic::new(STATUS_TOPIC, GatewayStatus::default()));
        let status_pub = &*self.status_pub.init(Publisher::new(status, Class::NonRealTime));
        let status_out = &*self.status_out.init(RemoteSubscriber::new(status_pub));
        // Sized by `pool_size` for exactly these: cannot fail.
        let wired = status.advertise(status_pub).and_then(|()| status.subscribe(status_out));
        wired.expect("the status topic is sized for its endpoints");
        Endpoints { status, status_pub, status_out }
    }
}

#[cfg(any(test, feature = "std"))]
impl Endpoints<'static> {
    /// A fresh set of endpoints on the host (its storage is leaked: one per emulated board).
    pub fn leak() -> Self {
        std::boxed::Box::leak(std::boxed::Box::new(Storage::new())).build()
    }
}
