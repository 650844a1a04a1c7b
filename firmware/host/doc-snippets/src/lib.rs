//! docs/middleware.md's Rust snippets, compiled. build.rs copies each ```rust block of the
//! document out (in order, `snippet!(N)`), and each is compiled below inside the context it
//! assumes: its imports, the node and bus it talks to, the helpers it calls. A snippet that no
//! longer compiles (an API renamed, an argument changed) fails the build of this crate, which
//! `scripts/lint` (make test's lint stage) builds; the error names the snippet's
//! `docs/middleware.md:LINE`. A new snippet needs a context here: the count is checked.
//!
//! Never run: the snippets loop forever on a module's bus.
#![allow(dead_code, unused_variables, unused_mut, unreachable_code, unused_must_use)]
// A snippet is a block of statements standing for a part of a program.
#![allow(clippy::unnecessary_operation, clippy::diverging_sub_expression)]

use embassy_futures::select::{select, Either};
use embassy_time::{Instant, Timer};
use r2p_middleware::{pool_size, Class, Msg, Publisher, Subscriber, Topic};
use r2p_node::{NoParams, Node, NodeConfig, NodeError, RemotePublisher, RemoteSubscriber};
use rtcan::CanController;

/// The document's snippet `n`, as a block.
macro_rules! snippet {
    ($n:literal) => {
        include!(concat!(env!("OUT_DIR"), "/snippet", $n, ".rs"))
    };
}

/// Contexts below, one per snippet of the document.
const CONTEXTS: usize = 7;
const _: () = assert!(
    include!(concat!(env!("OUT_DIR"), "/count.rs")) == CONTEXTS,
    "docs/middleware.md's ```rust blocks and this crate's contexts differ in number: give each \
     block a context here (or mark an illustration ```text)"
);

/// What `?` in a snippet converts to.
#[derive(Debug)]
enum Error {
    Topic(r2p_middleware::Error),
    Node(NodeError),
}

impl From<r2p_middleware::Error> for Error {
    fn from(e: r2p_middleware::Error) -> Self {
        Error::Topic(e)
    }
}

impl From<NodeError> for Error {
    fn from(e: NodeError) -> Self {
        Error::Node(e)
    }
}

/// A node as the module examples declare it.
type ModuleNode = Node<'static, 4, 4, 32, 4, 64>;

/// "Declaring a topic statically".
fn declaring_a_topic() -> Result<(), Error> {
    snippet!(0);
    Ok(())
}

/// "Wiring a module": the publishing side, on a node the module has built.
fn publishing_module(node: &mut ModuleNode) -> Result<(), Error> {
    snippet!(1);
    Ok(())
}

/// "Wiring a module": the subscribing side.
fn subscribing_module(node: &mut ModuleNode) -> Result<(), Error> {
    snippet!(2);
    Ok(())
}

/// The module's parameters (none here).
static PARAMS: NoParams = NoParams;

/// "Wiring a module": the node driven by a task, unslotted.
async fn driven_by_a_task(uid: [u8; 12], mut can: impl CanController) -> Result<(), Error> {
    snippet!(3);
    Ok(())
}

/// "Wiring a module": the node driven by the slot timer.
async fn driven_by_the_slot_timer(uid: [u8; 12], mut can: impl CanController) -> Result<(), Error> {
    snippet!(4);
    Ok(())
}

/// The paper's listings' topics.
mod listings {
    use super::*;

    #[derive(Clone, Copy)]
    pub struct Proximity {
        pub distance: f32,
    }

    #[derive(Clone, Copy)]
    pub struct VelocityCmd {
        pub setpoint: f32,
    }

    #[derive(Clone, Copy)]
    pub struct Velocity {
        pub setpoint: f32,
    }

    pub const THRESHOLD: f32 = 0.3;

    pub static PROXIMITY: Topic<'static, Proximity, { pool_size(&[4], 1) }, 1> =
        Topic::new("proximity", Proximity { distance: 0.0 });
    pub static PROXIMITY_PUB: Publisher<'static, Proximity> =
        Publisher::new(&PROXIMITY, Class::NonRealTime);
    pub static OBSTACLE: Topic<'static, Proximity, { pool_size(&[4], 1) }, 1> =
        Topic::new("obstacle", Proximity { distance: 0.0 });
    pub static OBSTACLE_PUB: Publisher<'static, Proximity> =
        Publisher::new(&OBSTACLE, Class::AsyncRealTime { deadline_us: 10_000 });
    pub static OBSTACLE_SUB: Subscriber<'static, Proximity, 4> = Subscriber::new();
    pub static VELOCITY_CMD: Topic<'static, VelocityCmd, { pool_size(&[2], 1) }, 1> =
        Topic::new("velocity_cmd", VelocityCmd { setpoint: 0.0 });
    pub static VELOCITY_CMD_SUB: Subscriber<'static, VelocityCmd, 2> = Subscriber::new();
    pub static VELOCITY: Topic<'static, Velocity, { pool_size(&[2], 1) }, 1> =
        Topic::new("velocity", Velocity { setpoint: 0.0 });
    pub static VELOCITY_PUB: Publisher<'static, Velocity> =
        Publisher::new(&VELOCITY, Class::SyncRealTime { period_us: 10_000 });

    pub async fn read_distance() -> f32 {
        0.5
    }

    pub fn avoid_collision(cmd: &Msg<'static, VelocityCmd>, obstacle: &Msg<'static, Proximity>) {}

    /// "Example: the paper's Listing 1".
    pub async fn listing_1() -> Result<(), Error> {
        snippet!(5);
        Ok(())
    }

    /// "Example": the subscriber side of Listing 2.
    pub async fn listing_2() -> Result<(), Error> {
        snippet!(6);
        Ok(())
    }
}
