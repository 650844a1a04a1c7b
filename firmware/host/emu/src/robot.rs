//! An emulated robot from a robot file (`robots/*.toml`, format in robots/README.md): every
//! module's firmware application on its own board, on one virtual bus, against the world
//! model, in virtual time.
//!
//! Each board runs the module's application crate (`r2p-app-psu`, `-motor`, `-proximity`, `-imu`,
//! `-gateway`; the gateway also runs `r2p-app-base`, the robot-level nodes) with the same node
//! runtime and parameter store as on the MCU. The gateway serves the bus on TCP through its own
//! application's server when asked ([`EmuRobot::serve_gateway`]). Only the board-support layer
//! differs: [`boards`] reads the world where the MCU reads its ADC, timers and pins, and
//! applies the application's command to the world where the MCU drives its outputs.
//! Parameters live in an emulated flash per board ([`BoardFlash`], a `RamFlash`) that survives
//! reboots; the robot file's `[modules.params]` are stored there before the first boot.

use std::cell::RefCell;
use std::io;
use std::net::SocketAddr;
use std::path::Path;
use std::rc::Rc;
use std::sync::{Arc, Mutex};

use r2p_vbus::Config;
use r2p_world::robot_file::{Module, Robot};
use r2p_world::BoardKind;
use r2p_world::World;
use rtcan::CycleConfig;

use crate::boards::{self, GatewayBoot, Probe};
pub use crate::boards::{BoardFlash, BoardNode};
use crate::gateway_net::{GatewayServer, LinkSlot, NetSlot};
use crate::gateway_zenoh::{RosSlot, ZenohClient};
use crate::{App, Mode, Sim};

/// One board of the robot.
pub struct BoardInfo {
    /// Module name from the robot file.
    pub name: String,
    /// What it is.
    pub kind: BoardKind,
    /// Its parameter flash (kept across reboots).
    pub flash: Rc<RefCell<BoardFlash>>,
    /// Times it booted.
    pub boots: u32,
}

/// A robot file running on emulated boards. See the module documentation.
pub struct EmuRobot {
    /// The boards on the bus, in robot-file order (board `i` is on port `i`).
    pub sim: Sim<'static, BoardNode>,
    /// The physical world the boards sense and drive.
    pub world: Rc<RefCell<World>>,
    /// The robot description.
    pub robot: Robot,
    /// The boards, in robot-file order.
    pub boards: Vec<BoardInfo>,
    /// What the robot-level application (on the gateway) computes: odometry and commands.
    pub probe: Rc<RefCell<Probe>>,
    /// The gateway's link of its current boot, for its network server.
    gateway_link: LinkSlot,
    /// The network as the gateway sees it.
    gateway_net: NetSlot,
    /// What the gateway's step and its Zenoh client share, while connected.
    gateway_ros: RosSlot,
}

