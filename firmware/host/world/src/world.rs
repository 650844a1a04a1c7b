//! The world: a robot's physics and its boards' view of it, stepped in virtual time.
//!
//! [`World::advance_ns`] (or [`World::step`]) runs fixed sub-steps of at most
//! [`DEFAULT_SUBSTEP_NS`] (50 µs) with the inputs held (zero-order hold, as timer compare
//! registers and GPIOs hold them between the firmware's writes). Each sub-step:
//!
//! 1. the battery's terminal voltage from the loads at the start of the sub-step (motor
//!    bridges and boards through their leads, and the PSU's converter as a constant-power
//!    load), and the motor boards' supply VMOT ([`crate::motor_bus`]: the battery's, or its
//!    bulk capacitors' while a supply that cannot sink blocks braking current);
//! 2. each H-bridge's terminal voltage, each winding current (exact exponential step);
//! 3. the coupled mechanics of base, wheels and rotors ([`Base::accelerate`]), the pose;
//! 4. the charge drawn from the battery, and the energy books.
//!
//! After the sub-steps, the encoders follow their shafts and the rangers take the
//! measurements that fell due. Inputs take effect at the next sub-step; outputs (ADC counts,
//! counters, levels) are those at the end of the last one. ADC reads draw noise from a
//! stream per signal, so one board reading more often leaves the others' noise untouched.
//! Nothing reads a clock, no output depends on hash order: the same robot file, seed and
//! sequence of calls give the same state ([`World::state_digest`]).

use std::fmt;

use crate::base::{Acceleration, Base};
use crate::battery::Battery;
use crate::boards::{BoardKind, SignalKind};
use crate::encoder::Encoder;
use crate::frontends;
use crate::geometry::{Pose, Twist};
use crate::gnss::GnssFix;
use crate::hbridge::{HBridge, HBridgeInput};
use crate::imu::{Imu, ImuReading};
use crate::imu_module::{GnssAntenna, ImuModule, ImuSensor};
use crate::kinematics::Kinematics;
use crate::linalg::{self, Mat3};
use crate::magnetic::MagSample;
use crate::motor::{Gearbox, Motor, Terminal};
use crate::motor_bus::{MotorBus, MotorSupply};
use crate::noise::Noise;
use crate::obstacles::Obstacles;
use crate::pressure::BaroSample;
use crate::psu::{supply_voltage, Psu, PsuParams};
use crate::ranger::Ranger;
use crate::robot_file::{Robot, Uid, Wiring};
use crate::sensor_switch::SensorSwitch;
use crate::site::Site;

/// Longest sub-step, ns: 50 µs, one PWM period. The electrical step is exact for any length
/// and the coupled mechanics' fastest pole is ~20 s⁻¹ (see `motor.rs`), so this costs
/// ~0.1 % of accuracy in transients; halving it halves that (the energy test shows it).
pub const DEFAULT_SUBSTEP_NS: u64 = 50_000;

pub use crate::motor_bus::DRIVER_UVLO_V;

/// Up to this many wheels the inverse mass matrices are cached (2^n of them).
const MASS_CACHE_WHEELS: usize = 8;

/// Noise stream numbers: per board signal, per ranger measurement, per ranger phase.
const STREAM_BOARD: u64 = 1;
const STREAM_RANGER: u64 = 10_000;
const STREAM_PHASE: u64 = 20_000;
// IMU modules' devices: streams from 30 000 (crate::imu_module).

/// A wheel and its drive train.
#[derive(Clone, Debug)]
struct Wheel {
    motor: Motor,
    gearbox: Gearbox,
    bridge: HBridge,
    encoder: Encoder,
    fault_injected: bool,
    wheel_inertia: f64,
    angle: f64,
    speed: f64,
    load_torque: f64,
    motoring: bool,
    supply_current: f64,
}

/// What a board is connected to.
#[derive(Clone, Debug)]
enum Link {
    Psu,
    Motor { wheel: usize },
    Proximity { channels: [Option<usize>; 4], switch: SensorSwitch },
    Gateway,
    Imu { imu: usize },
    Template,
}

#[derive(Clone, Debug)]
struct Board {
    name: String,
    kind: BoardKind,
    uid: Uid,
    link: Link,
    /// One stream per signal of the kind's table.
    noise: Vec<Noise>,
}

/// A board as the world knows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BoardInfo<'a> {
    /// Module name.
    pub name: &'a str,
    /// Module kind.
    pub kind: BoardKind,
    /// 96-bit unique ID.
    pub uid: Uid,
}

/// A wheel's drive train at the end of the last step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelState {
    /// Winding current, A.
    pub motor_current: f64,
    /// Motor shaft speed, rad/s.
    pub motor_speed: f64,
    /// Motor shaft angle, rad (unwrapped).
    pub motor_angle: f64,
    /// Wheel speed, rad/s.
    pub wheel_speed: f64,
    /// Wheel angle, rad (unwrapped).
    pub wheel_angle: f64,
    /// Load torque at the motor shaft: the motor's torque not spent on its own rotor, i.e.
    /// what the gearbox passes on to the wheel and the base, N·m.
    pub load_torque: f64,
    /// Current drawn by the bridge from the supply, A (average of the last sub-step).
    pub supply_current: f64,
    /// Encoder timer register.
    pub encoder_count: u16,
    /// H-bridge inputs.
    pub bridge: HBridgeInput,
    /// Whether the driver is faulted (its outputs off).
    pub driver_fault: bool,
}

