//! The gateway board. Its firmware (Ethernet, ROS bridge) is a later issue; in the emulator it
//! runs the robot-level nodes of the paper's Triskar2 (`r2p-app-base`: inverse kinematics,
//! obstacle avoidance, odometry) and plays the robot file's `[[teleop]]` script on `cmd_vel`,
//! as a teleoperator behind the gateway would.

use r2p_app_base::endpoints::Names;
use r2p_app_base::{params, App, Endpoints};
use r2p_msgs::Twist2D;
use r2p_node::{NodeConfig, ParamStore};
use r2p_world::robot_file::Wiring;

use super::{load_params, node, persist, Booted, Ctx};

/// Period of the teleop script's `cmd_vel` (a joystick's rate).
const TELEOP_PERIOD_US: u64 = 50_000;

/// Boots the gateway's base controller.
pub fn gateway(ctx: Ctx<'_>) -> Result<Booted, String> {
    let p = load_params(params::DEFAULTS, &ctx.flash)?;
    let names = names(&ctx)?;
    let ik_hz = match p.get(params::IK_RATE_HZ) {
        Ok(r2p_management::message::Value::U32(v)) => v.max(1),
        _ => 100,
    };
    let ep = Endpoints::leak(names, 1_000_000 / ik_hz);
    let cmd_local = ep.cmd_local;
    let mut a = App::new(ep, p);
    // The standby master: rank 1 after the PSU.
    let config = NodeConfig { rank: Some(1), ..NodeConfig::new(ctx.module.uid.0, "gateway") };
    let mut n = node(config, &ctx, p)?;
    a.register(&mut n).map_err(|e| format!("registering topics: {e:?}"))?;
    let script: Vec<_> = ctx.robot.teleop.clone();
    let (flash, probe) = (ctx.flash, ctx.probe);
    Ok((
        n,
        Box::new(move |now, _node| {
            if now % TELEOP_PERIOD_US == 0 {
                if let Some(t) = script.iter().rev().find(|t| (t.at_s * 1e6) as u64 <= now) {
                    let (vx, vy, wz) = (t.vx as f32, t.vy as f32, t.wz as f32);
                    let _ = cmd_local.publish_with(|m| *m = Twist2D { vx, vy, wz });
                }
            }
            a.step(now);
            let mut pr = probe.borrow_mut();
            pr.odometry = a.pose();
            let c = a.command(now);
            pr.command = (c.vx, c.vy, c.wz);
            pr.setpoints_dropped = a.dropped;
            persist(p, &flash);
        }),
    ))
}

/// Topic names from the robot's motors (by wheel) and proximity module, as their `instance`
/// parameters select them.
fn names(ctx: &Ctx<'_>) -> Result<Names, String> {
    let mut states = [""; 3];
    let mut setpoints = [""; 3];
    let mut obstacle = "proximity/obstacle";
    let mut ranges = "proximity/ranges";
    for m in &ctx.robot.modules {
        let instance = m.params.iter().find(|(n, _)| n == "instance").map_or(0, |(_, v)| match v {
            r2p_world::robot_file::ParamValue::Int(i) => *i as u32,
            _ => 0,
        });
        match &m.wiring {
            Wiring::Motor { wheel, .. } if *wheel < 3 => {
                let n = r2p_app_motor::Names::of(instance);
                states[*wheel] = n.state;
                setpoints[*wheel] = n.setpoint;
            }
            Wiring::Proximity { .. } => {
                let n = r2p_app_proximity::NAMES[(instance as usize).min(3)];
                (obstacle, ranges) = (n.obstacle, n.ranges);
            }
            _ => {}
        }
    }
    if states.contains(&"") {
        return Err(
            "the base controller drives three wheels: wheels 0, 1 and 2 need a motor".into()
        );
    }
    Ok(Names { cmd_vel: "cmd_vel", obstacle, ranges, states, setpoints, odom: "odom" })
}
