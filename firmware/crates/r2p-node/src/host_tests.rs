//! Host-only tests: modules on a `Vec`-based in-memory bus, node-ID conflicts, late joiners,
//! and property tests that garbage from the bus is counted, never fatal.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;
use std::vec::Vec;

use proptest::prelude::*;
use r2p_management::message::{DecodeError, Message, ModuleState};
use r2p_management::node_id::initial_node_id;
use r2p_management::NodeId;
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use rtcan::controller::{BusState, ErrorCounters, Filter, Received, TxError, TxMode, TxResult};
use rtcan::id::EXTENDED_ID_MAX;
use rtcan::{fragments, CanController, Frame, FrameId, Laxity, MessageId, Micros};

use crate::node::{Event, ImportState, Node, NodeConfig};
use crate::remote::Export;
use crate::{NoParams, RemotePublisher, RemoteSubscriber};

type HostNode<'a> = Node<'a, 4, 4, 64, 8, 128>;

#[derive(Default)]
struct Wires {
    inboxes: Vec<VecDeque<Received>>,
    now: Micros,
    frames: usize,
}

/// One module's controller on the in-memory bus: what it sends reaches every other module.
struct Loopback {
    wires: Rc<RefCell<Wires>>,
    me: usize,
    /// Every frame goes out at once: its result is `Sent` (the last `TX_RESULTS` are kept).
    results: VecDeque<TxResult>,
}

impl CanController for Loopback {
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        let mut w = self.wires.borrow_mut();
        let at = w.now;
        w.frames += 1;
        for (i, q) in w.inboxes.iter_mut().enumerate() {
            if i != self.me {
                q.push_back(Received { frame: *frame, at });
            }
        }
        if self.results.len() == rtcan::controller::TX_RESULTS {
            self.results.pop_front();
        }
        self.results.push_back(TxResult::new(frame.id(), rtcan::TxOutcome::Sent));
        Ok(())
    }
    fn set_tx_mode(&mut self, _: TxMode) {}
    fn take_tx_result(&mut self) -> Option<TxResult> {
        self.results.pop_front()
    }
    fn try_receive(&mut self) -> Option<Received> {
        self.wires.borrow_mut().inboxes[self.me].pop_front()
    }
    fn set_filters(&mut self, _: &[Filter]) {}
    fn abort_pending(&mut self) -> usize {
        0
    }
    fn bus_state(&self) -> BusState {
        BusState::ErrorActive
    }
    fn error_counters(&self) -> ErrorCounters {
        ErrorCounters::default()
    }
}

struct VecBus {
    wires: Rc<RefCell<Wires>>,
    ports: Vec<Loopback>,
}

impl VecBus {
    fn new(n: usize) -> Self {
        let wires = Rc::new(RefCell::new(Wires::default()));
        wires.borrow_mut().inboxes = (0..n).map(|_| VecDeque::new()).collect();
        let ports = (0..n)
            .map(|me| Loopback { wires: wires.clone(), me, results: VecDeque::new() })
            .collect();
        Self { wires, ports }
    }

    fn now(&self) -> Micros {
        self.wires.borrow().now
    }

