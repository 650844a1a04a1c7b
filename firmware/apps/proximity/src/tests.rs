//! The application driven through `App::step` with ADC codes made from the sensors' curves,
//! as the MCU and the emulated board drive it.

use std::boxed::Box;
use std::vec::Vec;

use r2p_management::message::{ParamFault, Value};
use r2p_middleware::{Class, Subscriber, TopicInfo};
use r2p_msgs::{Obstacle, Proximity};
use r2p_node::{ParamStore, RamParams};

use crate::channel::{
    NO_SENSOR_SAMPLES, STATUS_NO_SENSOR, STATUS_OK, STATUS_TOO_FAR, STATUS_TOO_NEAR,
};
use crate::curves::{curve, Curve, GP2Y0A02YK, GP2Y0A21YK, MAXSONAR_LV_EZ_5V, M_PER_INCH};
use crate::endpoints::SPARE_QUEUE;
use crate::frontend::{counts, LSB_V};
use crate::params::{self, COUNT, DEFAULTS, SENSOR0};
use crate::{node_config, App, Command, Endpoints, Sample};

struct Rig {
    app: App<'static>,
    params: &'static RamParams<COUNT>,
    ranges: &'static Subscriber<'static, Proximity, SPARE_QUEUE>,
    obstacle: &'static Subscriber<'static, Obstacle, SPARE_QUEUE>,
    published: Vec<(u64, Proximity)>,
    obstacles: Vec<(u64, Obstacle)>,
    now_us: u64,
    last: Command,
}

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

impl Rig {
    fn new(sensors: [u32; 4]) -> Self {
        let params = leak(RamParams::new(DEFAULTS));
        for (c, s) in sensors.iter().enumerate() {
            params.set(SENSOR0 + c as u16, Value::U32(*s)).unwrap();
        }
        let ep = Endpoints::leak(params);
        let ranges = leak(Subscriber::new());
        let obstacle = leak(Subscriber::new());
        ep.ranges.topic.subscribe(ranges).unwrap();
        ep.obstacle.topic.subscribe(obstacle).unwrap();
        Self {
            app: App::new(ep, params),
            params,
            ranges,
            obstacle,
            published: Vec::new(),
            obstacles: Vec::new(),
            now_us: 0,
            last: Command::default(),
        }
    }

    fn run(&mut self, ms: u64, adc: [u16; 4]) -> Proximity {
        self.run_sample(ms, Sample { adc, ..Sample::default() })
    }

    fn run_sample(&mut self, ms: u64, sample: Sample) -> Proximity {
        for _ in 0..ms {
            self.last = self.app.step(self.now_us, &sample);
            while let Some(m) = self.ranges.try_recv() {
                self.published.push((self.now_us, *m));
            }
            while let Some(m) = self.obstacle.try_recv() {
                self.obstacles.push((self.now_us, *m));
            }
            self.now_us += 1000;
        }
        self.app.ranges()
    }
}

/// The ADC code a sensor on `curve` gives for a target at `d` m.
fn code(curve: &Curve, d: f32) -> u16 {
    counts(curve.volts_at(d))
}

/// Half an LSB over the curve's flattest calibrated slope: the round trip's quantisation bound.
fn quantisation_m(c: &Curve) -> f32 {
    let slope = c
        .points
        .windows(2)
        .filter(|w| w[0].0 >= c.min_range_m && w[1].0 <= c.max_range_m)
        .map(|w| ((w[1].1 - w[0].1) / (w[1].0 - w[0].0)).abs())
        .fold(f32::INFINITY, f32::min);
    0.5 * LSB_V / slope
}

#[test]
fn distance_to_voltage_to_distance_round_trips_within_quantisation() {
    for (kind, c) in [(1, GP2Y0A21YK), (2, GP2Y0A02YK), (3, MAXSONAR_LV_EZ_5V)] {
        let bound = quantisation_m(&c) + 1e-5;
        assert!(bound < 0.0015, "{}: {bound}", c.name);
        for i in 0..=20 {
            let d =
                c.min_range_m + 0.001 + (c.max_range_m - c.min_range_m - 0.002) * i as f32 / 20.0;
            let mut r = Rig::new([kind, 0, 0, 0]);
            let p = r.run(500, [code(&c, d), 0, 0, 0]);
            assert_eq!(p.status[0], STATUS_OK, "{} at {d} m", c.name);
            assert!(
                (p.distance[0] - d).abs() <= bound,
                "{} at {d} m read {}",
                c.name,
                p.distance[0]
            );
        }
    }
}

