//! RTCAN master failover measured on the virtual bus (issue 22's figures; `make bench` prints
//! them, no test asserts them): the demo's three boards (`r2p_emu::demo`: the master M of rank
//! 0, A publishing an HRT setpoint every 20 ms, B of rank 1 subscribing to it), the master
//! powered off at a random instant after the stream runs, and from B's side:
//!
//! - **takeover**: from the last sync of the dead master to the first sync of the new one, in
//!   cycles;
//! - **HRT cycles lost**: the longest gap between two setpoints B received around the death,
//!   less the stream's period, in cycles (what the control loop behind B goes without).
//!
//! Deaths are spread uniformly over 2 cycles (where in the cycle the master dies) with one
//! virtual-bus seed each, twice: from 3 s, when the standby trusts its copy of the calendar
//! (it predicted a hyperperiod of the master's masks) and continues the cycle, and from 600 ms,
//! before it does, when it starts a new calendar after the rank-ordered delays and every node
//! registers again (the rule before issue 22's failover, measured in the same run). Prints one
//! JSON object: the count, and min / median / p99 / max of each measure for each case.

use std::cell::RefCell;
use std::rc::Rc;

use r2p_emu::demo::{tdma, DemoNode};
use r2p_emu::{Mode, Sim};
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_node::{NoParams, RemotePublisher, RemoteSubscriber};
use r2p_vbus::Config;
use rtcan::failover::Role;
use rtcan::Micros;

const MS: u64 = 1_000_000;
const CYCLE_NS: u64 = 10_000_000;
/// The HRT stream's period: every other cycle.
const PERIOD_US: u64 = 20_000;

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

/// One run: the master dies at `death_ns`; returns (takeover cycles, HRT cycles lost).
fn run(seed: u64, death_ns: u64) -> (f64, f64) {
    let a_topic: &'static Topic<'static, u32, { pool_size(&[2], 1) }, 1> =
        leak(Topic::new("setpoint", 0));
    let a_pub = leak(Publisher::new(a_topic, Class::SyncRealTime { period_us: 20_000 }));
    let a_out: &'static RemoteSubscriber<'static, u32, 2> = leak(RemoteSubscriber::new(a_pub));
    a_topic.subscribe(a_out).unwrap();
    let b_topic: &'static Topic<'static, u32, { pool_size(&[16], 1) }, 1> =
        leak(Topic::new("setpoint", 0));
    let b_pub = leak(Publisher::new(b_topic, Class::NonRealTime));
    let b_in = leak(RemotePublisher::new(b_pub, b_topic));
    let b_sub: &'static Subscriber<'static, u32, 16> = leak(Subscriber::new());
    b_topic.subscribe(b_sub).unwrap();

    let mut sim: Sim<'static, DemoNode> =
        Sim::new(4, Config { seed, ..Config::default() }, Mode::Tdma);
    let m = DemoNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = DemoNode::new(tdma(2, "motor", None), &NoParams).unwrap();
    let mut b = DemoNode::new(tdma(3, "control", Some(1)), &NoParams).unwrap();
    a.export(a_out).unwrap();
    b.import(b_in).unwrap();
    let mut k = 0u32;
    let app_a = move |now: Micros, _: &mut DemoNode| {
        if now >= 200_000 && now.is_multiple_of(PERIOD_US) {
            let _ = a_pub.publish_with(|v| *v = k);
            k += 1;
        }
    };
    let seen = Rc::new(RefCell::new(Vec::<Micros>::new()));
    let s = seen.clone();
    let app_b = move |now: Micros, _: &mut DemoNode| {
        while b_sub.try_recv().is_some() {
            s.borrow_mut().push(now);
        }
    };
    sim.add_board(m, 0, None);
    sim.add_board(a, 1, Some(Box::new(app_a)));
    sim.add_board(b, 2, Some(Box::new(app_b)));
    sim.run_until(death_ns);
    sim.power(0, false);
    sim.run_until(death_ns + 1_500 * MS);
    assert_eq!(sim.node(2).role(), Role::Master, "the standby took over");

    let syncs = r2p_emu::sync_starts(sim.bus());
    let last_old = syncs.iter().filter(|s| s.1 == 0).map(|s| s.0).max().unwrap();
    let first_new = syncs.iter().filter(|s| s.1 == 2).map(|s| s.0).min().unwrap();
    let takeover = (first_new - last_old) as f64 / CYCLE_NS as f64;
    let seen = seen.borrow();
    let death_us = death_ns / 1000;
    let gap = seen
        .windows(2)
        .filter(|w| w[1] > death_us && w[0] < death_us + 1_500_000)
        .map(|w| w[1] - w[0])
        .max()
        .unwrap_or(1_500_000);
    let lost = (gap.saturating_sub(PERIOD_US)) as f64 / (CYCLE_NS / 1000) as f64;
    (takeover, lost)
}

fn summary(mut v: Vec<f64>) -> serde_json::Value {
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    serde_json::json!({"min": at(0.0), "median": at(0.5), "p99": at(0.99), "max": at(1.0)})
}

/// `runs` deaths spread over two cycles from `from_ns`: the summaries of both measures.
fn deaths(runs: u64, from_ns: u64) -> serde_json::Value {
    let (mut takeovers, mut lost) = (Vec::new(), Vec::new());
    for i in 0..runs {
        // Uniform over two cycles, by a Weyl sequence: deterministic, evenly spread.
        let frac = (i as f64 * 0.618_033_988_749_895).fract();
        let (t, l) = run(i + 1, from_ns + (frac * 2.0 * CYCLE_NS as f64) as u64);
        takeovers.push(t);
        lost.push(l);
    }
    serde_json::json!({"takeover_cycles": summary(takeovers), "hrt_cycles_lost": summary(lost)})
}

fn main() {
    let runs: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1000);
    println!(
        "{}",
        serde_json::json!({
            "bench": "rtcan_failover",
            "runs": runs,
            // The stream runs from about 300 ms; the standby trusts its copy after 2.56 s.
            "continuing": deaths(runs, 3_000 * MS),
            "new_calendar": deaths(runs, 600 * MS),
        })
    );
}
