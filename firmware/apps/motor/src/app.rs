//! The application: one control step per millisecond, from a [`Sample`] to a [`Command`].

use r2p_module::filters::LowPass;
use r2p_module::leds::{self, Status};
use r2p_module::TopicNode;
use r2p_msgs::{MotorFault, WheelState};
use r2p_node::{NodeError, ParamStore};

use crate::control::{Cascade, Measured, Setpoint, INNER_DT_S, OUTER_DIVIDER, OUTER_DT_S};
use crate::encoder::{Encoder, Scale};
use crate::endpoints::Endpoints;
use crate::faults::{Faults, Persistence};
use crate::frontend;
use crate::names::Names;
use crate::params::{index, Config, COUNT};

/// Current-sensor samples averaged for its zero at start-up (and after its fault is cleared),
/// with the bridge off.
pub const CALIBRATION_SAMPLES: u32 = 64;
/// Cut-off of the speed estimate's low-pass (sampled at 200 Hz), Hz.
pub const SPEED_FILTER_HZ: f32 = 100.0;
/// Cut-off of the published current's low-pass (sampled at 1 kHz), Hz.
pub const CURRENT_FILTER_HZ: f32 = 20.0;
/// After the watchdog fired, the motor is braked once slower than this (rad/s, output)...
pub const STOPPED_SPEED: f32 = 0.2;
/// ... or at the latest this long after the watchdog fired, µs.
pub const STOP_TIMEOUT_US: u64 = 1_000_000;
/// Smallest |duty| at which the encoder-loss check looks at the back-EMF.
pub const ENCODER_CHECK_DUTY: f32 = 0.1;

/// Raw readings the board-support layer takes each step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// TIM3's counter (encoder mode, counting both edges of ENC_A and ENC_B).
    pub encoder_count: u16,
    /// MOTOR_CURRENT, ADC counts (12 bit).
    pub current_adc: u16,
    /// VMOT_SENSE, ADC counts (12 bit).
    pub vmot_adc: u16,
    /// TIM1's break flag: the driver pulled DRV_FAULT and the hardware cut the PWM outputs
    /// since the last step (the board clears the flag once read).
    pub driver_fault: bool,
    /// The node's and the module's state as the LEDs show it (`running`: node ID claimed;
    /// `synced`, `traffic`, `storage_fault`); the application adds its own faults.
    pub status: Status,
}

/// What the board-support layer applies after the step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Command {
    /// H-bridge duty, −1..1: the average motor voltage is `duty` × VMOT; positive drives the
    /// motor forward (encoder counting up, positive current).
    pub duty: f32,
    /// DRV_EN and TIM1's main output enable. Off: every switch open, the motor coasts.
    pub bridge_enable: bool,
    /// Both low-side switches on, the motor shorted (dynamic brake); `duty` is then 0.
    pub brake: bool,
    /// LED_STATUS, LED_BUS, LED_FAULT: true = lit (the board file says which level lights).
    pub leds: [bool; 3],
}

impl Command {
    /// Every switch open.
    pub const OFF: Self = Self { duty: 0.0, bridge_enable: false, brake: false, leds: [false; 3] };
}

/// What the application counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Setpoints taken.
    pub setpoints: u32,
    /// Setpoints refused: unknown mode or not a finite number.
    pub bad_setpoints: u32,
    /// Setpoints dropped because a fault was latched.
    pub ignored_setpoints: u32,
    /// States published.
    pub states: u32,
    /// Fault events published.
    pub fault_events: u32,
    /// States or events not published: the topic's pool was empty.
    pub pool_empty: u32,
}

#[derive(Clone, Copy)]
enum Zero {
    /// Summing samples.
    Calibrating { sum: u32, n: u32 },
    /// Calibrated zero, counts.
    Done(f32),
}

