//! Deterministic physical model of an R2P robot, feeding the simulated peripherals of
//! emulated boards: brushed DC motors behind H-bridges with encoders and Hall current
//! sensors, a wheeled base (three-wheel omni or differential) with its rigid-body dynamics, a
//! battery discharging under the motors' load, the PSU's 5 V bus, and IR/ultrasonic rangers
//! seeing 2-D obstacles through their datasheet transfer curves; an IMU feeling the base's
//! motion ([`imu`]), the Earth's magnetic field with the robot's iron ([`magnetic`]), the
//! air pressure at its altitude ([`pressure`]), a GNSS receiver's fixes around the robot's
//! origin ([`gnss`]) at the robot file's site ([`site`]), the four wired to each IMU module
//! ([`imu_module`]), and a single-point LiDAR ranging the obstacles
//! ([`lidar`]), which the emulator's I2C/SPI/UART device models encode.
//!
//! A [`Robot`] is read from a robot file (`robots/*.toml`, format in `robots/README.md`);
//! [`World::from_robot`] builds its world; [`World::advance_ns`] steps it in virtual time;
//! boards read and drive it by the signal names of their HAL board files
//! ([`World::read_adc`], [`World::read_counter`], [`World::set_pwm`], [`World::set_output`],
//! [`World::read_input`]). Same robot file, seed and calls → same state, bit for bit: no
//! clock is read and all noise comes from seeded streams.
//!
//! One model per module, each documenting its equations, integrator and assumptions, each
//! with tests against analytic results. The rangers' datasheet curves are
//! `r2p_drivers::rangers`, the same ones the proximity firmware inverts.

pub mod adc;
pub mod base;
pub mod battery;
pub mod boards;
pub mod current_sensor;
pub mod encoder;
pub mod frontends;
pub mod geometry;
pub mod gnss;
pub mod hbridge;
pub mod imu;
pub mod imu_module;
pub mod kinematics;
pub mod lidar;
mod linalg;
pub mod magnetic;
pub mod motor;
pub mod motor_bus;
pub mod noise;
pub mod obstacles;
pub mod pressure;
pub mod psu;
pub mod ranger;
pub mod robot_file;
pub mod sensor_switch;
pub mod site;
pub mod world;

pub use boards::{BoardKind, ModuleKind, SignalKind, MODULE_KINDS};
pub use geometry::{Pose, Twist, Vec2};
pub use robot_file::{Robot, RobotError, Uid};
pub use world::{IoError, World};