    /// Polls node i on port i every millisecond until `until`; nodes after `active` are off.
    fn run(&mut self, nodes: &mut [&mut HostNode<'_>], active: usize, until: Micros) {
        while self.now() < until {
            let now = self.now();
            for (i, n) in nodes.iter_mut().enumerate().take(active) {
                n.poll(now, &mut self.ports[i]);
            }
            // Frames sent to modules that are off are lost, as on a bus they were not on.
            for q in self.wires.borrow_mut().inboxes.iter_mut().skip(active) {
                q.clear();
            }
            self.wires.borrow_mut().now = now + 1_000;
        }
    }
}

fn uid(n: u32) -> [u8; 12] {
    let mut u = [0u8; 12];
    u[8..].copy_from_slice(&n.to_be_bytes());
    u
}

fn config(u: [u8; 12], name: &'static str) -> NodeConfig {
    NodeConfig {
        heartbeat_period_us: 10_000,
        request_timeout_us: 30_000,
        ..NodeConfig::new(u, name)
    }
}

#[test]
fn three_modules_the_longest_remote_queue_decides_and_both_receive() {
    static IMU: Topic<'static, [f32; 3], { pool_size(&[8], 1) }, 1> = Topic::new("imu", [0.0; 3]);
    static IMU_PUB: Publisher<'static, [f32; 3]> =
        Publisher::new(&IMU, Class::AsyncRealTime { deadline_us: 10_000 });
    static IMU_OUT: RemoteSubscriber<'static, [f32; 3], 8> = RemoteSubscriber::new(&IMU_PUB);
    static B_IMU: Topic<'static, [f32; 3], { pool_size(&[2], 1) }, 1> = Topic::new("imu", [0.0; 3]);
    static B_PUB: Publisher<'static, [f32; 3]> = Publisher::new(&B_IMU, Class::NonRealTime);
    static B_IN: RemotePublisher<'static, [f32; 3]> = RemotePublisher::new(&B_PUB, &B_IMU);
    static B_SUB: Subscriber<'static, [f32; 3], 2> = Subscriber::new();
    static C_IMU: Topic<'static, [f32; 3], { pool_size(&[5], 1) }, 1> = Topic::new("imu", [0.0; 3]);
    static C_PUB: Publisher<'static, [f32; 3]> = Publisher::new(&C_IMU, Class::NonRealTime);
    static C_IN: RemotePublisher<'static, [f32; 3]> = RemotePublisher::new(&C_PUB, &C_IMU);
    static C_SUB: Subscriber<'static, [f32; 3], 5> = Subscriber::new();
    IMU.advertise(&IMU_PUB).unwrap();
    IMU.subscribe(&IMU_OUT).unwrap();
    B_IMU.subscribe(&B_SUB).unwrap();
    C_IMU.subscribe(&C_SUB).unwrap();

    let mut bus = VecBus::new(3);
    let mut a = HostNode::new(config(uid(10), "imu"), &NoParams).unwrap();
    let mut b = HostNode::new(config(uid(11), "motor"), &NoParams).unwrap();
    let mut c = HostNode::new(config(uid(12), "logger"), &NoParams).unwrap();
    a.export(&IMU_OUT).unwrap();
    b.import(&B_IN).unwrap();
    c.import(&C_IN).unwrap();
    bus.run(&mut [&mut a, &mut b, &mut c], 3, 50_000);
    assert!(matches!(b.import_state(0), Some(ImportState::Subscribed { .. })));
    assert!(matches!(c.import_state(0), Some(ImportState::Subscribed { .. })));
    assert_eq!(IMU_OUT.active_len(), 5, "the longest queue asked for (C's) decides");

    for k in 0..4 {
        IMU_PUB.publish_with(|m| *m = [k as f32, 1.0, -1.0]).unwrap();
    }
    bus.run(&mut [&mut a, &mut b, &mut c], 3, 60_000);
    let got: Vec<f32> = core::iter::from_fn(|| C_SUB.try_recv()).map(|m| m[0]).collect();
    assert_eq!(got, [0.0, 1.0, 2.0, 3.0]);
    // B's queue holds 2: it misses the newer ones, exactly as a local subscriber would.
    let got: Vec<f32> = core::iter::from_fn(|| B_SUB.try_recv()).map(|m| m[0]).collect();
    assert_eq!(got, [0.0, 1.0]);
    assert_eq!(B_SUB.missed(), 2);
}

#[test]
fn same_name_modules_get_unique_ids_and_subscriptions_follow_a_move() {
    // Two unique IDs that hash to the same first node ID.
    let u1 = uid(1);
    let n2 = (2..).find(|&n| initial_node_id(&uid(n)) == initial_node_id(&u1)).unwrap();
    let u2 = uid(n2);
    assert!(u1 < u2);

    static ODO: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("odometry", 0);
    static ODO_PUB: Publisher<'static, u32> = Publisher::new(&ODO, Class::NonRealTime);
    static ODO_OUT: RemoteSubscriber<'static, u32, 4> = RemoteSubscriber::new(&ODO_PUB);
    static C_ODO: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("odometry", 0);
    static C_PUB: Publisher<'static, u32> = Publisher::new(&C_ODO, Class::NonRealTime);
    static C_IN: RemotePublisher<'static, u32> = RemotePublisher::new(&C_PUB, &C_ODO);
    static C_SUB: Subscriber<'static, u32, 4> = Subscriber::new();
    ODO.subscribe(&ODO_OUT).unwrap();
    C_ODO.subscribe(&C_SUB).unwrap();

    let mut bus = VecBus::new(3);
    let mut a = HostNode::new(config(u1, "motor"), &NoParams).unwrap();
    let mut b = HostNode::new(config(u2, "motor"), &NoParams).unwrap();
    let mut c = HostNode::new(config(uid(99), "base"), &NoParams).unwrap();
    b.export(&ODO_OUT).unwrap();
    c.import(&C_IN).unwrap();
    assert_eq!(a.node_id(), b.node_id());
    let contested = a.node_id();
    bus.run(&mut [&mut a, &mut b, &mut c], 3, 200_000);

    assert_eq!(a.node_id(), contested, "the smaller unique ID keeps the node ID");
    assert_ne!(b.node_id(), contested);
    assert_ne!(c.node_id(), a.node_id());
    assert_ne!(c.node_id(), b.node_id());
    let moved = b.node_id();
    assert!(core::iter::from_fn(|| b.next_event()).any(|e| e == Event::NodeIdChanged(moved)));
    let message = b.node_id().message_id(1);
    assert_eq!(c.import_state(0), Some(ImportState::Subscribed { from: b.node_id(), message }));

    ODO_PUB.publish_with(|m| *m = 42).unwrap();
    bus.run(&mut [&mut a, &mut b, &mut c], 3, 210_000);
    assert_eq!(*C_SUB.try_recv().unwrap(), 42);
}

/// Two unique IDs whose first node ID is the same: the smaller, the larger.
fn contending_uids() -> ([u8; 12], [u8; 12]) {
    let n = (2..).find(|&n| initial_node_id(&uid(n)) == initial_node_id(&uid(1))).unwrap();
    (uid(1), uid(n))
}

/// `config` as a module's: it listens one heartbeat period before it claims its node ID.
fn module(u: [u8; 12], name: &'static str) -> NodeConfig {
    NodeConfig { listen_first: true, ..config(u, name) }
}

#[test]
fn a_module_plugged_into_a_running_robot_never_moves_a_running_one() {
    // The running module has the larger unique ID: by unique IDs alone it would lose the
    // contested node ID to the newcomer.
    let (small, large) = contending_uids();
    for newcomer_listens in [true, false] {
        let mut bus = VecBus::new(2);
        let mut running = HostNode::new(module(large, "motor"), &NoParams).unwrap();
        let plugged =
            if newcomer_listens { module(small, "motor") } else { config(small, "motor") };
        let mut newcomer = HostNode::new(plugged, &NoParams).unwrap();
        bus.run(&mut [&mut running, &mut newcomer], 1, 500_000);
        let contested = running.node_id();
        assert_eq!(contested, initial_node_id(&large));
        let _ = core::iter::from_fn(|| running.next_event()).count();
        bus.run(&mut [&mut running, &mut newcomer], 2, 800_000);
        // Listening, the newcomer hears the ID in use and claims another; not listening (a
        // heartbeat missed), it claims the contested ID while `Starting` and loses it.
        assert_eq!(running.node_id(), contested, "listening: {newcomer_listens}");
        assert_ne!(newcomer.node_id(), contested);
        assert!(core::iter::from_fn(|| running.next_event())
            .all(|e| !matches!(e, Event::NodeIdChanged(_))));
    }
}

#[test]
fn modules_powered_up_together_listen_in_silence_and_end_unique() {
    // Both listen for a heartbeat period, hear nobody, and claim: the first claim's heartbeat
    // reaches the other while it still listens (here they end listening in the same
    // millisecond, polled in order), so it takes the next free ID without any conflict.
    let (small, large) = contending_uids();
    let mut bus = VecBus::new(2);
    let mut a = HostNode::new(module(large, "motor"), &NoParams).unwrap();
    let mut b = HostNode::new(module(small, "motor"), &NoParams).unwrap();
    bus.run(&mut [&mut a, &mut b], 2, 10_000);
    assert_eq!(bus.wires.borrow().frames, 0, "silent while listening");
    bus.run(&mut [&mut a, &mut b], 2, 200_000);
    assert_eq!(a.node_id(), initial_node_id(&large), "the first to claim keeps its ID");
    assert_ne!(a.node_id(), b.node_id());
    assert_eq!(b.stats().dropped_on_move, 0, "no conflict to settle");
}

#[test]
fn a_late_joiner_learns_the_topics_advertised_before_it_arrived() {
    static T: Topic<'static, u16, { pool_size(&[2], 1) }, 1> = Topic::new("battery/voltage", 0);
    static P: Publisher<'static, u16> = Publisher::new(&T, Class::NonRealTime);
    static OUT: RemoteSubscriber<'static, u16, 2> = RemoteSubscriber::new(&P);
    static L: Topic<'static, u16, { pool_size(&[2], 1) }, 1> = Topic::new("battery/voltage", 0);
    static LP: Publisher<'static, u16> = Publisher::new(&L, Class::NonRealTime);
    static IN: RemotePublisher<'static, u16> = RemotePublisher::new(&LP, &L);
    static SUB: Subscriber<'static, u16, 2> = Subscriber::new();
    T.subscribe(&OUT).unwrap();
    L.subscribe(&SUB).unwrap();
    let mut bus = VecBus::new(2);
    let mut psu = HostNode::new(config(uid(5), "psu"), &NoParams).unwrap();
    let mut late = HostNode::new(config(uid(6), "display"), &NoParams).unwrap();
    psu.export(&OUT).unwrap();
    late.import(&IN).unwrap();
    bus.run(&mut [&mut psu, &mut late], 1, 300_000); // the display is not on the bus yet
    assert_eq!(late.import_state(0), Some(ImportState::Waiting));
    bus.run(&mut [&mut psu, &mut late], 2, 340_000);
    assert!(matches!(late.import_state(0), Some(ImportState::Subscribed { .. })));
    P.publish_with(|v| *v = 12_600).unwrap();
    bus.run(&mut [&mut psu, &mut late], 2, 345_000);
    assert_eq!(*SUB.try_recv().unwrap(), 12_600);
}

#[test]
fn a_subscription_request_without_answer_is_repeated() {
    // The publisher never hears the first request.
    static T: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("led", 0);
    static P: Publisher<'static, u8> = Publisher::new(&T, Class::NonRealTime);
    static OUT: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P);
    static L: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("led", 0);
    static LP: Publisher<'static, u8> = Publisher::new(&L, Class::NonRealTime);
    static IN: RemotePublisher<'static, u8> = RemotePublisher::new(&LP, &L);
    T.subscribe(&OUT).unwrap();
    let mut bus = VecBus::new(2);
    let mut a = HostNode::new(config(uid(1), "a"), &NoParams).unwrap();
    let mut b = HostNode::new(config(uid(2), "b"), &NoParams).unwrap();
    a.export(&OUT).unwrap();
    b.import(&IN).unwrap();
    // Run until B has asked (A polls before B, so A has not read it yet), then lose it.
    while !matches!(b.import_state(0), Some(ImportState::Requested { .. })) {
        bus.run(&mut [&mut a, &mut b], 2, bus.now() + 1_000);
    }
    bus.wires.borrow_mut().inboxes[0].clear();
    assert_eq!(OUT.active_len(), 0);
    bus.run(&mut [&mut a, &mut b], 2, bus.now() + 60_000);
    assert!(matches!(b.import_state(0), Some(ImportState::Subscribed { .. })));
    assert_eq!(OUT.active_len(), 1);
}