#[test]
fn four_channels_four_sensor_types() {
    let mut r = Rig::new([1, 2, 3, 0]);
    let adc = [code(&GP2Y0A21YK, 0.3), code(&GP2Y0A02YK, 1.0), code(&MAXSONAR_LV_EZ_5V, 2.0), 2000];
    let p = r.run(500, adc);
    assert_eq!(p.status, [STATUS_OK, STATUS_OK, STATUS_OK, STATUS_NO_SENSOR]);
    for (got, want) in p.distance[..3].iter().zip([0.3, 1.0, 2.0]) {
        assert!((got - want).abs() < 0.002, "{got} vs {want}");
    }
    assert!(p.distance[3].is_nan(), "type 0 (none) is not a distance even with a voltage");
}

#[test]
fn out_of_range_is_a_status_with_nan_not_a_distance() {
    let mut r = Rig::new([1, 1, 2, 3]);
    let adc = [
        code(&GP2Y0A21YK, 0.07), // 3.05 V: above the 10 cm output
        counts(0.30),            // below the 80 cm output
        code(&GP2Y0A02YK, 0.17), // between the peak and 20 cm
        code(&MAXSONAR_LV_EZ_5V, 254.0 * M_PER_INCH), // nothing in view
    ];
    let p = r.run(500, adc);
    assert_eq!(p.status, [STATUS_TOO_NEAR, STATUS_TOO_FAR, STATUS_TOO_NEAR, STATUS_TOO_FAR]);
    assert!(p.distance.iter().all(|d| d.is_nan()), "{:?}", p.distance);
    let mut r = Rig::new([3, 0, 0, 0]);
    let p = r.run(500, [code(&MAXSONAR_LV_EZ_5V, 3.0 * M_PER_INCH), 0, 0, 0]);
    assert_eq!(p.status[0], STATUS_TOO_NEAR, "the sonar reads 6 in for 3 in: too near");
}

#[test]
fn a_disconnected_sensor_reads_no_sensor_not_zero() {
    let mut r = Rig::new([1, 3, 1, 1]);
    // Pulled down to 0 V (plus an LSB of noise).
    let p = r.run(500, [0, 1, 0, 1]);
    assert_eq!(p.status, [STATUS_NO_SENSOR; 4]);
    assert!(p.distance.iter().all(|d| d.is_nan()));
    assert!(r.published.iter().all(|(_, m)| m.status == [STATUS_NO_SENSOR; 4]));
    assert!(r.obstacles.is_empty(), "no sensor is no obstacle");

    // Unplugged while reading: the last reading holds, then "no sensor" at the 12th sample
    // (the median passes 0 V at the third, the tenth below 30 mV decides).
    let mut r = Rig::new([1, 0, 0, 0]);
    r.run(500, [code(&GP2Y0A21YK, 0.5), 0, 0, 0]);
    let held = r.run(2 + u64::from(NO_SENSOR_SAMPLES) - 1, [0; 4]);
    assert_eq!(held.status[0], STATUS_OK);
    assert!((held.distance[0] - 0.5).abs() < 0.002);
    assert_eq!(r.run(1, [0; 4]).status[0], STATUS_NO_SENSOR);
}

#[test]
fn the_median_rejects_spikes() {
    let mut r = Rig::new([1, 0, 0, 0]);
    let steady = code(&GP2Y0A21YK, 0.30);
    let d0 = r.run(300, [steady, 0, 0, 0]).distance[0];
    let mut worst = 0.0f32;
    for i in 0..200 {
        // A full-scale spike, then a drop to 0 V, two samples each, every 10 ms.
        let spike = match i % 10 {
            0 | 1 => 4095,
            5 | 6 => 0,
            _ => steady,
        };
        let d = r.run(1, [spike, 0, 0, 0]).distance[0];
        worst = worst.max((d - d0).abs());
    }
    assert!(worst < 0.0005, "spikes moved the reading by {worst} m");
    assert!(r.obstacles.is_empty(), "a spike is not an obstacle");
}

