//! The base controller's topics and their endpoints.
//!
//! | topic | type | direction | class |
//! |---|---|---|---|
//! | `cmd_vel` | `Twist2D` | in (imported; local publisher for a gateway's ROS 2 side) | — |
//! | `<proximity>/obstacle` | `Obstacle` | in | — |
//! | `<proximity>/ranges` | `Proximity` | in | — |
//! | `<motor i>/state` | `WheelState` | in, one per wheel | — |
//! | `<motor i>/setpoint` | `WheelSetpoint` | out, one per wheel | HRT, one per IK period |
//! | `odom` | `Odometry` | out | NRT |
//!
//! The names come from parameters at boot ([`Names`]), so the objects are made then in a
//! [`Storage`] of cells (r2p-module's [`Inbound`] and [`Outbound`], each written once): a
//! `static` on an MCU (no heap) and a leaked one per emulated board on the host
//! ([`Endpoints::leak`], feature `std`: each board its own, so several robots or reboots never
//! share a topic).

use r2p_middleware::{pool_size, Class, Error, Publisher, Subscriber};
use r2p_module::{Inbound, InboundCell, Outbound, OutboundCell};
use r2p_msgs::{Obstacle, Odometry, Proximity, Twist2D, WheelSetpoint, WheelState};
use r2p_node::{Export, Import};

use crate::names::Names;

/// Queue of the obstacle events (they come in bursts: one per channel).
const OBSTACLE_QUEUE: usize = 4;
/// Queue of every other topic the controller reads (it keeps the newest).
const QUEUE: usize = 2;
/// Queue of each remote subscriber of the setpoints and odometry.
const REMOTE_QUEUE: usize = 2;

/// Pool of a topic whose one subscriber queues `q` messages, with one publisher.
const fn pool(q: usize) -> usize {
    pool_size(&[q], 1)
}
const POOL: usize = pool(QUEUE);
const OBSTACLE_POOL: usize = pool(OBSTACLE_QUEUE);
const OUT_POOL: usize = pool(REMOTE_QUEUE);

/// Number of topics the node exports: the three setpoints and odometry.
pub const EXPORTS: usize = 4;
/// Number of topics the node imports: the command, obstacles, ranges and three wheel states.
pub const IMPORTS: usize = 6;

