//! Test rig: the application driving a simulated brushed DC motor through the same `Sample`s
//! and `Command`s the MCU exchanges with it.
#![allow(dead_code)]

pub mod motor;

use r2p_app_motor::params::{self, COUNT};
use r2p_app_motor::{App, Command, Endpoints, Names, Sample};
use r2p_management::message::Value;
use r2p_middleware::Subscriber;
use r2p_msgs::{FaultClear, MotorFault, R2pMessage, WheelSetpoint, WheelState};
use r2p_node::{Import, ParamStore, RamParams};

pub use motor::Motor;

/// One millisecond.
pub const MS: u64 = 1_000;

/// Changes a sample at a time (µs): fault injection.
pub type Tamper = Box<dyn FnMut(u64, &mut Sample)>;

pub struct Rig {
    pub app: App<'static>,
    pub ep: Endpoints<'static>,
    pub params: &'static RamParams<COUNT>,
    pub motor: Motor,
    pub now_us: u64,
    pub last: Command,
    pub states: &'static Subscriber<'static, WheelState, 2>,
    pub events: &'static Subscriber<'static, MotorFault, 2>,
    /// Fault injection: changes the sample the motor gives at `now_us`.
    pub tamper: Tamper,
}

fn leak<T>(v: T) -> &'static T {
    Box::leak(Box::new(v))
}

impl Rig {
    /// The application on a fresh motor, with `set` applied to its parameters first.
    pub fn with_params(set: &[(u16, Value)]) -> Self {
        let params = leak(RamParams::new(params::DEFAULTS));
        for &(i, v) in set {
            params.set(i, v).expect("test parameter in range");
        }
        let ep = Endpoints::leak(Names::from_params(params));
        let states = leak(Subscriber::new());
        let events = leak(Subscriber::new());
        ep.state.topic.subscribe(states).unwrap();
        ep.fault.topic.subscribe(events).unwrap();
        Self {
            app: App::new(ep, params),
            ep,
            params,
            motor: Motor::default(),
            now_us: 0,
            last: Command::OFF,
            states,
            events,
            tamper: Box::new(|_, _| {}),
        }
    }

    pub fn new() -> Self {
        Self::with_params(&[])
    }

    /// A rig past the current sensor's calibration.
    pub fn calibrated() -> Self {
        let mut r = Self::new();
        r.run_ms(100);
        assert!(r.app.is_calibrated());
        r
    }

    /// One step: sample the motor, run the application, apply its command for 1 ms.
    pub fn step(&mut self) -> Command {
        let mut s = self.motor.sample();
        (self.tamper)(self.now_us, &mut s);
        let cmd = self.app.step(self.now_us, &s);
        self.motor.advance(&cmd, 1e-3);
        self.now_us += MS;
        self.last = cmd;
        cmd
    }

    pub fn run_ms(&mut self, ms: u64) {
        for _ in 0..ms {
            self.step();
        }
        self.drain();
    }

    /// Drops queued states and events (the queues are short).
    pub fn drain(&self) {
        while self.states.try_recv().is_some() {}
    }

    /// A setpoint as the bus delivers it (encoded bytes through the remote publisher).
    pub fn send(&self, mode: u8, value: f32) {
        let mut buf = [0u8; WheelSetpoint::SIZE];
        WheelSetpoint { mode, value }.encode(&mut buf).unwrap();
        self.ep.setpoint.remote.publish_bytes(&buf).unwrap();
    }

    /// A clear command as the bus delivers it.
    pub fn clear(&self, mask: u8) {
        let mut buf = [0u8; FaultClear::SIZE];
        FaultClear { mask }.encode(&mut buf).unwrap();
        self.ep.clear_faults.remote.publish_bytes(&buf).unwrap();
    }

    /// Runs `ms` steps sending the setpoint every 10 ms (as a gateway at 100 Hz), calling
    /// `each` after every step.
    pub fn hold(&mut self, mode: u8, value: f32, ms: u64, mut each: impl FnMut(&mut Self)) {
        for k in 0..ms {
            if k % 10 == 0 {
                self.send(mode, value);
            }
            self.step();
            each(self);
            self.drain();
        }
    }

    pub fn take_events(&self) -> Vec<MotorFault> {
        let mut v = Vec::new();
        while let Some(e) = self.events.try_recv() {
            v.push(*e);
        }
        v
    }

    /// Output-shaft speed of the simulated motor, rad/s.
    pub fn speed(&self) -> f64 {
        self.motor.output_speed()
    }
}