fn mgmt_frames(from: u8, bytes: &[u8]) -> Vec<Frame> {
    let stream = NodeId::new(from).unwrap().management();
    let template = FrameId { laxity: Laxity::NRT, message: stream, fragment: 0 };
    fragments(template, bytes).unwrap().collect()
}

/// A frame: mostly on management streams and near-valid topic streams, sometimes anything.
fn frame() -> impl Strategy<Value = Frame> {
    let data = prop::collection::vec(any::<u8>(), 0..=8);
    prop_oneof![
        (0..=EXTENDED_ID_MAX, data.clone()).prop_map(|(raw, d)| Frame::from_raw(raw, &d).unwrap()),
        (0u8..64, 1u8..=254, 0u8..3, 0u8..6, data).prop_map(|(lax, node, index, frag, d)| {
            let id = FrameId {
                laxity: Laxity::from_code(lax),
                message: MessageId(u16::from(node) << 8 | u16::from(index)),
                fragment: frag,
            };
            Frame::new(id, &d).unwrap()
        }),
    ]
}

static GARBAGE_T: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("cmd", 0);
static GARBAGE_P: Publisher<'static, u32> = Publisher::new(&GARBAGE_T, Class::NonRealTime);
static GARBAGE_IN: RemotePublisher<'static, u32> = RemotePublisher::new(&GARBAGE_P, &GARBAGE_T);
static GARBAGE_O: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("state", 0);
static GARBAGE_OP: Publisher<'static, u32> =
    Publisher::new(&GARBAGE_O, Class::AsyncRealTime { deadline_us: 1_000 });
