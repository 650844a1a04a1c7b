//! The base controller's topics, built on the heap for an emulated board (each board its own,
//! so several robots or reboots never share a topic).

use std::boxed::Box;

use r2p_middleware::{pool_size, Class, Publisher, Subscriber};
use r2p_module::{Inbound, InboundCell, Outbound, OutboundCell};
use r2p_msgs::{Obstacle, Odometry, Proximity, Twist2D, WheelSetpoint, WheelState};
use r2p_node::{Export, Import};

/// Topic names the base controller uses (the motors' and the proximity module's names depend
/// on their `instance` parameters).
#[derive(Clone, Copy, Debug)]
pub struct Names {
    /// Velocity command in.
    pub cmd_vel: &'static str,
    /// Obstacle events in.
    pub obstacle: &'static str,
    /// The proximity module's periodic ranges in.
    pub ranges: &'static str,
    /// Each wheel's state in.
    pub states: [&'static str; 3],
    /// Each wheel's setpoint out.
    pub setpoints: [&'static str; 3],
    /// Odometry out.
    pub odom: &'static str,
}

impl Names {
    /// Triskar2's names: motors 0–2, the proximity module's `obstacle` event.
    pub const TRISKAR2: Names = Names {
        cmd_vel: "cmd_vel",
        obstacle: "proximity/obstacle",
        ranges: "proximity/ranges",
        states: ["motor0/state", "motor1/state", "motor2/state"],
        setpoints: ["motor0/setpoint", "motor1/setpoint", "motor2/setpoint"],
        odom: "odom",
    };
}

/// Everything the application and its node need: local ends for the application, remote
/// ends for the node.
pub struct Endpoints<'a> {
    /// `cmd_vel` as received.
    pub cmd: &'a Subscriber<'a, Twist2D, 2>,
    /// Publishes `cmd_vel` on this board (a gateway's ROS bridge, an emulator's teleop script);
    /// the bus's publishers arrive through the import.
    pub cmd_local: &'a Publisher<'a, Twist2D>,
    /// Obstacle events as received.
    pub obstacle: &'a Subscriber<'a, Obstacle, 4>,
    /// Ranges as received.
    pub ranges: &'a Subscriber<'a, Proximity, 2>,
    /// Wheel states as received.
    pub states: [&'a Subscriber<'a, WheelState, 2>; 3],
    /// Wheel setpoints (hard real time, one per IK period).
    pub setpoints: [&'a Publisher<'a, WheelSetpoint>; 3],
    /// Odometry (best effort).
    pub odom: &'a Publisher<'a, Odometry>,
    /// What the node exports.
    pub exports: [&'a dyn Export; 4],
    /// What the node imports.
    pub imports: [&'a dyn Import; 6],
}

/// Pool of a topic whose one subscriber queues `q` messages, with one publisher.
const fn pool(q: usize) -> usize {
    pool_size(&[q], 1)
}

/// A topic received from the bus, on the heap: the local subscriber, the node's import, the
/// local publisher.
fn inbound<T, const SLOTS: usize, const Q: usize>(
    name: &'static str,
) -> Inbound<'static, T, SLOTS, 1, Q>
where
    T: Copy + Default + Send + Sync + 'static,
{
    let cell: &'static InboundCell<T, SLOTS, 1, Q> = Box::leak(Box::new(InboundCell::new()));
    cell.build(name, T::default()).expect("a new topic has room for its endpoints")
}

/// A topic sent on the bus, on the heap: the local publisher and the node's export.
fn outbound<T, const SLOTS: usize, const Q: usize>(
    name: &'static str,
    class: Class,
) -> Outbound<'static, T, SLOTS, 1, Q>
where
    T: Copy + Default + Send + Sync + 'static,
{
    let cell: &'static OutboundCell<T, SLOTS, 1, Q> = Box::leak(Box::new(OutboundCell::new()));
    cell.build(name, T::default(), class).expect("a new topic has room for its endpoints")
}

impl Endpoints<'static> {
    /// Builds a fresh set of topics named `names`, with setpoints hard real time every
    /// `ik_period_us`.
    pub fn leak(names: Names, ik_period_us: u32) -> Self {
        let hrt = Class::SyncRealTime { period_us: ik_period_us };
        let cmd = inbound::<Twist2D, { pool(2) }, 2>(names.cmd_vel);
        let obstacle = inbound::<Obstacle, { pool(4) }, 4>(names.obstacle);
        let ranges = inbound::<Proximity, { pool(2) }, 2>(names.ranges);
        let s = names.states.map(inbound::<WheelState, { pool(2) }, 2>);
        let p = names.setpoints.map(|n| outbound::<WheelSetpoint, { pool(2) }, 2>(n, hrt));
        let odom = outbound::<Odometry, { pool(2) }, 2>(names.odom, Class::NonRealTime);
        Endpoints {
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
        }
    }
}
