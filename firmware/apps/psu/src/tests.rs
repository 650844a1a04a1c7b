//! The application driven through `App::step` with synthetic samples, as the MCU and the
//! emulated board drive it.

use std::boxed::Box;
use std::vec::Vec;

use r2p_management::message::{ParamFault, Value};
use r2p_middleware::{Class, Subscriber};
use r2p_msgs::{Battery, BusPower, PsuEvent, PsuState};
use r2p_node::{ParamStore, RamParams};

use crate::charge::UNKNOWN_REMAINING;
use crate::endpoints::SPARE_QUEUE;
use crate::event::*;
use crate::frontend::{iin_amps, iin_counts, vin_counts, vin_volts, vout_counts};
use crate::params::{self, COUNT, DEFAULTS};
use crate::{node_config, App, Command, Endpoints, Sample};

/// An application on fresh endpoints, with subscribers on what it publishes.
struct Rig {
    app: App<'static>,
    params: &'static RamParams<COUNT>,
    battery: &'static Subscriber<'static, Battery, SPARE_QUEUE>,
    state: &'static Subscriber<'static, PsuState, SPARE_QUEUE>,
    event: &'static Subscriber<'static, PsuEvent, SPARE_QUEUE>,
    /// Every event received, with the time of the step that published it (µs).
    events: Vec<(u64, PsuEvent)>,
    batteries: Vec<(u64, Battery)>,
    states: Vec<PsuState>,
    now_us: u64,
    last: Command,
}

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

impl Rig {
    fn new(set: &[(u16, Value)]) -> Self {
        let params = leak(RamParams::new(DEFAULTS));
        for &(i, v) in set {
            params.set(i, v).unwrap();
        }
        let ep = Endpoints::leak(params);
        let battery = leak(Subscriber::new());
        let state = leak(Subscriber::new());
        let event = leak(Subscriber::new());
        ep.battery.topic.subscribe(battery).unwrap();
        ep.state.topic.subscribe(state).unwrap();
        ep.event.topic.subscribe(event).unwrap();
        Self {
            app: App::new(ep, params),
            params,
            battery,
            state,
            event,
            events: Vec::new(),
            batteries: Vec::new(),
            states: Vec::new(),
            now_us: 0,
            last: Command::default(),
        }
    }

    /// Steps every millisecond for `ms` with `sample`, collecting what is published.
    fn run(&mut self, ms: u64, sample: Sample) -> Command {
        for _ in 0..ms {
            self.last = self.app.step(self.now_us, &sample);
            while let Some(e) = self.event.try_recv() {
                self.events.push((self.now_us, *e));
            }
            while let Some(b) = self.battery.try_recv() {
                self.batteries.push((self.now_us, *b));
            }
            while let Some(s) = self.state.try_recv() {
                self.states.push(*s);
            }
            self.now_us += 1000;
        }
        self.last
    }

    fn command(&self, on: bool) {
        let ep = self.app.endpoints();
        ep.power.publisher.publish_with(|m| *m = BusPower { on }).unwrap();
    }

    fn kinds(&self) -> Vec<(u8, u8)> {
        self.events.iter().map(|(_, e)| (e.kind, e.cause)).collect()
    }
}

fn sample(volts: f32, amps: f32) -> Sample {
    Sample {
        vin: vin_counts(volts),
        iin: iin_counts(amps),
        vout: vout_counts(5.0),
        ..Sample::default()
    }
}

#[test]
fn readings_match_the_front_end_math_and_the_calibration() {
    let mut r = Rig::new(&[]);
    r.run(10, sample(12.0, 2.0));
    let b = r.app.battery();
    // Quantisation: half a count (4.4 mV, 1.6 mA); the filter settles on a constant input.
    assert!((b.voltage - 12.0).abs() < 0.0045, "{}", b.voltage);
    assert!((b.current - 2.0).abs() < 0.0017, "{}", b.current);
    assert_eq!(b.voltage, vin_volts(vin_counts(12.0)), "exactly the converted code");
    assert_eq!(b.current, iin_amps(iin_counts(2.0)));

    let mut r = Rig::new(&[
        (params::VIN_GAIN, Value::F32(1.05)),
        (params::VIN_OFFSET_V, Value::F32(-0.1)),
        (params::IIN_OFFSET_A, Value::F32(0.25)),
    ]);
    r.run(10, sample(12.0, 2.0));
    let b = r.app.battery();
    assert!((b.voltage - (12.0 * 1.05 - 0.1)).abs() < 0.005, "{}", b.voltage);
    assert!((b.current - 2.25).abs() < 0.002, "{}", b.current);
}

