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
//! items with `const` initialisers: [`endpoints!`](crate::endpoints!) places each one in a
//! `StaticCell` on the MCU (no heap, one board per image) and [`Endpoints::leak`] boxes them on
//! the host (any number of boards per process, none sharing a topic).
//!
//! Why SRT for the state: it feeds odometry and the robot's control loops, where a late value
//! is worth less than the next one; EDF sends it before NRT traffic (parameters, heartbeats),
//! and a value still queued after one period (10 ms at the default 100 Hz) is dropped and
//! counted instead of delaying the next. (HRT needs a single frame; `WheelState` takes two.)
//! The fault event is SRT with a shorter deadline: the most urgent thing the module says.

use r2p_middleware::{pool_size, Publisher, Subscriber, Topic};
use r2p_msgs::{FaultClear, MotorFault, WheelSetpoint, WheelState};
use r2p_node::{Node, NodeError, RemotePublisher, RemoteSubscriber};

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

/// `<name>/setpoint`: the bus's publisher and one local one (a kinematics node on this module).
pub type SetpointTopic<'a> = Topic<'a, WheelSetpoint, { pool_size(&[SETPOINT_QUEUE], 2) }, 1>;
/// `<name>/clear_faults`: the bus's publisher and one local one.
pub type ClearTopic<'a> = Topic<'a, FaultClear, { pool_size(&[CLEAR_QUEUE], 2) }, 1>;
/// `<name>/state`: the bus and one local subscriber.
pub type StateTopic<'a> =
    Topic<'a, WheelState, { pool_size(&[STATE_BUS_QUEUE, LOCAL_QUEUE], 1) }, 2>;
/// `<name>/fault`: the bus and one local subscriber.
pub type FaultTopic<'a> =
    Topic<'a, MotorFault, { pool_size(&[FAULT_BUS_QUEUE, LOCAL_QUEUE], 1) }, 2>;

/// Every object of the module's four topics (see the module documentation).
#[derive(Clone, Copy)]
pub struct Endpoints<'a> {
    /// The names they were built with.
    pub names: Names,
    /// Setpoints in.
    pub setpoint: &'a SetpointTopic<'a>,
    /// The node publishes setpoints from the bus through it.
    pub setpoint_in: &'a RemotePublisher<'a, WheelSetpoint>,
    /// The application's queue of setpoints.
    pub setpoint_sub: &'a Subscriber<'a, WheelSetpoint, SETPOINT_QUEUE>,
    /// Clear commands in.
    pub clear_faults: &'a ClearTopic<'a>,
    /// The node publishes clear commands from the bus through it.
    pub clear_in: &'a RemotePublisher<'a, FaultClear>,
    /// The application's queue of clear commands.
    pub clear_sub: &'a Subscriber<'a, FaultClear, CLEAR_QUEUE>,
    /// State out.
    pub state: &'a StateTopic<'a>,
    /// The application publishes the state through it.
    pub state_pub: &'a Publisher<'a, WheelState>,
    /// Takes the state to the bus.
    pub state_out: &'a RemoteSubscriber<'a, WheelState, STATE_BUS_QUEUE>,
    /// Fault events out.
    pub fault: &'a FaultTopic<'a>,
    /// The application publishes fault events through it.
    pub fault_pub: &'a Publisher<'a, MotorFault>,
    /// Takes fault events to the bus.
    pub fault_out: &'a RemoteSubscriber<'a, MotorFault, FAULT_BUS_QUEUE>,
}