static GARBAGE_OUT: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&GARBAGE_OP);

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Arbitrary frames never panic the node: every one is taken and counted, and the node still
    /// sends its heartbeat afterwards.
    #[test]
    fn arbitrary_frames_are_counted_not_fatal(frames in prop::collection::vec(frame(), 0..300)) {
        static WIRED: std::sync::Once = std::sync::Once::new();
        WIRED.call_once(|| GARBAGE_O.subscribe(&GARBAGE_OUT).unwrap());
        GARBAGE_OUT.activate(2);
        let mut node = HostNode::new(config(uid(77), "victim"), &NoParams).unwrap();
        node.import(&GARBAGE_IN).unwrap();
        node.export(&GARBAGE_OUT).unwrap();
        let mut bus = VecBus::new(1);
        for (i, f) in frames.iter().enumerate() {
            let at = i as Micros * 50;
            node.on_frame(&Received { frame: *f, at });
            if i % 16 == 0 {
                let _ = GARBAGE_OP.publish_with(|m| *m = i as u32);
                node.poll(at, &mut bus.ports[0]);
            }
        }
        let s = node.stats();
        prop_assert_eq!(s.frames_received as usize, frames.len());
        let sent = bus.wires.borrow().frames;
        node.poll(1 << 40, &mut bus.ports[0]);
        prop_assert!(bus.wires.borrow().frames > sent, "still sends heartbeats");
    }

    /// Random bytes on a management stream: counted as malformed exactly when they do not
    /// decode as a node reads them (a node that never asked leaves replies unread, malformed or
    /// not); a message that does decode is handled (nothing panics either way).
    #[test]
    fn malformed_management_messages_are_counted(
        messages in prop::collection::vec(prop::collection::vec(any::<u8>(), 0..80), 1..20)
    ) {
        let mut node = HostNode::new(config(uid(78), "victim"), &NoParams).unwrap();
        let from = if node.node_id().get() == 0x42 { 0x43 } else { 0x42 };
        let mut bad = 0;
        for (i, m) in messages.iter().enumerate() {
            if !matches!(Message::decode_requests(m), Ok(_) | Err(DecodeError::Reply(_))) {
                bad += 1;
            }
            for f in mgmt_frames(from, m) {
                node.on_frame(&Received { frame: f, at: i as Micros });
            }
        }
        prop_assert_eq!(node.stats().malformed, bad);
    }
}