/// The DC motor controller application (crate documentation).
pub struct App<'a> {
    ep: Endpoints<'a>,
    params: &'a dyn ParamStore,
    cfg: Config,
    scale: Scale,
    next_param: u16,
    steps: u64,
    encoder: Encoder,
    /// Extended counts of the last `OUTER_DIVIDER` steps (ring): speed over one 5 ms window,
    /// every millisecond.
    counts: [i32; OUTER_DIVIDER as usize],
    /// Unfiltered speed over the last 5 ms, rad/s (the back-EMF feed-forward's, every step).
    window_speed: f32,
    last_edge_us: u64,
    speed_filter: LowPass,
    current_filter: LowPass,
    zero: Zero,
    m: Measured,
    cascade: Cascade,
    setpoint: Option<Setpoint>,
    last_setpoint_us: Option<u64>,
    faults: Faults,
    over_current: Persistence,
    encoder_loss: Persistence,
    stop_since: Option<u64>,
    braked: bool,
    /// VMOT was above `regen_start_v` at some step since the last state (its bit 5).
    regen_limited: bool,
    applied_duty: f32,
    next_publish_us: u64,
    stats: Stats,
}

impl<'a> App<'a> {
    /// The application on its `endpoints`, reading its parameters from `params` (the table
    /// `params::DEFAULTS`, in RAM or flash).
    pub fn new(endpoints: Endpoints<'a>, params: &'a dyn ParamStore) -> Self {
        let cfg = Config::load(params);
        Self {
            ep: endpoints,
            params,
            cfg,
            scale: Scale::new(cfg.encoder_lines, cfg.gear_ratio),
            next_param: 0,
            steps: 0,
            encoder: Encoder::new(),
            counts: [0; OUTER_DIVIDER as usize],
            window_speed: 0.0,
            last_edge_us: 0,
            speed_filter: LowPass::new(SPEED_FILTER_HZ, OUTER_DT_S),
            current_filter: LowPass::new(CURRENT_FILTER_HZ, INNER_DT_S),
            zero: Zero::Calibrating { sum: 0, n: 0 },
            m: Measured::default(),
            cascade: Cascade::new(),
            setpoint: None,
            last_setpoint_us: None,
            faults: Faults::NONE,
            over_current: Persistence::new(),
            encoder_loss: Persistence::new(),
            stop_since: None,
            braked: false,
            regen_limited: false,
            applied_duty: 0.0,
            next_publish_us: 0,
            stats: Stats::default(),
        }
    }

    /// Exports `state` and `fault` and imports `setpoint` and `clear_faults` on `node`.
    pub fn register(&self, node: &mut impl TopicNode<'a>) -> Result<(), NodeError> {
        self.ep.register(node)
    }

    /// One control step at `now_us` (every 1 ms): measurements, bus commands, the 200 Hz loops
    /// every fifth step, the current loop, the safety checks, publication.
    pub fn step(&mut self, now_us: u64, sample: &Sample) -> Command {
        self.refresh_one_param();
        self.measure(now_us, sample);
        self.take_clear_commands();
        self.take_setpoints(now_us);
        self.check_watchdog(now_us);
        self.window();
        let outer = self.steps.is_multiple_of(u64::from(OUTER_DIVIDER));
        if outer {
            self.m.speed = self.speed_filter.push(self.window_speed);
        }
        self.m.speed_now = self.window_speed;
        self.check_faults(now_us, sample);
        let mut cmd = self.drive(now_us, outer);
        self.applied_duty = if cmd.bridge_enable { cmd.duty } else { 0.0 };
        self.publish_state(now_us);
        let status = Status {
            running: sample.status.running && self.is_calibrated(),
            fault: sample.status.fault || !self.faults.is_empty(),
            ..sample.status
        };
        cmd.leds = leds::levels(status, now_us / 1000);
        self.steps += 1;
        cmd
    }

    /// The latched faults.
    pub fn faults(&self) -> Faults {
        self.faults
    }

    /// The parameters in use.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// The latest measurements.
    pub fn measured(&self) -> Measured {
        self.m
    }

    /// The current setpoint the current loop follows, A.
    pub fn current_ref(&self) -> f32 {
        self.cascade.current_ref()
    }

    /// The setpoint being followed (`None`: idle, stopping or faulted).
    pub fn setpoint(&self) -> Option<Setpoint> {
        self.setpoint
    }

    /// Whether the current sensor's zero is known.
    pub fn is_calibrated(&self) -> bool {
        matches!(self.zero, Zero::Done(_))
    }

    /// The current sensor's calibrated zero, ADC counts.
    pub fn current_zero(&self) -> Option<f32> {
        match self.zero {
            Zero::Done(z) => Some(z),
            Zero::Calibrating { .. } => None,
        }
    }