/// Everything the application and its node need: local ends for the application, remote
/// ends for the node.
pub struct Endpoints<'a> {
    /// `cmd_vel` as received.
    pub cmd: &'a Subscriber<'a, Twist2D, QUEUE>,
    /// Publishes `cmd_vel` on this board (a gateway's ROS 2 side, an emulator's teleop
    /// script); the bus's publishers arrive through the import.
    pub cmd_local: &'a Publisher<'a, Twist2D>,
    /// Obstacle events as received.
    pub obstacle: &'a Subscriber<'a, Obstacle, OBSTACLE_QUEUE>,
    /// Ranges as received.
    pub ranges: &'a Subscriber<'a, Proximity, QUEUE>,
    /// Wheel states as received.
    pub states: [&'a Subscriber<'a, WheelState, QUEUE>; 3],
    /// Wheel setpoints (hard real time, one per IK period).
    pub setpoints: [&'a Publisher<'a, WheelSetpoint>; 3],
    /// Odometry (best effort).
    pub odom: &'a Publisher<'a, Odometry>,
    /// What the node exports.
    pub exports: [&'a dyn Export; EXPORTS],
    /// What the node imports.
    pub imports: [&'a dyn Import; IMPORTS],
}

/// Room for one set of endpoints: a `static` on the MCU, then [`Storage::build`] once.
pub struct Storage {
    cmd: InboundCell<Twist2D, POOL, 1, QUEUE>,
    obstacle: InboundCell<Obstacle, OBSTACLE_POOL, 1, OBSTACLE_QUEUE>,
    ranges: InboundCell<Proximity, POOL, 1, QUEUE>,
    states: [InboundCell<WheelState, POOL, 1, QUEUE>; 3],
    setpoints: [OutboundCell<WheelSetpoint, OUT_POOL, 1, REMOTE_QUEUE>; 3],
    odom: OutboundCell<Odometry, OUT_POOL, 1, REMOTE_QUEUE>,
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
            cmd: InboundCell::new(),
            obstacle: InboundCell::new(),
            ranges: InboundCell::new(),
            states: [InboundCell::new(), InboundCell::new(), InboundCell::new()],
            setpoints: [OutboundCell::new(), OutboundCell::new(), OutboundCell::new()],
            odom: OutboundCell::new(),
        }
    }

    /// The topics named `names`, with the setpoints hard real time every `ik_period_us`.
    ///
    /// # Panics
    /// If called twice on one storage (each cell is initialised once).
    pub fn build(&'static self, names: Names, ik_period_us: u32) -> Endpoints<'static> {
        let hrt = Class::SyncRealTime { period_us: ik_period_us };
        // Sized for exactly these endpoints (tested): a failure here is a bug, found at boot.
        let built = (|| -> Result<_, Error> {
            let cmd = self.cmd.build(names.cmd_vel, Twist2D::default())?;
            let obstacle = self.obstacle.build(names.obstacle, Obstacle::default())?;
            let ranges = self.ranges.build(names.ranges, Proximity::default())?;
            let s = [0, 1, 2].map(|i| self.states[i].build(names.states[i], WheelState::default()));
            let [s0, s1, s2] = s;
            let s: [Inbound<'static, WheelState, POOL, 1, QUEUE>; 3] = [s0?, s1?, s2?];
            let p = [0, 1, 2].map(|i| {
                self.setpoints[i].build(names.setpoints[i], WheelSetpoint::default(), hrt)
            });
            let [p0, p1, p2] = p;
            let p: [Outbound<'static, WheelSetpoint, OUT_POOL, 1, REMOTE_QUEUE>; 3] =
                [p0?, p1?, p2?];
            let odom = self.odom.build(names.odom, Odometry::default(), Class::NonRealTime)?;
            Ok(Endpoints {
                cmd: cmd.subscriber,
                cmd_local: cmd.publisher,
                obstacle: obstacle.subscriber,
                ranges: ranges.subscriber,
                states: s.map(|s| s.subscriber),
                setpoints: p.map(|p| p.publisher),
                odom: odom.publisher,
                exports: [p[0].remote, p[1].remote, p[2].remote, odom.remote],
                imports: [
                    cmd.remote,
                    obstacle.remote,
                    ranges.remote,
                    s[0].remote,
                    s[1].remote,
                    s[2].remote,
                ],
            })
        })();
        built.expect("the base controller's topics are sized for their endpoints")
    }
}

#[cfg(any(test, feature = "std"))]
impl Endpoints<'static> {
    /// A fresh set of topics named `names` on the heap (never freed: a board lives as long as
    /// the process), with setpoints hard real time every `ik_period_us`.
    pub fn leak(names: Names, ik_period_us: u32) -> Self {
        std::boxed::Box::leak(std::boxed::Box::new(Storage::new())).build(names, ik_period_us)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use r2p_middleware::Class;

    /// What an MCU image does: a `static` storage (no heap), built once at boot.
    static STORAGE: Storage = Storage::new();

    #[test]
    fn a_static_storage_builds_the_named_topics_with_their_classes() {
        let names = Names::of([1, 2, 3], 2);
        let e = STORAGE.build(names, 10_000);
        let exported: [(&str, Class); EXPORTS] = e.exports.map(|x| (x.topic(), x.class()));
        let hrt = Class::SyncRealTime { period_us: 10_000 };
        assert_eq!(
            exported,
            [
                ("motor1/setpoint", hrt),
                ("motor2/setpoint", hrt),
                ("motor3/setpoint", hrt),
                ("odom", Class::NonRealTime),
            ]
        );
        let imported: [&str; IMPORTS] = e.imports.map(|x| x.topic());
        assert_eq!(
            imported,
            [
                "cmd_vel",
                "proximity2/obstacle",
                "proximity2/ranges",
                "motor1/state",
                "motor2/state",
                "motor3/state"
            ]
        );
    }

    #[test]
    fn what_the_node_imports_reaches_the_application_and_what_it_publishes_the_bus() {
        let e = Endpoints::leak(Names::of([1, 2, 3], 0), 5_000);
        assert_eq!(e.exports[0].class(), Class::SyncRealTime { period_us: 5_000 });
        // A wheel state from the bus: the import publishes it, the application's subscriber
        // has it.
        let mut buf = [0u8; 64];
        let state = WheelState { speed: 3.5, ..WheelState::default() };
        let n = r2p_msgs::R2pMessage::encode(&state, &mut buf).unwrap();
        e.imports[4].publish_bytes(&buf[..n]).unwrap();
        assert_eq!(e.states[1].try_recv().map(|m| m.speed), Some(3.5));
        assert!(e.states[0].try_recv().is_none() && e.states[2].try_recv().is_none());
        // The local cmd_vel publisher (a gateway's ROS 2 side) reaches the same subscriber.
        e.cmd_local.publish_with(|m| m.vx = 0.25).unwrap();
        assert_eq!(e.cmd.try_recv().map(|m| m.vx), Some(0.25));
        // A setpoint published reaches the node's export once it is subscribed.
        e.exports[2].activate(2);
        e.setpoints[2].publish_with(|m| m.value = 7.0).unwrap();
        assert_eq!(e.exports[2].pending(), 1);
        assert_eq!(e.exports[1].pending(), 0);
    }
}
