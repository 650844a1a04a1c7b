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
//!
//! Each board has its MCU's flash with the bootloader's map ([`boards::chip`]: the modules' F103,
//! the gateway's F407): its parameters
//! (the robot file's `[modules.params]` stored there before the first boot), a signed image in
//! its active slot, and the slot an update over the bus is written to. At every reset the
//! emulated bootloader runs first ([`boards::firmware`]): after an update it swaps the images
//! (the board is off the bus for as long as its MCU takes), and a new image that does not
//! confirm itself is rolled back. A board resets when a REBOOT request reaches it or its trial
//! runs out.

use std::cell::{Cell, RefCell};
use std::io;
use std::net::SocketAddr;
use std::path::Path;
use std::rc::Rc;
use std::sync::{Arc, Mutex};

use embassy_boot::State;
use r2p_vbus::Config;
use r2p_world::robot_file::{BaseController, Module, Robot};
use r2p_world::BoardKind;
use r2p_world::World;
use rtcan::{CycleConfig, Micros};

use crate::boards::chip::{new_chip, Mcu};
use crate::boards::firmware::{self, around_app, factory_image, flash_active};
use crate::boards::{self, GatewayBoot, Probe};
pub use crate::boards::{BoardChip, BoardFlash, BoardNode};
use crate::gateway_net::{GatewayServer, LinkSlot, NetSlot};
use crate::gateway_zenoh::{RosSlot, ZenohClient};
use crate::{App, Mode, PortTap, Reset, Sim};

/// One board of the robot.
pub struct BoardInfo {
    /// Module name from the robot file.
    pub name: String,
    /// What it is.
    pub kind: BoardKind,
    /// Its flash: parameters and image slots, kept across reboots.
    pub flash: &'static BoardChip,
    /// Times it booted.
    pub boots: Rc<Cell<u32>>,
}

/// What booting a board needs, shared by the robot and the sim's resets.
struct Booter {
    robot: Robot,
    world: Rc<RefCell<World>>,
    probe: Rc<RefCell<Probe>>,
    /// The gateway's link of its current boot, for its network server.
    gateway_link: LinkSlot,
    /// The network as the gateway sees it.
    gateway_net: NetSlot,
    /// What the gateway's step and its Zenoh client share, while connected.
    gateway_ros: RosSlot,
    flash: Vec<&'static BoardChip>,
    boots: Vec<Rc<Cell<u32>>>,
    /// Set by a board's firmware when it resets itself.
    resets: Vec<Rc<Cell<bool>>>,
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
    /// What the robot-level application (the base controller) computes: odometry and
    /// commands.
    pub probe: Rc<RefCell<Probe>>,
    /// The port of the host's node that runs the base controller (`[base] controller =
    /// "host"`), after the modules' ports.
    pub host: Option<usize>,
    booter: Rc<RefCell<Booter>>,
}