#[test]
fn the_low_pass_smooths_noise() {
    let mut r = Rig::new([1, 0, 0, 0]);
    let c = code(&GP2Y0A21YK, 0.50);
    // ±8 LSB of alternating noise at 0.5 m (about ±1.5 cm if unfiltered).
    let mut worst = 0.0f32;
    for i in 0..1000u32 {
        let n = [c + 8, c + 8, c + 8, c - 8, c - 8, c - 8][(i % 6) as usize];
        let d = r.run(1, [n, 0, 0, 0]).distance[0];
        if i > 300 {
            worst = worst.max((d - 0.5).abs());
        }
    }
    assert!(worst < 0.005, "{worst}");
}

#[test]
fn obstacle_event_is_srt_with_the_deadline_once_per_approach() {
    let mut r = Rig::new([1, 1, 0, 0]);
    assert_eq!(
        r.app.endpoints().obstacle.publisher.class(),
        Class::AsyncRealTime { deadline_us: 10_000 }
    );
    let far = code(&GP2Y0A21YK, 0.50);
    r.run(500, [far, far, 0, 0]);
    assert!(r.obstacles.is_empty());

    // Channel 1 sees a target at 0.2 m (threshold 0.25 m).
    let t0 = r.now_us;
    r.run(1000, [far, code(&GP2Y0A21YK, 0.20), 0, 0]);
    assert_eq!(r.obstacles.len(), 1, "not repeated while the obstacle stays");
    let (t, o) = r.obstacles[0];
    assert_eq!(o.channel, 1);
    assert!(o.distance < 0.25 && o.distance > 0.2, "reported as it crosses: {}", o.distance);
    // Median (2 samples) + one low-pass time constant (10 ms) or so.
    assert!(t - t0 <= 15_000, "within 15 ms of the step: {} µs", t - t0);

    // Inside the hysteresis band (0.25–0.30 m) and back: quiet.
    r.run(300, [far, code(&GP2Y0A21YK, 0.28), 0, 0]);
    r.run(300, [far, code(&GP2Y0A21YK, 0.20), 0, 0]);
    assert_eq!(r.obstacles.len(), 1);
    // Clear (0.4 m), then near again: a second event.
    r.run(300, [far, code(&GP2Y0A21YK, 0.40), 0, 0]);
    r.run(300, [far, code(&GP2Y0A21YK, 0.15), 0, 0]);
    assert_eq!(r.obstacles.len(), 2);
    assert!((r.obstacles[1].1.distance - 0.15).abs() < 0.1);

    // Too near to measure is an obstacle at (at most) the sensor's nearest distance.
    let mut r = Rig::new([1, 0, 0, 0]);
    r.run(300, [code(&GP2Y0A21YK, 0.07), 0, 0, 0]);
    let o: Vec<_> = r.obstacles.iter().map(|(_, o)| (o.channel, o.distance)).collect();
    assert_eq!(o, [(0, 0.10)]);
}

#[test]
fn the_obstacle_threshold_and_deadline_are_parameters() {
    let params = leak(RamParams::new(DEFAULTS));
    params.set(params::OBSTACLE_DEADLINE_MS, Value::U32(3)).unwrap();
    let ep = Endpoints::leak(params);
    assert_eq!(ep.obstacle.publisher.class(), Class::AsyncRealTime { deadline_us: 3_000 });

    let mut r = Rig::new([2, 0, 0, 0]);
    r.params.set(params::OBSTACLE_M, Value::F32(1.0)).unwrap();
    r.run(500, [code(&GP2Y0A02YK, 0.9), 0, 0, 0]);
    assert_eq!(r.obstacles.len(), 1);
    assert!((r.obstacles[0].1.distance - 0.9).abs() < 0.002, "{}", r.obstacles[0].1.distance);
}

