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
//! objects are made at boot from the parameters, in a [`Storage`] of cells (`r2p_module`'s
//! [`Outbound`] and [`Inbound`], each topic written once): a `static` one on the MCU, a leaked
//! one per emulated board on the host ([`Endpoints::leak`]), so two boards in one process never
//! share a topic.

use r2p_middleware::{pool_size, Class, Error};
use r2p_module::{Inbound, InboundCell, Outbound, OutboundCell};
use r2p_msgs::{Battery, BusPower, PsuEvent, PsuState};
use r2p_node::ParamStore;

use crate::params::{EVENT_DEADLINE_MS, INSTANCE};

/// A module's name and its topics' names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Names {
    /// Node name (heartbeats).
    pub node: &'static str,
    /// Battery readings: published (NRT) and exported.
    pub battery: &'static str,
    /// Output state: published (NRT) and exported.
    pub state: &'static str,
    /// Protection and output events: published (SRT) and exported.
    pub event: &'static str,
    /// Output on/off commands: imported, read by the application.
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

/// Everything the application and the node use, by reference: one field a topic.
#[derive(Clone, Copy)]
pub struct Endpoints<'a> {
    /// The names in use.
    pub names: &'static Names,
    /// Battery readings: published (NRT) and exported.
    pub battery: Outbound<'a, Battery, OUT_POOL, 2, REMOTE_QUEUE>,
    /// Output state: published (NRT) and exported.
    pub state: Outbound<'a, PsuState, OUT_POOL, 2, REMOTE_QUEUE>,
    /// Protection and output events: published (SRT) and exported.
    pub event: Outbound<'a, PsuEvent, OUT_POOL, 2, REMOTE_QUEUE>,
    /// Output on/off commands: imported, read by the application.
    pub power: Inbound<'a, BusPower, POWER_POOL, 2, POWER_QUEUE>,
}

/// Room for one set of endpoints: declare it `static` on the MCU, then [`Storage::build`] once.
#[derive(Default)]
pub struct Storage {
    battery: OutboundCell<Battery, OUT_POOL, 2, REMOTE_QUEUE>,
    state: OutboundCell<PsuState, OUT_POOL, 2, REMOTE_QUEUE>,
    event: OutboundCell<PsuEvent, OUT_POOL, 2, REMOTE_QUEUE>,
    power: InboundCell<BusPower, POWER_POOL, 2, POWER_QUEUE>,
}

impl Storage {
    /// Empty storage.
    pub const fn new() -> Self {
        Self {
            battery: OutboundCell::new(),
            state: OutboundCell::new(),
            event: OutboundCell::new(),
            power: InboundCell::new(),
        }
    }

    /// Makes and wires the endpoints with the names and event deadline `params` give.
    ///
    /// # Panics
    /// If called twice on one storage (each cell is initialised once).
    pub fn build(&'static self, params: &dyn ParamStore) -> Endpoints<'static> {
        let names = names(params);
        let deadline_us = crate::params::typed(params).u32(EVENT_DEADLINE_MS) * 1000;
        let (nrt, srt) = (Class::NonRealTime, Class::AsyncRealTime { deadline_us });
        // Sized by `pool_size` for exactly these: cannot fail.
        let built = (|| -> Result<_, Error> {
            Ok(Endpoints {
                names,
                battery: self.battery.build(names.battery, Battery::default(), nrt)?,
                state: self.state.build(names.state, PsuState::default(), nrt)?,
                event: self.event.build(names.event, PsuEvent::default(), srt)?,
                power: self.power.build(names.power, BusPower::default())?,
            })
        })();
        built.expect("PSU topics are sized for their endpoints")
    }
}

#[cfg(any(test, feature = "std"))]
impl Endpoints<'static> {
    /// A fresh set of endpoints on the host (its storage is leaked: one per emulated board).
    pub fn leak(params: &dyn ParamStore) -> Self {
        std::boxed::Box::leak(std::boxed::Box::new(Storage::new())).build(params)
    }
}
