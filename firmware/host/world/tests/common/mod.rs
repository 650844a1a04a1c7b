//! Robots for the tests.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use r2p_world::{Robot, World};

/// robots/triskar2.toml.
pub fn triskar_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../robots/triskar2.toml")
}

/// The Triskar2 robot.
pub fn triskar() -> Robot {
    Robot::load(triskar_path()).unwrap()
}

/// The Triskar2 world.
pub fn triskar_world() -> World {
    World::from_robot(&triskar())
}

/// A small differential robot on a 6S LiPo in an empty room with one wall ahead.
pub const DIFF_ROBOT: &str = r#"
[robot]
name = "diffbot"
seed = 7

[bus]
bit_rate = 500_000
cycle_us = 10_000

[base]
kind = "differential"
mass_kg = 8.0
inertia_kg_m2 = 0.2
footprint_radius_m = 0.2
wheel_radius_m = 0.04
track_m = 0.3
wheel_inertia_kg_m2 = 1.0e-4
rolling_resistance = 0.02

[drive]
motor = "maxon-re35-24v"
gear_ratio = 15.0
gear_efficiency = 0.81
encoder_cpr = 500
pwm_hz = 20_000
dead_time_ns = 610
switch_resistance_ohm = 0.010

[battery]
name = "pack"
chemistry = "lipo"
cells = 6
capacity_ah = 5.0
internal_resistance_ohm = 0.03
initial_soc = 0.9

[[obstacles]]
kind = "wall"
from = [3.0, -3.0]
to = [3.0, 3.0]

[[modules]]
kind = "psu"
name = "psu"
uid = "000000000000000000000001"
battery = "pack"

[[modules]]
kind = "motor"
name = "left"
uid = "000000000000000000000002"
wheel = 0

[[modules]]
kind = "motor"
name = "right"
uid = "000000000000000000000003"
wheel = 1

[[modules]]
kind = "proximity"
name = "prox"
uid = "000000000000000000000004"

[[modules.rangers]]
channel = 0
sensor = "maxsonar-lv-ez"
pose = { x_m = 0.2, y_m = 0.0, theta_deg = 0.0 }
"#;

/// The differential robot.
pub fn diff() -> Robot {
    Robot::parse(DIFF_ROBOT, "diffbot.toml").unwrap()
}
