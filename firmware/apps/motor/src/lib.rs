//! The R2P DC motor controller's application: closed-loop control of a brushed DC motor
//! through an H-bridge, as the module's default firmware runs it (README.md lists its topics,
//! parameters, LEDs and faults).
//!
//! Sans-IO and deterministic: the board-support layer (the MCU image in
//! firmware/targets/f103/motor, or an emulated board) calls [`App::step`] every millisecond
//! with a [`Sample`] of raw readings and applies the [`Command`] it returns. Nothing here reads
//! a clock or touches hardware, so the same code runs on the module and on the host.
//!
//! - **Measurement** ([`encoder`], [`frontend`]): TIM3's 16-bit quadrature count extended to
//!   32 bits, scaled to output-shaft radians; speed from the count difference over the 5 ms
//!   speed-loop period, low-passed; current from the Hall sensor, its zero calibrated at
//!   start-up with the bridge off.
//! - **Control** ([`control`], [`pi`]): position (P) → speed (PI) at 200 Hz → current (PI) at
//!   1 kHz → duty, with anti-windup, the current limit on the current setpoint in every mode
//!   and a duty limit. Setpoints (`WheelSetpoint`) choose torque, speed or position.
//! - **Safety** ([`faults`]): setpoint watchdog (controlled stop, then brake), over-current
//!   trip, encoder loss, the driver's fault flag and a bad current-sensor zero; latched until a
//!   `FaultClear` command, published as `MotorFault` events and in `WheelState.faults`.
//! - **Bus** ([`endpoints`], [`names`], [`params`]): topics named by the `instance`
//!   parameter; parameters with ranges, refused out of range by the store.
//!
//! ```
//! use r2p_app_motor::{params, App, Endpoints, Names, Sample};
//! use r2p_node::RamParams;
//!
//! let params: &'static RamParams<{ params::COUNT }> =
//!     Box::leak(Box::new(RamParams::new(params::DEFAULTS)));
//! let mut app = App::new(Endpoints::leak(Names::from_params(params)), params);
//! let idle = Sample { current_adc: 2048, vmot_adc: 1862, ..Default::default() };
//! for ms in 0..100 {
//!     let cmd = app.step(ms * 1000, &idle);
//!     assert!(!cmd.bridge_enable, "no setpoint yet: the bridge stays off");
//! }
//! assert_eq!(app.current_zero(), Some(2048.0));
//! assert_eq!(app.names().state, "motor/state");
//! ```
#![no_std]
#![warn(missing_docs)]

#[cfg(feature = "std")]
extern crate std;

pub mod app;
pub mod control;
pub mod encoder;
pub mod endpoints;
pub mod faults;
pub mod frontend;
pub mod names;
pub mod params;
pub mod pi;
#[cfg(feature = "std")]
pub mod readme;

pub use app::{App, Command, Sample, Stats};
pub use control::Setpoint;
pub use endpoints::{Endpoints, Storage};
pub use faults::Faults;
pub use names::Names;
