//! Multi-frame HRT streams (issue 22; docs/middleware.md, "The TDMA cycle and HRT streams"): a
//! message longer than one frame gets one slot per frame at one offset, goes out first frame to
//! last in its slots' cycle order and arrives whole; a message published between its frames
//! waits for the next occurrence; a frame that cannot go out drops the rest of its message, and so
//! does a message whose last slots never came round; a standby's copy of the calendar holds every
//! frame's slot, so the stream survives the master.

use r2p_middleware::{pool_size, Class, Fault, Publisher, Subscriber, Topic};
use rtcan::failover::Role;
use rtcan::{Micros, StreamSlots};

use crate::node::{HrtState, NodeConfig};
use crate::tdma_tests::{tdma, CYCLE, CYCLE_US};
use crate::testbus::{run_slots, Bus, TestNode};
use crate::{Export, Import, NoParams, RemotePublisher, RemoteSubscriber};

/// 20 bytes: with the transfer CRC, three frames.
type Pose = [u8; 20];
/// 8 ms: every second cycle.
const EVERY_2: Class = Class::SyncRealTime { period_us: 2 * CYCLE_US as u32 };

/// Message `k`: byte i is 32·k + i, so each frame's first byte names the message and the frame.
fn pose(k: u8) -> Pose {
    core::array::from_fn(|i| k.wrapping_mul(32).wrapping_add(i as u8))
}