#[test]
fn ranges_are_published_at_the_rate_parameter() {
    let mut r = Rig::new([1, 0, 0, 0]);
    r.run(1000, [code(&GP2Y0A21YK, 0.3), 0, 0, 0]);
    let times: Vec<u64> = r.published.iter().map(|(t, _)| *t).collect();
    assert_eq!(times, (0..20).map(|i| i * 50_000).collect::<Vec<_>>(), "20 Hz by default");
    assert_eq!(r.published[0].1.status[0], STATUS_NO_SENSOR, "powering up at boot");
    assert_eq!(r.published[19].1.status[0], STATUS_OK);
    r.params.set(params::RATE_HZ, Value::U32(100)).unwrap();
    r.published.clear();
    r.run(1000, [code(&GP2Y0A21YK, 0.3), 0, 0, 0]);
    assert_eq!(r.published.len(), 100);
    assert_eq!(r.app.endpoints().ranges.publisher.class(), Class::NonRealTime);
}

#[test]
fn sensor_power_follows_its_parameter_and_sensors_settle_after_it() {
    let mut r = Rig::new([1, 3, 0, 0]);
    let adc = [code(&GP2Y0A21YK, 0.3), code(&MAXSONAR_LV_EZ_5V, 1.0), 0, 0];
    r.run(500, adc);
    assert!(r.last.sensor_power);
    r.params.set(params::SENSOR_POWER, Value::Bool(false)).unwrap();
    let p = r.run(1, adc);
    assert!(!r.last.sensor_power);
    assert_eq!(p.status[..2], [STATUS_NO_SENSOR; 2], "sensors off");
    r.params.set(params::SENSOR_POWER, Value::Bool(true)).unwrap();
    assert_eq!(r.run(59, adc).status[0], STATUS_NO_SENSOR, "Sharp powering up");
    assert_eq!(r.run(2, adc).status[0], STATUS_OK);
    assert_eq!(r.run(330, adc).status[1], STATUS_NO_SENSOR, "sonar powering up (400 ms)");
    assert_eq!(r.run(20, adc).status[1], STATUS_OK);
}

#[test]
fn the_supply_switch_fault_flag_is_read_each_step_and_published_in_ranges() {
    let mut r = Rig::new([1, 1, 1, 1]);
    let adc = [code(&GP2Y0A21YK, 0.5); 4];
    assert!(!r.run(200, adc).supply_fault);
    let published = r.published.len();
    let p = r.run_sample(1, Sample { adc, supply_fault: true, ..Sample::default() });
    assert!(p.supply_fault, "read in the step it is asserted");
    r.run_sample(200, Sample { adc, supply_fault: true, ..Sample::default() });
    let after: Vec<_> = r.published[published..].iter().map(|(_, m)| m.supply_fault).collect();
    assert!(!after.is_empty() && after.iter().all(|f| *f), "every ranges carries it: {after:?}");
    assert!(!r.run(1, adc).supply_fault, "and it clears with the flag");
}

#[test]
fn changing_a_sensor_type_rereads_the_channel() {
    let mut r = Rig::new([1, 0, 0, 0]);
    let v = GP2Y0A02YK.volts_at(1.0);
    let p = r.run(500, [counts(v), 0, 0, 0]);
    assert!((p.distance[0] - GP2Y0A21YK.distance_at(v).unwrap()).abs() < 0.002);
    r.params.set(SENSOR0, Value::U32(2)).unwrap();
    let p = r.run(100, [counts(v), 0, 0, 0]);
    assert!((p.distance[0] - 1.0).abs() < 0.003, "{}", p.distance[0]);
    assert_eq!(curve(2).unwrap().name, "GP2Y0A02YK0F");
}

#[test]
fn instance_names_the_node_and_topics() {
    let params = leak(RamParams::new(DEFAULTS));
    params.set(params::INSTANCE, Value::U32(1)).unwrap();
    let ep = Endpoints::leak(params);
    assert_eq!(ep.ranges.topic.name(), "proximity1/ranges");
    assert_eq!(ep.obstacle.topic.name(), "proximity1/obstacle");
    assert_eq!(node_config([1; 12], params).name, "proximity1");
    assert_eq!(node_config([1; 12], params).rank, None);
}

#[test]
fn out_of_range_parameters_are_refused_and_not_applied() {
    let r = Rig::new([1, 1, 1, 1]);
    assert_eq!(r.params.set(SENSOR0 + 3, Value::U32(7)), Err(ParamFault::OutOfRange));
    assert_eq!(r.params.set(params::RATE_HZ, Value::U32(1000)), Err(ParamFault::OutOfRange));
    assert_eq!(r.params.get(SENSOR0 + 3), Ok(Value::U32(1)));
}
