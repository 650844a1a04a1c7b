//! The base controller on a computer on the bus (`[base] controller = "host"`): a node of the
//! emulator's own, as a PC on a CAN adapter would run `r2p-app-base` beside the modules — the
//! paper's robot-level nodes moved off the gateway. Its parameters are the robot's, as the
//! gateway's are ([`super::params::base_values`]), kept in RAM: a PC's process starts from
//! its configuration each time. No slot lead: the host's path to its controller is not an
//! MCU's interrupt (`NodeConfig::slot_lead_us`).

use r2p_app_base::{params, App, Endpoints, Names};
use r2p_node::{NodeConfig, RamParams};
use r2p_world::robot_file::Robot;
use rtcan::CycleConfig;

use super::params::{base_values, set_values};
use super::{leak, BoardNode, Booted, Probe};

/// The host node's name (heartbeats, tools).
pub const HOST_NODE: &str = "base";

/// The host's unique ID: not an MCU's, and none a module's (a robot file's are 96-bit MCU IDs;
/// this one is the ASCII of "r2p-hostbase").
pub const HOST_UID: [u8; 12] = *b"r2p-hostbase";

/// Boots the base controller as a node of its own on `robot`'s bus, reporting to `probe`.
pub fn base_on_host(
    robot: &Robot,
    probe: std::rc::Rc<std::cell::RefCell<Probe>>,
) -> Result<Booted, String> {
    let p = leak(RamParams::new(params::DEFAULTS));
    set_values(p, &params::DEFAULTS, &base_values(robot, Vec::new()))
        .map_err(|e| format!("{HOST_NODE} ({}): {e}", robot.file.display()))?;
    let ep = Endpoints::leak(Names::from_params(p), params::ik_period_us(p));
    let mut a = App::new(ep, p);
    let cycle = CycleConfig {
        bit_rate: robot.bus.bit_rate,
        cycle_us: robot.bus.cycle_us,
        ..CycleConfig::DEFAULT
    };
    let config = NodeConfig { cycle, ..NodeConfig::new(HOST_UID, HOST_NODE) };
    let mut n = BoardNode::new(config, p).map_err(|e| format!("{HOST_NODE}: node: {e:?}"))?;
    a.register(&mut n).map_err(|e| format!("{HOST_NODE}: registering topics: {e:?}"))?;
    Ok((
        n,
        Box::new(move |now, _node| {
            a.step(now);
            probe.borrow_mut().record(&a, now);
        }),
    ))
}
