//! The slot timer's two kinds of tick (docs/rtcan.md, "Node slot policy"): slot boundaries,
//! and a loaded frame's guard (its latest start) between them. A guard must not shift the
//! boundaries, and a guard that falls on a boundary (slots exactly one worst-case frame long)
//! is still that boundary's tick.

use r2p_management::NodeId;
use r2p_middleware::{pool_size, Class, Publisher, Topic};
use rtcan::cycle::ClockState;
use rtcan::failover::Role;
use rtcan::{CycleConfig, Frame, FrameId, Laxity, Micros};

use crate::node::NodeConfig;
use crate::remote::Export;
use crate::testbus::{uid, Bus, TestNode};
use crate::{NoParams, RemoteSubscriber};

/// A module with 8 frames to send, with its own topic (one per test: tests run in parallel):
/// its controller holds some at every tick.
macro_rules! busy_sender {
    ($config:expr) => {{
        static T: Topic<'static, [u8; 8], { pool_size(&[8], 1) }, 1> = Topic::new("scan", [0; 8]);
        static P: Publisher<'static, [u8; 8]> = Publisher::new(&T, Class::NonRealTime);
        static OUT: RemoteSubscriber<'static, [u8; 8], 8> = RemoteSubscriber::new(&P);
        T.subscribe(&OUT).unwrap();
        OUT.activate(8);
        let mut n = TestNode::new($config, &NoParams).unwrap();
        n.export(&OUT).unwrap();
        for k in 0..8 {
            P.publish_with(|m| *m = [k; 8]).unwrap();
        }
        n
    }};
}

#[test]
fn without_a_cycle_a_guard_does_not_shift_the_slot_grid() {
    // No master on the bus; the bus is kept busy by others (nothing this node loads goes out):
    // every loaded frame is withdrawn at its guard and loaded again at the next boundary.
    let cycle = CycleConfig { bit_rate: 1_000_000, cycle_us: 4_000, slots: 16 };
    let slot_us = Micros::from(cycle.slot_us());
    let bus = Bus::<1>::slotted(cycle);
    let mut n = busy_sender!(NodeConfig { cycle, ..NodeConfig::new(uid(1), "lidar") });
    let mut t: Micros = 0;
    let mut ticks = std::vec::Vec::new();
    while t < 200_000 {
        bus.now.set(t);
        n.slot_tick(t, &mut bus.port(0));
        ticks.push(t);
        t = n.next_slot_at(t).max(t + 1);
    }
    // Then the bus frees up: the frames go out, and the idle node still ticks every slot (to
    // take in what it receives and hear a master that comes up).
    while t < 300_000 {
        bus.now.set(t);
        n.slot_tick(t, &mut bus.port(0));
        bus.arbitrate();
        ticks.push(t);
        t = n.next_slot_at(t).max(t + 1);
    }
    assert_eq!(n.tx_pending(), 0, "all sent once the bus was free");
    let idle: std::vec::Vec<_> = ticks.iter().copied().filter(|&t| t >= 250_000).collect();
    assert_eq!(idle.len(), 200, "a tick every slot for 50 ms");
    assert!(idle.windows(2).all(|w| w[1] - w[0] == slot_us), "idle ticks: {idle:?}");
    // While the bus was busy, after the sync timeout: windows of one slot each: boundary,
    // guard, boundary, …
    let frame_us = Micros::from(cycle.frame_us());
    let late: std::vec::Vec<_> =
        ticks.iter().copied().filter(|&t| (100_000..200_000).contains(&t)).collect();
    let first = late.iter().position(|&t| ticks.contains(&(t + slot_us - frame_us))).unwrap();
    let b0 = late[first];
    for (k, pair) in late[first..].chunks(2).enumerate().take(40) {
        let b = b0 + k as Micros * slot_us;
        assert_eq!(pair[0], b, "boundary {k}");
        if let Some(&g) = pair.get(1) {
            assert_eq!(g, b + slot_us - frame_us, "guard {k}");
        }
    }
}

#[test]
fn a_guard_on_a_boundary_is_still_that_boundarys_tick() {
    // Slots of exactly one worst-case frame (160 µs at 1 Mbit/s): a merged window's guard is
    // the start of its last slot. The node still runs that slot: it takes in what it received.
    let cycle = CycleConfig { bit_rate: 1_000_000, cycle_us: 160 * 16, slots: 16 };
    assert_eq!(cycle.slot_us(), cycle.frame_us());
    let bus = Bus::<2>::slotted(cycle);
    let config =
        NodeConfig { cycle, rank: Some(0), hrt_slots: 2, ..NodeConfig::new(uid(1), "psu") };
    let mut m = busy_sender!(config);
    let mut t: Micros = 0;
    let mut checked = 0;
    let other = NodeId::new(0x40).unwrap().management();
    while t < 60_000 {
        bus.now.set(t);
        // Another module's management frame arrives before every tick.
        bus.inject(
            Frame::new(FrameId { laxity: Laxity::NRT, message: other, fragment: 0 }, &[0; 8])
                .unwrap(),
        );
        let before = m.stats().frames_received;
        let slot = match m.clock().state(t) {
            ClockState::Running(p) if m.clock().slot_start(p.cycle, p.slot) == Some(t) => {
                Some(p.slot)
            }
            _ => None,
        };
        let at_guard_and_boundary = m.role() == Role::Master && slot == Some(cycle.slots - 1);
        m.slot_tick(t, &mut bus.port(0));
        if at_guard_and_boundary && m.stats().frames_received > before {
            checked += 1;
        } else if at_guard_and_boundary {
            panic!("the boundary at {t} µs took in nothing");
        }
        // Only one frame in four goes out: the rest of the window the bus is someone else's.
        if slot.is_none_or(|s| s % 4 == 0) {
            bus.arbitrate();
        }
        t = m.next_slot_at(t).max(t + 1);
    }
    assert!(checked >= 10, "{checked} guard-and-boundary ticks");
}