#[test]
fn a_rebooted_peer_gets_the_advertisements_again() {
    static T: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("mode", 0);
    static P: Publisher<'static, u8> = Publisher::new(&T, Class::NonRealTime);
    static OUT: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P);
    T.subscribe(&OUT).unwrap();
    let mut a = HostNode::new(config(uid(1), "a"), &NoParams).unwrap();
    a.export(&OUT).unwrap();
    let mut bus = VecBus::new(1);
    a.poll(0, &mut bus.ports[0]);
    let heartbeat = |state, who| {
        let mut buf = [0u8; 64];
        let n = Message::Heartbeat {
            uid: uid(who),
            name: "b".try_into().unwrap(),
            state,
            uptime_s: 0,
            tx_errors: 0,
            rx_errors: 0,
            dropped: 0,
        }
        .encode(&mut buf)
        .unwrap();
        mgmt_frames(0x50, &buf[..n])
    };
    let advertised_by = |a: &mut HostNode<'_>, bus: &mut VecBus, who, state, at| {
        for f in heartbeat(state, who) {
            a.on_frame(&Received { frame: f, at });
        }
        let before = bus.wires.borrow().frames;
        a.tick(at);
        a.transmit(at, &mut bus.ports[0]);
        // A heartbeat (5 frames) is not due; an advertisement is 3 frames.
        bus.wires.borrow().frames - before == 3
    };
    let advertised =
        |a: &mut HostNode<'_>, bus: &mut VecBus, state, at| advertised_by(a, bus, 2, state, at);
    assert!(advertised(&mut a, &mut bus, ModuleState::Starting, 1), "new peer");
    assert!(advertised(&mut a, &mut bus, ModuleState::Starting, 2), "a start's second heartbeat");
    assert!(!advertised(&mut a, &mut bus, ModuleState::Running, 3));
    assert!(!advertised(&mut a, &mut bus, ModuleState::Running, 4));
    assert!(advertised(&mut a, &mut bus, ModuleState::Starting, 5), "it rebooted");
    // It went away during its start (a CLI tool that exits at once); the next tool to claim
    // the node ID starts too and must get the advertisements, though it is no new peer.
    assert!(
        advertised_by(&mut a, &mut bus, 3, ModuleState::Starting, 6),
        "the node ID's next holder"
    );
    assert_eq!(a.peer_count(), 1);
}