/// Energy and charge flows since the start, for conservation checks. Every term is ≥ 0
/// except `chemical_j` (negative while charging).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EnergyLedger {
    /// Drawn from the battery's open-circuit source, ∫OCV·I dt, J.
    pub chemical_j: f64,
    /// Lost in the battery's internal resistance, J.
    pub battery_loss_j: f64,
    /// Taken by the PSU's converter (bus load and conversion loss), J.
    pub bus_j: f64,
    /// Lost in windings and bridge switches (I²R), J.
    pub conduction_loss_j: f64,
    /// Lost in bridge diodes while coasting, and in a motor supply's diode, J.
    pub diode_loss_j: f64,
    /// Taken by the motor boards' own circuits from VMOT (gate driver supply, dividers), J.
    pub motor_boards_j: f64,
    /// Lost to motor friction, J.
    pub friction_loss_j: f64,
    /// Lost in gearboxes, J.
    pub gear_loss_j: f64,
    /// Lost to rolling resistance, J.
    pub rolling_loss_j: f64,
    /// Charge drawn by the motor boards' leads (bridges, the boards' own circuits, their bulk
    /// capacitors), C.
    pub motor_charge_c: f64,
    /// Charge drawn by the PSU's converter, C.
    pub bus_charge_c: f64,
}

impl EnergyLedger {
    /// Sum of the losses and the bus's consumption, J.
    pub fn spent_j(&self) -> f64 {
        self.battery_loss_j
            + self.bus_j
            + self.conduction_loss_j
            + self.diode_loss_j
            + self.motor_boards_j
            + self.friction_loss_j
            + self.gear_loss_j
            + self.rolling_loss_j
    }
}

/// A board I/O request the world cannot serve.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum IoError {
    /// No board of that name.
    UnknownBoard {
        /// The name asked for.
        board: String,
        /// The boards there are.
        known: Vec<String>,
    },
    /// The board has no such signal of that kind.
    UnknownSignal {
        /// Board name.
        board: String,
        /// Its kind.
        kind: BoardKind,
        /// The signal asked for.
        signal: String,
        /// What it was asked as.
        wanted: SignalKind,
        /// The board's signals of that kind.
        known: Vec<&'static str>,
    },
    /// The request does not apply to this board or value.
    Invalid {
        /// Board name.
        board: String,
        /// What is wrong.
        problem: String,
    },
}

impl fmt::Display for IoError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            IoError::UnknownBoard { board, known } => {
                write!(f, "no board `{board}` in this world (boards: {})", known.join(", "))
            }
            IoError::UnknownSignal { board, kind, signal, wanted, known } => {
                let list = if known.is_empty() { "none".to_string() } else { known.join(", ") };
                write!(
                    f,
                    "board `{board}` ({}) has no {} `{signal}` ({}s: {list})",
                    kind.name(),
                    wanted.describe(),
                    wanted.describe()
                )
            }
            IoError::Invalid { board, problem } => write!(f, "board `{board}`: {problem}"),
        }
    }
}

impl std::error::Error for IoError {}

/// A robot's physics and its boards' peripherals. See the module documentation.
#[derive(Clone, Debug)]
pub struct World {
    time_ns: u64,
    substep_ns: u64,
    kin: Kinematics,
    base: Base,
    pose: Pose,
    q: [f64; 3],
    /// q̇ of the last sub-step (what an accelerometer on the base feels).
    q_dot: [f64; 3],
    wheels: Vec<Wheel>,
    battery: Battery,
    supply_v: f64,
    /// The motor boards' supply: their leads, bulk capacitors and own draw.
    motor_bus: MotorBus,
    /// The PSU's input current from the battery, A (what its shunt measures).
    psu_input_a: f64,
    psu: Option<Psu>,
    bus_base_load_a: f64,
    rangers: Vec<Ranger>,
    ranger_noise: Vec<Noise>,
    imus: Vec<ImuModule>,
    site: Site,
    obstacles: Obstacles,
    boards: Vec<Board>,
    ledger: EnergyLedger,
    stored_at_start_j: f64,
    /// Per-wheel torques and inertias of a sub-step (kept to avoid allocating per step).
    scratch: (Vec<f64>, Vec<f64>),
    /// Inverse mass matrices by which gearboxes are motoring (bit k: wheel k), computed
    /// when first needed: the mass matrix depends only on that.
    mass_inv: Vec<Option<Mat3>>,
}

