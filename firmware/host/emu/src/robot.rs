//! An emulated robot from a robot file (`robots/*.toml`, format in robots/README.md): every
//! module's firmware application on its own board, on one virtual bus, against the world
//! model, in virtual time.
//!
//! Each board runs the module's application crate (`r2p-app-psu`, `-motor`, `-proximity`, `-imu`; the
//! gateway runs `r2p-app-base`, the robot-level nodes, until the gateway firmware lands) with
//! the same node runtime and parameter store as on the MCU. Only the board-support layer
//! differs: [`boards`] reads the world where the MCU reads its ADC, timers and pins, and
//! applies the application's command to the world where the MCU drives its outputs.
//! Parameters live in an emulated flash per board ([`BoardFlash`], a `RamFlash`) that survives
//! reboots; the robot file's `[modules.params]` are stored there before the first boot.

use std::cell::RefCell;
use std::path::Path;
use std::rc::Rc;

use r2p_vbus::Config;
use r2p_world::robot_file::{Module, Robot};
use r2p_world::BoardKind;
use r2p_world::World;
use rtcan::CycleConfig;

use crate::boards::{self, Probe};
pub use crate::boards::{BoardFlash, BoardNode};
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
        let mut r = EmuRobot { sim, world, robot, boards: Vec::new(), probe };
        for (i, m) in r.robot.modules.clone().iter().enumerate() {
            let flash = Rc::new(RefCell::new(BoardFlash::new()));
            boards::store_params(m, &r.robot, &mut flash.borrow_mut())?;
            r.boards.push(BoardInfo { name: m.name.clone(), kind: m.kind(), flash, boots: 0 });
            let (node, app) = r.boot(i)?;
            r.sim.add_board(node, i, Some(app));
        }
        Ok(r)
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
    fn boot(&mut self, i: usize) -> Result<(BoardNode, App<'static, BoardNode>), String> {
        let module: Module = self.robot.modules[i].clone();
        let cycle = self.cycle();
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
        };
        boards::boot(module.kind(), ctx).map_err(|e| format!("{}: {e}", module.name))
    }

    /// Reboots the board called `name` (a reset: RAM state gone, parameters kept in flash).
    pub fn reboot(&mut self, name: &str) -> Result<(), String> {
        let i = self.board(name).ok_or_else(|| format!("no board called {name}"))?;
        let (node, app) = self.boot(i)?;
        self.sim.reboot(i, node, Some(app));
        Ok(())
    }
}
