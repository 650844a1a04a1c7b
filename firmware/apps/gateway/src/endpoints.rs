//! The gateway's topic, its publisher, and the proxy that puts it on the bus.
//!
//! | topic | type | class |
//! |---|---|---|
//! | `gateway/status` | `GatewayStatus` | NRT, 1 Hz |
//! | `psu/battery` | `Battery` | imported: for ROS 2's `/battery_state` |
//! | `imu` | `Imu` | imported: for ROS 2's `/imu/data` |
//! | `imu/mag`, `imu/baro`, `imu/gnss` | `MagneticField`, `Barometer`, `GnssFix` | imported: for ROS 2's `/imu/mag`, `/imu/pressure`, `/gnss/fix` |
//! | `psu/state`, `psu/event`, `motor1/fault` … `motor3/fault` | their types | imported: ROS 2 topics of the same names, as `r2p_msgs` types ([`MIRRORED`]) |
//!
//! The objects are made at boot in a [`Storage`] of cells (`r2p_module`'s [`Outbound`], each
//! topic written once): a `static` one on the MCU, a leaked one per emulated board on the host
//! ([`Endpoints::leak`]).

use r2p_middleware::{pool_size, Class};
use r2p_module::{Inbound, InboundCell, Outbound, OutboundCell};
use r2p_msgs::{
    Barometer, Battery, GatewayStatus, GnssFix, Imu, MagneticField, MotorFault, PsuEvent, PsuState,
};

/// The topic's name.
pub const STATUS_TOPIC: &str = "gateway/status";
/// The PSU's battery (what `/battery_state` carries).
pub const BATTERY_TOPIC: &str = "psu/battery";
/// The IMU module's reading (what `/imu/data` carries).
pub const IMU_TOPIC: &str = "imu";
/// The IMU module's magnetic field (`/imu/mag`).
pub const MAG_TOPIC: &str = "imu/mag";
/// The IMU module's barometer (`/imu/pressure`).
pub const BARO_TOPIC: &str = "imu/baro";
/// The GNSS receiver on the IMU module (`/gnss/fix`).
pub const GNSS_TOPIC: &str = "imu/gnss";

/// The R2P topics without a standard ROS 2 type that the gateway imports and republishes as
/// their `r2p_msgs` type under the same name (what no robot-level node imports itself: a node
/// imports a topic once): name and R2P type, in [`Endpoints::mirrored`]'s order.
pub const MIRRORED: [(&str, &str); 5] = [
    ("psu/state", "PsuState"),
    ("psu/event", "PsuEvent"),
    ("motor1/fault", "MotorFault"),
    ("motor2/fault", "MotorFault"),
    ("motor3/fault", "MotorFault"),
];

/// Topics the gateway imports ([`crate::App::register`]): the battery, the IMU's four and the
/// mirrored topics; the image's node is sized with it.
pub const IMPORTS: usize = 5 + MIRRORED.len();

/// Queue each remote subscriber may ask for.
pub const REMOTE_QUEUE: usize = 2;
/// Room left on the topic for one more local subscriber with this queue (a user's node, a
/// test).
pub const SPARE_QUEUE: usize = 2;

const POOL: usize = pool_size(&[REMOTE_QUEUE, SPARE_QUEUE], 1);
/// An imported topic: the gateway's one subscriber keeps the latest two.
const IN_POOL: usize = pool_size(&[2], 1);