impl World {
    /// The world of `robot`, at rest at its initial pose, at time 0.
    pub fn from_robot(robot: &Robot) -> World {
        let kin = Kinematics::new(robot.base.layout.clone());
        let base = Base::new(robot.base.params, &kin);
        let d = &robot.drive;
        let mut wheels: Vec<Wheel> = (0..kin.wheel_count())
            .map(|_| Wheel {
                motor: Motor::new(d.motor),
                gearbox: d.gearbox,
                bridge: HBridge::new(d.bridge),
                encoder: Encoder::new(d.encoder_cpr, 0.0),
                fault_injected: false,
                wheel_inertia: robot.base.wheel_inertia_kg_m2,
                angle: 0.0,
                speed: 0.0,
                load_torque: 0.0,
                motoring: true,
                supply_current: 0.0,
            })
            .collect();
        let battery = Battery::new(robot.battery.params, robot.battery.initial_soc);
        let mut psu = None;
        let mut bus_base_load_a = 0.0;
        let mut rangers = Vec::new();
        let mut ranger_noise = Vec::new();
        let mut imus = Vec::new();
        let mut boards = Vec::new();
        for (bi, m) in robot.modules.iter().enumerate() {
            let kind = m.kind();
            let link = match &m.wiring {
                Wiring::Psu { bus_load_a, .. } => {
                    psu = Some(Psu::new(PsuParams::R2P));
                    bus_base_load_a = *bus_load_a;
                    Link::Psu
                }
                Wiring::Motor { wheel, encoder_inverted } => {
                    wheels[*wheel].encoder.inverted = *encoder_inverted;
                    Link::Motor { wheel: *wheel }
                }
                Wiring::Proximity { rangers: mounts } => {
                    let mut channels = [None; 4];
                    for r in mounts {
                        let i = rangers.len() as u64;
                        let first =
                            Noise::new(robot.seed, STREAM_PHASE + i).uniform() * r.kind.period_s();
                        let mut ranger = Ranger::new(r.kind, r.mount, first);
                        ranger.set_connected(r.connected);
                        channels[usize::from(r.channel)] = Some(rangers.len());
                        rangers.push(ranger);
                        ranger_noise.push(Noise::new(robot.seed, STREAM_RANGER + i));
                    }
                    // settled as the rangers start: powered, from a bus that is up
                    let demand: f64 = mounts
                        .iter()
                        .filter(|r| r.connected)
                        .map(|r| r.kind.supply_current_a())
                        .sum();
                    let mut switch = SensorSwitch::default();
                    switch.settle(demand, true);
                    Link::Proximity { channels, switch }
                }
                Wiring::Gateway => Link::Gateway,
                Wiring::Template => Link::Template,
                Wiring::Imu { mount, iron, unplugged } => {
                    let i = imus.len();
                    imus.push(ImuModule::new(*mount, *iron, unplugged, &robot.site, robot.seed, i));
                    Link::Imu { imu: i }
                }
            };
            let noise = (0..kind.signals().len())
                .map(|s| Noise::new(robot.seed, STREAM_BOARD + 64 * bi as u64 + s as u64))
                .collect();
            boards.push(Board { name: m.name.clone(), kind, uid: m.uid, link, noise });
        }
        let supply_v = battery.ocv();
        let motor_boards = boards.iter().filter(|b| matches!(b.link, Link::Motor { .. })).count();
        let mut w = World {
            time_ns: 0,
            substep_ns: DEFAULT_SUBSTEP_NS,
            kin,
            base,
            pose: robot.initial_pose,
            q: [0.0; 3],
            q_dot: [0.0; 3],
            wheels: std::mem::take(&mut wheels),
            battery,
            supply_v,
            motor_bus: MotorBus::new(motor_boards, supply_v),
            psu_input_a: 0.0,
            psu,
            bus_base_load_a,
            rangers,
            ranger_noise,
            imus,
            site: robot.site,
            obstacles: Obstacles::new(robot.obstacles.clone()),
            boards,
            ledger: EnergyLedger::default(),
            stored_at_start_j: 0.0,
            scratch: (Vec::new(), Vec::new()),
            mass_inv: Vec::new(),
        };
        // The sensors have been running before time 0: each starts with a measurement.
        for (r, n) in w.rangers.iter_mut().zip(&mut w.ranger_noise) {
            r.prime(&w.pose, &w.obstacles, n);
        }
        w.stored_at_start_j = w.stored_energy_j();
        w
    }

    // ----- Time ------------------------------------------------------------------------

    /// Virtual time, ns.
    pub fn time_ns(&self) -> u64 {
        self.time_ns
    }

    /// Virtual time, s.
    pub fn time_s(&self) -> f64 {
        self.time_ns as f64 * 1e-9
    }

    /// Sets the longest sub-step (ns, ≥ 1); the default is [`DEFAULT_SUBSTEP_NS`].
    pub fn set_substep_ns(&mut self, ns: u64) {
        self.substep_ns = ns.max(1);
    }

    /// Advances by `dt_s` seconds (rounded to the nanosecond).
    pub fn step(&mut self, dt_s: f64) {
        self.advance_ns((dt_s * 1e9).round().max(0.0) as u64);
    }

    /// Advances to virtual time `t_ns` (no-op if already there or past).
    pub fn advance_to_ns(&mut self, t_ns: u64) {
        self.advance_ns(t_ns.saturating_sub(self.time_ns));
    }

    /// Advances by `dt_ns` in equal sub-steps of at most the sub-step length.
    pub fn advance_ns(&mut self, dt_ns: u64) {
        if dt_ns == 0 {
            return;
        }
        let n = dt_ns.div_ceil(self.substep_ns);
        let h = dt_ns as f64 * 1e-9 / n as f64;
        for _ in 0..n {
            self.substep(h);
        }
        self.time_ns += dt_ns;
        for w in &mut self.wheels {
            w.encoder.update(w.motor.angle());
        }
        self.power_rangers();
        let now = self.time_s();
        for (r, n) in self.rangers.iter_mut().zip(&mut self.ranger_noise) {
            r.update(now, &self.pose, &self.obstacles, n);
        }
    }

