//! Frame-sized reservations (issue 22; r2p-node's `node/framed.rs`, feature
//! `framed-reservations`), on the µs-exact virtual bus: on a bus whose nodes have frame-sized
//! reservations (`hrt_blocks` above 0), the master places each reservation as long as its frames and says where in its grants;
//! every node — the stream's owner, its subscriber, a bystander, one plugged in later — ends up
//! knowing where every reservation lies, exactly as the master placed it; a standby that takes
//! over gives the same positions; a node of the other layout is not fooled. Throughout, every
//! HRT frame starts where a reservation of its cycle starts (the slot path, `framed_tx.rs`).

use r2p_emu::{Mode, Sim};
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_node::{HrtState, NoParams, Node, NodeConfig, RemotePublisher, RemoteSubscriber};
use r2p_vbus::{Config, EventKind};
use rtcan::failover::Role;
use rtcan::layout::{Layout, Span, RESERVATION_GUARD_BITS};
use rtcan::{CycleConfig, FrameId, Laxity, Micros, StreamSlots, SyncFrame};

/// 4 ms cycles of 16 slots of 250 µs at 1 Mbit/s.
const CYCLE: CycleConfig = CycleConfig { bit_rate: 1_000_000, cycle_us: 4_000, slots: 16 };
const CYCLE_US: Micros = 4_000;
/// 20 bytes: with the transfer CRC, three frames.
type Pose = [u8; 20];
const EVERY_CYCLE: Class = Class::SyncRealTime { period_us: CYCLE_US as u32 };
const EVERY_2: Class = Class::SyncRealTime { period_us: 2 * CYCLE_US as u32 };

type TestNode = Node<'static, 2, 2, 24, 4, 64>;

/// A module on the test cycle, fast protocol timers, two HRT slots' time (the grid).
fn tdma(n: u32, name: &'static str, rank: Option<u8>) -> NodeConfig {
    NodeConfig { cycle: CYCLE, hrt_slots: 2, ..r2p_emu::demo::tdma(n, name, rank) }
}

/// A node of a bus with frame-sized reservations in two blocks and room for four slots' time.
fn framed(n: u32, name: &'static str, rank: Option<u8>) -> NodeConfig {
    NodeConfig { hrt_slots: 4, hrt_blocks: 2, ..tdma(n, name, rank) }
}

/// The boards `nodes` on ports 0, 1, … of a new bus.
fn sim(nodes: Vec<TestNode>) -> Sim<'static, TestNode> {
    let mut sim = Sim::new(nodes.len(), Config { seed: 3, ..Config::default() }, Mode::Tdma);
    for (port, n) in nodes.into_iter().enumerate() {
        sim.add_board(n, port, None);
    }
    sim
}

/// Runs `sim` for `us` more µs.
fn run_for(sim: &mut Sim<'static, TestNode>, us: Micros) {
    sim.run_until((sim.now_us() + us) * 1_000);
}

fn granted(n: &TestNode, export: usize) -> StreamSlots {
    match n.hrt_state(export) {
        Some(HrtState::Granted { slots }) => slots,
        other => panic!("export {export} not granted: {other:?}"),
    }
}

/// The slots of `s`, lowest first.
fn slots_of(s: StreamSlots) -> Vec<u8> {
    (1..64).filter(|&x| s.frame_in(x).is_some()).collect()
}

/// Every position `n` knows, slot by slot.
fn positions(n: &TestNode) -> Vec<(u8, Span)> {
    (1..64).filter_map(|s| n.reservation(s).map(|r| (s, r))).collect()
}

/// HRT frames on the bus from `from_us` on that do not start where one of `known`'s
/// reservations starts in their cycle (whole cycles after the last sync's start: a cycle
/// whose sync did not come runs on), within the guard bits by which the nodes' clocks may
/// differ.
fn hrt_off_position(sim: &Sim<'static, TestNode>, from_us: Micros, known: &[(u8, Span)]) -> usize {
    let mut cycle_start = None;
    let mut off = 0;
    for e in sim.bus().trace() {
        let EventKind::Sent { start_ns, frame, .. } = e.kind else { continue };
        let start_us = start_ns / 1_000;
        if SyncFrame::from_frame(&frame).is_ok() {
            cycle_start = Some(start_us);
            continue;
        }
        let (Some(c0), true) = (cycle_start, frame.id().laxity == Laxity::HRT) else { continue };
        if start_us < from_us {
            continue;
        }
        let at = ((start_us - c0) % CYCLE_US) as i64;
        let guard = i64::from(RESERVATION_GUARD_BITS);
        if !known.iter().any(|(_, s)| (at - i64::from(s.start_us)).abs() <= guard) {
            off += 1;
        }
    }
    off
}