mod tdma {
    //! The TDMA cycle on the slotted loopback bus, in virtual time.

    use super::*;
    use crate::node::HrtState;
    use crate::slot_tx::FreeSlots;
    use crate::tdma_tests::{tdma, CYCLE, CYCLE_US};
    use crate::testbus::{run_slots, Bus, TestNode};
    use rtcan::failover::{Role, RANK_STEP_CYCLES, TAKEOVER_BASE_CYCLES};

    /// The phase HRT export `export` of `n` was granted, if it was.
    fn granted(n: &TestNode<'_>, export: usize) -> Option<rtcan::Phase> {
        match n.hrt_state(export) {
            Some(HrtState::Granted { slots }) => Some(slots.first()),
            _ => None,
        }
    }

    #[test]
    fn srt_and_nrt_traffic_never_uses_a_reserved_slot() {
        // A: an HRT stream every cycle and a busy SRT stream; B subscribes to both; M is master.
        static H: Topic<'static, u16, { pool_size(&[2], 1) }, 1> = Topic::new("torque", 0);
        static HP: Publisher<'static, u16> =
            Publisher::new(&H, Class::SyncRealTime { period_us: 4_000 });
        static HO: RemoteSubscriber<'static, u16, 2> = RemoteSubscriber::new(&HP);
        static S: Topic<'static, [u32; 4], { pool_size(&[8], 1) }, 1> = Topic::new("scan", [0; 4]);
        static SP: Publisher<'static, [u32; 4]> =
            Publisher::new(&S, Class::AsyncRealTime { deadline_us: 20_000 });
        static SO: RemoteSubscriber<'static, [u32; 4], 8> = RemoteSubscriber::new(&SP);
        static BH: Topic<'static, u16, { pool_size(&[4], 1) }, 1> = Topic::new("torque", 0);
        static BHP: Publisher<'static, u16> = Publisher::new(&BH, Class::NonRealTime);
        static BHI: RemotePublisher<'static, u16> = RemotePublisher::new(&BHP, &BH);
        static BHS: Subscriber<'static, u16, 4> = Subscriber::new();
        static BS: Topic<'static, [u32; 4], { pool_size(&[8], 1) }, 1> = Topic::new("scan", [0; 4]);
        static BSP: Publisher<'static, [u32; 4]> = Publisher::new(&BS, Class::NonRealTime);
        static BSI: RemotePublisher<'static, [u32; 4]> = RemotePublisher::new(&BSP, &BS);
        static BSS: Subscriber<'static, [u32; 4], 8> = Subscriber::new();
        H.subscribe(&HO).unwrap();
        S.subscribe(&SO).unwrap();
        BH.subscribe(&BHS).unwrap();
        BS.subscribe(&BSS).unwrap();

        // One frame per free slot, one-shot: what this bus models (it carries one frame per
        // slot); merged windows are tested on the virtual bus (r2p-vbus's
        // `tests/node_slot_policy.rs`).
        let single =
            |n, name, rank| NodeConfig { free_slots: FreeSlots::Single, ..tdma(n, name, rank) };
        let bus = Bus::<3>::slotted(CYCLE);
        let mut m = TestNode::new(single(1, "psu", Some(0)), &NoParams).unwrap();
        let mut a = TestNode::new(single(2, "a", Some(1)), &NoParams).unwrap();
        let mut b = TestNode::new(single(3, "b", None), &NoParams).unwrap();
        a.export(&HO).unwrap();
        a.export(&SO).unwrap();
        b.import(&BHI).unwrap();
        b.import(&BSI).unwrap();
        run_slots(&bus, &mut [&mut m, &mut a, &mut b], 150_000);
        assert!(granted(&a, 0).is_some());
        assert!(matches!(b.import_state(1), Some(ImportState::Subscribed { .. })));

        // Every cycle: one HRT message and two 16-byte SRT messages (3 frames each) — about
        // half of the free slots — while heartbeats keep going.
        let (mut torque, mut scans) = (Vec::new(), Vec::new());
        for k in 0..100u32 {
            HP.publish_with(|v| *v = k as u16).unwrap();
            SP.publish_with(|v| *v = [k; 4]).unwrap();
            SP.publish_with(|v| *v = [k + 1000; 4]).unwrap();
            let until = bus.now.get() + CYCLE_US;
            run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
            torque.extend(core::iter::from_fn(|| BHS.try_recv()).map(|v| *v));
            scans.extend(core::iter::from_fn(|| BSS.try_recv()).map(|v| v[0]));
        }
        run_slots(&bus, &mut [&mut m, &mut a, &mut b], bus.now.get() + 10 * CYCLE_US);
        scans.extend(core::iter::from_fn(|| BSS.try_recv()).map(|v| v[0]));
        assert_eq!(torque, (0..100).collect::<Vec<u16>>());
        let want: Vec<u32> = (0..100).flat_map(|k| [k, k + 1000]).collect();
        assert_eq!(scans, want, "every SRT message, in order, none lost to arbitration");
        assert_eq!(bus.violations(), 0);
        assert_eq!(a.stats().deadline_misses, 0);
        assert!(a.stats().slot_retries > 0, "arbitration was lost sometimes and retried");
        assert_eq!(
            a.stats().late_withdrawals,
            0,
            "this bus starts every frame at its slot's start"
        );
        // The HRT stream kept its slot every cycle: no jitter.
        let log = bus.hrt_log();
        assert!(log.len() >= 20);
        for w in log.windows(2) {
            assert_eq!((w[1].at - w[0].at, w[1].slot), (CYCLE_US, w[0].slot));
        }
    }

