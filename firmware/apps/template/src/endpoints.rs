//! The template's one topic, its publisher, and the proxy that puts it on the bus.
//!
//! | topic | type | class |
//! |---|---|---|
//! | `template/count` | `u32` | NRT, at `rate_hz` |
//!
//! The objects are made at boot in a [`Storage`] of `StaticCell`s: a `static` one on the MCU,
//! a leaked one per emulated board on the host ([`Endpoints::leak`]).

use r2p_middleware::{pool_size, Class, Publisher, Topic};
use r2p_node::RemoteSubscriber;
use static_cell::StaticCell;

/// The topic's name.
pub const COUNT_TOPIC: &str = "template/count";

/// Queue each remote subscriber may ask for.
pub const REMOTE_QUEUE: usize = 4;
/// Room left on the topic for one more local subscriber with this queue (a user's node on the
/// module, or a test).
pub const SPARE_QUEUE: usize = 4;

const POOL: usize = pool_size(&[REMOTE_QUEUE, SPARE_QUEUE], 1);

/// `count` topic.
pub type CountTopic<'a> = Topic<'a, u32, POOL, 2>;

/// Everything the application and the node use, by reference.
#[derive(Clone, Copy)]
pub struct Endpoints<'a> {
    /// `count` topic (subscribe here to read it on the module).
    pub count: &'a CountTopic<'a>,
    /// Its publisher (NRT).
    pub count_pub: &'a Publisher<'a, u32>,
    /// Its remote subscriber (exported).
    pub count_out: &'a RemoteSubscriber<'a, u32, REMOTE_QUEUE>,
}

/// Room for one set of endpoints: declare it `static` on the MCU, then [`Storage::build`] once.
pub struct Storage {
    count: StaticCell<CountTopic<'static>>,
    count_pub: StaticCell<Publisher<'static, u32>>,
    count_out: StaticCell<RemoteSubscriber<'static, u32, REMOTE_QUEUE>>,
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
            count: StaticCell::new(),
            count_pub: StaticCell::new(),
            count_out: StaticCell::new(),
        }
    }

    /// Makes and wires the endpoints.
    ///
    /// # Panics
    /// If called twice on one storage (each `StaticCell` is initialised once).
    pub fn build(&'static self) -> Endpoints<'static> {
        let count = &*self.count.init(Topic::new(COUNT_TOPIC, 0));
        let count_pub = &*self.count_pub.init(Publisher::new(count, Class::NonRealTime));
        let count_out = &*self.count_out.init(RemoteSubscriber::new(count_pub));
        // Sized by `pool_size` for exactly these: cannot fail.
        let wired = count.advertise(count_pub).and_then(|()| count.subscribe(count_out));
        wired.expect("the count topic is sized for its endpoints");
        Endpoints { count, count_pub, count_out }
    }
}

#[cfg(any(test, feature = "std"))]
impl Endpoints<'static> {
    /// A fresh set of endpoints on the host (its storage is leaked: one per emulated board).
    pub fn leak() -> Self {
        std::boxed::Box::leak(std::boxed::Box::new(Storage::new())).build()
    }
}
