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
//! Sans-IO: [`App::step`] every millisecond. On an emulated board the endpoints are built on
//! the heap ([`Endpoints::leak`], feature `std`).
#![no_std]
#![warn(missing_docs)]

#[cfg(any(test, feature = "std"))]
extern crate std;

pub mod app;
#[cfg(any(test, feature = "std"))]
pub mod endpoints;
pub mod kinematics;
pub mod params;

pub use app::App;
#[cfg(any(test, feature = "std"))]
pub use endpoints::Endpoints;
pub use kinematics::Omni3;
