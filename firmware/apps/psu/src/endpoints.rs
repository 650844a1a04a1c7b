//! The PSU's topics, their publishers and subscribers, and the proxies that put them on the bus.
//!
//! | topic | type | direction | class |
//! |---|---|---|---|
//! | `psu/battery` | `Battery` | published | NRT, at `battery_rate_hz` |
//! | `psu/state` | `PsuState` | published | NRT, with `battery` |
//! | `psu/event` | `PsuEvent` | published | SRT, deadline `event_deadline_ms` |
//! | `psu/power` | `BusPower` | subscribed | (the sender's) |
//!
//! Topic names depend on the `instance` parameter and a publisher's class on a parameter, so the
//! objects are made at boot from the parameters, in a [`Storage`] of `StaticCell`s: a `static`
//! one on the MCU, a leaked one per emulated board on the host ([`Endpoints::leak`]), so two
//! boards in one process never share a topic.

use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_msgs::{Battery, BusPower, PsuEvent, PsuState};
use r2p_node::{ParamStore, RemotePublisher, RemoteSubscriber};
use static_cell::StaticCell;

use crate::params::{EVENT_DEADLINE_MS, INSTANCE};

/// A module's name and its topics' names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Names {
    /// Node name (heartbeats).
    pub node: &'static str,
    /// Battery readings.
    pub battery: &'static str,
    /// Output state.
    pub state: &'static str,
    /// Protection and output events.
    pub event: &'static str,
    /// Output on/off commands.
    pub power: &'static str,
}

/// Names by `instance` parameter.
pub const NAMES: [Names; 4] = [
    Names {
        node: "psu",
        battery: "psu/battery",
        state: "psu/state",
        event: "psu/event",
        power: "psu/power",
    },
    Names {
        node: "psu1",
        battery: "psu1/battery",
        state: "psu1/state",
        event: "psu1/event",
        power: "psu1/power",
    },
    Names {
        node: "psu2",
        battery: "psu2/battery",
        state: "psu2/state",
        event: "psu2/event",
        power: "psu2/power",
    },
    Names {
        node: "psu3",
        battery: "psu3/battery",
        state: "psu3/state",
        event: "psu3/event",
        power: "psu3/power",
    },
];

/// The names the parameters select.
pub fn names(params: &dyn ParamStore) -> &'static Names {
    let i = crate::params::typed(params).u32(INSTANCE) as usize;
    &NAMES[i.min(NAMES.len() - 1)]
}

/// Queue each remote subscriber of a published topic may ask for.
pub const REMOTE_QUEUE: usize = 4;
/// Queue of the application's `power` subscriber.
pub const POWER_QUEUE: usize = 4;
/// Room left on every topic for one more local subscriber with this queue (a user's node on
/// the module, a test), and on `power` for one more local publisher.
pub const SPARE_QUEUE: usize = 2;

const OUT_POOL: usize = pool_size(&[REMOTE_QUEUE, SPARE_QUEUE], 1);
const POWER_POOL: usize = pool_size(&[POWER_QUEUE, SPARE_QUEUE], 2);

/// `battery` topic.
pub type BatteryTopic<'a> = Topic<'a, Battery, OUT_POOL, 2>;
/// `state` topic.
pub type StateTopic<'a> = Topic<'a, PsuState, OUT_POOL, 2>;
/// `event` topic.
pub type EventTopic<'a> = Topic<'a, PsuEvent, OUT_POOL, 2>;
/// `power` topic.
pub type PowerTopic<'a> = Topic<'a, BusPower, POWER_POOL, 2>;

/// Everything the application and the node use, by reference.
#[derive(Clone, Copy)]
pub struct Endpoints<'a> {
    /// The names in use.
    pub names: &'static Names,
    /// `battery` topic (subscribe here to read it on the module).
    pub battery: &'a BatteryTopic<'a>,
    /// Its publisher (NRT).
    pub battery_pub: &'a Publisher<'a, Battery>,
    /// Its remote subscriber (exported).
    pub battery_out: &'a RemoteSubscriber<'a, Battery, REMOTE_QUEUE>,
    /// `state` topic.
    pub state: &'a StateTopic<'a>,
    /// Its publisher (NRT).
    pub state_pub: &'a Publisher<'a, PsuState>,
    /// Its remote subscriber (exported).
    pub state_out: &'a RemoteSubscriber<'a, PsuState, REMOTE_QUEUE>,
    /// `event` topic.
    pub event: &'a EventTopic<'a>,
    /// Its publisher (SRT).
    pub event_pub: &'a Publisher<'a, PsuEvent>,
    /// Its remote subscriber (exported).
    pub event_out: &'a RemoteSubscriber<'a, PsuEvent, REMOTE_QUEUE>,
    /// `power` topic.
    pub power: &'a PowerTopic<'a>,
    /// The publisher the node publishes received commands with (NRT; local code may use it).
    pub power_in_pub: &'a Publisher<'a, BusPower>,
    /// The remote publisher (imported).
    pub power_in: &'a RemotePublisher<'a, BusPower>,
    /// The application's subscriber.
    pub power_sub: &'a Subscriber<'a, BusPower, POWER_QUEUE>,
}

