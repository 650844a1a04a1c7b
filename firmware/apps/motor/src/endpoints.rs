//! The motor controller's topics and their endpoints, built per board.
//!
//! | topic | type | direction | class |
//! |---|---|---|---|
//! | `<name>/setpoint` | `WheelSetpoint` | in (imported) | NRT |
//! | `<name>/clear_faults` | `FaultClear` | in (imported) | NRT |
//! | `<name>/state` | `WheelState` | out (exported) | SRT, 10 ms deadline |
//! | `<name>/fault` | `MotorFault` | out (exported) | SRT, 5 ms deadline |
//!
//! The names come from the `instance` parameter at run time, so the objects cannot be `static`
//! items with `const` initialisers: a [`Storage`] of cells (`r2p_module`'s [`Outbound`] and
//! [`Inbound`], each topic written once) holds them, a `static` on the MCU (no heap, one board
//! per image) and a leaked one per board on the host ([`Endpoints::leak`]: any number of boards
//! per process, none sharing a topic).
//!
//! Why SRT for the state: it feeds odometry and the robot's control loops, where a late value
//! is worth less than the next one; EDF sends it before NRT traffic (parameters, heartbeats),
//! and a value still queued after one period (10 ms at the default 100 Hz) is dropped and
//! counted instead of delaying the next. (HRT needs a single frame; `WheelState` takes two.)
//! The fault event is SRT with a shorter deadline: the most urgent thing the module says.

use r2p_middleware::{pool_size, Class, Error};
use r2p_module::TopicNode;
use r2p_module::{Inbound, InboundCell, Outbound, OutboundCell};
use r2p_msgs::{FaultClear, MotorFault, WheelSetpoint, WheelState};
use r2p_node::NodeError;

use crate::names::Names;

/// Setpoints the application may find queued at one step (it uses the newest).
pub const SETPOINT_QUEUE: usize = 2;
/// Clear commands queued at one step.
pub const CLEAR_QUEUE: usize = 2;
/// States queued for the bus (the longest queue remote subscribers may ask for).
pub const STATE_BUS_QUEUE: usize = 2;
/// Fault events queued for the bus.
pub const FAULT_BUS_QUEUE: usize = 4;
/// Room for one more local subscriber on `state` and `fault` (a node of the user's on this
/// module, e.g. odometry: paper §5), with a queue of up to this length.
pub const LOCAL_QUEUE: usize = 2;
/// Deadline of `state` on the bus, µs (one period at the default 100 Hz).
pub const STATE_DEADLINE_US: u32 = 10_000;
/// Deadline of `fault` on the bus, µs.
pub const FAULT_DEADLINE_US: u32 = 5_000;

/// `<name>/setpoint` and `<name>/clear_faults` have room for the bus's publisher and one local
/// one (a kinematics node on this module); `state` and `fault` for the bus's subscriber and one
/// local one (e.g. odometry).
const SETPOINT_POOL: usize = pool_size(&[SETPOINT_QUEUE], 2);
const CLEAR_POOL: usize = pool_size(&[CLEAR_QUEUE], 2);
const STATE_POOL: usize = pool_size(&[STATE_BUS_QUEUE, LOCAL_QUEUE], 1);
const FAULT_POOL: usize = pool_size(&[FAULT_BUS_QUEUE, LOCAL_QUEUE], 1);

/// Every object of the module's four topics (see the module documentation): one field a topic.
#[derive(Clone, Copy)]
pub struct Endpoints<'a> {
    /// The names they were built with.
    pub names: Names,
    /// Setpoints: imported, queued for the application (it uses the newest).
    pub setpoint: Inbound<'a, WheelSetpoint, SETPOINT_POOL, 1, SETPOINT_QUEUE>,
    /// Clear commands: imported, queued for the application.
    pub clear_faults: Inbound<'a, FaultClear, CLEAR_POOL, 1, CLEAR_QUEUE>,
    /// The state: published (SRT) and exported.
    pub state: Outbound<'a, WheelState, STATE_POOL, 2, STATE_BUS_QUEUE>,
    /// Fault events: published (SRT) and exported.
    pub fault: Outbound<'a, MotorFault, FAULT_POOL, 2, FAULT_BUS_QUEUE>,
}

/// Room for one board's endpoints: a `static` on the MCU (one board per image), then
/// [`Storage::build`] once; on the host, [`Endpoints::leak`].
#[derive(Default)]
pub struct Storage {
    setpoint: InboundCell<WheelSetpoint, SETPOINT_POOL, 1, SETPOINT_QUEUE>,
    clear_faults: InboundCell<FaultClear, CLEAR_POOL, 1, CLEAR_QUEUE>,
    state: OutboundCell<WheelState, STATE_POOL, 2, STATE_BUS_QUEUE>,
    fault: OutboundCell<MotorFault, FAULT_POOL, 2, FAULT_BUS_QUEUE>,
}

impl Storage {
    /// Empty storage.
    pub const fn new() -> Self {
        Self {
            setpoint: InboundCell::new(),
            clear_faults: InboundCell::new(),
            state: OutboundCell::new(),
            fault: OutboundCell::new(),
        }
    }

    /// The endpoints of the board named by `names`, advertised and subscribed.
    ///
    /// # Panics
    /// If called twice on one storage (each cell is initialised once).
    pub fn build(&'static self, names: Names) -> Endpoints<'static> {
        let state_class = Class::AsyncRealTime { deadline_us: STATE_DEADLINE_US };
        let fault_class = Class::AsyncRealTime { deadline_us: FAULT_DEADLINE_US };
        let idle = WheelSetpoint { mode: 0, value: 0.0 };
        // Sized for exactly these endpoints (tested): a failure here is a bug, found at boot.
        let built = (|| -> Result<_, Error> {
            Ok(Endpoints {
                names,
                setpoint: self.setpoint.build(names.setpoint, idle)?,
                clear_faults: self
                    .clear_faults
                    .build(names.clear_faults, FaultClear { mask: 0 })?,
                state: self.state.build(names.state, WheelState::default(), state_class)?,
                fault: self.fault.build(names.fault, MotorFault::default(), fault_class)?,
            })
        })();
        built.expect("the motor's topics are sized for their endpoints")
    }
}

impl<'a> Endpoints<'a> {
    /// Exports `state` and `fault` and imports `setpoint` and `clear_faults` on `node` (what
    /// [`App::register`](crate::App::register) does; usable where the node and the application
    /// are built in different tasks).
    pub fn register(&self, node: &mut impl TopicNode<'a>) -> Result<(), NodeError> {
        node.export(self.state.remote)?;
        node.export(self.fault.remote)?;
        node.import(self.setpoint.remote)?;
        node.import(self.clear_faults.remote)?;
        Ok(())
    }
}

#[cfg(feature = "std")]
impl Endpoints<'static> {
    /// The endpoints of one emulated board named by `names`, on the heap (never freed: a board
    /// lives as long as the process). Each call builds new topics.
    pub fn leak(names: Names) -> Self {
        std::boxed::Box::leak(std::boxed::Box::new(Storage::new())).build(names)
    }
}
