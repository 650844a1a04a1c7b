//! The application driven through `App::step`, as the MCU and the emulated board drive it.

use std::boxed::Box;
use std::vec::Vec;

use r2p_management::message::Value;
use r2p_middleware::{Subscriber, TopicInfo};
use r2p_module::leds::Status;
use r2p_node::{Node, ParamStore, RamParams};

use crate::endpoints::{COUNT_TOPIC, SPARE_QUEUE};
use crate::params::{COUNT, DEFAULTS, RATE_HZ};
use crate::{node_config, App, Endpoints, Sample};

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

/// Runs `ms` one-millisecond steps from `from_ms`; returns (step time in ms, count) of each
/// message published.
fn run(
    app: &mut App<'static>,
    sub: &Subscriber<'static, u32, SPARE_QUEUE>,
    from_ms: u64,
    ms: u64,
) -> Vec<(u64, u32)> {
    let mut out = Vec::new();
    for t in from_ms..from_ms + ms {
        app.step(t * 1000, &Sample::default());
        while let Some(m) = sub.try_recv() {
            out.push((t, *m));
        }
    }
    out
}

fn rig() -> (App<'static>, &'static RamParams<COUNT>, &'static Subscriber<'static, u32, SPARE_QUEUE>)
{
    let params = leak(RamParams::new(DEFAULTS));
    let ep = Endpoints::leak();
    let sub = leak(Subscriber::new());
    ep.count.topic.subscribe(sub).unwrap();
    (App::new(ep, params), params, sub)
}

#[test]
fn count_is_published_at_rate_hz_with_the_steps_run() {
    let (mut app, params, sub) = rig();
    let got = run(&mut app, sub, 0, 1000);
    // 10 Hz by default: at 0, 100, …, 900 ms, carrying the number of steps run so far.
    assert_eq!(got, (0..10).map(|i| (i * 100, i as u32 * 100 + 1)).collect::<Vec<_>>());
    params.set(RATE_HZ, Value::U32(50)).unwrap();
    let got = run(&mut app, sub, 1000, 100);
    assert_eq!(got.iter().map(|g| g.0).collect::<Vec<_>>(), [1000, 1020, 1040, 1060, 1080]);
}

#[test]
fn a_stall_does_not_cause_a_burst() {
    let (mut app, _, sub) = rig();
    run(&mut app, sub, 0, 1);
    // The next step comes 550 ms late: one message, then one period on.
    let got = run(&mut app, sub, 550, 201);
    assert_eq!(got.iter().map(|g| g.0).collect::<Vec<_>>(), [550, 650, 750]);
}

#[test]
fn leds_show_the_node_state() {
    let (mut app, _, _) = rig();
    let idle = app.step(0, &Sample::default());
    let running = Status { running: true, synced: true, traffic: true, ..Status::default() };
    let on = app.step(1000, &Sample { status: running });
    assert_ne!(idle, on, "the LEDs follow the node's state");
    let faulty = app.step(2000, &Sample { status: Status { fault: true, ..running } });
    assert!(faulty.led_fault && !on.led_fault);
}

#[test]
fn the_node_exports_the_topic_under_the_module_name() {
    let (app, params, _) = rig();
    let mut node: Node<'static, 4, 4, 8, 4, 64> = Node::new(node_config([1; 12]), params).unwrap();
    app.register(&mut node).unwrap();
    assert!(app.register(&mut node).is_err(), "exported once; a second export of it is refused");
    assert_eq!(node_config([1; 12]).name, crate::NAME);
    assert_eq!(app.endpoints().count.topic.name(), COUNT_TOPIC);
    assert!(COUNT_TOPIC.starts_with(crate::NAME));
    assert_eq!(params.get(RATE_HZ), Ok(Value::U32(10)));
}