/// Room for one set of endpoints: declare it `static` on the MCU, then [`Storage::build`] once.
pub struct Storage {
    battery: StaticCell<BatteryTopic<'static>>,
    battery_pub: StaticCell<Publisher<'static, Battery>>,
    battery_out: StaticCell<RemoteSubscriber<'static, Battery, REMOTE_QUEUE>>,
    state: StaticCell<StateTopic<'static>>,
    state_pub: StaticCell<Publisher<'static, PsuState>>,
    state_out: StaticCell<RemoteSubscriber<'static, PsuState, REMOTE_QUEUE>>,
    event: StaticCell<EventTopic<'static>>,
    event_pub: StaticCell<Publisher<'static, PsuEvent>>,
    event_out: StaticCell<RemoteSubscriber<'static, PsuEvent, REMOTE_QUEUE>>,
    power: StaticCell<PowerTopic<'static>>,
    power_in_pub: StaticCell<Publisher<'static, BusPower>>,
    power_in: StaticCell<RemotePublisher<'static, BusPower>>,
    power_sub: StaticCell<Subscriber<'static, BusPower, POWER_QUEUE>>,
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
            battery: StaticCell::new(),
            battery_pub: StaticCell::new(),
            battery_out: StaticCell::new(),
            state: StaticCell::new(),
            state_pub: StaticCell::new(),
            state_out: StaticCell::new(),
            event: StaticCell::new(),
            event_pub: StaticCell::new(),
            event_out: StaticCell::new(),
            power: StaticCell::new(),
            power_in_pub: StaticCell::new(),
            power_in: StaticCell::new(),
            power_sub: StaticCell::new(),
        }
    }

    /// Makes and wires the endpoints with the names and event deadline `params` give.
    ///
    /// # Panics
    /// If called twice on one storage (each `StaticCell` is initialised once).
    pub fn build(&'static self, params: &dyn ParamStore) -> Endpoints<'static> {
        let names = names(params);
        let deadline_us = crate::params::typed(params).u32(EVENT_DEADLINE_MS) * 1000;

        let battery = &*self.battery.init(Topic::new(names.battery, Battery::default()));
        let battery_pub = &*self.battery_pub.init(Publisher::new(battery, Class::NonRealTime));
        let battery_out = &*self.battery_out.init(RemoteSubscriber::new(battery_pub));
        let state = &*self.state.init(Topic::new(names.state, PsuState::default()));
        let state_pub = &*self.state_pub.init(Publisher::new(state, Class::NonRealTime));
        let state_out = &*self.state_out.init(RemoteSubscriber::new(state_pub));
        let event = &*self.event.init(Topic::new(names.event, PsuEvent::default()));
        let class = Class::AsyncRealTime { deadline_us };
        let event_pub = &*self.event_pub.init(Publisher::new(event, class));
        let event_out = &*self.event_out.init(RemoteSubscriber::new(event_pub));
        let power = &*self.power.init(Topic::new(names.power, BusPower::default()));
        let power_in_pub = &*self.power_in_pub.init(Publisher::new(power, Class::NonRealTime));
        let power_in = &*self.power_in.init(RemotePublisher::new(power_in_pub, power));
        let power_sub = &*self.power_sub.init(Subscriber::new());

        // Sized by `pool_size` for exactly these: cannot fail.
        let wired = (|| {
            battery.advertise(battery_pub)?;
            battery.subscribe(battery_out)?;
            state.advertise(state_pub)?;
            state.subscribe(state_out)?;
            event.advertise(event_pub)?;
            event.subscribe(event_out)?;
            power.advertise(power_in_pub)?;
            power.subscribe(power_sub)
        })();
        wired.expect("PSU topics are sized for their endpoints");

        Endpoints {
            names,
            battery,
            battery_pub,
            battery_out,
            state,
            state_pub,
            state_out,
            event,
            event_pub,
            event_out,
            power,
            power_in_pub,
            power_in,
            power_sub,
        }
    }
}

#[cfg(any(test, feature = "std"))]
impl Endpoints<'static> {
    /// A fresh set of endpoints on the host (its storage is leaked: one per emulated board).
    pub fn leak(params: &dyn ParamStore) -> Self {
        std::boxed::Box::leak(std::boxed::Box::new(Storage::new())).build(params)
    }
}