/// A node of the test bus with four HRT slots (slots 1, 2, 4, 5 of 16).
fn node(n: u32, name: &'static str, rank: Option<u8>) -> TestNode<'static> {
    TestNode::new(NodeConfig { hrt_slots: 4, ..tdma(n, name, rank) }, &NoParams).unwrap()
}

fn granted(n: &TestNode<'_>) -> StreamSlots {
    match n.hrt_state(0) {
        Some(HrtState::Granted { slots }) => slots,
        other => panic!("not granted: {other:?}"),
    }
}

/// The slots of `s` in cycle order.
fn slots_of(s: StreamSlots) -> std::vec::Vec<u8> {
    (1..64).filter(|&x| s.frame_in(x).is_some()).collect()
}

/// Runs slot by slot until `n` more HRT frames have been on the bus.
fn until_frames<const P: usize>(bus: &Bus<P>, nodes: &mut [&mut TestNode<'_>], n: usize) {
    let start = bus.hrt_log().len();
    let step = Micros::from(CYCLE.slot_us());
    let give_up = bus.now.get() + 4 * CYCLE_US;
    while bus.hrt_log().len() < start + n {
        assert!(
            bus.now.get() < give_up,
            "{n} HRT frames from {start} not seen: {:?}",
            bus.hrt_log()
        );
        let until = bus.now.get() + step;
        run_slots(bus, nodes, until);
    }
}

/// Runs one slot: the receivers take the last frame in at their next slot.
fn one_slot<const P: usize>(bus: &Bus<P>, nodes: &mut [&mut TestNode<'_>]) {
    let until = bus.now.get() + Micros::from(CYCLE.slot_us());
    run_slots(bus, nodes, until);
}

/// Runs slot by slot to the end of the cycle of HRT frame `frame` of the log, without node
/// `stalled`'s slot ticks: its CPU stalls (a flash page erase stops instruction fetch,
/// docs/rtcan.md), so the rest of that cycle's slots pass without it.
fn stall_to_cycle_end<const P: usize>(
    bus: &Bus<P>,
    nodes: &mut [&mut TestNode<'_>],
    stalled: usize,
    frame: usize,
) {
    let f = bus.hrt_log()[frame];
    let end = f.at - Micros::from(CYCLE.slot_offset_us(f.slot)) + CYCLE_US;
    let step = Micros::from(CYCLE.slot_us());
    while bus.now.get() < end {
        let now = bus.now.get();
        for (i, n) in nodes.iter_mut().enumerate().filter(|&(i, _)| i != stalled) {
            n.slot_tick(now, &mut bus.port(i));
        }
        bus.arbitrate();
        bus.now.set(now + step);
    }
}

/// Declares the publisher `P` of the 3-frame topic with its remote subscriber `OUT` (a queue of
/// `$q`), and the subscribing module's remote publisher `IN` with a local subscriber `SUB`.
macro_rules! pose_topics {
    ($q:literal) => {
        static T: Topic<'static, Pose, { pool_size(&[$q], 1) }, 1> = Topic::new("pose", [0; 20]);
        static P: Publisher<'static, Pose> = Publisher::new(&T, EVERY_2);
        static OUT: RemoteSubscriber<'static, Pose, $q> = RemoteSubscriber::new(&P);
        static L: Topic<'static, Pose, { pool_size(&[8], 1) }, 1> = Topic::new("pose", [0; 20]);
        static LP: Publisher<'static, Pose> = Publisher::new(&L, Class::NonRealTime);
        static IN: RemotePublisher<'static, Pose> = RemotePublisher::new(&LP, &L);
        static SUB: Subscriber<'static, Pose, 8> = Subscriber::new();
        T.subscribe(&OUT).unwrap();
        L.subscribe(&SUB).unwrap();
    };
}

/// The master, module A offering `out` and module B importing it (`b_rank`: B may stand by).
fn rig(
    out: &'static dyn Export,
    inp: &'static dyn Import,
    b_rank: Option<u8>,
) -> (Bus<3>, TestNode<'static>, TestNode<'static>, TestNode<'static>) {
    let bus = Bus::<3>::slotted(CYCLE);
    let (m, mut a, mut b) = (node(1, "psu", Some(0)), node(2, "imu", None), node(3, "b", b_rank));
    a.export(out).unwrap();
    b.import(inp).unwrap();
    (bus, m, a, b)
}

#[test]
fn a_three_frame_message_goes_a_frame_per_slot_in_order_and_arrives_whole() {
    pose_topics!(1);

    let (bus, mut m, mut a, mut b) = rig(&OUT, &IN, None);
    run_slots(&bus, &mut [&mut m, &mut a, &mut b], 200_000);
    let slots = granted(&a);
    assert_eq!(slots.frames(), 3, "one slot per frame: {slots:?}");
    let message = a.node_id().message_id(1);

    bus.clear_hrt_log();
    for k in 0..6 {
        P.publish_with(|v| *v = pose(k)).unwrap();
        let until = bus.now.get() + 2 * CYCLE_US;
        run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
    }
    let got: std::vec::Vec<Pose> = core::iter::from_fn(|| SUB.try_recv()).map(|v| *v).collect();
    assert_eq!(got, (0..6).map(pose).collect::<std::vec::Vec<_>>(), "every message whole");
    // Each message's frames in one cycle of its offset, in its slots in cycle order.
    let log = bus.hrt_log();
    assert_eq!(log.len(), 18, "{log:?}");
    for (k, frames) in log.chunks(3).enumerate() {
        let at: std::vec::Vec<u8> = frames.iter().map(|f| f.slot).collect();
        assert_eq!(at, slots_of(slots), "message {k}: {frames:?}");
        for (j, f) in frames.iter().enumerate() {
            assert_eq!((f.message, f.cycle % 2), (message, u32::from(slots.offset)));
            assert_eq!((f.cycle, f.first), (frames[0].cycle, pose(k as u8)[8 * j]), "{frames:?}");
        }
    }
    assert_eq!((a.stats().hrt_sent, a.stats().hrt_missed), (18, 0));
    assert_eq!(P.stats().deadline_misses, 0);
    assert_eq!(bus.violations(), 0, "nothing but HRT in reserved slots, no HRT elsewhere");
}

#[test]
fn a_message_published_between_its_frames_waits_for_the_next_occurrence() {
    pose_topics!(2);

    let (bus, mut m, mut a, mut b) = rig(&OUT, &IN, None);
    let nodes = &mut [&mut m, &mut a, &mut b];
    run_slots(&bus, nodes, 200_000);
    granted(nodes[1]);

    P.publish_with(|v| *v = pose(1)).unwrap();
    until_frames(&bus, nodes, 1);
    // Its first frame is out; a newer message arrives before the second.
    P.publish_with(|v| *v = pose(2)).unwrap();
    until_frames(&bus, nodes, 2);
    one_slot(&bus, nodes);
    assert_eq!(SUB.try_recv().map(|v| *v), Some(pose(1)), "the message in flight completes");
    until_frames(&bus, nodes, 3);
    one_slot(&bus, nodes);
    assert_eq!(SUB.try_recv().map(|v| *v), Some(pose(2)), "the newer one at the next occurrence");
    let log = bus.hrt_log();
    assert_eq!(log[3].cycle, log[0].cycle + 2, "{log:?}");
    assert_eq!(P.stats().deadline_misses, 0, "neither missed its deadline");
    assert_eq!(nodes[1].stats().hrt_missed, 0);
}

#[test]
fn a_frame_that_cannot_go_out_drops_the_rest_of_its_message() {
    pose_topics!(2);

    let (bus, mut m, mut a, mut b) = rig(&OUT, &IN, None);
    let nodes = &mut [&mut m, &mut a, &mut b];
    run_slots(&bus, nodes, 200_000);
    granted(nodes[1]);

    P.publish_with(|v| *v = pose(1)).unwrap();
    until_frames(&bus, nodes, 1);
    // After the first frame, A's controller refuses frames until the next period; the next
    // message is published at once.
    bus.unplug(1, true);
    P.publish_with(|v| *v = pose(2)).unwrap();
    let until = bus.now.get() + CYCLE_US;
    run_slots(&bus, nodes, until);
    bus.unplug(1, false);
    assert_eq!(nodes[1].stats().hrt_missed, 1, "the second frame; the third was not tried");
    assert_eq!(P.stats().deadline_misses, 1, "the publisher heard of it");
    assert!(SUB.try_recv().is_none(), "nothing partial is delivered");
    // The message is gone, and the next one did not start in the third frame's slot: the next
    // occurrence carries it, whole.
    let until = bus.now.get() + 2 * CYCLE_US;
    run_slots(&bus, nodes, until);
    assert_eq!(SUB.try_recv().map(|v| *v), Some(pose(2)));
    assert!(SUB.try_recv().is_none());
    assert_eq!((nodes[1].stats().hrt_missed, P.stats().deadline_misses), (1, 1));
}

#[test]
fn a_standby_holds_every_frames_slot_and_continues_the_stream_when_the_master_dies() {
    pose_topics!(1);

    let (bus, mut m, mut a, mut b) = rig(&OUT, &IN, Some(1));
    let nodes = &mut [&mut m, &mut a, &mut b];
    // A hyperperiod of 4 ms syncs after the grants: the standby's copy predicted every mask.
    run_slots(&bus, nodes, 1_400_000);
    let slots = granted(nodes[1]);
    assert!(nodes[2].knows_calendar(), "the copy holds all three frames' slots");

    let (mut sent, mut got) = (0u8, std::vec::Vec::new());
    let mut publish = |nodes: &mut [&mut TestNode<'_>], periods: u8| {
        for _ in 0..periods {
            P.publish_with(|v| *v = pose(sent)).unwrap();
            sent += 1;
            let until = bus.now.get() + 2 * CYCLE_US;
            run_slots(&bus, nodes, until);
            got.extend(core::iter::from_fn(|| SUB.try_recv()).map(|v| *v));
        }
    };
    publish(nodes, 4);
    let death = bus.now.get() + CYCLE_US / 3;
    run_slots(&bus, nodes, death);
    bus.power(0, false);
    publish(nodes, 12);
    assert_eq!(nodes[2].role(), Role::Master, "the standby continued the cycle");
    assert_eq!(granted(nodes[1]), slots, "the stream never registered again");
    assert_eq!(got, (0..16).map(pose).collect::<std::vec::Vec<_>>(), "no message lost");
    assert_eq!(nodes[1].stats().hrt_missed, 0);
    assert_eq!(bus.violations(), 0);
}

#[test]
fn a_message_whose_last_slots_never_came_round_is_one_missed_occurrence() {
    pose_topics!(2);

    let (bus, mut m, mut a, mut b) = rig(&OUT, &IN, None);
    let nodes = &mut [&mut m, &mut a, &mut b];
    run_slots(&bus, nodes, 200_000);
    let slots = granted(nodes[1]);
    bus.clear_hrt_log();
    let _ = P.take_fault();

    P.publish_with(|v| *v = pose(1)).unwrap();
    until_frames(&bus, nodes, 1);
    // Its first frame is out, the next message is published, and A stalls through the slots of
    // the second and third frames: at the next occurrence the first message is unfinished.
    P.publish_with(|v| *v = pose(2)).unwrap();
    stall_to_cycle_end(&bus, nodes, 1, 0);
    assert_eq!(bus.hrt_log().len(), 1, "nothing of the stream went meanwhile");
    let until = bus.now.get() + 2 * CYCLE_US;
    run_slots(&bus, nodes, until);

    assert_eq!(nodes[1].stats().hrt_missed, 1, "the unfinished message: one missed occurrence");
    assert_eq!(P.stats().deadline_misses, 1, "the publisher heard of it once");
    assert_eq!(P.take_fault(), Some(Fault::DeadlineMiss));
    let got: std::vec::Vec<Pose> = core::iter::from_fn(|| SUB.try_recv()).map(|v| *v).collect();
    assert_eq!(got, [pose(2)], "nothing of the unfinished message, the next one whole");
    // The next message went whole at the next occurrence, first frame to last in its slots.
    let log = bus.hrt_log();
    assert_eq!(log.len(), 4, "{log:?}");
    let next = &log[1..];
    assert_eq!(next[0].cycle, log[0].cycle + 2, "{log:?}");
    for (j, f) in next.iter().enumerate() {
        assert_eq!((f.cycle, f.slot, f.first), (next[0].cycle, slots_of(slots)[j], pose(2)[8 * j]));
    }
    assert_eq!(bus.violations(), 0);
}

#[test]
fn an_unfinished_message_is_not_sent_again_at_the_next_occurrence() {
    pose_topics!(2);

    let (bus, mut m, mut a, mut b) = rig(&OUT, &IN, None);
    let nodes = &mut [&mut m, &mut a, &mut b];
    run_slots(&bus, nodes, 200_000);
    granted(nodes[1]);
    bus.clear_hrt_log();

    P.publish_with(|v| *v = pose(1)).unwrap();
    until_frames(&bus, nodes, 1);
    // A stalls through the rest of the cycle, and nothing newer is published: the next
    // occurrence is a period after the message's deadline, so it carries nothing.
    stall_to_cycle_end(&bus, nodes, 1, 0);
    let until = bus.now.get() + 2 * CYCLE_US;
    run_slots(&bus, nodes, until);
    assert_eq!(bus.hrt_log().len(), 1, "the late message did not go: {:?}", bus.hrt_log());
    assert!(SUB.try_recv().is_none(), "neither partial nor late");
    assert_eq!((nodes[1].stats().hrt_missed, P.stats().deadline_misses), (1, 1));
    // The stream goes on with the next message, whole.
    P.publish_with(|v| *v = pose(3)).unwrap();
    let until = bus.now.get() + 2 * CYCLE_US;
    run_slots(&bus, nodes, until);
    assert_eq!(SUB.try_recv().map(|v| *v), Some(pose(3)));
    assert_eq!(bus.hrt_log().len(), 4);
    assert_eq!((nodes[1].stats().hrt_missed, P.stats().deadline_misses), (1, 1));
}
