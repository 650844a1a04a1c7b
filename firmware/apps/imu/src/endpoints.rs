//! The IMU module's topic, its publisher, and the proxy that puts it on the bus.
//!
//! | topic | type | class |
//! |---|---|---|
//! | `imu` | `Imu` | NRT, at `rate_hz` |
//! | `imu/mag` | `MagneticField` | NRT, at `mag_rate_hz` |
//! | `imu/baro` | `Barometer` | NRT, at `baro_rate_hz` |
//!
//! The topic's name depends on the `instance` parameter, so the objects are made at boot from
//! the parameters, in a [`Storage`] of cells (`r2p_module`'s [`Outbound`], each topic written
//! once): a `static` one on the MCU, a leaked one per emulated board on the host
//! ([`Endpoints::leak`]).

use r2p_middleware::{pool_size, Class};
use r2p_module::{Outbound, OutboundCell};
use r2p_msgs::{Barometer, Imu, MagneticField};
use r2p_node::ParamStore;

use crate::params::INSTANCE;

/// A module's node name and its topic's name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Names {
    /// Node name (heartbeats).
    pub node: &'static str,
    /// The `Imu` topic.
    pub imu: &'static str,
    /// The `MagneticField` topic.
    pub mag: &'static str,
    /// The `Barometer` topic.
    pub baro: &'static str,
}

/// Names by `instance` parameter.
pub const NAMES: [Names; 4] = [
    Names { node: "imu", imu: "imu", mag: "imu/mag", baro: "imu/baro" },
    Names { node: "imu1", imu: "imu1", mag: "imu1/mag", baro: "imu1/baro" },
    Names { node: "imu2", imu: "imu2", mag: "imu2/mag", baro: "imu2/baro" },
    Names { node: "imu3", imu: "imu3", mag: "imu3/mag", baro: "imu3/baro" },
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

/// Everything the application and the node use, by reference: one field a topic.
#[derive(Clone, Copy)]
pub struct Endpoints<'a> {
    /// The names in use.
    pub names: &'static Names,
    /// The readings: published (NRT) and exported.
    pub imu: Outbound<'a, Imu, POOL, 2, REMOTE_QUEUE>,
    /// The magnetic field.
    pub mag: Outbound<'a, MagneticField, POOL, 2, REMOTE_QUEUE>,
    /// Pressure and altitude.
    pub baro: Outbound<'a, Barometer, POOL, 2, REMOTE_QUEUE>,
}

/// Room for one set of endpoints: declare it `static` on the MCU, then [`Storage::build`] once.
#[derive(Default)]
pub struct Storage {
    imu: OutboundCell<Imu, POOL, 2, REMOTE_QUEUE>,
    mag: OutboundCell<MagneticField, POOL, 2, REMOTE_QUEUE>,
    baro: OutboundCell<Barometer, POOL, 2, REMOTE_QUEUE>,
}

impl Storage {
    /// Empty storage.
    pub const fn new() -> Self {
        Self { imu: OutboundCell::new(), mag: OutboundCell::new(), baro: OutboundCell::new() }
    }

    /// Makes and wires the endpoints with the names `params` give.
    ///
    /// # Panics
    /// If called twice on one storage (each cell is initialised once).
    pub fn build(&'static self, params: &dyn ParamStore) -> Endpoints<'static> {
        let names = names(params);
        let no_data = crate::app::STATUS_NO_DATA;
        let imu = Imu { status: no_data, ..Imu::default() };
        let mag = MagneticField { status: no_data, ..MagneticField::default() };
        let baro = Barometer { status: no_data, ..Barometer::default() };
        // Sized by `pool_size` for exactly these: cannot fail.
        const SIZED: &str = "the topics are sized for their endpoints";
        Endpoints {
            names,
            imu: self.imu.build(names.imu, imu, Class::NonRealTime).expect(SIZED),
            mag: self.mag.build(names.mag, mag, Class::NonRealTime).expect(SIZED),
            baro: self.baro.build(names.baro, baro, Class::NonRealTime).expect(SIZED),
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
