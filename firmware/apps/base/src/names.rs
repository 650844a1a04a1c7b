//! The topics the base controller uses, named after the modules it drives: the motors' and
//! the proximity module's names depend on their `instance` parameters, so the base controller
//! takes each wheel's and the proximity module's instance as parameters of its own and their
//! names from the modules' own tables (`&'static str`, as a topic's name must be).

use r2p_node::{ParamStore, Typed};

use crate::params::{self as p, DEFAULTS};

/// Topic names the base controller uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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

/// The velocity command's topic.
pub const CMD_VEL: &str = "cmd_vel";
/// The odometry's topic.
pub const ODOM: &str = "odom";

impl Names {
    /// The names for the motor controllers of `instance` `wheels[i]` on wheel `i` and the
    /// proximity module of `instance` `proximity` (beyond the modules' tables: their last).
    pub fn of(wheels: [u32; 3], proximity: u32) -> Self {
        let motors = wheels.map(r2p_app_motor::Names::of);
        let prox = r2p_app_proximity::NAMES;
        let prox = prox[(proximity as usize).min(prox.len() - 1)];
        Names {
            cmd_vel: CMD_VEL,
            obstacle: prox.obstacle,
            ranges: prox.ranges,
            states: motors.map(|m| m.state),
            setpoints: motors.map(|m| m.setpoint),
            odom: ODOM,
        }
    }

    /// The names the parameters in `params` select (the base controller's table, [`DEFAULTS`]).
    pub fn from_params(params: &dyn ParamStore) -> Self {
        let t = Typed::new(params, &DEFAULTS);
        let wheels = [p::WHEEL0_INSTANCE, p::WHEEL1_INSTANCE, p::WHEEL2_INSTANCE].map(|i| t.u32(i));
        Self::of(wheels, t.u32(p::PROXIMITY_INSTANCE))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use r2p_management::message::Value;
    use r2p_node::RamParams;

    #[test]
    fn the_defaults_name_triskar2s_modules() {
        let params = RamParams::new(DEFAULTS);
        let n = Names::from_params(&params);
        assert_eq!(n.states, ["motor1/state", "motor2/state", "motor3/state"]);
        assert_eq!(n.setpoints, ["motor1/setpoint", "motor2/setpoint", "motor3/setpoint"]);
        assert_eq!((n.ranges, n.obstacle), ("proximity/ranges", "proximity/obstacle"));
        assert_eq!((n.cmd_vel, n.odom), ("cmd_vel", "odom"));
    }

    #[test]
    fn each_wheel_and_the_proximity_module_follow_their_instance_parameter() {
        let params = RamParams::new(DEFAULTS);
        for (i, v) in [(p::WHEEL0_INSTANCE, 5), (p::WHEEL1_INSTANCE, 0), (p::WHEEL2_INSTANCE, 7)] {
            params.set(i, Value::U32(v)).unwrap();
        }
        params.set(p::PROXIMITY_INSTANCE, Value::U32(2)).unwrap();
        let n = Names::from_params(&params);
        assert_eq!(n.states, ["motor5/state", "motor/state", "motor7/state"]);
        assert_eq!(n.setpoints, ["motor5/setpoint", "motor/setpoint", "motor7/setpoint"]);
        assert_eq!((n.ranges, n.obstacle), ("proximity2/ranges", "proximity2/obstacle"));
    }

    #[test]
    fn the_instance_ranges_are_the_modules_tables() {
        let params = RamParams::new(DEFAULTS);
        let motors = r2p_app_motor::names::INSTANCES.len() as u32;
        let proximity = r2p_app_proximity::NAMES.len() as u32;
        assert!(params.set(p::WHEEL2_INSTANCE, Value::U32(motors - 1)).is_ok());
        assert!(params.set(p::WHEEL2_INSTANCE, Value::U32(motors)).is_err());
        assert!(params.set(p::PROXIMITY_INSTANCE, Value::U32(proximity - 1)).is_ok());
        assert!(params.set(p::PROXIMITY_INSTANCE, Value::U32(proximity)).is_err());
        // Beyond the tables (a store without the range check): the last instance.
        let last = Names::of([99, 8, 7], 99);
        assert_eq!(last.states, ["motor7/state"; 3]);
        assert_eq!(last.ranges, "proximity3/ranges");
    }
}