    /// Powers each ranger through its board's sensor switch (SENSOR_PWR_EN, its current limit)
    /// from the bus (a bus that went down during a step is seen at its end).
    fn power_rangers(&mut self) {
        let now = self.time_s();
        let bus_on = self.bus_voltage() > 4.5;
        for b in &mut self.boards {
            if let Link::Proximity { channels, switch } = &mut b.link {
                let demand: f64 = channels
                    .iter()
                    .flatten()
                    .map(|r| &self.rangers[*r])
                    .filter(|r| r.connected())
                    .map(|r| r.kind.supply_current_a())
                    .sum();
                let rail_up = switch.settle(demand, bus_on);
                for r in channels.iter().flatten() {
                    self.rangers[*r].set_powered(rail_up, now);
                }
            }
        }
    }

    /// Current drawn from the 5 V bus, A: the modules' own plus what the sensor switches pass.
    pub fn bus_load_a(&self) -> f64 {
        let sensors: f64 = self
            .boards
            .iter()
            .map(|b| match &b.link {
                Link::Proximity { switch, .. } => switch.load_a(),
                _ => 0.0,
            })
            .sum();
        self.bus_base_load_a + sensors
    }

    fn substep(&mut self, h: f64) {
        let ocv = self.battery.ocv();
        let rb = self.battery.params.internal_resistance_ohm;
        // 1. Supply voltage from the loads now: the motor boards' through their leads (none
        // while a diode in them blocks), the PSU's converter.
        let mut motor_a = self.motor_bus.load_a;
        let driver_off = self.motor_bus.driver_off();
        for w in &mut self.wheels {
            w.bridge.fault = w.fault_injected || driver_off;
            let i = w.motor.current();
            motor_a += match w.bridge.terminal(1.0, i) {
                Terminal::Driven { volts, .. } => volts * i,
                Terminal::Open { .. } => -i.abs(),
            };
        }
        let lead_a = self.motor_bus.lead_current(motor_a, h, self.supply_v);
        let conducting = lead_a.is_some();
        let motor_a = lead_a.unwrap_or(0.0);
        let (ocv_seen, r_seen) = self.motor_bus.source(conducting, ocv, rb, h);
        let load_a = self.bus_load_a();
        let (v, power) = match &mut self.psu {
            Some(psu) => {
                psu.check_load(load_a);
                let want = psu.input_power(load_a);
                let min = psu.params.min_input_v;
                match supply_voltage(ocv_seen, r_seen, motor_a, want).filter(|&v| v >= min) {
                    Some(v) => {
                        psu.set_input_ok(true);
                        (v, want)
                    }
                    None => {
                        psu.set_input_ok(false);
                        ((ocv_seen - r_seen * motor_a).max(0.0), 0.0)
                    }
                }
            }
            None => ((ocv_seen - r_seen * motor_a).max(0.0), 0.0),
        };
        self.supply_v = v;
        self.psu_input_a = if v > 0.0 { power / v } else { 0.0 };
        let vm = self.motor_bus.voltage(conducting, v);
        // 2. Bridges and windings.
        let mut charge = 0.0;
        for w in &mut self.wheels {
            let term = w.bridge.terminal(vm, w.motor.current());
            let e = w.motor.update_current(term, h);
            let q = w.bridge.supply_charge(term, vm, &e);
            w.supply_current = q / h;
            charge += q;
            self.ledger.conduction_loss_j += e.resistance * e.i2t;
            self.ledger.diode_loss_j += vm * q - e.energy_in;
        }
        let boards_q = self.motor_bus.load_a * h;
        self.ledger.motor_boards_j += vm * boards_q;
        let bulk_q = self.motor_bus.settle(conducting, vm, charge + boards_q);
        // What the leads carried from the battery, and lost in a diode on the way.
        let lead_q = if conducting { charge + boards_q + bulk_q } else { 0.0 };
        self.ledger.diode_loss_j += (v - vm) * lead_q;
        // 3. Mechanics: wheel torques through the gearboxes, inertias turning with each wheel.
        let (torques, inertias) = &mut self.scratch;
        torques.clear();
        inertias.clear();
        let mut mask = 0usize;
        for (k, w) in self.wheels.iter().enumerate() {
            let f = w.gearbox.torque_factor(w.motoring);
            torques.push(f * w.motor.shaft_torque());
            inertias.push(w.wheel_inertia + f * w.gearbox.ratio * w.motor.params.rotor_inertia);
            mask |= usize::from(w.motoring) << k.min(usize::BITS as usize - 1);
        }
        let (rhs, rolling_loss) = self.base.forces(&self.kin, &self.q, torques);
        let dof = self.kin.dof();
        let q_dot = if self.wheels.len() <= MASS_CACHE_WHEELS {
            if self.mass_inv.is_empty() {
                self.mass_inv = vec![None; 1 << self.wheels.len()];
            }
            let inv = *self.mass_inv[mask].get_or_insert_with(|| {
                linalg::inverse(&self.base.mass_matrix(&self.kin, inertias), dof)
            });
            let mut x = [0.0; 3];
            for (xi, row) in x.iter_mut().zip(&inv).take(dof) {
                *xi = row.iter().zip(&rhs).take(dof).map(|(m, r)| m * r).sum();
            }
            x
        } else {
            linalg::solve(&self.base.mass_matrix(&self.kin, inertias), &rhs, dof)
        };
        let acc = Acceleration { q_dot, rolling_loss };
        for (q, a) in self.q.iter_mut().zip(acc.q_dot) {
            *q += h * a;
        }
        self.q_dot = acc.q_dot;
        self.pose.integrate(&self.kin.twist(&self.q), h);
        for (k, w) in self.wheels.iter_mut().enumerate() {
            let n = w.gearbox.ratio;
            let p = &w.motor.params;
            let shaft = w.motor.shaft_torque();
            let friction = p.friction(w.motor.speed());
            let eta = w.gearbox.torque_factor(w.motoring) / n;
            w.speed = self.kin.wheel_rate(k, &self.q);
            w.angle += h * w.speed;
            let wm = n * w.speed;
            w.load_torque = shaft - p.rotor_inertia * n * self.kin.wheel_rate(k, &acc.q_dot);
            self.ledger.friction_loss_j += friction * wm * h;
            self.ledger.gear_loss_j += (1.0 - eta) * w.load_torque * wm * h;
            w.motoring = w.load_torque * wm >= 0.0;
            w.motor.set_mechanical(wm, n * w.angle);
        }
        self.ledger.rolling_loss_j += acc.rolling_loss * h;
        // 4. Battery.
        let bus_charge = if v > 0.0 { power / v * h } else { 0.0 };
        let total = lead_q + bus_charge;
        self.battery.draw(total, h);
        self.ledger.chemical_j += ocv * total;
        self.ledger.battery_loss_j += rb * total * total / h;
        self.ledger.bus_j += power * h;
        self.ledger.motor_charge_c += lead_q;
        self.ledger.bus_charge_c += bus_charge;
    }

