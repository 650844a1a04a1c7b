//! The gateway board: the gateway's application (`r2p-app-gateway`: its node's status, the bus
//! on TCP through its bus tap, network parameters) as the STM32F407 image runs it, its server
//! over host TCP ([`crate::gateway_net`]); and the robot-level nodes of the paper's Triskar2
//! (`r2p-app-base`: inverse kinematics, obstacle avoidance, odometry), which the gateway runs
//! for the robot (issue 20 item 5; not in the F407 image yet), playing the robot file's
//! `[[teleop]]` script on `cmd_vel` as a teleoperator behind the gateway would.
//!
//! One node serves both applications' parameters: the base controller's first (their indices
//! are unchanged), the network's after them ([`PARAMS`]).

use r2p_app_base::endpoints::Names;
use r2p_app_base::{params, App, Endpoints};
use r2p_app_gateway::params::{after, COUNT as NET_COUNT};
use r2p_app_gateway::{BusLink, BusTap};
use r2p_msgs::Twist2D;
use r2p_node::{Param, ParamStore};
use r2p_world::robot_file::Wiring;
use rtcan::{CanController, Micros};

use super::{leak, load_params, node, persist, Booted, Ctx, Leds};
use crate::PortTap;

/// Number of the gateway node's parameters.
pub const PARAM_COUNT: usize = params::DEFAULTS.len() + NET_COUNT;

/// The gateway node's parameters: the base controller's, then the network's.
pub const PARAMS: [Param; PARAM_COUNT] = after(params::DEFAULTS);

/// Index of the first network parameter.
pub const NET_FIRST: u16 = params::DEFAULTS.len() as u16;

/// The gateway's bus tap between its node and its port, as on the MCU.
pub struct GatewayTap(pub BusTap<'static>);

impl PortTap for GatewayTap {
    fn run(
        &mut self,
        now: Micros,
        port: &mut dyn CanController,
        node: &mut dyn FnMut(&mut dyn CanController),
    ) {
        self.0.run(now, port, |c| node(c));
    }
}

/// What a gateway's boot leaves for the robot: the tap to put on its port and the link its
/// network server serves.
pub struct GatewayBoot {
    /// Goes between the node and the board's port ([`crate::Sim::set_tap`]).
    pub tap: GatewayTap,
    /// The queues between the tap and the network clients.
    pub link: &'static BusLink,
}

/// Period of the teleop script's `cmd_vel` (a joystick's rate).
const TELEOP_PERIOD_US: u64 = 50_000;

/// Boots the gateway: its application and the base controller on one node.
pub fn gateway(ctx: Ctx<'_>) -> Result<Booted, String> {
    let p = load_params(PARAMS, ctx.flash)?;
    let names = names(&ctx)?;
    let ik_hz = match p.get(params::IK_RATE_HZ) {
        Ok(r2p_management::message::Value::U32(v)) => v.max(1),
        _ => 100,
    };
    let ep = Endpoints::leak(names, 1_000_000 / ik_hz);
    let cmd_local = ep.cmd_local;
    let mut a = App::new(ep, p);
    let link = leak(BusLink::new());
    let mut gw = r2p_app_gateway::App::new(r2p_app_gateway::Endpoints::leak(), link);
    // The standby master: rank 1 after the PSU.
    let config = r2p_app_gateway::node_config(ctx.module.uid.0);
    let mut n = node(config, &ctx, p)?;
    a.register(&mut n).map_err(|e| format!("registering topics: {e:?}"))?;
    gw.register(&mut n).map_err(|e| format!("registering gateway/status: {e:?}"))?;
    *ctx.gateway.borrow_mut() = Some(GatewayBoot { tap: GatewayTap(BusTap::new(link)), link });
    let mut leds = Leds::new(&ctx, config.heartbeat_period_us);
    let net = ctx.net.clone();
    let ros = ctx.ros.clone();
    let script: Vec<_> = ctx.robot.teleop.clone();
    let (flash, probe) = (ctx.flash, ctx.probe);
    Ok((
        n,
        Box::new(move |now, node| {
            let status = leds.status(now, node, false);
            let net = *net.lock().unwrap_or_else(|e| e.into_inner());
            gw.step(now, &r2p_app_gateway::Sample { status, net });
            // ROS 2 over Zenoh: the latest values out, /cmd_vel in (it takes over from the
            // teleop script while it arrives; its watchdog's zero command stops the base).
            let mut driving = false;
            if let Some(sh) = ros.lock().unwrap_or_else(|e| e.into_inner()).as_mut() {
                let (x, y, theta) = a.pose();
                let (vx, vy, wz) = a.velocity();
                sh.latest.odom = Some(r2p_msgs::Odometry { x, y, theta, vx, vy, wz });
                sh.latest.status = Some(gw.status(&net));
                sh.latest.battery = gw.battery();
                sh.latest.imu = gw.imu();
                sh.latest.mirrored = gw.mirrored();
                sh.latest.proximity = a.ranges();
                if let Some(c) = sh.cmd.take() {
                    let _ = cmd_local.publish_with(|m| *m = c);
                }
                driving = sh.driving;
            }
            if now % TELEOP_PERIOD_US == 0 && !driving {
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
            persist(p, flash);
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
