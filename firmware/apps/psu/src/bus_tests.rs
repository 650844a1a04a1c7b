//! The PSU on a virtual CAN bus with another module: its topics reach the other module, that
//! module's `power` command switches the output, and its PARAM_SETs are checked.

use std::boxed::Box;
use std::vec::Vec;

use r2p_management::message::{ParamFault, Value};
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_msgs::{Battery, BusPower, PsuEvent};
use r2p_node::{
    Event, NoParams, Node, NodeConfig, ParamStore, RamParams, RemotePublisher, RemoteSubscriber,
};
use r2p_vbus::{Bus, Config};

use crate::event::{CAUSE_COMMAND, OUTPUT_OFF};
use crate::frontend::{iin_counts, vin_counts, vout_counts};
use crate::params::{self, COUNT, DEFAULTS};
use crate::{node_config, App, Endpoints, Sample};

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

type Q4<T> = Topic<'static, T, { pool_size(&[4], 1) }, 1>;

/// The other module: imports `psu/battery` and `psu/event`, exports `psu/power`.
struct Tool {
    node: Node<'static, 1, 2, 32, 4, 64>,
    battery: &'static Subscriber<'static, Battery, 4>,
    event: &'static Subscriber<'static, PsuEvent, 4>,
    power_pub: &'static Publisher<'static, BusPower>,
}

impl Tool {
    fn new() -> Self {
        let battery_t: &Q4<Battery> = leak(Topic::new("psu/battery", Battery::default()));
        let battery_p = leak(Publisher::new(battery_t, Class::NonRealTime));
        let battery = leak(Subscriber::new());
        battery_t.advertise(battery_p).unwrap();
        battery_t.subscribe(battery).unwrap();
        let event_t: &Q4<PsuEvent> = leak(Topic::new("psu/event", PsuEvent::default()));
        let event_p = leak(Publisher::new(event_t, Class::NonRealTime));
        let event = leak(Subscriber::new());
        event_t.advertise(event_p).unwrap();
        event_t.subscribe(event).unwrap();
        let power_t: &Q4<BusPower> = leak(Topic::new("psu/power", BusPower::default()));
        let power_pub = leak(Publisher::new(power_t, Class::NonRealTime));
        let power_out = leak(RemoteSubscriber::<BusPower, 4>::new(power_pub));
        power_t.advertise(power_pub).unwrap();
        power_t.subscribe(power_out).unwrap();

        let mut node = Node::new(NodeConfig::new([2; 12], "tool"), &NoParams).unwrap();
        node.import(leak(RemotePublisher::new(battery_p, battery_t))).unwrap();
        node.import(leak(RemotePublisher::new(event_p, event_t))).unwrap();
        node.export(power_out).unwrap();
        Self { node, battery, event, power_pub }
    }
}

struct Rig {
    bus: Bus,
    psu_node: Node<'static, 4, 2, 32, 4, 64>,
    app: App<'static>,
    params: &'static RamParams<COUNT>,
    tool: Tool,
    now_us: u64,
    tool_events: Vec<Event>,
}

impl Rig {
    fn new() -> Self {
        let params = leak(RamParams::new(DEFAULTS));
        let app = App::new(Endpoints::leak(params), params);
        let mut psu_node = Node::new(node_config([1; 12], params), params).unwrap();
        app.register(&mut psu_node).unwrap();
        let bus = Bus::new(2, Config::default());
        Self { bus, psu_node, app, params, tool: Tool::new(), now_us: 0, tool_events: Vec::new() }
    }

    /// Runs `ms` milliseconds: the bus and both nodes every 100 µs, the application every 1 ms.
    fn run(&mut self, ms: u64, sample: Sample) -> bool {
        // vbus ports send their mailboxes in load order (bxCAN's TXFP = 1), as the node needs.
        let (mut p0, mut p1) = (self.bus.port(0), self.bus.port(1));
        let mut on = false;
        for _ in 0..ms * 10 {
            self.bus.advance_to(self.now_us * 1000);
            self.psu_node.poll(self.now_us, &mut p0);
            self.tool.node.poll(self.now_us, &mut p1);
            while let Some(e) = self.tool.node.next_event() {
                self.tool_events.push(e);
            }
            if self.now_us.is_multiple_of(1000) {
                on = self.app.step(self.now_us, &sample).bus_en;
            }
            self.now_us += 100;
        }
        on
    }
}

#[test]
fn another_module_reads_the_battery_and_switches_the_output() {
    let mut r = Rig::new();
    let s = Sample {
        vin: vin_counts(12.0),
        iin: iin_counts(1.5),
        vout: vout_counts(5.0),
        ..Sample::default()
    };
    assert!(r.run(1000, s));
    let mut got = Vec::new();
    while let Some(b) = r.tool.battery.try_recv() {
        got.push(*b);
    }
    assert!(!got.is_empty(), "battery reached the other module");
    let b = got.last().unwrap();
    assert!((b.voltage - 12.0).abs() < 0.01 && (b.current - 1.5).abs() < 0.01, "{b:?}");

    r.tool.power_pub.publish_with(|m| m.on = false).unwrap();
    assert!(!r.run(20, s), "switched off over the bus");
    let e = r.tool.event.try_recv().expect("the event came back");
    assert_eq!((e.kind, e.cause), (OUTPUT_OFF, CAUSE_COMMAND));
}

#[test]
fn an_out_of_range_param_set_over_the_bus_is_refused() {
    let mut r = Rig::new();
    let s = Sample { vin: vin_counts(12.0), ..Sample::default() };
    r.run(500, s);
    let psu = r.psu_node.node_id();
    r.tool.node.set_param(psu, params::OC_THRESHOLD_A, Value::F32(20.0)).unwrap();
    r.run(20, s);
    assert!(r.tool_events.contains(&Event::ParamError {
        from: psu,
        index: params::OC_THRESHOLD_A,
        fault: ParamFault::OutOfRange
    }));
    assert_eq!(r.params.get(params::OC_THRESHOLD_A), Ok(Value::F32(5.0)), "not applied");

    r.tool.node.set_param(psu, params::OC_THRESHOLD_A, Value::F32(6.0)).unwrap();
    r.run(20, s);
    assert!(r.tool_events.contains(&Event::ParamValue {
        from: psu,
        index: params::OC_THRESHOLD_A,
        value: Value::F32(6.0)
    }));
    assert_eq!(r.params.get(params::OC_THRESHOLD_A), Ok(Value::F32(6.0)));
}