/// Builds a board's endpoints, placing each object with `$place!(Type, value)` (a macro giving
/// a `&'static Type`), advertises the publishers and subscribes the subscribers.
#[doc(hidden)]
#[macro_export]
macro_rules! __endpoints {
    ($names:expr, $place:ident) => {{
        use $crate::__private as p;
        let names: $crate::Names = $names;
        let setpoint = $crate::$place!(
            $crate::endpoints::SetpointTopic<'static>,
            p::Topic::new(names.setpoint, p::WheelSetpoint { mode: 0, value: 0.0 })
        );
        let setpoint_pub = $crate::$place!(
            p::Publisher<'static, p::WheelSetpoint>,
            p::Publisher::new(setpoint, p::Class::NonRealTime)
        );
        let setpoint_in = $crate::$place!(
            p::RemotePublisher<'static, p::WheelSetpoint>,
            p::RemotePublisher::new(setpoint_pub, setpoint)
        );
        let setpoint_sub = $crate::$place!(
            p::Subscriber<'static, p::WheelSetpoint, { $crate::endpoints::SETPOINT_QUEUE }>,
            p::Subscriber::new()
        );
        let clear_faults = $crate::$place!(
            $crate::endpoints::ClearTopic<'static>,
            p::Topic::new(names.clear_faults, p::FaultClear { mask: 0 })
        );
        let clear_pub = $crate::$place!(
            p::Publisher<'static, p::FaultClear>,
            p::Publisher::new(clear_faults, p::Class::NonRealTime)
        );
        let clear_in = $crate::$place!(
            p::RemotePublisher<'static, p::FaultClear>,
            p::RemotePublisher::new(clear_pub, clear_faults)
        );
        let clear_sub = $crate::$place!(
            p::Subscriber<'static, p::FaultClear, { $crate::endpoints::CLEAR_QUEUE }>,
            p::Subscriber::new()
        );
        let state = $crate::$place!(
            $crate::endpoints::StateTopic<'static>,
            p::Topic::new(names.state, p::WheelState::default())
        );
        let state_pub = $crate::$place!(
            p::Publisher<'static, p::WheelState>,
            p::Publisher::new(
                state,
                p::Class::AsyncRealTime { deadline_us: $crate::endpoints::STATE_DEADLINE_US }
            )
        );
        let state_out = $crate::$place!(
            p::RemoteSubscriber<'static, p::WheelState, { $crate::endpoints::STATE_BUS_QUEUE }>,
            p::RemoteSubscriber::new(state_pub)
        );
        let fault = $crate::$place!(
            $crate::endpoints::FaultTopic<'static>,
            p::Topic::new(names.fault, p::MotorFault::default())
        );
        let fault_pub = $crate::$place!(
            p::Publisher<'static, p::MotorFault>,
            p::Publisher::new(
                fault,
                p::Class::AsyncRealTime { deadline_us: $crate::endpoints::FAULT_DEADLINE_US }
            )
        );
        let fault_out = $crate::$place!(
            p::RemoteSubscriber<'static, p::MotorFault, { $crate::endpoints::FAULT_BUS_QUEUE }>,
            p::RemoteSubscriber::new(fault_pub)
        );
        let endpoints = $crate::Endpoints {
            names,
            setpoint,
            setpoint_in,
            setpoint_sub,
            clear_faults,
            clear_in,
            clear_sub,
            state,
            state_pub,
            state_out,
            fault,
            fault_pub,
            fault_out,
        };
        // Sized for exactly these endpoints (tested): a failure here is a bug, found at boot.
        endpoints
            .connect(setpoint_pub, clear_pub)
            .expect("the motor's topics are sized for their endpoints");
        endpoints
    }};
}

/// The endpoints of the board named by `names` (a [`Names`]), in `StaticCell`s: for an MCU
/// image, which has one board. Evaluates to `Endpoints<'static>`; panics if evaluated twice.
///
/// ```ignore
/// let names = r2p_app_motor::Names::from_params(&PARAMS);
/// let app = r2p_app_motor::App::new(r2p_app_motor::endpoints!(names), &PARAMS);
/// ```
#[macro_export]
macro_rules! endpoints {
    ($names:expr) => {
        $crate::__endpoints!($names, __place_static)
    };
}

/// Places `$e` of type `$ty` in a `StaticCell` of its own.
#[doc(hidden)]
#[macro_export]
macro_rules! __place_static {
    ($ty:ty, $e:expr) => {{
        static CELL: $crate::__private::StaticCell<$ty> = $crate::__private::StaticCell::new();
        let placed: &'static $ty = CELL.init($e);
        placed
    }};
}

/// Places `$e` of type `$ty` on the heap, for good.
#[cfg(feature = "std")]
#[doc(hidden)]
#[macro_export]
macro_rules! __place_leak {
    ($ty:ty, $e:expr) => {{
        let placed: &'static $ty = $crate::__private::Box::leak($crate::__private::Box::new($e));
        placed
    }};
}

impl<'a> Endpoints<'a> {
    /// Advertises the publishers (the application's and the bus's, `setpoint_pub` and
    /// `clear_pub`) and subscribes the subscribers.
    #[doc(hidden)]
    pub fn connect(
        &self,
        setpoint_pub: &'a Publisher<'a, WheelSetpoint>,
        clear_pub: &'a Publisher<'a, FaultClear>,
    ) -> Result<(), r2p_middleware::Error> {
        self.setpoint.advertise(setpoint_pub)?;
        self.setpoint.subscribe(self.setpoint_sub)?;
        self.clear_faults.advertise(clear_pub)?;
        self.clear_faults.subscribe(self.clear_sub)?;
        self.state.advertise(self.state_pub)?;
        self.state.subscribe(self.state_out)?;
        self.fault.advertise(self.fault_pub)?;
        self.fault.subscribe(self.fault_out)
    }

    /// Exports `state` and `fault` and imports `setpoint` and `clear_faults` on `node` (what
    /// [`App::register`](crate::App::register) does; usable where the node and the application
    /// are built in different tasks).
    pub fn register<
        const E: usize,
        const I: usize,
        const T: usize,
        const R: usize,
        const B: usize,
    >(
        &self,
        node: &mut Node<'a, E, I, T, R, B>,
    ) -> Result<(), NodeError> {
        node.export(self.state_out)?;
        node.export(self.fault_out)?;
        node.import(self.setpoint_in)?;
        node.import(self.clear_in)?;
        Ok(())
    }
}

#[cfg(feature = "std")]
impl Endpoints<'static> {
    /// The endpoints of one emulated board named by `names`, on the heap (never freed: a board
    /// lives as long as the process). Each call builds new topics.
    pub fn leak(names: Names) -> Self {
        crate::__endpoints!(names, __place_leak)
    }
}
