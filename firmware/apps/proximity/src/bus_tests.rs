//! The proximity module on a virtual CAN bus with another module (the paper's obstacle
//! avoidance, Listing 2's side): ranges and obstacle events reach it, the obstacle as SRT within
//! its deadline, and its PARAM_SETs are checked.

use std::boxed::Box;
use std::vec::Vec;

use r2p_management::message::{ParamFault, Value};
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_msgs::{Obstacle, Proximity};
use r2p_node::{Event, NoParams, Node, NodeConfig, ParamStore, RamParams, RemotePublisher};
use r2p_vbus::{Bus, Config};

use crate::curves::GP2Y0A21YK;
use crate::frontend::counts;
use crate::params::{self, COUNT, DEFAULTS};
use crate::{node_config, App, Endpoints, Sample};

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

type Q4<T> = Topic<'static, T, { pool_size(&[4], 1) }, 1>;

struct Rig {
    bus: Bus,
    node: Node<'static, 2, 1, 32, 4, 64>,
    app: App<'static>,
    params: &'static RamParams<COUNT>,
    /// The other module.
    avoid: Node<'static, 1, 2, 32, 4, 64>,
    ranges: &'static Subscriber<'static, Proximity, 4>,
    obstacle: &'static Subscriber<'static, Obstacle, 4>,
    now_us: u64,
    events: Vec<Event>,
    /// (time received by the other module, message).
    obstacles: Vec<(u64, Obstacle)>,
}

impl Rig {
    fn new() -> Self {
        let params = leak(RamParams::new(DEFAULTS));
        let app = App::new(Endpoints::leak(params), params);
        let mut node = Node::new(node_config([1; 12], params), params).unwrap();
        app.register(&mut node).unwrap();

        let ranges_t: &Q4<Proximity> = leak(Topic::new("proximity/ranges", Proximity::default()));
        let ranges_p = leak(Publisher::new(ranges_t, Class::NonRealTime));
        let ranges = leak(Subscriber::new());
        ranges_t.advertise(ranges_p).unwrap();
        ranges_t.subscribe(ranges).unwrap();
        let obstacle_t: &Q4<Obstacle> = leak(Topic::new("proximity/obstacle", Obstacle::default()));
        let obstacle_p = leak(Publisher::new(obstacle_t, Class::NonRealTime));
        let obstacle = leak(Subscriber::new());
        obstacle_t.advertise(obstacle_p).unwrap();
        obstacle_t.subscribe(obstacle).unwrap();
        let mut avoid = Node::new(NodeConfig::new([2; 12], "avoid"), &NoParams).unwrap();
        avoid.import(leak(RemotePublisher::new(ranges_p, ranges_t))).unwrap();
        avoid.import(leak(RemotePublisher::new(obstacle_p, obstacle_t))).unwrap();

        Self {
            bus: Bus::new(2, Config::default()),
            node,
            app,
            params,
            avoid,
            ranges,
            obstacle,
            now_us: 0,
            events: Vec::new(),
            obstacles: Vec::new(),
        }
    }

    /// Runs `ms` milliseconds: the bus and both nodes every 100 µs, the application every 1 ms.
    fn run(&mut self, ms: u64, adc: [u16; 4]) {
        // vbus ports send their mailboxes in load order (bxCAN's TXFP = 1), as the node needs.
        let (mut p0, mut p1) = (self.bus.port(0), self.bus.port(1));
        for _ in 0..ms * 10 {
            self.bus.advance_to(self.now_us * 1000);
            self.node.poll(self.now_us, &mut p0);
            self.avoid.poll(self.now_us, &mut p1);
            while let Some(e) = self.avoid.next_event() {
                self.events.push(e);
            }
            while let Some(o) = self.obstacle.try_recv() {
                self.obstacles.push((self.now_us, *o));
            }
            if self.now_us.is_multiple_of(1000) {
                self.app.step(self.now_us, &Sample { adc, ..Sample::default() });
            }
            self.now_us += 100;
        }
    }
}

#[test]
fn the_obstacle_reaches_the_other_module_within_its_deadline() {
    let mut r = Rig::new();
    let far = counts(GP2Y0A21YK.volts_at(0.6));
    r.run(1000, [far; 4]);
    let mut got = Vec::new();
    while let Some(m) = r.ranges.try_recv() {
        got.push(*m);
    }
    assert!(!got.is_empty(), "ranges reached the other module");
    assert!(got.last().unwrap().distance.iter().all(|d| (d - 0.6).abs() < 0.002));

    // Channel 2 closes to 0.15 m: the app publishes within a few ms; the other module has it
    // within the 10 ms deadline of that.
    let published_before = r.app.endpoints().obstacle.publisher.stats().published;
    let t0 = r.now_us;
    let mut adc = [far; 4];
    adc[2] = counts(GP2Y0A21YK.volts_at(0.15));
    let mut published_at = None;
    for _ in 0..100 {
        r.run(1, adc);
        if published_at.is_none()
            && r.app.endpoints().obstacle.publisher.stats().published > published_before
        {
            published_at = Some(r.now_us - 1000);
        }
    }
    let published_at = published_at.expect("published");
    let (received_at, o) = r.obstacles[0];
    assert_eq!(r.obstacles.len(), 1);
    assert_eq!(o.channel, 2);
    assert!(received_at - published_at <= 10_000, "{} µs", received_at - published_at);
    assert!(published_at - t0 <= 15_000);
    assert_eq!(r.app.endpoints().obstacle.publisher.stats().deadline_misses, 0);
}

#[test]
fn an_out_of_range_param_set_over_the_bus_is_refused() {
    let mut r = Rig::new();
    r.run(500, [0; 4]);
    let id = r.node.node_id();
    r.avoid.set_param(id, params::SENSOR0 + 1, Value::U32(9)).unwrap();
    r.avoid.set_param(id, params::OBSTACLE_M, Value::F32(-1.0)).unwrap();
    r.avoid.set_param(id, params::SENSOR_POWER, Value::U32(0)).unwrap();
    r.run(30, [0; 4]);
    for (index, fault) in [
        (params::SENSOR0 + 1, ParamFault::OutOfRange),
        (params::OBSTACLE_M, ParamFault::OutOfRange),
        (params::SENSOR_POWER, ParamFault::WrongType),
    ] {
        assert!(
            r.events.contains(&Event::ParamError { from: id, index, fault }),
            "{index}: {:?}",
            r.events
        );
    }
    assert_eq!(r.params.get(params::SENSOR0 + 1), Ok(Value::U32(1)), "not applied");
    assert_eq!(r.params.get(params::OBSTACLE_M), Ok(Value::F32(0.25)));

    r.avoid.set_param(id, params::SENSOR_POWER, Value::Bool(false)).unwrap();
    r.run(30, [0; 4]);
    assert_eq!(r.params.get(params::SENSOR_POWER), Ok(Value::Bool(false)));
    assert!(!r.app.step(r.now_us, &Sample::default()).sensor_power, "applied at once");
}
