//! The built-in demo robot `r2p-emu demo` runs: three boards in TDMA mode (10 ms cycles of 40
//! slots at 1 Mbit/s) on ports 0–2 of a 4-port bus, port 3 spare for a bridge.
//!
//! - `psu` (rank 0): the master, sends the syncs;
//! - `motor`: publishes `setpoint` (u32, hard real time every 20 ms) and `scan` ([u32; 4], soft
//!   real time every 10 ms, 20 ms deadline) from 200 ms on;
//! - `control` (rank 1, the standby master): subscribes to both.
//!
//! Every board sends heartbeats on its management stream every 20 ms. Topics are `static`s, so
//! [`build`] works once per process.

use std::cell::Cell;
use std::rc::Rc;
use std::sync::atomic::{AtomicBool, Ordering};

use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_node::{NoParams, Node, NodeConfig, RemotePublisher, RemoteSubscriber};
use r2p_vbus::Config;
use rtcan::{CycleConfig, Micros};

use crate::{Mode, Sim};

/// The demo's node runtime.
pub type DemoNode = Node<'static, 2, 2, 32, 4, 64>;
/// The demo's bus ports: boards on 0–2, port 3 spare.
pub const PORTS: usize = 4;
/// The spare port (for a bridge).
pub const SPARE_PORT: usize = 3;
/// 10 ms cycles of 40 slots of 250 µs at 1 Mbit/s.
pub const CYCLE: CycleConfig = CycleConfig { bit_rate: 1_000_000, cycle_us: 10_000, slots: 40 };

/// What the `control` board received.
#[derive(Clone, Default)]
pub struct Received {
    /// `setpoint` values received.
    pub setpoints: Rc<Cell<u64>>,
    /// `scan` values received.
    pub scans: Rc<Cell<u64>>,
}

/// A test unique ID: `n` in the last four bytes.
pub fn uid(n: u32) -> [u8; 12] {
    let mut u = [0u8; 12];
    u[8..].copy_from_slice(&n.to_be_bytes());
    u
}

/// The configuration of the demo's boards (and of the tests' rigs): unique ID `n`, TDMA on
/// [`CYCLE`], heartbeats every 20 ms, up to 4 HRT slots per cycle.
pub fn tdma(n: u32, name: &'static str, rank: Option<u8>) -> NodeConfig {
    NodeConfig {
        heartbeat_period_us: 20_000,
        request_timeout_us: 30_000,
        cycle: CYCLE,
        rank,
        hrt_slots: 4,
        slot_lead_us: r2p_node::MODULE_SLOT_LEAD_US,
        sync_lead_us: r2p_node::MODULE_SYNC_LEAD_US,
        framed_leads: r2p_node::MODULE_FRAMED_LEADS,
        ..NodeConfig::new(uid(n), name)
    }
}

static BUILT: AtomicBool = AtomicBool::new(false);

/// The demo robot on a new bus with fault seed `seed`; `None` if it was built before in this
/// process (its topics are statics).
pub fn build(seed: u64) -> Option<(Sim<'static, DemoNode>, Received)> {
    static M_H: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("setpoint", 0);
    static M_HP: Publisher<'static, u32> =
        Publisher::new(&M_H, Class::SyncRealTime { period_us: 20_000 });
    static M_HO: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&M_HP);
    static M_S: Topic<'static, [u32; 4], { pool_size(&[8], 1) }, 1> = Topic::new("scan", [0; 4]);
    static M_SP: Publisher<'static, [u32; 4]> =
        Publisher::new(&M_S, Class::AsyncRealTime { deadline_us: 20_000 });
    static M_SO: RemoteSubscriber<'static, [u32; 4], 8> = RemoteSubscriber::new(&M_SP);
    static C_H: Topic<'static, u32, { pool_size(&[16], 1) }, 1> = Topic::new("setpoint", 0);
    static C_HP: Publisher<'static, u32> = Publisher::new(&C_H, Class::NonRealTime);
    static C_HI: RemotePublisher<'static, u32> = RemotePublisher::new(&C_HP, &C_H);
    static C_HS: Subscriber<'static, u32, 16> = Subscriber::new();
    static C_S: Topic<'static, [u32; 4], { pool_size(&[16], 1) }, 1> = Topic::new("scan", [0; 4]);
    static C_SP: Publisher<'static, [u32; 4]> = Publisher::new(&C_S, Class::NonRealTime);
    static C_SI: RemotePublisher<'static, [u32; 4]> = RemotePublisher::new(&C_SP, &C_S);
    static C_SS: Subscriber<'static, [u32; 4], 16> = Subscriber::new();

    if BUILT.swap(true, Ordering::SeqCst) {
        return None;
    }
    M_H.subscribe(&M_HO).ok()?;
    M_S.subscribe(&M_SO).ok()?;
    C_H.subscribe(&C_HS).ok()?;
    C_S.subscribe(&C_SS).ok()?;

    let config = Config { seed, ..Config::default() };
    let mut sim: Sim<'static, DemoNode> = Sim::new(PORTS, config, Mode::Tdma);
    let psu = DemoNode::new(tdma(1, "psu", Some(0)), &NoParams).ok()?;
    let mut motor = DemoNode::new(tdma(2, "motor", None), &NoParams).ok()?;
    let mut control = DemoNode::new(tdma(3, "control", Some(1)), &NoParams).ok()?;
    motor.export(&M_HO).ok()?;
    motor.export(&M_SO).ok()?;
    control.import(&C_HI).ok()?;
    control.import(&C_SI).ok()?;

    let (mut hk, mut sk) = (0u32, 0u32);
    let app_motor = move |now: Micros, _: &mut DemoNode| {
        if now >= 200_000 && now.is_multiple_of(10_000) {
            if now.is_multiple_of(20_000) {
                let _ = M_HP.publish_with(|v| *v = hk);
                hk = hk.wrapping_add(1);
            }
            let _ = M_SP.publish_with(|v| *v = [sk; 4]);
            sk = sk.wrapping_add(1);
        }
    };
    let received = Received::default();
    let r = received.clone();
    let app_control = move |_: Micros, _: &mut DemoNode| {
        while C_HS.try_recv().is_some() {
            r.setpoints.set(r.setpoints.get() + 1);
        }
        while C_SS.try_recv().is_some() {
            r.scans.set(r.scans.get() + 1);
        }
    };
    sim.add_board(psu, 0, None);
    sim.add_board(motor, 1, Some(Box::new(app_motor)));
    sim.add_board(control, 2, Some(Box::new(app_control)));
    Some((sim, received))
}
