//! Robot files: a robot's modules, what each is wired to, its base, drive train, battery and
//! surroundings, in TOML (format: `robots/README.md`).
//!
//! [`Robot::load`] parses and validates a file; every error names the file, the key (a path
//! such as `modules[2].wheel`) and what to do about it.

use std::fmt;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::base::BaseParams;
use crate::battery::{BatteryParams, Chemistry};
use crate::boards::{BoardKind, ModuleKind, MODULE_KINDS};
use crate::geometry::{Pose, Vec2};
use crate::hbridge::HBridgeParams;
use crate::imu_module::ImuSensor;
use crate::kinematics::Layout;
use crate::magnetic::{EarthField, Iron};
use crate::motor::{Gearbox, MotorParams};
use crate::obstacles::Obstacle;
use crate::ranger::RangerKind;
use crate::site::Site;

/// Where the format is documented (quoted in error messages).
const FORMAT_DOC: &str = "robots/README.md";

/// A robot file that cannot be used: which file, which key, what is wrong, what to do.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RobotError {
    /// The file.
    pub file: PathBuf,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// The key, as a path (`modules[2].wheel`); empty for the whole file.
    pub key: String,
    /// What is wrong.
    pub problem: String,
    /// What to do.
    pub fix: String,
}

impl fmt::Display for RobotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(l) = self.line {
            write!(f, ":{l}")?;
        }
        if !self.key.is_empty() {
            write!(f, ": {}", self.key)?;
        }
        write!(f, ": {}; {}", self.problem, self.fix)
    }
}

impl std::error::Error for RobotError {}

/// A module's 96-bit unique ID (the STM32 device ID), most significant byte first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Uid(pub [u8; 12]);

impl fmt::Display for Uid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.iter().try_for_each(|b| write!(f, "{b:02X}"))
    }
}

impl Uid {
    /// Parses 24 hex digits.
    pub fn parse(s: &str) -> Option<Uid> {
        if s.len() != 24 || !s.bytes().all(|b| b.is_ascii_hexdigit()) {
            return None;
        }
        let mut out = [0u8; 12];
        for (i, b) in out.iter_mut().enumerate() {
            *b = u8::from_str_radix(&s[2 * i..2 * i + 2], 16).ok()?;
        }
        Some(Uid(out))
    }
}

/// CAN bus settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BusSettings {
    /// Bit rate, bit/s (≤ 1 Mbit/s).
    pub bit_rate: u32,
    /// RTCAN cycle, µs.
    pub cycle_us: u32,
}

/// The base: wheel layout, mass properties, floor contact.
#[derive(Clone, Debug, PartialEq)]
pub struct BaseSpec {
    /// Wheel layout.
    pub layout: Layout,
    /// Mass, inertia, rolling resistance.
    pub params: BaseParams,
    /// Radius of the robot's footprint, m.
    pub footprint_radius_m: f64,
    /// Inertia of one wheel about its axle, kg·m².
    pub wheel_inertia_kg_m2: f64,
}

/// Every wheel's drive train (all wheels alike).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveSpec {
    /// Motor.
    pub motor: MotorParams,
    /// Gearbox between motor and wheel.
    pub gearbox: Gearbox,
    /// Encoder lines per motor revolution.
    pub encoder_cpr: u32,
    /// H-bridge and PWM.
    pub bridge: HBridgeParams,
}

/// The battery.
#[derive(Clone, Debug, PartialEq)]
pub struct BatterySpec {
    /// Its name (modules refer to it).
    pub name: String,
    /// Its constants.
    pub params: BatteryParams,
    /// State of charge at start, 0..1.
    pub initial_soc: f64,
}

/// A ranger on a proximity module.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RangerMount {
    /// Channel 0–3 (`PROX_CHn`).
    pub channel: u8,
    /// Sensor.
    pub kind: RangerKind,
    /// Pose on the base (beam along +x of this pose).
    pub mount: Pose,
    /// Whether its cable is plugged in at start.
    pub connected: bool,
}

/// What a module is wired to.
#[derive(Clone, Debug, PartialEq)]
pub enum Wiring {
    /// PSU: its input on the battery (its shunt carries its own input current; the motor
    /// drivers take their supply from the battery directly, as docs/bus.md requires), its
    /// output the bus.
    Psu {
        /// Battery name.
        battery: String,
        /// Modules' own consumption from the 5 V bus, A (rangers are added).
        bus_load_a: f64,
    },
    /// Motor controller driving one wheel's motor.
    Motor {
        /// Wheel index.
        wheel: usize,
        /// Whether its encoder counts down for positive motor rotation.
        encoder_inverted: bool,
    },
    /// Proximity module and its rangers.
    Proximity {
        /// Rangers by channel.
        rangers: Vec<RangerMount>,
    },
    /// Gateway: nothing in the world.
    Gateway,
    /// IMU module, mounted on the base, and the robot's iron around it.
    Imu {
        /// Its pose on the base (the sensor's x along the pose's heading, z up).
        mount: Pose,
        /// The robot's hard and soft iron at the module, in the base frame.
        iron: Iron,
        /// Sensors unplugged at start (`unplugged`).
        unplugged: Vec<ImuSensor>,
    },
    /// The module template (or a new module's stub model): nothing in the world.
    Template,
}

