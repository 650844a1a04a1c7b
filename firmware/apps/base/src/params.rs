//! The base controller's parameters (index = position in [`DEFAULTS`]).

use r2p_node::{Param, ParamStore, Typed};

/// Wheel radius, m.
pub const WHEEL_RADIUS: u16 = 0;
/// Centre-to-wheel distance, m.
pub const BASE_RADIUS: u16 = 1;
/// Angle of wheel 0 from the x axis, degrees.
pub const FIRST_WHEEL_DEG: u16 = 2;
/// Inverse-kinematics (setpoint) rate, Hz.
pub const IK_RATE_HZ: u16 = 3;
/// A `cmd_vel` older than this stops the base, ms.
pub const CMD_TIMEOUT_MS: u16 = 4;
/// Obstacles nearer than this block motion towards them, m.
pub const STOP_DISTANCE: u16 = 5;
/// How long an obstacle event keeps blocking, ms.
pub const OBSTACLE_HOLD_MS: u16 = 6;
/// Direction of proximity channel 0 from the x axis, degrees (channels 1–3 follow at `+90°`
/// steps unless set).
pub const CHANNEL0_DEG: u16 = 7;
/// Direction of proximity channel 1, degrees.
pub const CHANNEL1_DEG: u16 = 8;
/// Direction of proximity channel 2, degrees.
pub const CHANNEL2_DEG: u16 = 9;
/// Direction of proximity channel 3, degrees.
pub const CHANNEL3_DEG: u16 = 10;
/// Odometry publication rate, Hz.
pub const ODOM_RATE_HZ: u16 = 11;
/// The `instance` of the motor controller on wheel 0 (its topics `motor<i>/state`,
/// `motor<i>/setpoint`: r2p-app-motor's names); wheels 1 and 2 follow.
pub const WHEEL0_INSTANCE: u16 = 12;
/// The motor controller on wheel 1.
pub const WHEEL1_INSTANCE: u16 = 13;
/// The motor controller on wheel 2.
pub const WHEEL2_INSTANCE: u16 = 14;
/// The `instance` of the proximity module whose ranges and obstacle events stop the base.
pub const PROXIMITY_INSTANCE: u16 = 15;

/// Number of parameters.
pub const COUNT: usize = 16;

/// Defaults and ranges. Geometry defaults are the Triskar2's (60 cm base; wheels at 30°,
/// 150°, 270°), and so are the topics: motors 1–3 on wheels 0–2, proximity module 0. The
/// topics are chosen at boot (a change applies after a reboot).
pub const DEFAULTS: [Param; COUNT] = [
    Param::f32("wheel_radius_m", 0.06, 0.01, 0.5),
    Param::f32("base_radius_m", 0.25, 0.02, 2.0),
    Param::f32("first_wheel_deg", 30.0, -360.0, 360.0),
    Param::u32("ik_rate_hz", 100, 10, 500),
    Param::u32("cmd_timeout_ms", 500, 20, 10_000),
    Param::f32("stop_distance_m", 0.45, 0.05, 2.0),
    Param::u32("obstacle_hold_ms", 300, 10, 5_000),
    Param::f32("channel0_deg", 0.0, -360.0, 360.0),
    Param::f32("channel1_deg", 90.0, -360.0, 360.0),
    Param::f32("channel2_deg", 180.0, -360.0, 360.0),
    Param::f32("channel3_deg", 270.0, -360.0, 360.0),
    Param::u32("odom_rate_hz", 20, 1, 200),
    Param::u32("wheel0_instance", 1, 0, MOTOR_INSTANCE_MAX),
    Param::u32("wheel1_instance", 2, 0, MOTOR_INSTANCE_MAX),
    Param::u32("wheel2_instance", 3, 0, MOTOR_INSTANCE_MAX),
    Param::u32("proximity_instance", 0, 0, PROXIMITY_INSTANCE_MAX),
];

/// The motor controllers' instance range (their name table's).
const MOTOR_INSTANCE_MAX: u32 = r2p_app_motor::names::INSTANCES.len() as u32 - 1;
/// The proximity modules' instance range.
const PROXIMITY_INSTANCE_MAX: u32 = r2p_app_proximity::endpoints::NAMES.len() as u32 - 1;

/// The setpoints' period, µs, from the IK rate in `params` (the base controller's table): what
/// their HRT streams are registered with at boot.
pub fn ik_period_us(params: &dyn ParamStore) -> u32 {
    1_000_000 / Typed::new(params, &DEFAULTS).u32(IK_RATE_HZ).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use r2p_management::message::Value;
    use r2p_node::RamParams;

    #[test]
    fn the_setpoints_period_follows_the_ik_rate() {
        let params = RamParams::new(DEFAULTS);
        assert_eq!(ik_period_us(&params), 10_000, "100 Hz");
        params.set(IK_RATE_HZ, Value::U32(250)).unwrap();
        assert_eq!(ik_period_us(&params), 4_000);
    }

    #[test]
    fn every_angle_may_be_negative_as_a_ranger_facing_right_is() {
        let params = RamParams::new(DEFAULTS);
        for i in [FIRST_WHEEL_DEG, CHANNEL0_DEG, CHANNEL1_DEG, CHANNEL2_DEG, CHANNEL3_DEG] {
            assert_eq!(params.set(i, Value::F32(-90.0)), Ok(Value::F32(-90.0)), "{i}");
            assert!(params.set(i, Value::F32(-361.0)).is_err(), "{i}");
        }
    }
}