/// A frame on the bus: the port that sent it, its start of frame and its end (µs), and the
/// reservation mask it announces if it is a sync.
struct OnBus {
    port: usize,
    start_us: u64,
    end_us: u64,
    mask: Option<u64>,
}

fn on_bus(sim: &Sim<'static, TestNode>) -> Vec<OnBus> {
    sim.bus()
        .trace()
        .into_iter()
        .filter_map(|e| match e.kind {
            EventKind::Sent { start_ns, frame, .. } => Some(OnBus {
                port: e.port,
                start_us: start_ns / 1_000,
                end_us: e.time_ns.div_ceil(1_000),
                mask: SyncFrame::from_frame(&frame).ok().map(|s| s.reservations),
            }),
            _ => None,
        })
        .collect()
}

/// Where, on the bus, each reservation of `known` started in the cycles whose previous sync
/// announced it.
fn reservation_starts(sim: &Sim<'static, TestNode>, known: &[(u8, Span)]) -> Vec<u64> {
    let syncs: Vec<(u64, u64)> =
        on_bus(sim).into_iter().filter_map(|f| Some((f.start_us, f.mask?))).collect();
    syncs
        .windows(2)
        .filter(|w| w[1].0 - w[0].0 == CYCLE_US)
        .flat_map(|w| {
            let (c0, mask) = (w[1].0, w[0].1);
            known
                .iter()
                .filter(move |(slot, _)| mask & (1 << slot) != 0)
                .map(move |(_, span)| c0 + u64::from(span.start_us))
        })
        .collect()
}

/// One stream of a 4-byte message every cycle (O1) and one of a three-frame pose every second
/// cycle (O2), for A to export and B to import (I1, I2): statics of the calling test.
macro_rules! streams {
    () => {
        static T1: Topic<'static, u32, { pool_size(&[1], 1) }, 1> = Topic::new("speed", 0);
        static P1: Publisher<'static, u32> = Publisher::new(&T1, EVERY_CYCLE);
        static O1: RemoteSubscriber<'static, u32, 1> = RemoteSubscriber::new(&P1);
        static T2: Topic<'static, Pose, { pool_size(&[1], 1) }, 1> = Topic::new("pose", [0; 20]);
        static P2: Publisher<'static, Pose> = Publisher::new(&T2, EVERY_2);
        static O2: RemoteSubscriber<'static, Pose, 1> = RemoteSubscriber::new(&P2);
        static L1: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("speed", 0);
        static LP1: Publisher<'static, u32> = Publisher::new(&L1, Class::NonRealTime);
        static I1: RemotePublisher<'static, u32> = RemotePublisher::new(&LP1, &L1);
        static S1: Subscriber<'static, u32, 4> = Subscriber::new();
        static L2: Topic<'static, Pose, { pool_size(&[4], 1) }, 1> = Topic::new("pose", [0; 20]);
        static LP2: Publisher<'static, Pose> = Publisher::new(&L2, Class::NonRealTime);
        static I2: RemotePublisher<'static, Pose> = RemotePublisher::new(&LP2, &L2);
        static S2: Subscriber<'static, Pose, 4> = Subscriber::new();
        T1.subscribe(&O1).unwrap();
        T2.subscribe(&O2).unwrap();
        L1.subscribe(&S1).unwrap();
        L2.subscribe(&S2).unwrap();
    };
}

/// Publishes the speed every cycle and the pose every second cycle from `from_us` on (the
/// statics of `streams!`): what the slot path sends in the reservations.
macro_rules! publish {
    ($sim:expr, $until_us:expr) => {
        while $sim.now_us() < $until_us {
            let now = $sim.now_us();
            let _ = P1.publish_with(|v| *v = now as u32);
            if (now / CYCLE_US).is_multiple_of(2) {
                let _ = P2.publish_with(|v| v[0] = now as u8);
            }
            run_for(&mut $sim, CYCLE_US);
        }
    };
}