/// A parameter value as a robot file gives it (the emulator checks it against the module's
/// parameter table: name, type and range).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParamValue {
    /// `true` / `false`.
    Bool(bool),
    /// An integer.
    Int(i64),
    /// A number with a fraction.
    Float(f64),
}

/// One module on the bus.
#[derive(Clone, Debug, PartialEq)]
pub struct Module {
    /// Unique name.
    pub name: String,
    /// 96-bit unique ID.
    pub uid: Uid,
    /// What it is wired to.
    pub wiring: Wiring,
    /// Parameters stored in the module's flash before it boots (`[modules.params]`), by name.
    pub params: Vec<(String, ParamValue)>,
}

/// A velocity command the teleoperator sends from `at_s` on (`[[teleop]]`): what a user's
/// joystick or ROS would publish on `cmd_vel`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TeleopStep {
    /// From this time on, s.
    pub at_s: f64,
    /// Forward, m/s.
    pub vx: f64,
    /// Left, m/s.
    pub vy: f64,
    /// Counter-clockwise, rad/s.
    pub wz: f64,
}

impl Module {
    /// Its kind.
    pub fn kind(&self) -> BoardKind {
        match self.wiring {
            Wiring::Psu { .. } => BoardKind::Psu,
            Wiring::Motor { .. } => BoardKind::Motor,
            Wiring::Proximity { .. } => BoardKind::Proximity,
            Wiring::Gateway => BoardKind::Gateway,
            Wiring::Imu { .. } => BoardKind::Imu,
            Wiring::Template => BoardKind::Template,
        }
    }
}

/// A validated robot description.
#[derive(Clone, Debug, PartialEq)]
pub struct Robot {
    /// The file it came from.
    pub file: PathBuf,
    /// Robot name.
    pub name: String,
    /// Free text.
    pub description: String,
    /// Seed of every random draw in the world.
    pub seed: u64,
    /// Pose at start.
    pub initial_pose: Pose,
    /// CAN bus.
    pub bus: BusSettings,
    /// Base.
    pub base: BaseSpec,
    /// Drive trains.
    pub drive: DriveSpec,
    /// Battery.
    pub battery: BatterySpec,
    /// Obstacles.
    pub obstacles: Vec<Obstacle>,
    /// Modules, in file order.
    pub modules: Vec<Module>,
    /// Velocity commands over time, in time order.
    pub teleop: Vec<TeleopStep>,
    /// Which node runs the robot-level nodes (`r2p-app-base`), if any.
    pub base_controller: Option<BaseController>,
    /// Where on Earth the world's origin is (`[site]`; Milan by default).
    pub site: Site,
}

/// Where the base controller (`r2p-app-base`: inverse kinematics, obstacle avoidance,
/// odometry) runs: `[base] controller`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BaseController {
    /// On the gateway module of this index in [`Robot::modules`] (its image runs it: the
    /// default of a robot with a gateway and an omni base).
    Module(usize),
    /// On a computer on the bus (`"host"`: in the emulator, a node of the emulator's own, as a
    /// PC on a CAN adapter).
    Host,
}

/// The name `[base] controller` gives a computer on the bus.
pub const HOST_CONTROLLER: &str = "host";

// ----- The file as written -------------------------------------------------------------

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileDoc {
    robot: RobotSection,
    bus: BusSection,
    base: BaseSection,
    drive: DriveSection,
    battery: BatterySection,
    #[serde(default)]
    obstacles: Vec<ObstacleSection>,
    modules: Vec<ModuleSection>,
    #[serde(default)]
    teleop: Vec<TeleopSection>,
    site: Option<SiteSection>,
}

/// `[site]`: every key optional, Milan's value by default ([`Site::MILAN`]).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SiteSection {
    latitude_deg: Option<f64>,
    longitude_deg: Option<f64>,
    altitude_m: Option<f64>,
    geoid_separation_m: Option<f64>,
    field_intensity_ut: Option<f64>,
    field_inclination_deg: Option<f64>,
    field_declination_deg: Option<f64>,
    sea_level_pressure_pa: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TeleopSection {
    at_s: f64,
    #[serde(default)]
    vx: f64,
    #[serde(default)]
    vy: f64,
    #[serde(default)]
    wz: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RobotSection {
    name: String,
    #[serde(default)]
    description: String,
    seed: u64,
    #[serde(default)]
    initial_pose: PoseSection,
}

#[derive(Deserialize, Default, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct PoseSection {
    #[serde(default)]
    x_m: f64,
    #[serde(default)]
    y_m: f64,
    #[serde(default)]
    theta_deg: f64,
}