    /// The extended encoder count.
    pub fn encoder_count(&self) -> i32 {
        self.encoder.count()
    }

    /// Counters.
    pub fn stats(&self) -> Stats {
        self.stats
    }

    /// The topic and node names.
    pub fn names(&self) -> Names {
        self.ep.names
    }

    fn refresh_one_param(&mut self) {
        let i = self.next_param;
        self.cfg.reload(self.params, i);
        self.next_param = (i + 1) % COUNT as u16;
        if i == index::ENCODER_LINES || i == index::GEAR_RATIO {
            self.scale = Scale::new(self.cfg.encoder_lines, self.cfg.gear_ratio);
        }
    }

    fn measure(&mut self, now_us: u64, s: &Sample) {
        let before = self.encoder.count();
        let count = self.encoder.update(s.encoder_count);
        if count != before || self.steps == 0 {
            self.last_edge_us = now_us;
        }
        self.m.position = self.scale.position(count);
        self.m.vbus = frontend::vmot_volts(s.vmot_adc);
        let cfg = &self.cfg;
        self.regen_limited |=
            crate::control::regen_share(self.m.vbus, cfg.regen_start_v, cfg.regen_stop_v) < 1.0;
        self.zero = match self.zero {
            Zero::Calibrating { sum, n } => {
                let sum = sum + u32::from(s.current_adc);
                if n + 1 < CALIBRATION_SAMPLES {
                    Zero::Calibrating { sum, n: n + 1 }
                } else {
                    let zero = sum as f32 / CALIBRATION_SAMPLES as f32;
                    let nominal = f32::from(frontend::HALL_ZERO_COUNTS);
                    if (zero - nominal).abs() > f32::from(frontend::HALL_ZERO_TOLERANCE) {
                        self.latch(Faults::CURRENT_SENSOR);
                    }
                    Zero::Done(zero)
                }
            }
            done => done,
        };
        if let Zero::Done(zero) = self.zero {
            self.m.current = frontend::amps(s.current_adc, zero, self.cfg.hall_mv_per_a);
            self.current_filter.push(self.m.current);
        }
    }

    /// Speed over the last 5 ms (the speed-loop period) from the count difference, every step.
    fn window(&mut self) {
        let slot = (self.steps % u64::from(OUTER_DIVIDER)) as usize;
        let count = self.encoder.count();
        let old = core::mem::replace(&mut self.counts[slot], count);
        self.window_speed = if self.steps < u64::from(OUTER_DIVIDER) {
            0.0
        } else {
            self.scale.speed(old, count, OUTER_DT_S)
        };
    }

    fn take_clear_commands(&mut self) {
        while let Some(c) = self.ep.clear_faults.subscriber.try_recv() {
            let cleared = Faults(self.faults.0 & c.mask);
            if cleared.is_empty() {
                continue;
            }
            self.faults = Faults(self.faults.0 & !c.mask);
            if cleared.any(Faults::CURRENT_SENSOR) {
                self.zero = Zero::Calibrating { sum: 0, n: 0 };
            }
            if cleared.any(Faults::WATCHDOG) {
                self.stop_since = None;
                self.braked = false;
            }
            // Back to idle: the next setpoint starts the motor again.
            self.setpoint = None;
            self.last_setpoint_us = None;
            self.cascade.reset();
            self.over_current.reset();
            self.encoder_loss.reset();
            self.event(Faults::NONE);
        }
    }

    fn take_setpoints(&mut self, now_us: u64) {
        while let Some(msg) = self.ep.setpoint.subscriber.try_recv() {
            let Some(sp) = Setpoint::from_msg(&msg) else {
                self.stats.bad_setpoints += 1;
                continue;
            };
            if !self.faults.is_empty() || !self.is_calibrated() {
                self.stats.ignored_setpoints += 1;
                continue;
            }
            self.stats.setpoints += 1;
            self.setpoint = Some(sp);
            self.last_setpoint_us = Some(now_us);
        }
    }

