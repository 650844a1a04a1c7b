//! Board-support layers of the emulated modules: where the MCU reads its ADC, timers and pins,
//! these read the world; where it drives its outputs, these drive the world. Everything else
//! (node runtime, parameters, application) is the module's firmware crate, unchanged.
//!
//! Adding a model: write its boot function here (read the signals its board file names from
//! the world into the application's `Sample`, apply its `Command`) and name it in [`boot`],
//! and give the world a model of what the board is wired to (firmware/host/world). A module
//! without a model of its own runs the template's (`emulator = "template"` in modules.toml).

pub mod chip;
pub mod firmware;
mod gateway;
mod host;
mod imu;
pub mod imu_sensors;
mod motor;
mod params;
mod proximity;
mod psu;
mod template;

use std::cell::RefCell;
use std::rc::Rc;

use r2p_module::leds::Status;
use r2p_module::{FlashParams, ParamValues};
use r2p_node::node::STARTING_HEARTBEATS;
use r2p_node::{Node, NodeConfig, ParamStore};
use r2p_world::robot_file::{Module, Robot};
use r2p_world::{BoardKind, World};
use rtcan::cycle::ClockState;
use rtcan::failover::Role;
use rtcan::{CycleConfig, Micros};

pub use gateway::{gateway, GatewayBoot, GatewayTap, BASE_FIRST};
pub use host::base_on_host;
pub use imu::imu;
pub use motor::motor;
pub use params::store_params;
pub use proximity::proximity;
pub use psu::psu;
pub use template::template;

use crate::App;

/// Every emulated board's node runtime: room for each module's topics.
pub type BoardNode = Node<'static, 8, 16, 64, 16, 64>;

use crate::on_layout;
use chip::ChipLayout;
pub use chip::{BoardChip, Mcu, TimedFlash as BoardFlash};

/// What the robot-level application computed, for tests, plots and tools.
#[derive(Clone, Debug, Default)]
pub struct Probe {
    /// Odometry pose (x m, y m, θ rad), as the base controller integrates it.
    pub odometry: (f32, f32, f32),
    /// The command sent to the wheels after obstacle avoidance (vx, vy, ωz).
    pub command: (f32, f32, f32),
    /// Setpoints that found no room in the publisher's pool.
    pub setpoints_dropped: u32,
}

impl Probe {
    /// What the base controller `a` computed at its step at `now`.
    fn record(&mut self, a: &r2p_app_base::App<'_>, now: Micros) {
        self.odometry = a.pose();
        let c = a.command(now);
        self.command = (c.vx, c.vy, c.wz);
        self.setpoints_dropped = a.dropped;
    }
}

/// What a board's boot needs.
pub struct Ctx<'r> {
    /// The module in the robot file.
    pub module: &'r Module,
    /// The robot.
    pub robot: &'r Robot,
    /// The bus's TDMA cycle.
    pub cycle: CycleConfig,
    /// The world.
    pub world: Rc<RefCell<World>>,
    /// The board's flash (parameters, image slots).
    pub flash: &'static BoardChip,
    /// Virtual time of this boot, µs.
    pub boot_us: Micros,
    /// Where the gateway reports what it computes.
    pub probe: Rc<RefCell<Probe>>,
    /// Where the gateway's boot leaves its bus tap and link ([`GatewayBoot`]).
    pub gateway: Rc<RefCell<Option<GatewayBoot>>>,
    /// The network as the gateway sees it (its server's listening address).
    pub net: crate::gateway_net::NetSlot,
    /// What the gateway shares with its Zenoh client, while connected.
    pub ros: crate::gateway_zenoh::RosSlot,
}

