//! The gateway board: the gateway's application (`r2p-app-gateway`: its node's status, the bus
//! on TCP through its bus tap, network parameters) as the STM32F407 image runs it, its server
//! over host TCP ([`crate::gateway_net`]); and, with its `base_controller` parameter on (the
//! robot file's `[base] controller`, the gateway by default), the robot-level nodes of the
//! paper's Triskar2 (`r2p-app-base`: inverse kinematics, obstacle avoidance, odometry), as the
//! image runs them too; playing the robot file's `[[teleop]]` script on `cmd_vel` as a
//! teleoperator behind the gateway would (to the base controller here, or on the bus for the
//! node that runs it).
//!
//! The imports only ROS 2 wants (the gateway's own, and `odom` and the ranges when the base
//! runs elsewhere) follow the Zenoh subscribers as on the MCU ([`crate::gateway_zenoh`]).
//!
//! One node serves both applications' parameters, as the image's does: the gateway's first,
//! the base controller's after them ([`PARAMS`]).

use r2p_app_base::{params, App, Endpoints, Names};
use r2p_app_gateway::demand::{Feed, Follower, GATEWAY_FEEDS};
use r2p_app_gateway::params::{base_controller, followed_by, Offset, COUNT as NET_COUNT};
use r2p_app_gateway::{BusLink, BusTap, RemoteBase};
use r2p_middleware::{pool_size, Class, Publisher};
use r2p_module::OutboundCell;
use r2p_msgs::Twist2D;
use r2p_node::Param;
use rtcan::{CanController, Micros};

use super::{leak, load_params, node, persist, Booted, Ctx, Leds, Mcu};
use crate::PortTap;

/// Number of the gateway node's parameters.
pub const PARAM_COUNT: usize = NET_COUNT + params::COUNT;

/// The gateway node's parameters: the gateway's (network, `base_controller`), then the base
/// controller's.
pub const PARAMS: [Param; PARAM_COUNT] = followed_by(params::DEFAULTS);

/// Index of the base controller's first parameter.
pub const BASE_FIRST: u16 = NET_COUNT as u16;

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

/// Boots the gateway: its application and, if its parameters say so, the base controller on
/// one node.
pub fn gateway(ctx: Ctx<'_>) -> Result<Booted, String> {
    let p = load_params(PARAMS, ctx.flash)?;
    let bp = leak(Offset { store: p, first: BASE_FIRST });
    let mut base = base_controller(p, 0).then(|| {
        let ep = Endpoints::leak(Names::from_params(bp), params::ik_period_us(bp));
        (ep.cmd_local, App::new(ep, bp))
    });
    // Elsewhere: its odometry and ranges from the bus, for ROS 2.
    let mut remote = base.is_none().then(|| RemoteBase::leak(Names::from_params(bp).ranges));
    let link = leak(BusLink::new());
    let mut gw = r2p_app_gateway::App::new(r2p_app_gateway::Endpoints::leak(), link);
    // The standby master: rank 1 after the PSU.
    let config = r2p_app_gateway::node_config(ctx.module.uid.0, Mcu::F407.sysclk_hz());
    let mut n = node(config, &ctx, p)?;
    // `cmd_vel` to the base controller here, or on the bus for the node that runs it.
    let cmd_local: &'static Publisher<'static, Twist2D> = match &base {
        Some((cmd_local, a)) => {
            a.register(&mut n).map_err(|e| format!("registering topics: {e:?}"))?;
            cmd_local
        }
        None => {
            let cell: &'static OutboundCell<Twist2D, { pool_size(&[2], 1) }, 1, 2> =
                leak(OutboundCell::new());
            let out = cell
                .build(r2p_app_base::names::CMD_VEL, Twist2D::default(), Class::NonRealTime)
                .map_err(|e| format!("cmd_vel: {e:?}"))?;
            n.export(out.remote).map_err(|e| format!("exporting cmd_vel: {e:?}"))?;
            out.publisher
        }
    };
    if let Some(r) = &remote {
        r.register(&mut n).map_err(|e| format!("importing odom and ranges: {e:?}"))?;
    }
    gw.register(&mut n).map_err(|e| format!("registering gateway/status: {e:?}"))?;
    let mut feeds: Vec<Feed<'static>> = GATEWAY_FEEDS.to_vec();
    feeds.extend(remote.as_ref().map(|r| r.feeds()).into_iter().flatten());
    let mut follower = Follower::bind(&feeds, &n);
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
            let mut net = *net.lock().unwrap_or_else(|e| e.into_inner());
            // The Zenoh thread's write filter count, for gateway/status (as the F407's
            // `zenoh` task leaves it for its bus task).
            if let Some(sh) = ros.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
                net.ros_filtered = sh.stats.filtered;
            }
            gw.step(now, &r2p_app_gateway::Sample { status, net });
            // ROS 2 over Zenoh: the latest values out, /cmd_vel in (it takes over from the
            // teleop script while it arrives; its watchdog's zero command stops the base).
            let mut driving = false;
            let from_bus = remote.as_mut().map(|r| r.latest());
            if let Some(sh) = ros.lock().unwrap_or_else(|e| e.into_inner()).as_mut() {
                if let Some((_, a)) = &base {
                    let (x, y, theta) = a.pose();
                    let (vx, vy, wz) = a.velocity();
                    sh.latest.odom = Some(r2p_msgs::Odometry { x, y, theta, vx, vy, wz });
                    sh.latest.proximity = a.ranges();
                }
                if let Some((odom, ranges)) = from_bus {
                    (sh.latest.odom, sh.latest.proximity) = (odom, ranges);
                }
                sh.latest.status = Some(gw.status(&net));
                sh.latest.battery = gw.battery();
                sh.latest.imu = gw.imu();
                (sh.latest.mag, sh.latest.baro, sh.latest.gnss) = gw.imu_extras();
                sh.latest.mirrored = gw.mirrored();
                if let Some(c) = sh.cmd.take() {
                    let _ = cmd_local.publish_with(|m| *m = c);
                }
                driving = sh.driving;
                if sh.feeds != feeds {
                    sh.feeds.clone_from(&feeds);
                }
                if let Some(wanted) = sh.wanted {
                    follower.apply(wanted, node);
                }
            }
            if now % TELEOP_PERIOD_US == 0 && !driving {
                if let Some(t) = script.iter().rev().find(|t| (t.at_s * 1e6) as u64 <= now) {
                    let (vx, vy, wz) = (t.vx as f32, t.vy as f32, t.wz as f32);
                    let _ = cmd_local.publish_with(|m| *m = Twist2D { vx, vy, wz });
                }
            }
            if let Some((_, a)) = &mut base {
                a.step(now);
                probe.borrow_mut().record(a, now);
            }
            persist(p, flash);
        }),
    ))
}