    // ----- Board I/O -------------------------------------------------------------------

    /// The boards, in robot-file order.
    pub fn boards(&self) -> impl Iterator<Item = BoardInfo<'_>> {
        self.boards.iter().map(|b| BoardInfo { name: &b.name, kind: b.kind, uid: b.uid })
    }

    fn board_index(&self, board: &str) -> Result<usize, IoError> {
        self.boards.iter().position(|b| b.name == board).ok_or_else(|| IoError::UnknownBoard {
            board: board.to_string(),
            known: self.boards.iter().map(|b| b.name.clone()).collect(),
        })
    }

    fn signal(&self, b: usize, signal: &str, wanted: SignalKind) -> Result<usize, IoError> {
        let board = &self.boards[b];
        board.kind.signal_index(signal, wanted).ok_or_else(|| IoError::UnknownSignal {
            board: board.name.clone(),
            kind: board.kind,
            signal: signal.to_string(),
            wanted,
            known: board.kind.signal_names(wanted),
        })
    }

    fn wheel_of(&self, b: usize) -> Result<usize, IoError> {
        match self.boards[b].link {
            Link::Motor { wheel } => Ok(wheel),
            _ => Err(IoError::Invalid {
                board: self.boards[b].name.clone(),
                problem: format!("is a {} board, not a motor board", self.boards[b].kind.name()),
            }),
        }
    }

    /// Voltage on an analog pin now (noise-free: the Hall sensor's and the ADC's noise left
    /// out, a ranger's held output with its measurement noise).
    pub fn pin_volts(&self, board: &str, signal: &str) -> Result<f64, IoError> {
        let b = self.board_index(board)?;
        let s = self.signal(b, signal, SignalKind::Analog)?;
        Ok(self.analog(b, s, None, self.pwm_phase()))
    }

    /// What the board's ADC read on `signal` at its latest conversion, counts (0..4095), with
    /// noise. A motor board converts MOTOR_CURRENT and VMOT_SENSE on TIM1's update events
    /// (its injected group, as the motor image sets it up): the latest is at the bottom or the
    /// top of TIM1's count at or before now, where the current ripple crosses its average.
    /// Every other signal is converted now.
    pub fn read_adc(&mut self, board: &str, signal: &str) -> Result<u16, IoError> {
        let phase = self.pwm_phase();
        let update = (2.0 * phase).floor() / 2.0;
        self.convert(board, signal, update)
    }

    /// What the board's ADC reads on `signal` converting now (a software start: SWSTART),
    /// counts, with noise: on a motor board's MOTOR_CURRENT, the average current plus the
    /// ripple at this instant, the error a conversion out of step with the PWM makes.
    pub fn read_adc_now(&mut self, board: &str, signal: &str) -> Result<u16, IoError> {
        let phase = self.pwm_phase();
        self.convert(board, signal, phase)
    }

    /// The PWM phase now, in periods (0..1): TIM1 starts counting with the world, at the bottom
    /// of its centre-aligned count (every motor board's TIM1 at the same frequency).
    pub fn pwm_phase(&self) -> f64 {
        let hz = self.wheels.first().map_or(20_000.0, |w| w.bridge.params.pwm_hz);
        (self.time_ns as f64 * hz / 1e9).fract()
    }

    fn convert(&mut self, board: &str, signal: &str, phase: f64) -> Result<u16, IoError> {
        let b = self.board_index(board)?;
        let s = self.signal(b, signal, SignalKind::Analog)?;
        let mut noise = self.boards[b].noise[s].clone();
        let v = self.analog(b, s, Some(&mut noise), phase);
        let code = frontends::ADC.convert(v, &mut noise);
        self.boards[b].noise[s] = noise;
        Ok(code)
    }

    /// Signal `s`'s voltage on board `b`, at PWM phase `phase` for a motor current.
    fn analog(&self, b: usize, s: usize, noise: Option<&mut Noise>, phase: f64) -> f64 {
        let board = &self.boards[b];
        let name = board.kind.signals()[s].name;
        match (&board.link, name) {
            (Link::Psu, "VIN_SENSE") => frontends::VIN_SENSE.output(self.supply_v),
            (Link::Psu, "IIN_SENSE") => frontends::iin_sense(self.psu_input_a),
            (Link::Psu, "VOUT_SENSE") => frontends::VOUT_SENSE.output(self.bus_voltage()),
            (Link::Motor { wheel }, "MOTOR_CURRENT") => {
                let w = &self.wheels[*wheel];
                let l = w.motor.params.inductance_h;
                let i = w.motor.current() + w.bridge.ripple(self.motor_bus.volts(), l, phase);
                match noise {
                    Some(n) => frontends::MOTOR_CURRENT.output(i, n),
                    None => frontends::MOTOR_CURRENT.output_ideal(i),
                }
            }
            (Link::Motor { .. }, "VMOT_SENSE") => {
                frontends::VMOT_SENSE.output(self.motor_bus.volts())
            }
            (Link::Proximity { channels, .. }, ch) => {
                let c = usize::from(ch.as_bytes()[ch.len() - 1] - b'0');
                channels[c].map_or(0.0, |r| self.rangers[r].output_v())
            }
            _ => unreachable!("signal table and analog sources disagree on {name}"),
        }
    }

    /// The encoder timer register of the board's counter `signal` (`ENC_A`).
    pub fn read_counter(&self, board: &str, signal: &str) -> Result<u16, IoError> {
        let b = self.board_index(board)?;
        self.signal(b, signal, SignalKind::Counter)?;
        Ok(self.wheels[self.wheel_of(b)?].encoder.hardware_count())
    }

    /// Sets the duty (0..1, clamped) of the PWM output `signal` (`PWM_AH`: leg A, `PWM_BH`:
    /// leg B; each leg's low side is its complement).
    pub fn set_pwm(&mut self, board: &str, signal: &str, duty: f64) -> Result<(), IoError> {
        let b = self.board_index(board)?;
        let s = self.signal(b, signal, SignalKind::Pwm)?;
        if duty.is_nan() {
            return Err(IoError::Invalid {
                board: board.to_string(),
                problem: format!("duty for {signal} is NaN"),
            });
        }
        let w = self.wheel_of(b)?;
        let input = &mut self.wheels[w].bridge.input;
        match self.boards[b].kind.signals()[s].name {
            "PWM_AH" => input.duty_a = duty.clamp(0.0, 1.0),
            _ => input.duty_b = duty.clamp(0.0, 1.0),
        }
        Ok(())
    }

    /// Drives the digital output `signal` to level `high`.
    pub fn set_output(&mut self, board: &str, signal: &str, high: bool) -> Result<(), IoError> {
        let b = self.board_index(board)?;
        let s = self.signal(b, signal, SignalKind::Output)?;
        match self.boards[b].kind.signals()[s].name {
            "DRV_EN" => {
                let w = self.wheel_of(b)?;
                self.wheels[w].bridge.input.enabled = high;
            }
            "BUS_EN" => {
                if let Some(p) = &mut self.psu {
                    p.set_enabled(high);
                }
            }
            _ => {
                // SENSOR_PWR_EN: switches the sensors now.
                if let Link::Proximity { switch, .. } = &mut self.boards[b].link {
                    switch.enabled = high;
                }
                self.power_rangers();
            }
        }
        Ok(())
    }

    /// The level on the digital input `signal`.
    pub fn read_input(&self, board: &str, signal: &str) -> Result<bool, IoError> {
        let b = self.board_index(board)?;
        let s = self.signal(b, signal, SignalKind::Input)?;
        Ok(match self.boards[b].kind.signals()[s].name {
            // Active low: high while there is no fault.
            "DRV_FAULT" => !self.wheels[self.wheel_of(b)?].bridge.fault,
            "SENSOR_PWR_FAULT" => match &self.boards[b].link {
                Link::Proximity { switch, .. } => !switch.fault(),
                _ => unreachable!("SENSOR_PWR_FAULT is a proximity signal"),
            },
            _ => !self.psu.as_ref().is_some_and(|p| p.tripped()), // BUS_FAULT
        })
    }

    // ----- Faults ----------------------------------------------------------------------

    /// Connects or disconnects the encoder of motor board `board`.
    pub fn set_encoder_connected(&mut self, board: &str, connected: bool) -> Result<(), IoError> {
        let b = self.board_index(board)?;
        let w = self.wheel_of(b)?;
        self.wheels[w].encoder.set_connected(connected);
        Ok(())
    }

    /// Injects (or clears) a driver fault on motor board `board`: the bridge turns off and
    /// DRV_FAULT goes low.
    pub fn set_driver_fault(&mut self, board: &str, fault: bool) -> Result<(), IoError> {
        let b = self.board_index(board)?;
        let w = self.wheel_of(b)?;
        self.wheels[w].fault_injected = fault;
        self.wheels[w].bridge.fault = fault || self.motor_bus.driver_off();
        Ok(())
    }

    /// Connects or disconnects the ranger on `channel` of proximity board `board`.
    pub fn set_ranger_connected(
        &mut self,
        board: &str,
        channel: usize,
        connected: bool,
    ) -> Result<(), IoError> {
        let r = self.ranger_index(board, channel)?;
        self.rangers[r].set_connected(connected);
        Ok(())
    }

    /// Injects (or clears) a short on the sensor rail of proximity board `board`: its sensor
    /// switch goes into current limit and SENSOR_PWR_FAULT goes low while it is enabled.
    pub fn set_sensor_rail_shorted(&mut self, board: &str, shorted: bool) -> Result<(), IoError> {
        let b = self.board_index(board)?;
        match &mut self.boards[b].link {
            Link::Proximity { switch, .. } => switch.set_shorted(shorted),
            _ => {
                return Err(IoError::Invalid {
                    board: board.to_string(),
                    problem: format!(
                        "is a {} board, not a proximity board",
                        self.boards[b].kind.name()
                    ),
                })
            }
        }
        self.power_rangers();
        Ok(())
    }

    fn ranger_index(&self, board: &str, channel: usize) -> Result<usize, IoError> {
        let b = self.board_index(board)?;
        let invalid = |problem: String| IoError::Invalid { board: board.to_string(), problem };
        match &self.boards[b].link {
            Link::Proximity { channels, .. } => channels
                .get(channel)
                .copied()
                .flatten()
                .ok_or_else(|| invalid(format!("no ranger on channel {channel}"))),
            _ => Err(invalid(format!(
                "is a {} board, not a proximity board",
                self.boards[b].kind.name()
            ))),
        }
    }

    /// The IMU on board `board`: its device (mount, offsets, gains) and noise stream.
    pub fn imu(&self, board: &str) -> Result<&Imu, IoError> {
        Ok(&self.imus[self.imu_index(board)?].imu)
    }

    /// Everything IMU board `board` is wired to: its four devices (offsets, iron, receiver)
    /// and their plugs, for checks against the truth.
    pub fn imu_module(&self, board: &str) -> Result<&ImuModule, IoError> {
        Ok(&self.imus[self.imu_index(board)?])
    }

    /// Where the world's origin is, and its field and weather.
    pub fn site(&self) -> &Site {
        &self.site
    }

    /// One sample of the IMU on board `board` at output data rate `odr_hz`, for the base's
    /// motion now (what the board's LSM6DSO latches when a sample falls due).
    pub fn sample_imu(&mut self, board: &str, odr_hz: f64) -> Result<ImuReading, IoError> {
        let i = self.plugged(board, ImuSensor::AccelGyro)?;
        let (t, dt) = (self.twist(), self.twist_rate());
        Ok(self.imus[i].imu.measure(&t, &dt, odr_hz))
    }

    /// One sample of the magnetometer on board `board` for the base's heading now: the Earth's
    /// field through the robot's iron, the device's offset and noise (what the board's LIS3MDL
    /// latches when a sample falls due; its noise does not depend on the rate).
    pub fn sample_magnetometer(&mut self, board: &str) -> Result<MagSample, IoError> {
        let i = self.plugged(board, ImuSensor::Magnetometer)?;
        let heading = self.pose.theta;
        Ok(self.imus[i].magnetometer.sample(heading))
    }

    /// One sample of the barometer on board `board`: the atmosphere at the site's altitude
    /// under its sea-level pressure, the device's offset and noise (what the board's LPS22HH
    /// latches when a sample falls due).
    pub fn sample_pressure(&mut self, board: &str) -> Result<BaroSample, IoError> {
        let i = self.plugged(board, ImuSensor::Barometer)?;
        let m = &mut self.imus[i];
        Ok(m.barometer.sample(m.altitude_m))
    }

    /// Where the GNSS antenna of board `board` is and how it moves now (east-north-up from the
    /// site's origin), plugged or not: the truth a receiver's solution follows.
    pub fn gnss_antenna(&self, board: &str) -> Result<GnssAntenna, IoError> {
        let i = self.imu_index(board)?;
        Ok(self.imus[i].antenna(&self.pose, &self.twist()))
    }

    /// The navigation solution of the GNSS receiver on board `board` now (seconds since the
    /// world started, when the receiver powered up): no fix before its time to first fix,
    /// then its antenna's place on the ellipsoid with the receiver's wandering error. Calls
    /// advance the receiver's error: make them in time order. (The emulated board's u-blox
    /// model solves with its own copy of this receiver: `ImuModule::gnss`.)
    pub fn gnss_fix(&mut self, board: &str) -> Result<GnssFix, IoError> {
        let i = self.plugged(board, ImuSensor::Gnss)?;
        let (a, now) = (self.gnss_antenna(board)?, self.time_s());
        Ok(self.imus[i].gnss.solve(now, a.enu))
    }

    /// Plugs or unplugs `sensor` of IMU board `board` (fault injection: a sensor that fails or
    /// whose cable comes off). An unplugged sensor cannot be sampled; the emulated board's
    /// bus then reads what a bus with nothing on it reads.
    pub fn set_imu_sensor_connected(
        &mut self,
        board: &str,
        sensor: ImuSensor,
        connected: bool,
    ) -> Result<(), IoError> {
        let i = self.imu_index(board)?;
        self.imus[i].set_connected(sensor, connected);
        Ok(())
    }

    /// Whether `sensor` of IMU board `board` is plugged.
    pub fn imu_sensor_connected(&self, board: &str, sensor: ImuSensor) -> Result<bool, IoError> {
        Ok(self.imus[self.imu_index(board)?].connected(sensor))
    }

    /// The IMU module of board `board`, if `sensor` is plugged on it.
    fn plugged(&self, board: &str, sensor: ImuSensor) -> Result<usize, IoError> {
        let i = self.imu_index(board)?;
        if self.imus[i].connected(sensor) {
            Ok(i)
        } else {
            Err(IoError::Invalid {
                board: board.to_string(),
                problem: format!(
                    "its {} ({}) is unplugged: nothing to sample (set_imu_sensor_connected)",
                    sensor.name(),
                    sensor.part()
                ),
            })
        }
    }

    fn imu_index(&self, board: &str) -> Result<usize, IoError> {
        let b = self.board_index(board)?;
        match self.boards[b].link {
            Link::Imu { imu } => Ok(imu),
            _ => Err(IoError::Invalid {
                board: board.to_string(),
                problem: format!("is a {} board, not an imu board", self.boards[b].kind.name()),
            }),
        }
    }

    /// Sets the modules' own load on the 5 V bus, A (rangers are added to it).
    pub fn set_bus_load_a(&mut self, amps: f64) {
        self.bus_base_load_a = amps.max(0.0);
    }

    /// Moves the base to `pose`, at rest (tests and scenario set-up).
    pub fn set_pose(&mut self, pose: Pose) {
        self.pose = pose;
        self.q = [0.0; 3];
        self.q_dot = [0.0; 3];
        for w in &mut self.wheels {
            w.speed = 0.0;
            let angle = w.motor.angle();
            w.motor.set_mechanical(0.0, angle);
        }
    }

    // ----- State -----------------------------------------------------------------------

    /// The base's pose.
    pub fn pose(&self) -> Pose {
        self.pose
    }

    /// The base's velocity (body frame).
    pub fn twist(&self) -> Twist {
        self.kin.twist(&self.q)
    }

    /// The rate of change of the base's body twist over the last sub-step: (v̇x, v̇y, ω̇) in
    /// the body frame, the derivative of [`Self::twist`]'s components (not yet the
    /// acceleration: see [`crate::imu`] for the ω × v term).
    pub fn twist_rate(&self) -> Twist {
        self.kin.twist(&self.q_dot)
    }

    /// The base's kinematics.
    pub fn kinematics(&self) -> &Kinematics {
        &self.kin
    }

    /// Number of wheels.
    pub fn wheel_count(&self) -> usize {
        self.wheels.len()
    }

    /// Wheel `k`'s drive train.
    pub fn wheel(&self, k: usize) -> WheelState {
        let w = &self.wheels[k];
        WheelState {
            motor_current: w.motor.current(),
            motor_speed: w.motor.speed(),
            motor_angle: w.motor.angle(),
            wheel_speed: w.speed,
            wheel_angle: w.angle,
            load_torque: w.load_torque,
            supply_current: w.supply_current,
            encoder_count: w.encoder.hardware_count(),
            bridge: w.bridge.input,
            driver_fault: w.bridge.fault,
        }
    }

    /// The battery.
    pub fn battery(&self) -> &Battery {
        &self.battery
    }

    /// Battery terminal voltage at the last sub-step, V (the motors' supply while their leads
    /// conduct: [`Self::motor_bus_voltage`]).
    pub fn supply_voltage(&self) -> f64 {
        self.supply_v
    }

    /// The motor boards' supply VMOT at the last sub-step (what VMOT_SENSE divides), V: the
    /// battery's terminal voltage, less a diode, or above it while a supply that cannot sink
    /// blocks braking current ([`Self::set_motor_supply`]).
    pub fn motor_bus_voltage(&self) -> f64 {
        self.motor_bus.volts()
    }

    /// Connects the motor boards' leads to the battery as `supply` says (the world starts with
    /// [`MotorSupply::Battery`]). Their bulk capacitors keep their charge: behind a diode they
    /// first discharge into the boards' loads to the battery less its drop.
    pub fn set_motor_supply(&mut self, supply: MotorSupply) {
        self.motor_bus.supply = supply;
    }

    /// The PSU's input current from the battery (what its shunt measures), A.
    pub fn psu_input_current(&self) -> f64 {
        self.psu_input_a
    }

    /// The 5 V bus voltage (5 V without a PSU module: an external supply), V.
    pub fn bus_voltage(&self) -> f64 {
        self.psu.as_ref().map_or(PsuParams::R2P.bus_voltage_v, Psu::bus_voltage)
    }

    /// The ranger on `channel` of proximity board `board`.
    pub fn ranger(&self, board: &str, channel: usize) -> Result<&Ranger, IoError> {
        Ok(&self.rangers[self.ranger_index(board, channel)?])
    }

    /// The obstacles.
    pub fn obstacles(&self) -> &Obstacles {
        &self.obstacles
    }

    /// Energy and charge flows since the start.
    pub fn energy(&self) -> EnergyLedger {
        self.ledger
    }

    /// Energy stored now: kinetic (base, wheels, rotors) and magnetic (windings), J.
    pub fn stored_energy_j(&self) -> f64 {
        let wheels: f64 = self
            .wheels
            .iter()
            .map(|w| {
                0.5 * w.wheel_inertia * w.speed * w.speed
                    + 0.5 * w.motor.params.rotor_inertia * w.motor.speed() * w.motor.speed()
                    + w.motor.magnetic_energy()
            })
            .sum();
        self.base.kinetic_energy(&self.q) + wheels + self.motor_bus.stored_energy_j()
    }

    /// Energy drawn from the battery's source not accounted for by storage, losses and the
    /// bus, J: integration error only (first order in the sub-step).
    pub fn energy_residual_j(&self) -> f64 {
        self.ledger.chemical_j
            - (self.stored_energy_j() - self.stored_at_start_j)
            - self.ledger.spent_j()
    }

    /// A digest of the whole state (FNV-1a over its `Debug` form, which prints every float
    /// exactly): equal digests mean equal worlds, for determinism tests.
    pub fn state_digest(&self) -> u64 {
        let text = format!("{self:?}");
        text.bytes()
            .fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
    }
}