/// Everything the application and the node use, by reference: one field a topic.
#[derive(Clone, Copy)]
pub struct Endpoints<'a> {
    /// The status: published (NRT) and exported.
    pub status: Outbound<'a, GatewayStatus, POOL, 2, REMOTE_QUEUE>,
    /// The battery, imported.
    pub battery: Inbound<'a, Battery, IN_POOL, 1, 2>,
    /// The IMU's reading, imported.
    pub imu: Inbound<'a, Imu, IN_POOL, 1, 2>,
    /// The IMU's magnetic field, imported.
    pub mag: Inbound<'a, MagneticField, IN_POOL, 1, 2>,
    /// The IMU's barometer, imported.
    pub baro: Inbound<'a, Barometer, IN_POOL, 1, 2>,
    /// The IMU's GNSS fix, imported.
    pub gnss: Inbound<'a, GnssFix, IN_POOL, 1, 2>,
    /// The PSU's state, imported ([`MIRRORED`]).
    pub psu_state: Inbound<'a, PsuState, IN_POOL, 1, 2>,
    /// The PSU's events, imported.
    pub psu_event: Inbound<'a, PsuEvent, IN_POOL, 1, 2>,
    /// The motors' fault events, imported.
    pub motor_faults: [Inbound<'a, MotorFault, IN_POOL, 1, 2>; 3],
}

/// Room for one set of endpoints: declare it `static` on the MCU, then [`Storage::build`] once.
#[derive(Default)]
pub struct Storage {
    status: OutboundCell<GatewayStatus, POOL, 2, REMOTE_QUEUE>,
    battery: InboundCell<Battery, IN_POOL, 1, 2>,
    imu: InboundCell<Imu, IN_POOL, 1, 2>,
    mag: InboundCell<MagneticField, IN_POOL, 1, 2>,
    baro: InboundCell<Barometer, IN_POOL, 1, 2>,
    gnss: InboundCell<GnssFix, IN_POOL, 1, 2>,
    psu_state: InboundCell<PsuState, IN_POOL, 1, 2>,
    psu_event: InboundCell<PsuEvent, IN_POOL, 1, 2>,
    motor_faults: [InboundCell<MotorFault, IN_POOL, 1, 2>; 3],
}

impl Storage {
    /// Empty storage.
    pub const fn new() -> Self {
        Self {
            status: OutboundCell::new(),
            battery: InboundCell::new(),
            imu: InboundCell::new(),
            mag: InboundCell::new(),
            baro: InboundCell::new(),
            gnss: InboundCell::new(),
            psu_state: InboundCell::new(),
            psu_event: InboundCell::new(),
            motor_faults: [InboundCell::new(), InboundCell::new(), InboundCell::new()],
        }
    }

    /// Makes and wires the endpoints.
    ///
    /// # Panics
    /// If called twice on one storage (each cell is initialised once).
    pub fn build(&'static self) -> Endpoints<'static> {
        // Sized by `pool_size` for exactly these: cannot fail.
        let status = self.status.build(STATUS_TOPIC, GatewayStatus::default(), Class::NonRealTime);
        let battery = self.battery.build(BATTERY_TOPIC, Battery::default());
        let imu = self.imu.build(IMU_TOPIC, Imu::default());
        let sized = "an imported topic is sized for its endpoints";
        let psu_state = self.psu_state.build(MIRRORED[0].0, PsuState::default()).expect(sized);
        let psu_event = self.psu_event.build(MIRRORED[1].0, PsuEvent::default()).expect(sized);
        let fault = |i: usize| {
            self.motor_faults[i].build(MIRRORED[2 + i].0, MotorFault::default()).expect(sized)
        };
        Endpoints {
            status: status.expect("the status topic is sized for its endpoints"),
            battery: battery.expect(sized),
            imu: imu.expect(sized),
            mag: self.mag.build(MAG_TOPIC, MagneticField::default()).expect(sized),
            baro: self.baro.build(BARO_TOPIC, Barometer::default()).expect(sized),
            gnss: self.gnss.build(GNSS_TOPIC, GnssFix::default()).expect(sized),
            psu_state,
            psu_event,
            motor_faults: [fault(0), fault(1), fault(2)],
        }
    }
}

#[cfg(any(test, feature = "std"))]
impl Endpoints<'static> {
    /// A fresh set of endpoints on the host (its storage is leaked: one per emulated board).
    pub fn leak() -> Self {
        std::boxed::Box::leak(std::boxed::Box::new(Storage::new())).build()
    }
}