#[test]
fn the_low_pass_smooths_a_voltage_step_with_the_time_constant() {
    let mut r = Rig::new(&[(params::FILTER_TAU_MS, Value::U32(100))]);
    r.run(10, sample(10.0, 0.0));
    r.run(100, sample(20.0, 0.0));
    let v = r.app.battery().voltage;
    assert!((v - (10.0 + 10.0 * 0.632)).abs() < 0.2, "one time constant: {v}");
    r.run(900, sample(20.0, 0.0));
    assert!((r.app.battery().voltage - 20.0).abs() < 0.01);
}

#[test]
fn coulomb_counting_two_amps_for_thirty_minutes_is_one_amp_hour() {
    let mut r = Rig::new(&[]);
    r.run(30 * 60 * 1000, sample(12.0, 2.0));
    let used = r.app.battery().charge_used;
    assert!((used - 1.0).abs() < 0.01, "within 1 %: {used} Ah");
    // What is left is the ADC's quantisation of 2 A (621 codes = 2.0013 A).
    let expected = iin_amps(iin_counts(2.0)) * 0.5;
    assert!((used - expected).abs() < 1e-4, "{used} vs {expected}");
    let last = r.batteries.last().unwrap().1;
    assert!((last.charge_used - used).abs() < 1e-4, "published");
}

#[test]
fn remaining_time_comes_from_the_capacity_and_the_filtered_current() {
    let mut r = Rig::new(&[(params::CAPACITY_AH, Value::F32(10.0))]);
    r.run(60 * 1000, sample(12.0, 3.0));
    let b = r.app.battery();
    let expected = (10.0 - b.charge_used) / b.current * 3600.0;
    assert!((b.remaining_s as f32 - expected).abs() <= 1.0, "{} vs {expected}", b.remaining_s);
    assert!((b.remaining_s as f32 - 11_940.0).abs() < 20.0, "9.95 Ah at 3 A: {}", b.remaining_s);

    // Idle battery: unknown, not years.
    let mut r = Rig::new(&[(params::CAPACITY_AH, Value::F32(10.0))]);
    r.run(100, sample(12.0, 0.0));
    assert_eq!(r.app.battery().remaining_s, UNKNOWN_REMAINING);
    // Capacity not set: unknown.
    let mut r = Rig::new(&[]);
    r.run(100, sample(12.0, 3.0));
    assert_eq!(r.app.battery().remaining_s, UNKNOWN_REMAINING);
}

#[test]
fn battery_and_state_are_published_at_the_rate_parameter() {
    let mut r = Rig::new(&[]);
    r.run(1000, sample(12.0, 1.0));
    let times: Vec<u64> = r.batteries.iter().map(|(t, _)| *t).collect();
    assert_eq!(times, (0..10).map(|i| i * 100_000).collect::<Vec<_>>(), "10 Hz by default");
    assert_eq!(r.states.len(), 10);
    assert!(r.states.iter().all(|s| s.output_on && s.latched == 0 && !s.under_voltage));
    assert!((r.states[9].bus_voltage - 5.0).abs() < 0.002);

    r.params.set(params::BATTERY_RATE_HZ, Value::U32(50)).unwrap();
    r.batteries.clear();
    r.run(1000, sample(12.0, 1.0));
    assert_eq!(r.batteries.len(), 50);
    let ep = r.app.endpoints();
    assert_eq!(ep.battery.publisher.class(), Class::NonRealTime);
}

#[test]
fn over_current_fires_after_its_time_and_switches_the_output_off_latched() {
    let mut r = Rig::new(&[
        (params::OC_THRESHOLD_A, Value::F32(5.0)),
        (params::OC_TIME_MS, Value::U32(50)),
    ]);
    assert!(r.run(1000, sample(12.0, 4.0)).bus_en);
    assert!(r.events.is_empty());

    // 6 A from t = 1000 ms: trips on the step 50 ms later, not before.
    assert!(r.run(50, sample(12.0, 6.0)).bus_en, "still on at 1049 ms");
    let c = r.run(1, sample(12.0, 6.0));
    assert!(!c.bus_en && c.led_fault, "off at 1050 ms");
    assert_eq!(r.kinds(), [(OVER_CURRENT, 0), (OUTPUT_OFF, CAUSE_OVER_CURRENT)]);
    assert_eq!(r.events[0].0, 1_050_000);
    assert!((r.events[0].1.current - 6.0).abs() < 0.002, "the tripping current");
    assert_eq!(
        r.app.endpoints().event.publisher.class(),
        Class::AsyncRealTime { deadline_us: 10_000 }
    );

    // Latched: stays off when the current is gone.
    r.events.clear();
    assert!(!r.run(500, sample(12.0, 0.0)).bus_en);
    assert!(r.events.is_empty());
    assert_eq!(r.states.last().unwrap().latched, CAUSE_OVER_CURRENT);

    // An off command does not clear it; an on command does.
    r.command(false);
    assert!(!r.run(10, sample(12.0, 0.0)).bus_en);
    r.command(true);
    assert!(r.run(10, sample(12.0, 0.0)).bus_en);
    assert_eq!(r.kinds(), [(OUTPUT_ON, CAUSE_COMMAND)]);
    assert!(!r.last.led_fault);
}

