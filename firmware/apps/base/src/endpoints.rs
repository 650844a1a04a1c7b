//! The base controller's topics, built on the heap for an emulated board (each board its own,
//! so several robots or reboots never share a topic).

use std::boxed::Box;

use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_msgs::{Obstacle, Odometry, Proximity, Twist2D, WheelSetpoint, WheelState};
use r2p_node::{Export, Import, RemotePublisher, RemoteSubscriber};

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

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

/// A topic received from the bus: (local subscriber, the node's import, the local publisher).
macro_rules! incoming {
    ($ty:ty, $name:expr, $q:literal) => {{
        let topic: &'static Topic<'static, $ty, { pool_size(&[$q], 1) }, 1> =
            leak(Topic::new($name, <$ty>::default()));
        let publisher: &'static Publisher<'static, $ty> =
            leak(Publisher::new(topic, Class::NonRealTime));
        let sub: &'static Subscriber<'static, $ty, $q> = leak(Subscriber::new());
        topic.subscribe(sub).expect("a new topic has room for a subscriber");
        let import: &'static dyn Import = leak(RemotePublisher::new(publisher, topic));
        (sub, import, publisher)
    }};
}

/// A topic sent on the bus: (local publisher, the node's export).
macro_rules! outgoing {
    ($ty:ty, $name:expr, $class:expr, $q:literal) => {{
        let topic: &'static Topic<'static, $ty, { pool_size(&[$q], 1) }, 1> =
            leak(Topic::new($name, <$ty>::default()));
        let publisher: &'static Publisher<'static, $ty> = leak(Publisher::new(topic, $class));
        let out: &'static RemoteSubscriber<'static, $ty, $q> =
            leak(RemoteSubscriber::new(publisher));
        topic.subscribe(out).expect("a new topic has room for a subscriber");
        let export: &'static dyn Export = out;
        (publisher, export)
    }};
}

impl Endpoints<'static> {
    /// Builds a fresh set of topics named `names`, with setpoints hard real time every
    /// `ik_period_us`.
    pub fn leak(names: Names, ik_period_us: u32) -> Self {
        let hrt = Class::SyncRealTime { period_us: ik_period_us };
        let (cmd, cmd_in, cmd_local) = incoming!(Twist2D, names.cmd_vel, 2);
        let (obstacle, obstacle_in, _) = incoming!(Obstacle, names.obstacle, 4);
        let (ranges, ranges_in, _) = incoming!(Proximity, names.ranges, 2);
        let s0 = incoming!(WheelState, names.states[0], 2);
        let s1 = incoming!(WheelState, names.states[1], 2);
        let s2 = incoming!(WheelState, names.states[2], 2);
        let p0 = outgoing!(WheelSetpoint, names.setpoints[0], hrt, 2);
        let p1 = outgoing!(WheelSetpoint, names.setpoints[1], hrt, 2);
        let p2 = outgoing!(WheelSetpoint, names.setpoints[2], hrt, 2);
        let odom = outgoing!(Odometry, names.odom, Class::NonRealTime, 2);
        Endpoints {
            cmd,
            cmd_local,
            obstacle,
            ranges,
            states: [s0.0, s1.0, s2.0],
            setpoints: [p0.0, p1.0, p2.0],
            odom: odom.0,
            exports: [p0.1, p1.1, p2.1, odom.1],
            imports: [cmd_in, obstacle_in, ranges_in, s0.1, s1.1, s2.1],
        }
    }
}