impl EmuRobot {
    /// Loads a robot file and builds the robot.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, String> {
        let robot = Robot::load(path).map_err(|e| e.to_string())?;
        Self::build(robot)
    }

    /// Builds `robot`: a bus with one port per module plus a spare (for tools), the world,
    /// and every board booted at time 0.
    pub fn build(robot: Robot) -> Result<Self, String> {
        let config = Config { seed: robot.seed, bit_rate: robot.bus.bit_rate, ..Config::default() };
        let mut sim = Sim::new(robot.modules.len() + 1, config, Mode::Tdma);
        let world = Rc::new(RefCell::new(World::from_robot(&robot)));
        let w = world.clone();
        sim.set_world(Box::new(move |now_us| w.borrow_mut().advance_to_ns(now_us * 1_000)));
        let probe = Rc::new(RefCell::new(Probe::default()));
        let mut r = EmuRobot {
            sim,
            world,
            robot,
            boards: Vec::new(),
            probe,
            gateway_link: Arc::new(Mutex::new(None)),
            gateway_net: Arc::new(Mutex::new(Default::default())),
            gateway_ros: Arc::new(Mutex::new(None)),
        };
        for (i, m) in r.robot.modules.clone().iter().enumerate() {
            let flash = Rc::new(RefCell::new(BoardFlash::new()));
            boards::store_params(m, &r.robot, &mut flash.borrow_mut())?;
            r.boards.push(BoardInfo { name: m.name.clone(), kind: m.kind(), flash, boots: 0 });
            let (node, app, gateway) = r.boot(i)?;
            r.sim.add_board(node, i, Some(app));
            r.install(i, gateway);
        }
        Ok(r)
    }

    /// Puts a gateway's bus tap on its port and its link behind the network server.
    fn install(&mut self, i: usize, gateway: Option<GatewayBoot>) {
        if let Some(g) = gateway {
            self.sim.set_tap(i, Some(Box::new(g.tap)));
            *self.gateway_link.lock().unwrap_or_else(|e| e.into_inner()) = Some(g.link);
        }
    }

    /// Serves the bus on TCP at `addr` through the gateway's own socketcand server (its
    /// application's, over host TCP): the endpoint a real robot's gateway serves. The server
    /// runs until the returned handle is shut down or dropped; frames flow while the sim runs.
    pub fn serve_gateway(&self, addr: SocketAddr) -> io::Result<GatewayServer> {
        if !self.boards.iter().any(|b| b.kind == BoardKind::Gateway) {
            return Err(io::Error::new(
                io::ErrorKind::NotFound,
                format!("{} has no gateway module to serve the bus", self.robot.name),
            ));
        }
        GatewayServer::start(addr, self.gateway_link.clone(), self.gateway_net.clone())
    }

    /// Connects the gateway to the Zenoh router at `router` (its application's Zenoh client
    /// over host TCP): the robot's topics become ROS 2 topics (rmw_zenoh's conventions) in
    /// `domain` and `namespace`, and `/cmd_vel` drives the base. Runs until the returned handle
    /// is shut down or dropped; reconnects when the router goes away.
    pub fn connect_zenoh(
        &self,
        router: SocketAddr,
        domain: u32,
        namespace: &str,
    ) -> io::Result<ZenohClient> {
        let Some(m) = self.robot.modules.iter().find(|m| m.kind() == BoardKind::Gateway) else {
            return Err(io::Error::new(
                io::ErrorKind::NotFound,
                format!("{} has no gateway module to connect to a Zenoh router", self.robot.name),
            ));
        };
        ZenohClient::start(
            router,
            m.uid.0,
            domain,
            namespace.trim_matches('/').to_string(),
            self.gateway_ros.clone(),
        )
    }

    /// The spare port tools and bridges use.
    pub fn spare_port(&self) -> usize {
        self.robot.modules.len()
    }

    /// Index of the board called `name`.
    pub fn board(&self, name: &str) -> Option<usize> {
        self.boards.iter().position(|b| b.name == name)
    }

    fn cycle(&self) -> CycleConfig {
        CycleConfig {
            bit_rate: self.robot.bus.bit_rate,
            cycle_us: self.robot.bus.cycle_us,
            ..CycleConfig::DEFAULT
        }
    }

    /// Boots board `i`'s firmware: a new node and application over its flash.
    #[allow(clippy::type_complexity)]
    fn boot(
        &mut self,
        i: usize,
    ) -> Result<(BoardNode, App<'static, BoardNode>, Option<GatewayBoot>), String> {
        let module: Module = self.robot.modules[i].clone();
        let cycle = self.cycle();
        let gateway = Rc::new(RefCell::new(None));
        let board = &mut self.boards[i];
        board.boots += 1;
        let ctx = boards::Ctx {
            module: &module,
            robot: &self.robot,
            cycle,
            world: self.world.clone(),
            flash: board.flash.clone(),
            boot_us: self.sim.now_us(),
            probe: self.probe.clone(),
            gateway: gateway.clone(),
            net: self.gateway_net.clone(),
            ros: self.gateway_ros.clone(),
        };
        let (node, app) =
            boards::boot(module.kind(), ctx).map_err(|e| format!("{}: {e}", module.name))?;
        let booted = gateway.borrow_mut().take();
        Ok((node, app, booted))
    }

    /// Reboots the board called `name` (a reset: RAM state gone, parameters kept in flash).
    pub fn reboot(&mut self, name: &str) -> Result<(), String> {
        let i = self.board(name).ok_or_else(|| format!("no board called {name}"))?;
        let (node, app, gateway) = self.boot(i)?;
        self.sim.reboot(i, node, Some(app));
        self.install(i, gateway);
        Ok(())
    }
}
