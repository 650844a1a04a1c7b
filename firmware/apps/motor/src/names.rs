//! Node and topic names of each instance (topic names are `&'static str`, so they come from a
//! table chosen by the `instance` parameter).

use r2p_node::ParamStore;

use crate::params::{index, Config};

/// The node name and the topics of one motor controller.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Names {
    /// Node name (heartbeats, tools).
    pub node: &'static str,
    /// `WheelSetpoint` in: torque, speed or position.
    pub setpoint: &'static str,
    /// `FaultClear` in: clears latched faults.
    pub clear_faults: &'static str,
    /// `WheelState` out: position, speed, current, faults.
    pub state: &'static str,
    /// `MotorFault` out: an event each time a fault latches or faults are cleared.
    pub fault: &'static str,
}

macro_rules! names {
    ($($n:literal),*) => {
        [$(Names {
            node: $n,
            setpoint: concat!($n, "/setpoint"),
            clear_faults: concat!($n, "/clear_faults"),
            state: concat!($n, "/state"),
            fault: concat!($n, "/fault"),
        }),*]
    };
}

/// Names by instance (the `instance` parameter's range is this table's).
pub const INSTANCES: [Names; 8] =
    names!("motor", "motor1", "motor2", "motor3", "motor4", "motor5", "motor6", "motor7");

impl Names {
    /// The names of `instance` (the last instance's beyond the table: the store's range check
    /// keeps it inside).
    pub fn of(instance: u32) -> Self {
        let i = (instance as usize).min(INSTANCES.len() - 1);
        INSTANCES[i]
    }

    /// The names the `instance` parameter in `params` selects.
    pub fn from_params(params: &dyn ParamStore) -> Self {
        let mut c = Config::DEFAULT;
        c.reload(params, index::INSTANCE);
        Self::of(c.instance)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::DEFAULTS;
    use r2p_management::message::{is_name_char, is_topic_char, Value, NAME_MAX, TOPIC_MAX};
    use r2p_node::Param;

    #[test]
    fn every_instance_has_valid_distinct_names_and_the_table_matches_the_range() {
        let Param { min, max, .. } = DEFAULTS[index::INSTANCE as usize];
        assert_eq!((min, max), (Value::U32(0), Value::U32(INSTANCES.len() as u32 - 1)));
        for (i, n) in INSTANCES.iter().enumerate() {
            assert!(n.node.len() <= NAME_MAX && n.node.bytes().all(is_name_char));
            for t in [n.setpoint, n.clear_faults, n.state, n.fault] {
                assert!(t.starts_with(n.node) && t.len() <= TOPIC_MAX, "{t}");
                assert!(t.bytes().all(is_topic_char), "{t}");
            }
            assert_eq!(Names::of(i as u32), *n);
        }
        assert_eq!(Names::of(2).state, "motor2/state");
        assert_eq!(Names::of(0).setpoint, "motor/setpoint");
    }
}