    fn check_watchdog(&mut self, now_us: u64) {
        let Some(last) = self.last_setpoint_us else { return };
        if now_us.saturating_sub(last) > u64::from(self.cfg.watchdog_ms) * 1000 {
            self.last_setpoint_us = None;
            self.setpoint = None;
            self.stop_since = Some(now_us);
            self.latch(Faults::WATCHDOG);
        }
    }

    fn check_faults(&mut self, now_us: u64, s: &Sample) {
        if s.driver_fault {
            self.latch(Faults::DRIVER);
        }
        if !self.is_calibrated() {
            return;
        }
        let cfg = self.cfg;
        let over = self.m.current.abs() > cfg.trip_current;
        if self.over_current.check(over, now_us, u64::from(cfg.trip_ms) * 1000) {
            self.latch(Faults::OVER_CURRENT);
        }
        // Driving with a back-EMF that says the motor turns, while the encoder says it does
        // not. A stalled motor has no back-EMF (duty × VMOT ≈ R × I), so a stall is no encoder
        // loss.
        let emf = self.applied_duty * self.m.vbus - cfg.motor_resistance * self.m.current;
        let driving =
            self.applied_duty.abs() >= ENCODER_CHECK_DUTY && emf.abs() > cfg.encoder_emf_v;
        let still = self.last_edge_us;
        let hold = u64::from(cfg.encoder_timeout_ms) * 1000;
        if self.encoder_loss.check(driving, now_us, hold) && now_us.saturating_sub(still) >= hold {
            self.latch(Faults::ENCODER_LOSS);
        }
    }

    fn latch(&mut self, f: Faults) {
        let raised = Faults(f.0 & !self.faults.0);
        if raised.is_empty() {
            return;
        }
        self.faults = self.faults | raised;
        if self.faults.any(Faults::DISABLING) {
            self.setpoint = None;
            self.last_setpoint_us = None;
        }
        self.event(raised);
    }

    fn event(&mut self, raised: Faults) {
        let (faults, current) = (self.faults.0, self.m.current);
        let sent = self.ep.fault.publisher.publish_with(|m| {
            *m = MotorFault { faults, raised: raised.0, current };
        });
        match sent {
            Some(_) => self.stats.fault_events += 1,
            None => self.stats.pool_empty += 1,
        }
    }

    fn drive(&mut self, now_us: u64, outer: bool) -> Command {
        if !self.is_calibrated() || self.faults.any(Faults::DISABLING) {
            self.cascade.reset();
            return Command::OFF;
        }
        let sp = if self.faults.any(Faults::WATCHDOG) {
            let since = self.stop_since.unwrap_or(now_us);
            if self.m.speed.abs() < STOPPED_SPEED || now_us.saturating_sub(since) >= STOP_TIMEOUT_US
            {
                self.braked = true;
            }
            if self.braked {
                self.cascade.reset();
                return Command { brake: true, bridge_enable: true, ..Command::OFF };
            }
            Setpoint::Speed(0.0)
        } else {
            match self.setpoint {
                Some(sp) => sp,
                None => {
                    self.cascade.reset();
                    return Command::OFF;
                }
            }
        };
        if outer {
            self.cascade.outer(&self.cfg, sp, &self.m);
        }
        let duty = self.cascade.inner(&self.cfg, &self.m);
        Command { duty, bridge_enable: true, ..Command::OFF }
    }

    /// The condition bits for the next state (beside the latched faults).
    fn conditions(&self) -> Faults {
        if self.regen_limited {
            Faults::REGEN_LIMITED
        } else {
            Faults::NONE
        }
    }

    fn publish_state(&mut self, now_us: u64) {
        if now_us < self.next_publish_us {
            return;
        }
        let period = 1_000_000 / u64::from(self.cfg.publish_hz.max(1));
        self.next_publish_us += period;
        if self.next_publish_us <= now_us {
            self.next_publish_us = now_us + period; // fell behind (a long pause): no burst
        }
        let state = WheelState {
            position: self.m.position,
            speed: self.m.speed,
            current: self.current_filter.value().unwrap_or(0.0),
            faults: (self.faults | self.conditions()).0,
        };
        self.regen_limited = false;
        match self.ep.state.publisher.publish_with(|m| *m = state) {
            Some(_) => self.stats.states += 1,
            None => self.stats.pool_empty += 1,
        }
    }
}
