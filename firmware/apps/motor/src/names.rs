//! Node and topic names of each instance (topic names are `&'static str`): the motor image writes
//! its own once at boot into a [`NameBuf`] ([`Names::write`]), because the table of every
//! instance's names ([`INSTANCES`], 840 B of constants) cost it 444 B more than that code; other
//! modules' code that names a motor's topics (the base controller) takes them from the table,
//! which the motor image then does not carry. A test keeps the two the same.

use heapless::String;
use r2p_node::ParamStore;

use crate::params::{index, Config};

/// The node name of instance 0; instance n is `motor<n>`.
pub const PREFIX: &str = "motor";
/// The highest instance (the `instance` parameter's range: one digit).
pub const MAX_INSTANCE: u32 = 7;

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

/// Room for one board's names, each sized for the longest instance's (`motor7/clear_faults`).
#[derive(Default)]
pub struct NameBuf {
    node: String<6>,
    setpoint: String<15>,
    clear_faults: String<19>,
    state: String<12>,
    fault: String<12>,
}

impl NameBuf {
    /// Empty room.
    pub const fn new() -> Self {
        Self {
            node: String::new(),
            setpoint: String::new(),
            clear_faults: String::new(),
            state: String::new(),
            fault: String::new(),
        }
    }
}

/// `node` then `suffix` into `s` (sized for the longest: the pushes cannot fail).
fn join<const N: usize>(s: &mut String<N>, node: &str, suffix: &str) {
    let _ = s.push_str(node);
    let _ = s.push_str(suffix);
}

impl Names {
    /// The names of `instance` (beyond [`MAX_INSTANCE`]: the last instance's; the store's range
    /// check keeps the parameter inside), written into `buf`.
    pub fn write(instance: u32, buf: &'static mut NameBuf) -> Self {
        let mut node = String::<6>::new();
        let _ = node.push_str(PREFIX);
        let n = instance.min(MAX_INSTANCE);
        if n > 0 {
            let _ = node.push(char::from(b'0' + n as u8));
        }
        buf.node = node;
        let node = buf.node.as_str();
        join(&mut buf.setpoint, node, "/setpoint");
        join(&mut buf.clear_faults, node, "/clear_faults");
        join(&mut buf.state, node, "/state");
        join(&mut buf.fault, node, "/fault");
        let buf: &'static NameBuf = buf;
        Names {
            node: &buf.node,
            setpoint: &buf.setpoint,
            clear_faults: &buf.clear_faults,
            state: &buf.state,
            fault: &buf.fault,
        }
    }

    /// The names of `instance` from the table (beyond it: the last instance's).
    pub fn of(instance: u32) -> Self {
        INSTANCES[(instance as usize).min(INSTANCES.len() - 1)]
    }

    /// The `instance` parameter in `params`.
    pub fn instance(params: &dyn ParamStore) -> u32 {
        let mut c = Config::DEFAULT;
        c.reload(params, index::INSTANCE);
        c.instance
    }

    /// The names the `instance` parameter in `params` selects, from the table.
    pub fn from_params(params: &dyn ParamStore) -> Self {
        Self::of(Self::instance(params))
    }
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

/// Names by instance, 0 to [`MAX_INSTANCE`].
pub const INSTANCES: [Names; MAX_INSTANCE as usize + 1] =
    names!("motor", "motor1", "motor2", "motor3", "motor4", "motor5", "motor6", "motor7");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::DEFAULTS;
    use r2p_management::message::{is_name_char, is_topic_char, Value, NAME_MAX, TOPIC_MAX};
    use r2p_node::Param;

    #[test]
    fn every_instance_has_valid_distinct_names_and_the_table_matches_the_range() {
        let Param { min, max, .. } = DEFAULTS[index::INSTANCE as usize];
        assert_eq!((min, max), (Value::U32(0), Value::U32(MAX_INSTANCE)));
        let leak = || std::boxed::Box::leak(std::boxed::Box::new(NameBuf::new()));
        let all: std::vec::Vec<Names> = (0..=MAX_INSTANCE).map(|i| Names::write(i, leak())).collect();
        assert_eq!(all, INSTANCES, "written at boot as the table has them");
        for (i, n) in all.iter().enumerate() {
            assert!(n.node.len() <= NAME_MAX && n.node.bytes().all(is_name_char));
            for t in [n.setpoint, n.clear_faults, n.state, n.fault] {
                assert!(t.starts_with(n.node) && t.len() <= TOPIC_MAX, "{t}");
                assert!(t.bytes().all(is_topic_char), "{t}");
            }
            assert!(all[..i].iter().all(|o| o.node != n.node), "{} twice", n.node);
        }
        assert_eq!(Names::of(MAX_INSTANCE + 5), all[MAX_INSTANCE as usize], "beyond: the last");
        assert_eq!(Names::write(MAX_INSTANCE + 5, leak()), all[MAX_INSTANCE as usize]);
        assert_eq!(Names::of(2).state, "motor2/state");
        assert_eq!(Names::of(0).setpoint, "motor/setpoint");
        assert_eq!(Names::of(7).clear_faults, "motor7/clear_faults", "the longest fits");
        assert_eq!(Names::of(1).node, "motor1");
        assert_eq!(Names::of(3).fault, "motor3/fault");
    }
}