#[test]
fn a_short_spike_does_not_trip() {
    let mut r = Rig::new(&[(params::OC_TIME_MS, Value::U32(20))]);
    for _ in 0..10 {
        r.run(15, sample(12.0, 10.0));
        r.run(1, sample(12.0, 1.0));
    }
    assert!(r.last.bus_en);
    assert!(r.events.is_empty());
}

#[test]
fn under_voltage_has_hysteresis() {
    let mut r = Rig::new(&[
        (params::FILTER_TAU_MS, Value::U32(10)),
        (params::UV_THRESHOLD_V, Value::F32(10.0)),
        (params::UV_HYSTERESIS_V, Value::F32(0.5)),
    ]);
    r.run(200, sample(12.0, 1.0));
    r.run(200, sample(9.8, 1.0));
    assert_eq!(r.kinds(), [(UNDER_VOLTAGE, 0)]);
    assert!((r.events[0].1.voltage - 10.0).abs() < 0.05, "reported as it crosses");
    assert!(r.last.led_fault && r.last.bus_en, "reported, the output stays on");
    r.run(200, sample(10.1, 1.0));
    r.run(200, sample(9.9, 1.0));
    r.run(200, sample(10.4, 1.0));
    assert_eq!(r.events.len(), 1, "no chatter inside the hysteresis band");
    r.run(200, sample(10.6, 1.0));
    assert_eq!(r.kinds(), [(UNDER_VOLTAGE, 0), (VOLTAGE_RECOVERED, 0)]);
    assert!(!r.last.led_fault);
}

#[test]
fn no_under_voltage_event_at_boot() {
    let mut r = Rig::new(&[]);
    r.run(100, sample(12.0, 0.5));
    assert!(r.events.is_empty(), "the filter starts at the first sample, not at 0 V");
}

#[test]
fn the_power_command_switches_the_output() {
    let mut r = Rig::new(&[]);
    assert!(r.run(10, sample(12.0, 1.0)).bus_en, "on at boot");
    r.command(false);
    assert!(!r.run(1, sample(12.0, 1.0)).bus_en);
    r.command(false);
    r.run(10, sample(12.0, 0.0));
    r.command(true);
    assert!(r.run(1, sample(12.0, 0.0)).bus_en);
    assert_eq!(r.kinds(), [(OUTPUT_OFF, CAUSE_COMMAND), (OUTPUT_ON, CAUSE_COMMAND)]);
}

#[test]
fn an_efuse_fault_switches_the_output_off_latched() {
    let mut r = Rig::new(&[]);
    r.run(10, sample(12.0, 1.0));
    let fault = Sample { bus_fault: true, ..sample(12.0, 1.0) };
    assert!(r.run(2, fault).bus_en, "debounced");
    assert!(!r.run(1, fault).bus_en);
    assert_eq!(r.kinds(), [(OUTPUT_OFF, CAUSE_EFUSE)]);
    assert!(!r.run(100, sample(12.0, 0.0)).bus_en, "latched after the flag clears");
    r.command(true);
    assert!(r.run(10, sample(12.0, 0.0)).bus_en);
}

#[test]
fn instance_names_the_node_and_topics_and_the_psu_is_rank_0() {
    let mut r = Rig::new(&[(params::INSTANCE, Value::U32(2))]);
    let ep = *r.app.endpoints();
    assert_eq!(ep.names.battery, "psu2/battery");
    use r2p_middleware::TopicInfo;
    assert_eq!(ep.event.topic.name(), "psu2/event");
    assert_eq!(ep.power.topic.name(), "psu2/power");
    let cfg = node_config([7; 12], r.params);
    assert_eq!((cfg.name, cfg.rank), ("psu2", Some(0)));
    r.run(1, sample(12.0, 0.0));
}

#[test]
fn out_of_range_parameters_are_refused_and_not_applied() {
    let r = Rig::new(&[]);
    assert_eq!(r.params.set(params::OC_THRESHOLD_A, Value::F32(14.0)), Err(ParamFault::OutOfRange));
    assert_eq!(r.params.set(params::OC_TIME_MS, Value::U32(0)), Err(ParamFault::OutOfRange));
    assert_eq!(r.params.get(params::OC_THRESHOLD_A), Ok(Value::F32(5.0)));
}