/// A board's firmware after its bootloader: node, application, port tap, time off the bus.
type Boot = (BoardNode, App<'static, BoardNode>, Option<Box<dyn PortTap>>, u64);

impl Booter {
    fn cycle(&self) -> CycleConfig {
        CycleConfig {
            bit_rate: self.robot.bus.bit_rate,
            cycle_us: self.robot.bus.cycle_us,
            ..CycleConfig::DEFAULT
        }
    }

    /// Resets board `i` at `now_us`: its bootloader, then its firmware over its flash.
    fn boot(&mut self, i: usize, now_us: Micros) -> Result<Boot, String> {
        let module: Module = self.robot.modules[i].clone();
        let chip = self.flash[i];
        let booted = firmware::bootloader(chip).map_err(|r| {
            format!("{}: the bootloader finds no image it can run: {}", module.name, r.message())
        })?;
        if booted.state == State::Revert {
            // The old image, back after a rollback, tells the bootloader it knows.
            firmware::mark_booted(chip);
        }
        let boot_us = now_us + booted.stall_ns.div_ceil(1_000);
        let gateway = Rc::new(RefCell::new(None));
        self.boots[i].set(self.boots[i].get() + 1);
        let ctx = boards::Ctx {
            module: &module,
            robot: &self.robot,
            cycle: self.cycle(),
            world: self.world.clone(),
            flash: chip,
            boot_us,
            probe: self.probe.clone(),
            gateway: gateway.clone(),
            net: self.gateway_net.clone(),
            ros: self.gateway_ros.clone(),
        };
        let kind = module.kind();
        let (mut node, app) =
            boards::boot(kind, ctx).map_err(|e| format!("{}: {e}", module.name))?;
        node.set_firmware(booted.firmware.clone());
        node.set_update_sink(firmware::update_sink(chip, kind.name()));
        let heartbeat_us = Micros::from(node.config().heartbeat_period_us);
        let gateway_image = kind == BoardKind::Gateway;
        let reset = self.resets[i].clone();
        let app = around_app(app, chip, &booted, boot_us, heartbeat_us, gateway_image, reset);
        let tap = gateway.borrow_mut().take().map(|g: GatewayBoot| {
            *self.gateway_link.lock().unwrap_or_else(|e| e.into_inner()) = Some(g.link);
            Box::new(g.tap) as Box<dyn PortTap>
        });
        Ok((node, app, tap, booted.stall_ns))
    }
}

impl EmuRobot {
    /// Loads a robot file and builds the robot.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, String> {
        let robot = Robot::load(path).map_err(|e| e.to_string())?;
        Self::build(robot)
    }

    /// Builds `robot`: a bus with one port per module (and one for the host's node when the
    /// base controller runs there) plus a spare (for tools), the world, and every board
    /// flashed (its image, its parameters) and booted at time 0.
    pub fn build(robot: Robot) -> Result<Self, String> {
        Self::build_with_spares(robot, 1)
    }

    /// [`EmuRobot::build`] with `spares` spare ports (at least one), from
    /// [`EmuRobot::spare_port`] on: for benches that add nodes of their own (a load, a tool).
    pub fn build_with_spares(robot: Robot, spares: usize) -> Result<Self, String> {
        let config = Config { seed: robot.seed, bit_rate: robot.bus.bit_rate, ..Config::default() };
        let on_host = robot.base_controller == Some(BaseController::Host);
        let host = on_host.then_some(robot.modules.len());
        let ports = robot.modules.len() + usize::from(on_host) + spares.max(1);
        let mut sim = Sim::new(ports, config, Mode::Tdma);
        let world = Rc::new(RefCell::new(World::from_robot(&robot)));
        let w = world.clone();
        sim.set_world(Box::new(move |now_us| w.borrow_mut().advance_to_ns(now_us * 1_000)));
        let probe = Rc::new(RefCell::new(Probe::default()));
        let mut boards = Vec::new();
        for (i, m) in robot.modules.iter().enumerate() {
            let seed = robot.seed ^ (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
            let mcu = Mcu::of(m.kind());
            let chip = new_chip(mcu, seed);
            flash_active(chip, &factory_image(m.kind().name(), mcu));
            boards::store_params(m, &robot, chip)?;
            chip.lock(|c| c.borrow_mut().take_stall_ns()); // the factory's, not the robot's
            boards.push(BoardInfo {
                name: m.name.clone(),
                kind: m.kind(),
                flash: chip,
                boots: Rc::new(Cell::new(0)),
            });
        }
        let booter = Rc::new(RefCell::new(Booter {
            robot: robot.clone(),
            world: world.clone(),
            probe: probe.clone(),
            gateway_link: Arc::new(Mutex::new(None)),
            gateway_net: Arc::new(Mutex::new(Default::default())),
            gateway_ros: Arc::new(Mutex::new(None)),
            flash: boards.iter().map(|b| b.flash).collect(),
            boots: boards.iter().map(|b| b.boots.clone()).collect(),
            resets: boards.iter().map(|_| Rc::new(Cell::new(false))).collect(),
        }));
        for (i, b) in boards.iter().enumerate() {
            let (node, app, tap, _) = booter.borrow_mut().boot(i, 0)?;
            sim.add_board_on(node, i, Some(app), Mcu::of(b.kind));
            sim.set_tap(i, tap);
            let chip = b.flash;
            sim.set_stall(i, Box::new(move || chip.lock(|c| c.borrow_mut().take_stall_ns())));
        }
        if let Some(port) = host {
            let (node, app) = boards::base_on_host(&robot, probe.clone())?;
            sim.add_board(node, port, Some(app));
        }
        let b = booter.clone();
        sim.set_resetter(Box::new(move |i, now_us| {
            // Boards a test added beyond the robot's have no reset line.
            if !b.borrow().resets.get(i).is_some_and(|r| r.replace(false)) {
                return None;
            }
            let (node, app, tap, down_ns) =
                b.borrow_mut().boot(i, now_us).unwrap_or_else(|e| panic!("{e}"));
            Some(Reset { node, app: Some(app), tap, down_ns })
        }));
        Ok(EmuRobot { sim, world, robot, boards, probe, host, booter })
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
        let b = self.booter.borrow();
        GatewayServer::start(addr, b.gateway_link.clone(), b.gateway_net.clone())
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
        let slot = self.booter.borrow().gateway_ros.clone();
        ZenohClient::start(router, m.uid.0, domain, namespace.trim_matches('/').to_string(), slot)
    }

    /// The spare port tools and bridges use (the first, with [`EmuRobot::build_with_spares`]).
    pub fn spare_port(&self) -> usize {
        self.robot.modules.len() + usize::from(self.host.is_some())
    }

    /// Index of the board called `name`.
    pub fn board(&self, name: &str) -> Option<usize> {
        self.boards.iter().position(|b| b.name == name)
    }

    /// Reboots the board called `name` now (a reset: RAM state gone, its flash kept; its
    /// bootloader runs first, and a swap it does keeps the board off the bus meanwhile).
    pub fn reboot(&mut self, name: &str) -> Result<(), String> {
        let i = self.board(name).ok_or_else(|| format!("no board called {name}"))?;
        let (node, app, tap, _) = self.booter.borrow_mut().boot(i, self.sim.now_us())?;
        self.sim.reboot(i, node, Some(app));
        self.sim.set_tap(i, tap);
        Ok(())
    }
}