    #[test]
    fn a_standby_takes_over_when_the_master_dies_and_hrt_resumes() {
        static H: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("setpoint", 0);
        static HP: Publisher<'static, u32> =
            Publisher::new(&H, Class::SyncRealTime { period_us: 8_000 });
        static HO: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&HP);
        static BH: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("setpoint", 0);
        static BHP: Publisher<'static, u32> = Publisher::new(&BH, Class::NonRealTime);
        static BHI: RemotePublisher<'static, u32> = RemotePublisher::new(&BHP, &BH);
        static BHS: Subscriber<'static, u32, 4> = Subscriber::new();
        H.subscribe(&HO).unwrap();
        BH.subscribe(&BHS).unwrap();

        // M (rank 0) is master; B (rank 1, the HRT subscriber) is the standby; A publishes.
        let bus = Bus::<3>::slotted(CYCLE);
        let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
        let mut a = TestNode::new(tdma(2, "a", None), &NoParams).unwrap();
        let mut b = TestNode::new(tdma(3, "b", Some(1)), &NoParams).unwrap();
        a.export(&HO).unwrap();
        b.import(&BHI).unwrap();
        run_slots(&bus, &mut [&mut m, &mut a, &mut b], 150_000);
        assert_eq!(m.role(), Role::Master);
        assert!(granted(&a, 0).is_some());
        let publish = |k: u32, bus: &Bus<3>, nodes: &mut [&mut TestNode<'_>]| {
            HP.publish_with(|v| *v = k).unwrap();
            run_slots(bus, nodes, bus.now.get() + 2 * CYCLE_US);
            core::iter::from_fn(|| BHS.try_recv()).map(|v| *v).collect::<Vec<u32>>()
        };
        for k in 0..3 {
            assert_eq!(publish(k, &bus, &mut [&mut m, &mut a, &mut b]), [k]);
        }

