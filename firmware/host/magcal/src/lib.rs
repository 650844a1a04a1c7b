//! The IMU magnetometer's calibration maths for `r2p imu calibrate` (issue 21), apart from the
//! command so that it is tested, and mutation-tested, on its own:
//!
//! - [`ellipsoid`]: the hard- and soft-iron fit (3-D ellipsoid, or the x/y ellipse of a robot
//!   that turns on the floor) and its quality figures;
//! - [`coverage`]: the headings (and elevations) the samples cover;
//! - [`rules`]: planar or full, the values written, when a result is refused;
//! - [`synthetic`]: samples of a known distortion, for tests.

pub mod coverage;
pub mod ellipsoid;
pub mod rules;
pub mod synthetic;