/// A booted board: its node and its 1 kHz application step.
pub type Booted = (BoardNode, App<'static, BoardNode>);

/// Boots a board of model `kind`: the one place that knows which boot function runs which
/// model (a module's robot-file kind names its model through modules.toml).
pub fn boot(kind: BoardKind, ctx: Ctx<'_>) -> Result<Booted, String> {
    match kind {
        BoardKind::Psu => psu(ctx),
        BoardKind::Motor => motor(ctx),
        BoardKind::Proximity => proximity(ctx),
        BoardKind::Gateway => gateway(ctx),
        BoardKind::Imu => imu(ctx),
        BoardKind::Template => template(ctx),
    }
}

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

/// Parameters from the board's flash, as the MCU's boot loads them.
fn load_params<const N: usize>(
    defaults: [r2p_node::Param; N],
    flash: &'static BoardChip,
) -> Result<&'static FlashParams<N>, String> {
    // The parameter pages are the map's `params` partition, from its start.
    let params = leak(FlashParams::new(leak(defaults), leak(ParamValues::new()), 0));
    on_layout!(flash, load_on::<N>(params, flash))
        .map_err(|e| format!("reading parameters: {e:?}"))?;
    Ok(params)
}

fn load_on<L: ChipLayout, const N: usize>(
    params: &FlashParams<N>,
    flash: &'static BoardChip,
) -> Result<(), chip::FlashError> {
    params.load(&mut L::params(flash)).map(|_| ())
}

/// Writes parameters set over the bus to the board's flash (the MCU does it from its
/// application task, as here).
fn persist<const N: usize>(params: &FlashParams<N>, flash: &'static BoardChip) {
    if params.is_dirty() {
        // A failed write stays dirty and is retried next step, as on the MCU.
        let _ = on_layout!(flash, commit_on::<N>(params, flash));
    }
}

/// Writes `params` to the parameter pages of `flash`.
fn commit_on<L: ChipLayout, const N: usize>(
    params: &FlashParams<N>,
    flash: &'static BoardChip,
) -> Result<(), chip::FlashError> {
    params.commit(&mut L::params(flash)).map(|_| ())
}

/// The node with the module's configuration on the robot's cycle.
fn node(
    config: NodeConfig,
    ctx: &Ctx<'_>,
    params: &'static dyn ParamStore,
) -> Result<BoardNode, String> {
    let name: &'static str = Box::leak(ctx.module.name.clone().into_boxed_str());
    // Every board runs its MCU's slot timer (the emulated port models its path: `Sim::add_board_on`).
    let config = NodeConfig {
        uid: ctx.module.uid.0,
        name,
        cycle: ctx.cycle,
        slot_lead_us: Mcu::of(ctx.module.kind()).slot_lead_us(),
        sync_lead_us: Mcu::of(ctx.module.kind()).sync_lead_us(),
        framed_leads: Mcu::of(ctx.module.kind()).framed_leads(),
        ..config
    };
    BoardNode::new(config, params).map_err(|e| format!("node: {e:?}"))
}

/// The node's state as the status LEDs show it, computed as the MCU's module core does.
struct Leds {
    running_after_us: Micros,
    frames: u32,
    last_frame_at: Option<Micros>,
}

impl Leds {
    /// `heartbeat_period_us` from the node's configuration: "running" after the first
    /// [`STARTING_HEARTBEATS`], as on the MCU.
    fn new(ctx: &Ctx<'_>, heartbeat_period_us: u32) -> Self {
        let heartbeat = u64::from(heartbeat_period_us);
        Self {
            running_after_us: ctx.boot_us + u64::from(STARTING_HEARTBEATS) * heartbeat,
            frames: 0,
            last_frame_at: None,
        }
    }

    fn status(&mut self, now: Micros, node: &BoardNode, storage_fault: bool) -> Status {
        let received = node.stats().frames_received;
        if received != self.frames {
            (self.frames, self.last_frame_at) = (received, Some(now));
        }
        Status {
            running: now >= self.running_after_us,
            synced: node.role() == Role::Master
                || matches!(node.clock().state(now), ClockState::Running(_)),
            traffic: self.last_frame_at.is_some_and(|t| now - t < 1_000_000),
            fault: false,
            storage_fault,
        }
    }
}

/// Reads an ADC channel of `board`; the signal comes from the module's board file, so a
/// missing one is a bug of this layer.
fn adc(w: &mut World, board: &str, signal: &str) -> u16 {
    w.read_adc(board, signal).unwrap_or_else(|e| panic!("{e}"))
}