        // The master is powered off right after a sync.
        let syncs = m.stats().syncs_sent;
        while m.stats().syncs_sent == syncs {
            run_slots(&bus, &mut [&mut m, &mut a, &mut b], bus.now.get() + 250);
        }
        // `syncs_sent` counts a sync when the controller reports it sent, at the master's next
        // slot tick: the sync went out in the step before.
        let last_sync = bus.now.get() - 500;
        bus.power(0, false);
        let bound = Micros::from(TAKEOVER_BASE_CYCLES + RANK_STEP_CYCLES) * CYCLE_US;
        while b.role() != Role::Master {
            assert!(bus.now.get() - last_sync <= bound, "no takeover within the bound");
            run_slots(&bus, &mut [&mut m, &mut a, &mut b], bus.now.get() + 250);
        }
        let took_over = bus.now.get() - 250 - last_sync;
        assert_eq!(took_over, bound, "rank 1: (4 + 5) cycles after the last sync");
        assert_eq!(a.role(), Role::Slave);

        // A re-registers with B; HRT traffic resumes on the new master's calendar.
        run_slots(&bus, &mut [&mut m, &mut a, &mut b], bus.now.get() + 100_000);
        let phase = granted(&a, 0).expect("re-registered");
        assert!(b.stats().syncs_sent > 20);
        bus.clear_hrt_log();
        let mut got = Vec::new();
        for k in 10..16 {
            got.extend(publish(k, &bus, &mut [&mut m, &mut a, &mut b]));
        }
        assert_eq!(got, (10..16).collect::<Vec<u32>>());
        let log = bus.hrt_log();
        assert_eq!(log.len(), 6);
        for w in log.windows(2) {
            assert_eq!((w[1].at - w[0].at, w[1].slot), (2 * CYCLE_US, phase.slot));
        }
        assert_eq!(bus.violations(), 0);
        assert!(matches!(b.import_state(0), Some(ImportState::Subscribed { .. })));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]

        /// Arbitrary frames with sync identifiers (any length, any counter, any epoch) thrown at a
        /// running cycle: counted, never fatal; the bus keeps a master and the node keeps sending.
        #[test]
        fn garbage_syncs_are_counted_not_fatal(
            junk in prop::collection::vec((any::<u8>(), prop::collection::vec(any::<u8>(), 0..=8), 0u32..400), 1..20)
        ) {
            let bus = Bus::<2>::slotted(CYCLE);
            let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
            let mut s = TestNode::new(tdma(2, "s", Some(1)), &NoParams).unwrap();
            run_slots(&bus, &mut [&mut m, &mut s], 40_000);
            let mut bad = 0;
            for (cycle, data, gap) in &junk {
                if data.len() != 8 {
                    bad += 1;
                }
                bus.inject(Frame::new(FrameId::sync(u32::from(*cycle)), data).unwrap());
                // At least one slot, so the injected frame is received before the next one.
                run_slots(&bus, &mut [&mut m, &mut s], bus.now.get() + (u64::from(*gap) + 1) * 250);
            }
            prop_assert_eq!(s.stats().bad_syncs, bad);
            run_slots(&bus, &mut [&mut m, &mut s], bus.now.get() + 200_000);
            let roles = [m.role(), s.role()];
            prop_assert_eq!(roles.iter().filter(|r| **r == Role::Master).count(), 1);
            let sent = m.stats().frames_sent + s.stats().frames_sent;
            run_slots(&bus, &mut [&mut m, &mut s], bus.now.get() + 100_000);
            prop_assert!(m.stats().frames_sent + s.stats().frames_sent > sent, "still talking");
        }
    }
}