impl PoseSection {
    fn pose(self) -> Pose {
        Pose::new(self.x_m, self.y_m, crate::geometry::wrap_angle(self.theta_deg.to_radians()))
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BusSection {
    bit_rate: u32,
    cycle_us: u32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BaseSection {
    kind: String,
    mass_kg: f64,
    inertia_kg_m2: f64,
    footprint_radius_m: f64,
    wheel_radius_m: f64,
    wheel_inertia_kg_m2: f64,
    rolling_resistance: f64,
    wheel_distance_m: Option<f64>,
    wheel_angles_deg: Option<Vec<f64>>,
    track_m: Option<f64>,
    controller: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DriveSection {
    motor: String,
    gear_ratio: f64,
    gear_efficiency: f64,
    encoder_cpr: u32,
    pwm_hz: f64,
    dead_time_ns: f64,
    switch_resistance_ohm: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BatterySection {
    name: String,
    chemistry: String,
    cells: u32,
    capacity_ah: f64,
    internal_resistance_ohm: f64,
    initial_soc: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObstacleSection {
    kind: String,
    center: Option<[f64; 2]>,
    radius_m: Option<f64>,
    from: Option<[f64; 2]>,
    to: Option<[f64; 2]>,
    min: Option<[f64; 2]>,
    max: Option<[f64; 2]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ModuleSection {
    kind: String,
    name: String,
    uid: String,
    wheel: Option<usize>,
    encoder_inverted: Option<bool>,
    battery: Option<String>,
    bus_load_a: Option<f64>,
    rangers: Option<Vec<RangerSection>>,
    pose: Option<PoseSection>,
    hard_iron_ut: Option<[f64; 3]>,
    soft_iron: Option<[[f64; 3]; 3]>,
    unplugged: Option<Vec<String>>,
    #[serde(default)]
    params: std::collections::BTreeMap<String, toml::Value>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RangerSection {
    channel: u8,
    sensor: String,
    #[serde(default)]
    pose: PoseSection,
    #[serde(default = "yes")]
    connected: bool,
}

fn yes() -> bool {
    true
}

// ----- Errors ----------------------------------------------------------------------------

/// Builds errors for one file.
struct Ctx<'a> {
    file: &'a Path,
}

impl Ctx<'_> {
    fn err(
        &self,
        key: impl Into<String>,
        problem: impl Into<String>,
        fix: impl Into<String>,
    ) -> RobotError {
        RobotError {
            file: self.file.to_path_buf(),
            line: None,
            key: key.into(),
            problem: problem.into(),
            fix: fix.into(),
        }
    }

    /// Checks `ok`, else an error for a value out of its range.
    fn check(&self, ok: bool, key: &str, need: &str) -> Result<(), RobotError> {
        if ok {
            Ok(())
        } else {
            Err(self.err(key, format!("value out of range: must be {need}"), "correct the value"))
        }
    }
}

/// What to write for a missing key.
fn hint(key: &str) -> &'static str {
    match key {
        "uid" => "add it: the module's 96-bit unique ID as 24 hex digits, e.g. uid = \"0123456789ABCDEF01234567\"",
        "kind" => "add it: one of the kinds listed in robots/README.md",
        "name" => "add it: a name unique in this file",
        "seed" => "add it: any integer; the same seed gives the same noise",
        "modules" => "add [[modules]] tables: a robot needs at least a psu",
        _ => "add it (see robots/README.md for the format)",
    }
}

/// 1-based line of byte `offset` in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())].iter().filter(|&&b| b == b'\n').count() + 1
}

/// Turns a deserialisation error into a [`RobotError`].
fn decode_error(
    ctx: &Ctx<'_>,
    text: &str,
    e: serde_path_to_error::Error<toml::de::Error>,
) -> RobotError {
    let path = e.path().to_string();
    let inner = e.inner();
    let line = inner.span().map(|s| line_of(text, s.start));
    let msg = inner.message().trim().to_string();
    // The path ends at the table holding a missing key, and at an unknown key itself.
    let join = |k: &str| match path.as_str() {
        "" | "." => k.to_string(),
        p if p.ends_with(&format!(".{k}")) || p == k => p.to_string(),
        p => format!("{p}.{k}"),
    };
    let mut out =
        if let Some(k) = msg.strip_prefix("missing field `").and_then(|r| r.split('`').next()) {
            ctx.err(join(k), "missing key", hint(k))
        } else if let Some(rest) = msg.strip_prefix("unknown field `") {
            let k = rest.split('`').next().unwrap_or_default();
            let expected = rest.split_once(", expected ").map_or("", |x| x.1);
            ctx.err(
                join(k),
                "unknown key",
                format!("remove it or correct its spelling (expected {expected})"),
            )
        } else {
            let key = if path == "." { String::new() } else { path };
            ctx.err(key, msg, format!("see {FORMAT_DOC} for the format"))
        };
    out.line = line;
    out
}

// ----- Validation ------------------------------------------------------------------------

fn vec2(v: [f64; 2]) -> Vec2 {
    Vec2::new(v[0], v[1])
}

impl Robot {
    /// Reads and validates the robot file at `path`.
    pub fn load(path: impl AsRef<Path>) -> Result<Robot, RobotError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| RobotError {
            file: path.to_path_buf(),
            line: None,
            key: String::new(),
            problem: format!("cannot read the file: {e}"),
            fix: "check the path".into(),
        })?;
        Self::parse(&text, path)
    }

    /// Parses and validates `text`, naming it `file` in errors.
    pub fn parse(text: &str, file: impl AsRef<Path>) -> Result<Robot, RobotError> {
        let ctx = Ctx { file: file.as_ref() };
        let de = toml::de::Deserializer::parse(text).map_err(|e| {
            let mut r =
                ctx.err("", format!("not valid TOML: {}", e.message().trim()), "fix the syntax");
            r.line = e.span().map(|s| line_of(text, s.start));
            r
        })?;
        let doc: FileDoc =
            serde_path_to_error::deserialize(de).map_err(|e| decode_error(&ctx, text, e))?;
        validate(&ctx, doc)
    }

    /// The module called `name`.
    pub fn module(&self, name: &str) -> Option<&Module> {
        self.modules.iter().find(|m| m.name == name)
    }

    /// Number of wheels.
    pub fn wheel_count(&self) -> usize {
        match &self.base.layout {
            Layout::Omni { angles, .. } => angles.len(),
            Layout::Differential { .. } => 2,
        }
    }
}

fn validate(ctx: &Ctx<'_>, doc: FileDoc) -> Result<Robot, RobotError> {
    let r = &doc.robot;
    ctx.check(!r.name.trim().is_empty(), "robot.name", "a non-empty name")?;
    let b = &doc.bus;
    ctx.check(b.bit_rate > 0 && b.bit_rate <= 1_000_000, "bus.bit_rate", "1..=1000000 bit/s")?;
    ctx.check(b.cycle_us > 0, "bus.cycle_us", "a positive number of µs")?;
    let base = validate_base(ctx, &doc.base)?;
    let drive = validate_drive(ctx, &doc.drive)?;
    let battery = validate_battery(ctx, &doc.battery)?;
    let obstacles = doc
        .obstacles
        .iter()
        .enumerate()
        .map(|(i, o)| validate_obstacle(ctx, i, o))
        .collect::<Result<Vec<_>, _>>()?;
    let wheels = match &base.layout {
        Layout::Omni { angles, .. } => angles.len(),
        Layout::Differential { .. } => 2,
    };
    let mut modules: Vec<Module> = Vec::new();
    for (i, m) in doc.modules.iter().enumerate() {
        let module = validate_module(ctx, i, m, wheels, &battery.name)?;
        if let Some(j) = modules.iter().position(|o| o.name == module.name) {
            return Err(ctx.err(
                format!("modules[{i}].name"),
                format!("`{}` is already the name of modules[{j}]", module.name),
                "give every module its own name",
            ));
        }
        if let Some(j) = modules.iter().position(|o| o.uid == module.uid) {
            return Err(ctx.err(
                format!("modules[{i}].uid"),
                format!("{} is already the uid of modules[{j}]", module.uid),
                "every MCU has its own unique ID: copy the right one",
            ));
        }
        if let Wiring::Motor { wheel, .. } = module.wiring {
            if let Some(j) = modules
                .iter()
                .position(|o| matches!(o.wiring, Wiring::Motor { wheel: w, .. } if w == wheel))
            {
                return Err(ctx.err(
                    format!("modules[{i}].wheel"),
                    format!("wheel {wheel} is already driven by modules[{j}]"),
                    "give each motor module its own wheel",
                ));
            }
        }
        modules.push(module);
    }
    for w in 0..wheels {
        if !modules.iter().any(|m| matches!(m.wiring, Wiring::Motor { wheel, .. } if wheel == w)) {
            return Err(ctx.err(
                "modules",
                format!("wheel {w} has no motor module"),
                format!("add a [[modules]] with kind = \"motor\" and wheel = {w}"),
            ));
        }
    }
    let base_controller = validate_controller(ctx, &doc.base, &base, &modules)?;
    let site = doc.site.as_ref().map_or(Ok(Site::MILAN), |s| validate_site(ctx, s))?;
    let mut teleop = Vec::new();
    for (i, t) in doc.teleop.iter().enumerate() {
        let at = format!("teleop[{i}]");
        ctx.check(t.at_s.is_finite() && t.at_s >= 0.0, &format!("{at}.at_s"), "a time ≥ 0 s")?;
        if let Some(prev) = teleop.last().map(|p: &TeleopStep| p.at_s) {
            ctx.check(t.at_s > prev, &format!("{at}.at_s"), "times in increasing order")?;
        }
        for (k, v) in [("vx", t.vx), ("vy", t.vy), ("wz", t.wz)] {
            ctx.check(v.is_finite() && v.abs() <= 10.0, &format!("{at}.{k}"), "-10..=10")?;
        }
        teleop.push(TeleopStep { at_s: t.at_s, vx: t.vx, vy: t.vy, wz: t.wz });
    }
    let psus = modules.iter().filter(|m| m.kind() == BoardKind::Psu).count();
    if psus != 1 {
        return Err(ctx.err(
            "modules",
            format!("{psus} psu modules"),
            "a robot has exactly one psu module (it powers the bus and is the sync master)",
        ));
    }
    Ok(Robot {
        file: ctx.file.to_path_buf(),
        name: r.name.clone(),
        description: r.description.clone(),
        seed: r.seed,
        initial_pose: r.initial_pose.pose(),
        bus: BusSettings { bit_rate: b.bit_rate, cycle_us: b.cycle_us },
        base,
        drive,
        battery,
        obstacles,
        modules,
        teleop,
        base_controller,
        site,
    })
}

/// `[site]`: each key within what the Earth has (and the models handle), Milan's by default.
fn validate_site(ctx: &Ctx<'_>, s: &SiteSection) -> Result<Site, RobotError> {
    let d = Site::MILAN;
    let get = |v: Option<f64>, default: f64, key: &str, range: (f64, f64), need: &str| {
        let x = v.unwrap_or(default);
        ctx.check(x.is_finite() && (range.0..=range.1).contains(&x), &format!("site.{key}"), need)
            .map(|()| x)
    };
    let site = Site {
        latitude_deg: get(
            s.latitude_deg,
            d.latitude_deg,
            "latitude_deg",
            (-89.0, 89.0),
            "-89..=89 degrees (the local plane's longitude scale fails at the poles)",
        )?,
        longitude_deg: get(
            s.longitude_deg,
            d.longitude_deg,
            "longitude_deg",
            (-180.0, 180.0),
            "-180..=180 degrees",
        )?,
        altitude_m: get(
            s.altitude_m,
            d.altitude_m,
            "altitude_m",
            (-500.0, 9000.0),
            "-500..=9000 m above sea level (the standard atmosphere's troposphere)",
        )?,
        geoid_separation_m: get(
            s.geoid_separation_m,
            d.geoid_separation_m,
            "geoid_separation_m",
            (-110.0, 90.0),
            "-110..=90 m (the geoid's extremes)",
        )?,
        field: EarthField {
            intensity_ut: get(
                s.field_intensity_ut,
                d.field.intensity_ut,
                "field_intensity_ut",
                (1.0, 100.0),
                "1..=100 µT (the Earth's is 22-67 µT)",
            )?,
            inclination_deg: get(
                s.field_inclination_deg,
                d.field.inclination_deg,
                "field_inclination_deg",
                (-90.0, 90.0),
                "-90..=90 degrees (positive down)",
            )?,
            declination_deg: get(
                s.field_declination_deg,
                d.field.declination_deg,
                "field_declination_deg",
                (-180.0, 180.0),
                "-180..=180 degrees (positive east)",
            )?,
        },
        sea_level_pa: get(
            s.sea_level_pressure_pa,
            d.sea_level_pa,
            "sea_level_pressure_pa",
            (87_000.0, 108_500.0),
            "87000..=108500 Pa (the records of sea-level pressure)",
        )?,
    };
    Ok(site)
}

/// An IMU module's `hard_iron_ut`, `soft_iron` and `unplugged`.
fn validate_imu(
    ctx: &Ctx<'_>,
    i: usize,
    m: &ModuleSection,
) -> Result<(Iron, Vec<ImuSensor>), RobotError> {
    let key = |k: &str| format!("modules[{i}].{k}");
    let mut iron = Iron::NONE;
    if let Some(h) = m.hard_iron_ut {
        ctx.check(
            h.iter().all(|x| x.is_finite() && x.abs() <= 1600.0),
            &key("hard_iron_ut"),
            "three fields of -1600..=1600 µT (the LIS3MDL's widest full scale, ±16 gauss)",
        )?;
        iron.hard_ut = h;
    }
    if let Some(s) = m.soft_iron {
        ctx.check(
            s.iter().flatten().all(|x| x.is_finite() && x.abs() <= 10.0),
            &key("soft_iron"),
            "a 3 × 3 matrix of numbers within -10..=10 (rows: the base's x, y, z)",
        )?;
        let det = crate::linalg::det(&s);
        if det < 0.01 {
            return Err(ctx.err(
                key("soft_iron"),
                format!("determinant {det:.3}: iron bends and scales the field, it cannot mirror or flatten it"),
                "give a matrix near the identity, e.g. [[1.1, 0.05, 0.0], [0.05, 0.9, 0.0], [0.0, 0.0, 1.0]]",
            ));
        }
        iron.soft = s;
    }
    let mut unplugged = Vec::new();
    for (j, name) in m.unplugged.iter().flatten().enumerate() {
        let sensor = ImuSensor::from_name(name).ok_or_else(|| {
            let known: Vec<_> =
                ImuSensor::ALL.iter().map(|s| format!("\"{}\"", s.name())).collect();
            ctx.err(
                format!("modules[{i}].unplugged[{j}]"),
                format!("unknown sensor `{name}`"),
                format!("use one of {}", known.join(", ")),
            )
        })?;
        if unplugged.contains(&sensor) {
            return Err(ctx.err(
                format!("modules[{i}].unplugged[{j}]"),
                format!("`{name}` is listed twice"),
                "list each sensor once",
            ));
        }
        unplugged.push(sensor);
    }
    Ok((iron, unplugged))
}

/// `[base] controller`: a gateway module's name or `"host"`; by default the robot's gateway
/// when it has one and its base is one the controller drives (three omni wheels).
fn validate_controller(
    ctx: &Ctx<'_>,
    b: &BaseSection,
    base: &BaseSpec,
    modules: &[Module],
) -> Result<Option<BaseController>, RobotError> {
    let three_omni = matches!(&base.layout, Layout::Omni { angles, .. } if angles.len() == 3);
    let gateway = modules.iter().position(|m| m.kind() == BoardKind::Gateway);
    let Some(name) = &b.controller else {
        return Ok(gateway.filter(|_| three_omni).map(BaseController::Module));
    };
    let key = "base.controller";
    if !three_omni {
        return Err(ctx.err(
            key,
            "the base controller (r2p-app-base) drives three omni wheels",
            "remove it: drive this base's wheels from your own node",
        ));
    }
    if name == HOST_CONTROLLER {
        return Ok(Some(BaseController::Host));
    }
    let gateways: Vec<String> = modules
        .iter()
        .filter(|m| m.kind() == BoardKind::Gateway)
        .map(|m| format!("\"{}\"", m.name))
        .chain([format!("\"{HOST_CONTROLLER}\"")])
        .collect();
    let fix = format!("use {}", gateways.join(" or "));
    match modules.iter().position(|m| m.name == *name) {
        Some(i) if modules[i].kind() == BoardKind::Gateway => Ok(Some(BaseController::Module(i))),
        Some(_) => Err(ctx.err(
            key,
            format!(
                "module `{name}` cannot run the base controller: only the gateway's image has \
                 room for it (an F103 module's does not, docs/ros2.md)"
            ),
            fix,
        )),
        None => Err(ctx.err(key, format!("no module called `{name}`"), fix)),
    }
}

fn validate_base(ctx: &Ctx<'_>, b: &BaseSection) -> Result<BaseSpec, RobotError> {
    ctx.check(b.mass_kg > 0.0, "base.mass_kg", "positive")?;
    ctx.check(b.inertia_kg_m2 > 0.0, "base.inertia_kg_m2", "positive")?;
    ctx.check(b.footprint_radius_m > 0.0, "base.footprint_radius_m", "positive")?;
    ctx.check(b.wheel_radius_m > 0.0, "base.wheel_radius_m", "positive")?;
    ctx.check(b.wheel_inertia_kg_m2 >= 0.0, "base.wheel_inertia_kg_m2", "0 or more")?;
    ctx.check(b.rolling_resistance >= 0.0, "base.rolling_resistance", "0 or more")?;
    let misplaced = |key: &str, kind: &str| {
        ctx.err(format!("base.{key}"), format!("does not apply to a {kind} base"), "remove it")
    };
    let missing = |key: &str, kind: &str, what: &str| {
        ctx.err(format!("base.{key}"), "missing key", format!("a {kind} base needs {what}"))
    };
    let layout = match b.kind.as_str() {
        "omni" => {
            if b.track_m.is_some() {
                return Err(misplaced("track_m", "omni"));
            }
            let l = b.wheel_distance_m.ok_or_else(|| {
                missing("wheel_distance_m", "omni", "the distance from its centre to each wheel")
            })?;
            ctx.check(l > 0.0, "base.wheel_distance_m", "positive")?;
            let angles = b.wheel_angles_deg.clone().ok_or_else(|| {
                missing("wheel_angles_deg", "omni", "each wheel's angle, e.g. [60, 180, 300]")
            })?;
            ctx.check(angles.len() >= 3, "base.wheel_angles_deg", "at least 3 angles")?;
            // The drive directions must span the plane (and the wheels must not all be on one
            // diameter): the normal matrix of the Jacobian must be well conditioned.
            // Rows of the Jacobian, scaled by r and with ωz in units of L/r: (−sin α, cos α, 1).
            let mut n = [[0.0; 3]; 3];
            for a in angles.iter().map(|a| a.to_radians()) {
                let row = [-a.sin(), a.cos(), 1.0];
                for i in 0..3 {
                    for j in 0..3 {
                        n[i][j] += row[i] * row[j];
                    }
                }
            }
            let det = n[0][0] * (n[1][1] * n[2][2] - n[1][2] * n[2][1])
                - n[0][1] * (n[1][0] * n[2][2] - n[1][2] * n[2][0])
                + n[0][2] * (n[1][0] * n[2][1] - n[1][1] * n[2][0]);
            if det < 1e-6 {
                return Err(ctx.err(
                    "base.wheel_angles_deg",
                    "these wheel angles cannot move the base in every direction",
                    "spread the wheels around the base, e.g. [60, 180, 300]",
                ));
            }
            Layout::Omni {
                wheel_radius: b.wheel_radius_m,
                wheel_distance: l,
                angles: angles.iter().map(|a| a.to_radians()).collect(),
            }
        }
        "differential" => {
            if b.wheel_angles_deg.is_some() {
                return Err(misplaced("wheel_angles_deg", "differential"));
            }
            if b.wheel_distance_m.is_some() {
                return Err(misplaced("wheel_distance_m", "differential"));
            }
            let track = b.track_m.ok_or_else(|| {
                missing("track_m", "differential", "the distance between its wheels")
            })?;
            ctx.check(track > 0.0, "base.track_m", "positive")?;
            Layout::Differential { wheel_radius: b.wheel_radius_m, track }
        }
        other => {
            return Err(ctx.err(
                "base.kind",
                format!("unknown base kind `{other}`"),
                "use \"omni\" or \"differential\"",
            ))
        }
    };
    Ok(BaseSpec {
        layout,
        params: BaseParams {
            mass_kg: b.mass_kg,
            inertia_kg_m2: b.inertia_kg_m2,
            rolling_resistance: b.rolling_resistance,
            rolling_smoothing: 0.005,
        },
        footprint_radius_m: b.footprint_radius_m,
        wheel_inertia_kg_m2: b.wheel_inertia_kg_m2,
    })
}

fn validate_drive(ctx: &Ctx<'_>, d: &DriveSection) -> Result<DriveSpec, RobotError> {
    let motor = MotorParams::preset(&d.motor).ok_or_else(|| {
        let known: Vec<_> =
            MotorParams::PRESETS.iter().map(|p| format!("\"{}\"", p.name)).collect();
        ctx.err(
            "drive.motor",
            format!("unknown motor `{}`", d.motor),
            format!("use one of {}", known.join(", ")),
        )
    })?;
    ctx.check(d.gear_ratio > 0.0, "drive.gear_ratio", "positive")?;
    ctx.check(
        d.gear_efficiency > 0.0 && d.gear_efficiency <= 1.0,
        "drive.gear_efficiency",
        "in (0, 1]",
    )?;
    ctx.check(d.encoder_cpr > 0, "drive.encoder_cpr", "positive")?;
    ctx.check(d.pwm_hz > 0.0, "drive.pwm_hz", "positive")?;
    ctx.check(
        d.dead_time_ns >= 0.0 && d.dead_time_ns * 1e-9 < 0.5 / d.pwm_hz,
        "drive.dead_time_ns",
        "0 or more and under half a PWM period",
    )?;
    ctx.check(d.switch_resistance_ohm >= 0.0, "drive.switch_resistance_ohm", "0 or more")?;
    Ok(DriveSpec {
        motor,
        gearbox: Gearbox { ratio: d.gear_ratio, efficiency: d.gear_efficiency },
        encoder_cpr: d.encoder_cpr,
        bridge: HBridgeParams {
            pwm_hz: d.pwm_hz,
            dead_time_s: d.dead_time_ns * 1e-9,
            switch_resistance_ohm: d.switch_resistance_ohm,
            ..HBridgeParams::DEFAULT
        },
    })
}

fn validate_battery(ctx: &Ctx<'_>, b: &BatterySection) -> Result<BatterySpec, RobotError> {
    let chemistry = Chemistry::from_name(&b.chemistry).ok_or_else(|| {
        ctx.err(
            "battery.chemistry",
            format!("unknown chemistry `{}`", b.chemistry),
            "use \"lead-acid\" or \"lipo\"",
        )
    })?;
    ctx.check(!b.name.trim().is_empty(), "battery.name", "a non-empty name")?;
    ctx.check(b.cells > 0, "battery.cells", "positive")?;
    ctx.check(b.capacity_ah > 0.0, "battery.capacity_ah", "positive")?;
    ctx.check(b.internal_resistance_ohm >= 0.0, "battery.internal_resistance_ohm", "0 or more")?;
    ctx.check((0.0..=1.0).contains(&b.initial_soc), "battery.initial_soc", "between 0 and 1")?;
    Ok(BatterySpec {
        name: b.name.clone(),
        params: BatteryParams {
            chemistry,
            cells: b.cells,
            capacity_ah: b.capacity_ah,
            internal_resistance_ohm: b.internal_resistance_ohm,
        },
        initial_soc: b.initial_soc,
    })
}

fn validate_obstacle(ctx: &Ctx<'_>, i: usize, o: &ObstacleSection) -> Result<Obstacle, RobotError> {
    let key = |k: &str| format!("obstacles[{i}].{k}");
    let given = [
        ("center", o.center.is_some()),
        ("radius_m", o.radius_m.is_some()),
        ("from", o.from.is_some()),
        ("to", o.to.is_some()),
        ("min", o.min.is_some()),
        ("max", o.max.is_some()),
    ];
    let keys: &[&str] = match o.kind.as_str() {
        "circle" => &["center", "radius_m"],
        "wall" => &["from", "to"],
        "box" => &["min", "max"],
        other => {
            return Err(ctx.err(
                key("kind"),
                format!("unknown obstacle kind `{other}`"),
                "use \"circle\", \"wall\" or \"box\"",
            ))
        }
    };
    for (k, present) in given {
        if present && !keys.contains(&k) {
            return Err(ctx.err(
                key(k),
                format!("does not apply to a {}", o.kind),
                format!("a {} takes {}", o.kind, keys.join(" and ")),
            ));
        }
        if !present && keys.contains(&k) {
            return Err(ctx.err(
                key(k),
                "missing key",
                format!("a {} needs {}", o.kind, keys.join(" and ")),
            ));
        }
    }
    Ok(match o.kind.as_str() {
        "circle" => {
            let r = o.radius_m.unwrap_or_default();
            ctx.check(r > 0.0, &key("radius_m"), "positive")?;
            Obstacle::Circle { center: vec2(o.center.unwrap_or_default()), radius: r }
        }
        "wall" => {
            let (a, b) = (vec2(o.from.unwrap_or_default()), vec2(o.to.unwrap_or_default()));
            ctx.check((b - a).norm() > 0.0, &key("to"), "a point other than `from`")?;
            Obstacle::Wall { a, b }
        }
        _ => {
            let (lo, hi) = (vec2(o.min.unwrap_or_default()), vec2(o.max.unwrap_or_default()));
            ctx.check(lo.x < hi.x && lo.y < hi.y, &key("max"), "above and to the right of `min`")?;
            Obstacle::Box { min: lo, max: hi }
        }
    })
}

fn validate_module(
    ctx: &Ctx<'_>,
    i: usize,
    m: &ModuleSection,
    wheels: usize,
    battery: &str,
) -> Result<Module, RobotError> {
    let key = |k: &str| format!("modules[{i}].{k}");
    let module = ModuleKind::named(&m.kind).ok_or_else(|| {
        let known: Vec<_> = MODULE_KINDS.iter().map(|k| format!("\"{}\"", k.name)).collect();
        ctx.err(
            key("kind"),
            format!("unknown module kind `{}`", m.kind),
            format!(
                "use one of {} (the modules of modules.toml with an `emulator` entry)",
                known.join(", ")
            ),
        )
    })?;
    let kind =
        module.model().map_err(|e| ctx.err(key("kind"), e, "or give this module another kind"))?;
    ctx.check(!m.name.trim().is_empty(), &key("name"), "a non-empty name")?;
    let uid = Uid::parse(&m.uid).ok_or_else(|| {
        ctx.err(
            key("uid"),
            format!("`{}` is not a 96-bit unique ID", m.uid),
            "write exactly 24 hex digits, e.g. \"0123456789ABCDEF01234567\"",
        )
    })?;
    // Keys that belong to other kinds.
    let given = [
        ("wheel", m.wheel.is_some(), BoardKind::Motor),
        ("encoder_inverted", m.encoder_inverted.is_some(), BoardKind::Motor),
        ("battery", m.battery.is_some(), BoardKind::Psu),
        ("bus_load_a", m.bus_load_a.is_some(), BoardKind::Psu),
        ("rangers", m.rangers.is_some(), BoardKind::Proximity),
        ("pose", m.pose.is_some(), BoardKind::Imu),
        ("hard_iron_ut", m.hard_iron_ut.is_some(), BoardKind::Imu),
        ("soft_iron", m.soft_iron.is_some(), BoardKind::Imu),
        ("unplugged", m.unplugged.is_some(), BoardKind::Imu),
    ];
    for (k, present, owner) in given {
        if present && owner != kind {
            return Err(ctx.err(
                key(k),
                format!("does not apply to a {} module", kind.name()),
                format!("remove it (it belongs to {} modules)", owner.name()),
            ));
        }
    }
    let wiring = match kind {
        BoardKind::Psu => {
            let b = m.battery.clone().ok_or_else(|| {
                ctx.err(
                    key("battery"),
                    "missing key",
                    format!("a psu names its battery: battery = \"{battery}\""),
                )
            })?;
            if b != battery {
                return Err(ctx.err(
                    key("battery"),
                    format!("no battery named `{b}`"),
                    format!("use the [battery] table's name, \"{battery}\""),
                ));
            }
            let load = m.bus_load_a.unwrap_or(0.0);
            ctx.check((0.0..=4.0).contains(&load), &key("bus_load_a"), "0 to 4 A")?;
            Wiring::Psu { battery: b, bus_load_a: load }
        }
        BoardKind::Motor => {
            let wheel = m.wheel.ok_or_else(|| {
                ctx.err(
                    key("wheel"),
                    "missing key",
                    format!("a motor module names the wheel it drives: 0..{}", wheels - 1),
                )
            })?;
            ctx.check(
                wheel < wheels,
                &key("wheel"),
                &format!("a wheel index 0..{} (the base has {wheels})", wheels - 1),
            )?;
            Wiring::Motor { wheel, encoder_inverted: m.encoder_inverted.unwrap_or(false) }
        }
        BoardKind::Proximity => {
            let list = m.rangers.as_deref().unwrap_or_default();
            ctx.check(list.len() <= 4, &key("rangers"), "at most 4 rangers (channels 0–3)")?;
            let mut rangers: Vec<RangerMount> = Vec::new();
            for (j, r) in list.iter().enumerate() {
                let rk = |k: &str| format!("modules[{i}].rangers[{j}].{k}");
                ctx.check(r.channel < 4, &rk("channel"), "0, 1, 2 or 3")?;
                if rangers.iter().any(|o| o.channel == r.channel) {
                    return Err(ctx.err(
                        rk("channel"),
                        format!("channel {} is used twice", r.channel),
                        "give each ranger its own channel",
                    ));
                }
                let k = RangerKind::from_name(&r.sensor).ok_or_else(|| {
                    let known: Vec<_> =
                        RangerKind::ALL.iter().map(|k| format!("\"{}\"", k.name())).collect();
                    ctx.err(
                        rk("sensor"),
                        format!("unknown sensor `{}`", r.sensor),
                        format!("use one of {}", known.join(", ")),
                    )
                })?;
                rangers.push(RangerMount {
                    channel: r.channel,
                    kind: k,
                    mount: r.pose.pose(),
                    connected: r.connected,
                });
            }
            Wiring::Proximity { rangers }
        }
        BoardKind::Gateway => Wiring::Gateway,
        BoardKind::Template => Wiring::Template,
        BoardKind::Imu => {
            let (iron, unplugged) = validate_imu(ctx, i, m)?;
            Wiring::Imu { mount: m.pose.unwrap_or_default().pose(), iron, unplugged }
        }
    };
    let mut params = Vec::new();
    for (name, v) in &m.params {
        let value = match v {
            toml::Value::Boolean(b) => ParamValue::Bool(*b),
            toml::Value::Integer(n) => ParamValue::Int(*n),
            toml::Value::Float(f) => ParamValue::Float(*f),
            other => {
                return Err(ctx.err(
                    key(&format!("params.{name}")),
                    format!("a {} is not a parameter value", other.type_str()),
                    "give a boolean, an integer or a number",
                ))
            }
        };
        params.push((name.clone(), value));
    }
    Ok(Module { name: m.name.clone(), uid, wiring, params })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uid_parse_and_print() {
        let u = Uid::parse("0123456789abcdefFEDCBA98").unwrap();
        assert_eq!(u.0[0], 0x01);
        assert_eq!(u.0[11], 0x98);
        assert_eq!(u.to_string(), "0123456789ABCDEFFEDCBA98");
        assert_eq!(Uid::parse("0123"), None);
        assert_eq!(Uid::parse("0123456789abcdefFEDCBA9G"), None);
        assert_eq!(Uid::parse("0123456789abcdefFEDCBA9é"), None);
    }
}