#[test]
fn every_node_learns_where_each_reservation_lies_as_long_as_its_frames() {
    streams!();
    let m = TestNode::new(framed(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(framed(2, "motor", None), &NoParams).unwrap();
    let mut b = TestNode::new(framed(3, "gateway", None), &NoParams).unwrap();
    let c = TestNode::new(framed(4, "imu", None), &NoParams).unwrap();
    let late = TestNode::new(framed(5, "proximity", None), &NoParams).unwrap();
    a.export(&O1).unwrap();
    a.export(&O2).unwrap();
    b.import(&I1).unwrap();
    b.import(&I2).unwrap();
    let mut sim = sim(vec![m, a, b, c, late]);
    sim.power(4, false); // plugged in later
    publish!(sim, 300_000);
    let (m, a, b, c) = (sim.node(0), sim.node(1), sim.node(2), sim.node(3));
    let (speed, pose) = (granted(a, 0), granted(a, 1));
    assert_eq!((slots_of(speed).len(), slots_of(pose).len()), (1, 3));

    // The master's own placement, computed again: each slot as long as its stream's longest
    // frame's worst case (the speed: 4 bytes; the pose: 8, 8 and 6 bytes with the CRC).
    let layout = Layout::for_hrt_slots(CYCLE, 2, 4).unwrap();
    let frame_us = |export: u8, fragment: u8, len: usize| {
        let id = FrameId { laxity: Laxity::HRT, message: a.node_id().message_id(export), fragment };
        layout.reservation_us(id.to_raw(), len)
    };
    let speed_us = frame_us(1, 0, 4);
    let pose_us = (0..3).map(|j| frame_us(2, 2 - j, [8, 8, 6][usize::from(j)])).max().unwrap();
    assert!(speed_us < pose_us && pose_us < CYCLE.slot_us() as u16, "{speed_us} {pose_us}");
    let known = positions(m);
    assert_eq!(known.len(), 4, "four slots placed: {known:?}");
    for (slot, span) in &known {
        let want = if speed.frame_in(*slot).is_some() { speed_us } else { pose_us };
        assert_eq!(span.len_us, want, "slot {slot}");
    }
    // Back to back from the sync's end and from the second block's start, none overlapping.
    let mut starts: Vec<u32> = known.iter().map(|(_, s)| u32::from(s.start_us)).collect();
    starts.sort();
    let sync_end = layout.span(0).unwrap().end_us();
    assert!(starts.contains(&sync_end) && starts.contains(&(CYCLE_US as u32 / 2)), "{known:?}");
    for (i, (_, x)) in known.iter().enumerate() {
        assert!(known[i + 1..].iter().all(|(_, y)| !x.overlaps(*y)), "{known:?}");
    }

    // The owner, its subscriber and a bystander heard the grants.
    for (who, n) in [("owner", a), ("subscriber", b), ("bystander", c)] {
        assert_eq!(positions(n), known, "{who}");
    }
    // The speed and the pose went out in their reservations, each frame once.
    assert!(a.stats().hrt_sent > 100, "{:?}", a.stats());
    assert_eq!(a.stats().hrt_missed, 0, "{:?}", a.stats());
    assert_eq!(hrt_off_position(&sim, 0, &known), 0);

    // One plugged in later learns them from the master's calendar beacon (one entry per
    // heartbeat of 20 ms, 16 entries).
    sim.power(4, true);
    let plugged = sim.now_us();
    assert!(positions(sim.node(4)).is_empty());
    while positions(sim.node(4)) != known && sim.now_us() < plugged + 20 * 20_000 {
        run_for(&mut sim, CYCLE_US);
    }
    assert_eq!(positions(sim.node(4)), known, "the late node");
    assert_eq!(sim.node(4).stats().unexpected, 0);
    // Until then it knew the sync's masks but not where all the slots lie: it held the blocks'
    // shares for the slots it did not know, and no frame of its ran over a reservation's start.
    let late: Vec<(u64, u64)> = on_bus(&sim)
        .into_iter()
        .filter(|f| f.port == 4 && (plugged..sim.now_us()).contains(&f.start_us))
        .map(|f| (f.start_us, f.end_us))
        .collect();
    assert!(late.len() >= 5, "{} frames while it learned", late.len());
    for start in reservation_starts(&sim, &known) {
        let over = late.iter().find(|&&(s, e)| s <= start && start < e);
        assert!(over.is_none(), "{over:?} over a reservation starting at {start}");
    }
}

#[test]
fn a_released_slot_is_freed_and_a_standby_that_takes_over_grants_the_same_positions() {
    streams!();
    let m = TestNode::new(framed(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(framed(2, "motor", None), &NoParams).unwrap();
    let mut b = TestNode::new(framed(3, "gateway", Some(1)), &NoParams).unwrap();
    let c = TestNode::new(framed(4, "imu", None), &NoParams).unwrap();
    a.export(&O1).unwrap();
    a.export(&O2).unwrap();
    b.import(&I1).unwrap();
    b.import(&I2).unwrap();
    let mut sim = sim(vec![m, a, b, c]);
    // Until the standby trusts its copy of the calendar (a hyperperiod of syncs after the grants).
    publish!(sim, 1_400_000);
    assert!(sim.node(2).knows_calendar());
    let known = positions(sim.node(0));
    assert_eq!(positions(sim.node(2)), known);

    // The master dies: the standby continues the calendar, and its beacon repeats each grant
    // with the position the first master gave. The owner keeps its slots and sends in them;
    // no node counts a grant it did not expect.
    let before = (granted(sim.node(1), 0), granted(sim.node(1), 1));
    sim.power(0, false);
    let death = sim.now_us();
    let until = death + 20 * 20_000;
    publish!(sim, until);
    let (a, b, c) = (sim.node(1), sim.node(2), sim.node(3));
    assert_eq!(b.role(), Role::Master);
    assert_eq!((granted(a, 0), granted(a, 1)), before);
    assert_eq!(positions(b), known, "the new master's layout");
    assert_eq!(positions(c), known, "as its beacon repeats it");
    assert_eq!((a.stats().unexpected, c.stats().unexpected), (0, 0));
    assert_eq!(hrt_off_position(&sim, 0, &known), 0);

    // A goes silent (unplugged): the master releases its reservations and their time.
    sim.power(1, false);
    run_for(&mut sim, 400_000);
    let b = sim.node(2);
    assert!(b.stats().hrt_released >= 2, "{:?}", b.stats());
    assert_eq!(positions(b), Vec::new(), "every slot's time free again");
}

#[test]
fn a_node_of_the_slot_grid_is_not_fooled_by_a_framed_bus() {
    streams!();
    let m = TestNode::new(framed(1, "psu", Some(0)), &NoParams).unwrap();
    // A configured for the grid: the master's grants place reservations it does not know of.
    let mut a =
        TestNode::new(NodeConfig { hrt_slots: 4, ..tdma(2, "motor", None) }, &NoParams).unwrap();
    let mut b = TestNode::new(framed(3, "gateway", None), &NoParams).unwrap();
    a.export(&O1).unwrap();
    a.export(&O2).unwrap();
    b.import(&I1).unwrap();
    b.import(&I2).unwrap();
    let mut sim = sim(vec![m, a, b]);
    publish!(sim, 300_000);
    let a = sim.node(1);
    assert!(matches!(a.hrt_state(0), Some(HrtState::Requested { .. })), "{:?}", a.hrt_state(0));
    assert!(a.stats().unexpected >= 1, "the framed grant is counted: {:?}", a.stats());
    assert_eq!(a.reservation(1), None);
    assert_eq!(a.stats().hrt_sent, 0, "no HRT frame anywhere");
}

#[test]
fn bad_blocks_are_refused() {
    for blocks in [5, 200] {
        let e = TestNode::new(NodeConfig { hrt_blocks: blocks, ..tdma(4, "x", None) }, &NoParams);
        assert_eq!(e.err(), Some(r2p_node::NodeError::BadBlocks(blocks)));
    }
    // Blocks that cannot each hold their share of the HRT slots' time: 15 slots of 250 µs in
    // two blocks of 2 ms leave no room for the sync.
    let cfg = NodeConfig { hrt_slots: 15, hrt_blocks: 2, ..tdma(4, "x", None) };
    assert_eq!(TestNode::new(cfg, &NoParams).err(), Some(r2p_node::NodeError::BadBlocks(2)));
}

#[test]
fn a_new_calendar_makes_every_node_forget_the_old_positions() {
    streams!();
    // The master publishes the pose itself; A the speed. The standby has not heard the calendar
    // long enough to continue it, so when the master dies it starts a new one.
    let mut m = TestNode::new(framed(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(framed(2, "motor", None), &NoParams).unwrap();
    let mut b = TestNode::new(framed(3, "gateway", Some(1)), &NoParams).unwrap();
    let c = TestNode::new(framed(4, "imu", None), &NoParams).unwrap();
    m.export(&O2).unwrap();
    a.export(&O1).unwrap();
    b.import(&I1).unwrap();
    b.import(&I2).unwrap();
    let mut sim = sim(vec![m, a, b, c]);
    // The master's grants to itself reach the others in its beacon only: one table entry per
    // 20 ms heartbeat.
    publish!(sim, 400_000);
    let old = positions(sim.node(3));
    assert_eq!(old.len(), 4, "the pose's three slots and the speed's");
    assert!(!sim.node(2).knows_calendar());
    sim.power(0, false);
    let death = sim.now_us();
    publish!(sim, death + 400_000);
    let (a, b, c) = (sim.node(1), sim.node(2), sim.node(3));
    assert_eq!(b.role(), Role::Master);
    granted(a, 0);
    // Only the speed is registered again; the bystander knows nothing of the pose's old slots.
    let known = positions(b);
    assert_eq!(known.len(), 1, "{known:?}");
    assert_eq!(positions(c), known);
    assert_eq!(positions(a), known);
    // Before the death in the old calendar's reservations, after it in the new one's.
    let both: Vec<(u8, Span)> = old.into_iter().chain(known).collect();
    assert_eq!(hrt_off_position(&sim, 0, &both), 0);
}

#[test]
fn a_standby_continues_a_calendar_only_once_it_knows_where_each_reservation_lies() {
    streams!();
    // Heartbeats every second: the master's beacon repeats one grant a second.
    let slow =
        |n, name, rank| NodeConfig { heartbeat_period_us: 1_000_000, ..framed(n, name, rank) };
    let m = TestNode::new(slow(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(slow(2, "motor", None), &NoParams).unwrap();
    let mut b = TestNode::new(slow(3, "gateway", Some(1)), &NoParams).unwrap();
    a.export(&O1).unwrap();
    a.export(&O2).unwrap();
    b.import(&I1).unwrap();
    b.import(&I2).unwrap();
    let mut sim = sim(vec![m, a, b]);
    publish!(sim, 1_400_000);
    assert!(sim.node(2).knows_calendar() && positions(sim.node(2)).len() == 4);
    // The standby is cut off for a few cycles: back, it has lost track of the calendar, so it
    // forgets the positions and checks its copy against a hyperperiod of masks again.
    sim.power(2, false);
    run_for(&mut sim, 5 * CYCLE_US);
    sim.power(2, true);
    run_for(&mut sim, 1_100_000);
    // A hyperperiod of masks agreed, but the beacon has not yet repeated every grant: it would
    // not know where to say the reservations lie, so it would not continue the calendar.
    let b = sim.node(2);
    assert!(positions(b).len() < 4, "{:?}", positions(b));
    assert!(!b.knows_calendar());
    // Once the beacon has gone round (16 table entries, one a second), it does.
    run_for(&mut sim, 17_000_000);
    assert_eq!(positions(sim.node(2)), positions(sim.node(0)));
    assert!(sim.node(2).knows_calendar());
}

/// A subscribes to a stream of the master (`own`) or of B, then goes silent; the publisher
/// stops the stream when it misses its subscriber. The master's positions after that. (A
/// macro: each test has its own topics.)
macro_rules! after_the_subscriber_left {
    ($own:expr) => {{
        streams!();
        let own: bool = $own;
        let mut m = TestNode::new(framed(1, "psu", Some(0)), &NoParams).unwrap();
        let mut a = TestNode::new(framed(2, "motor", None), &NoParams).unwrap();
        let mut b = TestNode::new(framed(3, "gateway", None), &NoParams).unwrap();
        let publisher = if own { &mut m } else { &mut b };
        publisher.export(&O2).unwrap();
        a.import(&I2).unwrap();
        let mut sim = sim(vec![m, a, b]);
        publish!(sim, 300_000);
        assert_eq!(positions(sim.node(0)).len(), 3, "the pose's three slots");
        sim.power(1, false);
        run_for(&mut sim, 400_000);
        let publisher = if own { sim.node(0) } else { sim.node(2) };
        assert_eq!(publisher.hrt_state(0), Some(HrtState::Idle));
        let _ = (&O1, &I1);
        positions(sim.node(0))
    }};
}

#[test]
fn a_stream_of_the_master_whose_subscriber_left_frees_its_slots_time() {
    assert_eq!(after_the_subscriber_left!(true), Vec::new());
}

#[test]
fn a_stream_released_by_its_publisher_frees_its_slots_time() {
    // B asks the master to release it (HRT_REQUEST with period 0).
    assert_eq!(after_the_subscriber_left!(false), Vec::new());
}
