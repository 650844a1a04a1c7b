//! The robot-level nodes of the paper's Triskar2 (§5), as one application: a user's node built
//! on the R2P core, the way a lab writes its own.
//!
//! - **Inverse kinematics** at 100 Hz: `cmd_vel` ([`Twist2D`](r2p_msgs::Twist2D)) → one speed
//!   setpoint per wheel, published hard real time (`motor<i>/setpoint`, in a TDMA slot).
//! - **Obstacle avoidance** (the paper's Listing 2): an `obstacle` event removes the part of the
//!   commanded velocity that heads towards the obstacle, for a hold time.
//! - **Odometry**: forward kinematics of the wheels' measured speeds (`motor<i>/state`),
//!   integrated into a pose, published as `odom`.
//!
//! Sans-IO: [`App::step`] every millisecond. The topics' names come from parameters
//! ([`Names`]: which motor controller drives each wheel, which proximity module watches), so
//! the endpoints are made at boot: in a `static` [`Storage`] on an MCU (the gateway's image),
//! on the heap on an emulated board ([`Endpoints::leak`], feature `std`). Any node may run
//! it: the one whose board has room (docs/ros2.md, "Where the base controller runs").
#![no_std]
#![warn(missing_docs)]

#[cfg(any(test, feature = "std"))]
extern crate std;

pub mod app;
pub mod endpoints;
pub mod kinematics;
pub mod names;
pub mod params;

pub use app::App;
pub use endpoints::{Endpoints, Storage};
pub use kinematics::Omni3;
pub use names::Names;
