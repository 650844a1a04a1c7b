//! The node runtime's slot policy (`r2p_node::slot_tx`, docs/rtcan.md "Node slot policy") on
//! this bus: real nodes (frame times to the bit, stuffing, bitwise arbitration, one-shot losers
//! withdrawn at the bit where they lose), driven in virtual time as the emulator drives them —
//! every node's slot timer at the times `next_slot_at` asks for. They check what r2p-node's
//! loopback test bus cannot: when frames start and end.
//!
//! The rig: M (rank 0, master) subscribes to `scan_a` from A and `scan_b` from B (SRT, 14-byte
//! messages, two full frames with the transfer CRC, 20 ms deadline) and to `torque` from A (HRT, every cycle). A and B
//! publish at the same slot boundary, so their frames contend for the same free slots.

use std::collections::HashMap;

use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_node::{
    FreeSlots, HrtState, ImportState, NoParams, Node, NodeConfig, RemotePublisher, RemoteSubscriber,
};
use r2p_vbus::bits::INTERMISSION_BITS;
use r2p_vbus::{Bus, BxCanPort, Config, EventKind};
use rtcan::{CanController, CycleConfig, Frame, Laxity, LaxityEncoding, Micros, SyncFrame};

/// 4 ms cycles of 16 slots of 250 µs (250 bit times at 1 Mbit/s).
const CYCLE: CycleConfig = CycleConfig { bit_rate: 1_000_000, cycle_us: 4_000, slots: 16 };
const CYCLE_US: Micros = 4_000;

/// Two exports, three imports, 32 queued frames.
type VNode<'a> = Node<'a, 2, 3, 32, 6, 64>;

const SLOT_US: Micros = CYCLE_US / CYCLE.slots as Micros;
/// Short enough that the laxity code changes from slot to slot (linear, 100 µs per code), so
/// the tests see that a frame sent later carries the laxity of its deadline then.
const SRT_DEADLINE_US: u32 = 6_000;
const LAXITY: LaxityEncoding = LaxityEncoding::Linear { tick_us: 100 };

/// The bus and each node's port and next wake-up (ns).
struct Rig {
    bus: Bus,
    ports: Vec<BxCanPort>,
    wake: Vec<u64>,
}

impl Rig {
    fn new(nodes: usize, ports: usize) -> Self {
        Self::with_load_latency(nodes, ports, 0)
    }

    /// Every node's frames reach their mailbox `us` after the node read its clock.
    fn with_load_latency(nodes: usize, ports: usize, us: u64) -> Self {
        let bus = Bus::new(ports, Config::default());
        let ports = (0..nodes)
            .map(|i| BxCanPort::new(bus.port(i), CYCLE.bit_rate).with_load_latency(us))
            .collect();
        Self { bus, ports, wake: std::vec![0; nodes] }
    }

    /// Runs everything due before `until_us` (node i on port i).
    fn run(&mut self, nodes: &mut [&mut VNode<'_>], until_us: Micros) {
        let until = until_us * 1_000;
        loop {
            let now = self.bus.now();
            let bus_next = self.bus.next_event().map(|t| t.max(now));
            let t = self.wake.iter().copied().chain(bus_next).min().expect("nodes");
            if t >= until {
                self.bus.advance_to(until - 1);
                return;
            }
            self.bus.advance_to(t);
            for (i, n) in nodes.iter_mut().enumerate() {
                if self.wake[i] <= t {
                    n.slot_tick(t / 1_000, &mut self.ports[i]);
                    self.wake[i] = (n.next_slot_at(t / 1_000) * 1_000).max(t + 1);
                }
            }
        }
    }
}

/// What the bus carried, in slot terms.
struct Seen {
    /// Start of every cycle (the syncs' starts of frame), µs, and the reservations the sync
    /// before announced for it (sync slot included).
    cycles: Vec<(Micros, Option<u64>)>,
}

impl Seen {
    fn of(bus: &Bus) -> Self {
        let mut cycles: Vec<(Micros, Option<u64>)> = Vec::new();
        let mut announced = None;
        for e in bus.trace() {
            let EventKind::Sent { start_ns, frame, .. } = e.kind else { continue };
            if let Ok(sync) = SyncFrame::from_frame(&frame) {
                let at = start_ns / 1_000;
                let continuous = cycles.last().is_some_and(|c| at - c.0 == CYCLE_US);
                cycles.push((at, announced.filter(|_| continuous)));
                announced = Some(sync.reservations | 1);
            }
        }
        Self { cycles }
    }

    /// The cycle start, the slot and the reservations known for the time `t` µs.
    fn slot_of(&self, t: Micros) -> Option<(Micros, u8, Option<u64>)> {
        let &(start, mask) = self.cycles.iter().rev().find(|c| c.0 <= t)?;
        let slot = (t - start) / SLOT_US;
        (slot < Micros::from(CYCLE.slots)).then_some((start, slot as u8, mask))
    }
}

/// The node config of the rig: the test cycle, 2 HRT slots, fast protocol timers.
fn config(n: u32, name: &'static str, rank: Option<u8>, free_slots: FreeSlots) -> NodeConfig {
    let mut uid = [0u8; 12];
    uid[8..].copy_from_slice(&n.to_be_bytes());
    NodeConfig {
        heartbeat_period_us: 20_000,
        request_timeout_us: 30_000,
        cycle: CYCLE,
        rank,
        hrt_slots: 2,
        free_slots,
        laxity: LAXITY,
        ..NodeConfig::new(uid, name)
    }
}

/// The nodes of a rig and the topics the test drives.
struct Parts {
    m: VNode<'static>,
    a: VNode<'static>,
    b: VNode<'static>,
    scan_a: &'static Publisher<'static, Scan>,
    scan_b: &'static Publisher<'static, Scan>,
    torque: &'static Publisher<'static, u16>,
    got_a: &'static Subscriber<'static, Scan, 8>,
    got_b: &'static Subscriber<'static, Scan, 8>,
}

/// Declares the rig's topics — statics of their own per expansion, so tests running in
/// parallel never share one — and wires the nodes for free-slot policy `$policy`.
macro_rules! rig {
    ($policy:expr) => {{
        static SA: Topic<'static, Scan, { pool_size(&[8], 1) }, 1> = Topic::new("scan_a", [0; 7]);
        static SAP: Publisher<'static, Scan> =
            Publisher::new(&SA, Class::AsyncRealTime { deadline_us: SRT_DEADLINE_US });
        static SAO: RemoteSubscriber<'static, Scan, 8> = RemoteSubscriber::new(&SAP);
        static SB: Topic<'static, Scan, { pool_size(&[8], 1) }, 1> = Topic::new("scan_b", [0; 7]);
        static SBP: Publisher<'static, Scan> =
            Publisher::new(&SB, Class::AsyncRealTime { deadline_us: SRT_DEADLINE_US });
        static SBO: RemoteSubscriber<'static, Scan, 8> = RemoteSubscriber::new(&SBP);
        static H: Topic<'static, u16, { pool_size(&[2], 1) }, 1> = Topic::new("torque", 0);
        static HP: Publisher<'static, u16> =
            Publisher::new(&H, Class::SyncRealTime { period_us: CYCLE_US as u32 });
        static HO: RemoteSubscriber<'static, u16, 2> = RemoteSubscriber::new(&HP);
        static MA: Topic<'static, Scan, { pool_size(&[8], 1) }, 1> = Topic::new("scan_a", [0; 7]);
        static MAP: Publisher<'static, Scan> = Publisher::new(&MA, Class::NonRealTime);
        static MAI: RemotePublisher<'static, Scan> = RemotePublisher::new(&MAP, &MA);
        static MAS: Subscriber<'static, Scan, 8> = Subscriber::new();
        static MB: Topic<'static, Scan, { pool_size(&[8], 1) }, 1> = Topic::new("scan_b", [0; 7]);
        static MBP: Publisher<'static, Scan> = Publisher::new(&MB, Class::NonRealTime);
        static MBI: RemotePublisher<'static, Scan> = RemotePublisher::new(&MBP, &MB);
        static MBS: Subscriber<'static, Scan, 8> = Subscriber::new();
        static MH: Topic<'static, u16, { pool_size(&[4], 1) }, 1> = Topic::new("torque", 0);
        static MHP: Publisher<'static, u16> = Publisher::new(&MH, Class::NonRealTime);
        static MHI: RemotePublisher<'static, u16> = RemotePublisher::new(&MHP, &MH);
        static MHS: Subscriber<'static, u16, 4> = Subscriber::new();
        SA.subscribe(&SAO).unwrap();
        SB.subscribe(&SBO).unwrap();
        H.subscribe(&HO).unwrap();
        MA.subscribe(&MAS).unwrap();
        MB.subscribe(&MBS).unwrap();
        MH.subscribe(&MHS).unwrap();
        let mut m = VNode::new(config(1, "psu", Some(0), $policy), &NoParams).unwrap();
        let mut a = VNode::new(config(2, "a", None, $policy), &NoParams).unwrap();
        let mut b = VNode::new(config(3, "b", None, $policy), &NoParams).unwrap();
        a.export(&SAO).unwrap();
        a.export(&HO).unwrap();
        b.export(&SBO).unwrap();
        m.import(&MAI).unwrap();
        m.import(&MBI).unwrap();
        m.import(&MHI).unwrap();
        Parts { m, a, b, scan_a: &SAP, scan_b: &SBP, torque: &HP, got_a: &MAS, got_b: &MBS }
    }};
}

/// A message's tag: its publisher (0 = A, 1 = B) and sequence number, in every element.
fn tag(node: u32, k: u32) -> u32 {
    node << 16 | k
}

/// A scan message: 14 bytes, so that with its transfer CRC it fills two frames, and each frame
/// starts with the tag (low and high halves in elements 0, 1 and 4, 5).
type Scan = [u16; 7];

/// A scan message carrying `tag`.
fn scan(tag: u32) -> Scan {
    let (lo, hi) = (tag as u16, (tag >> 16) as u16);
    [lo, hi, lo, hi, lo, hi, lo]
}

/// The tag in a frame of a `Scan` message.
fn tag_of(frame: &Frame) -> Option<u32> {
    let p = frame.payload();
    (p.len() == 8).then(|| u32::from_le_bytes([p[0], p[1], p[2], p[3]]))
}

/// What a run offers.
struct Traffic {
    policy: FreeSlots,
    cycles: u32,
    /// Messages A and B each publish per cycle, at the start of slot `slot`.
    per_cycle: u32,
    slot: u8,
    /// A frame from port 3, which follows no cycle (a foreign node, or one whose clock is
    /// off), starts 20 µs before that slot and keeps the bus busy well into it.
    intrude: bool,
}

/// Runs the rig: `traffic`, and A's HRT stream every cycle; checks the slot policy on the bus
/// trace.
fn contend(parts: Parts, traffic: Traffic) -> Outcome {
    let Parts { mut m, mut a, mut b, scan_a, scan_b, torque, got_a, got_b } = parts;
    let Traffic { policy, cycles, per_cycle, slot: publish_slot, intrude } = traffic;
    let mut rig = Rig::new(3, 4);
    rig.run(&mut [&mut m, &mut a, &mut b], 200_000);
    assert!(matches!(a.hrt_state(1), Some(HrtState::Granted { .. })), "{:?}", a.hrt_state(1));
    for i in 0..3 {
        assert!(matches!(m.import_state(i), Some(ImportState::Subscribed { .. })));
    }
    let intruder = Frame::from_raw(0x1FFF_FFFF, &[0; 8]).unwrap();
    let mut port3 = rig.bus.port(3);
    let from = rig.bus.now() / 1_000;
    // Publish at slot boundaries well inside cycles; remember when (the deadline counts from
    // the node's tick at that boundary).
    let mut published: HashMap<u32, Micros> = HashMap::new();
    // The cycle's grid: the last sync's start of frame.
    let grid = Seen::of(&rig.bus).cycles.last().expect("the master syncs").0;
    let mut t =
        grid + (from - grid).next_multiple_of(CYCLE_US) + Micros::from(publish_slot) * SLOT_US;
    let mut got = Vec::new();
    for k in 0..cycles {
        if intrude {
            rig.run(&mut [&mut m, &mut a, &mut b], t - 20);
            port3.try_transmit(&intruder).unwrap();
        }
        rig.run(&mut [&mut m, &mut a, &mut b], t);
        torque.publish_with(|v| *v = k as u16).unwrap();
        for j in 0..per_cycle {
            let (x, y) = (tag(0, k * per_cycle + j), tag(1, k * per_cycle + j));
            scan_a.publish_with(|v| *v = scan(x)).unwrap();
            scan_b.publish_with(|v| *v = scan(y)).unwrap();
            published.insert(x, t);
            published.insert(y, t);
        }
        t += CYCLE_US;
        rig.run(&mut [&mut m, &mut a, &mut b], t);
        got.extend(
            core::iter::from_fn(|| got_a.try_recv())
                .map(|v| u32::from(v[0]) | u32::from(v[1]) << 16),
        );
        got.extend(
            core::iter::from_fn(|| got_b.try_recv())
                .map(|v| u32::from(v[0]) | u32::from(v[1]) << 16),
        );
    }
    rig.run(&mut [&mut m, &mut a, &mut b], t + 10 * CYCLE_US);
    got.extend(
        core::iter::from_fn(|| got_a.try_recv()).map(|v| u32::from(v[0]) | u32::from(v[1]) << 16),
    );
    got.extend(
        core::iter::from_fn(|| got_b.try_recv()).map(|v| u32::from(v[0]) | u32::from(v[1]) << 16),
    );

    // Check every frame of the run on the trace.
    let seen = Seen::of(&rig.bus);
    let mut out = Outcome::default();
    for e in rig.bus.trace() {
        let (start_ns, frame, sent) = match e.kind {
            EventKind::Sent { start_ns, frame, .. } => (start_ns, frame, true),
            EventKind::LostArbitration { start_ns, frame } => (start_ns, frame, false),
            _ => continue,
        };
        let start = start_ns / 1_000;
        if start < from || e.port == 3 {
            continue;
        }
        let Some((cycle, slot, mask)) = seen.slot_of(start) else { continue };
        let slot_start = cycle + Micros::from(slot) * SLOT_US;
        let id = frame.id();
        if SyncFrame::from_frame(&frame).is_ok() || !sent {
            if !sent {
                out.lost += 1;
            }
        } else if id.laxity == Laxity::HRT {
            out.hrt += 1;
            assert_eq!(start, slot_start, "HRT frame {frame:?} starts late in its slot");
            assert!(mask.is_none_or(|m| m & 1 << slot != 0), "HRT outside a reserved slot");
        } else {
            // SRT/NRT (management included): in a free slot, inside the window it opens.
            let mask = mask.expect("a frame in a free slot is sent only when the mask is known");
            assert!(slot != 0 && mask & 1 << slot == 0, "{frame:?} in reserved slot {slot}");
            let next = match policy {
                FreeSlots::Single => slot + 1,
                FreeSlots::Merged => {
                    (slot + 1..CYCLE.slots).find(|&j| mask & 1 << j != 0).unwrap_or(CYCLE.slots)
                }
            };
            let window_end = cycle + Micros::from(next) * SLOT_US;
            let idle = e.time_ns / 1_000 + Micros::from(INTERMISSION_BITS);
            assert!(
                idle <= window_end,
                "{frame:?} from {} runs {} µs past its window",
                e.port,
                idle - window_end
            );
            let latest = window_end - Micros::from(CYCLE.frame_us());
            assert!(
                start <= latest,
                "{frame:?} starts {} µs after its latest start",
                start - latest
            );
            out.queued += 1;
        }
        // A scan frame, sent or lost: its laxity is that of its deadline when it was loaded
        // (at this slot's start; in a merged window possibly the slot before).
        if let (Some(tag), true) = (tag_of(&frame), (1..=62).contains(&id.laxity.code())) {
            let Some(&p) = published.get(&tag) else { continue };
            let deadline = p + Micros::from(SRT_DEADLINE_US);
            let code_at = |t: Micros| LAXITY.encode((deadline - t) as u32).map(Laxity::code);
            let ok = code_at(slot_start) == Some(id.laxity.code())
                || (policy == FreeSlots::Merged
                    && code_at(slot_start - SLOT_US) == Some(id.laxity.code()));
            assert!(ok, "{frame:?} at {start}: laxity not from its deadline {deadline}");
            out.scan_frames += 1;
        }
    }
    let mut want: Vec<u32> = (0..cycles * per_cycle).flat_map(|k| [tag(0, k), tag(1, k)]).collect();
    want.sort_unstable();
    got.sort_unstable();
    out.delivered_all = got == want;
    out.deadline_misses = a.stats().deadline_misses + b.stats().deadline_misses;
    out.retries = a.stats().slot_retries + b.stats().slot_retries;
    out.late = a.stats().late_withdrawals + b.stats().late_withdrawals + m.stats().late_withdrawals;
    out.hrt_missed = a.stats().hrt_missed;
    out
}

#[derive(Debug, Default)]
struct Outcome {
    /// SRT/NRT frames sent (all checked to stay in their window).
    queued: u32,
    hrt: u32,
    /// One-shot frames that lost arbitration.
    lost: u32,
    /// Scan frames (sent or lost) whose laxity was checked against their deadline.
    scan_frames: u32,
    delivered_all: bool,
    deadline_misses: u32,
    retries: u32,
    late: u32,
    hrt_missed: u32,
}

#[test]
fn contending_nodes_stay_in_their_free_slot_and_the_loser_goes_later_with_its_deadline() {
    let traffic =
        Traffic { policy: FreeSlots::Single, cycles: 40, per_cycle: 2, slot: 3, intrude: false };
    let o = contend(rig!(FreeSlots::Single), traffic);
    assert!(o.lost > 40, "A and B contend for the same slots: {o:?}");
    assert!(o.retries >= o.lost / 2, "{o:?}");
    assert!(o.delivered_all && o.deadline_misses == 0, "{o:?}");
    assert!(o.scan_frames > 320 && o.queued > 320 && o.hrt >= 40 && o.hrt_missed == 0, "{o:?}");
    assert_eq!(o.late, 0, "every frame started at its slot's start");
}

#[test]
fn merged_windows_never_overrun_the_next_reserved_slot_or_sync() {
    let traffic =
        Traffic { policy: FreeSlots::Merged, cycles: 40, per_cycle: 3, slot: 3, intrude: false };
    let o = contend(rig!(FreeSlots::Merged), traffic);
    assert_eq!(o.lost, 0, "frames retry inside the window: {o:?}");
    assert!(o.delivered_all && o.deadline_misses == 0, "{o:?}");
    assert!(o.scan_frames >= 480 && o.hrt >= 40 && o.hrt_missed == 0, "{o:?}");
}

#[test]
fn a_frame_the_bus_kept_waiting_is_withdrawn_at_its_latest_start() {
    // The intruder ends about 120 µs into the slot; the slot's latest start is 90 µs in.
    let traffic =
        Traffic { policy: FreeSlots::Single, cycles: 30, per_cycle: 1, slot: 3, intrude: true };
    let o = contend(rig!(FreeSlots::Single), traffic);
    assert!(o.late >= 60, "A's and B's frames every cycle: {o:?}");
    assert!(o.delivered_all && o.deadline_misses == 0, "{o:?}");
}

#[test]
fn a_frame_the_bus_kept_waiting_at_a_merged_window_end_is_withdrawn_too() {
    // Published in the last free slot before the next cycle's sync: its latest start is 90 µs
    // into that slot; the intruder ends about 120 µs in.
    let traffic =
        Traffic { policy: FreeSlots::Merged, cycles: 30, per_cycle: 1, slot: 15, intrude: true };
    let o = contend(rig!(FreeSlots::Merged), traffic);
    assert!(o.late >= 60, "{o:?}");
    assert!(o.delivered_all && o.deadline_misses == 0, "{o:?}");
}

#[test]
fn an_nrt_backlog_never_keeps_an_srt_message_out_of_the_queue() {
    // A offers a log (NRT, 16 bytes: 3 frames with the transfer CRC) before its scan (SRT,
    // 6 ms): a drain that served exports in order until the queue is full would let a 30-message
    // log backlog (90 frames, 15 ms at one frame per slot) keep the scan out of the queue, past
    // its deadline.
    static L: Topic<'static, [u32; 4], { pool_size(&[32], 1) }, 1> = Topic::new("log", [0; 4]);
    static LP: Publisher<'static, [u32; 4]> = Publisher::new(&L, Class::NonRealTime);
    static LO: RemoteSubscriber<'static, [u32; 4], 32> = RemoteSubscriber::new(&LP);
    static S: Topic<'static, [u32; 4], { pool_size(&[4], 1) }, 1> = Topic::new("scan", [0; 4]);
    static SP: Publisher<'static, [u32; 4]> =
        Publisher::new(&S, Class::AsyncRealTime { deadline_us: SRT_DEADLINE_US });
    static SO: RemoteSubscriber<'static, [u32; 4], 4> = RemoteSubscriber::new(&SP);
    static ML: Topic<'static, [u32; 4], { pool_size(&[32], 1) }, 1> = Topic::new("log", [0; 4]);
    static MLP: Publisher<'static, [u32; 4]> = Publisher::new(&ML, Class::NonRealTime);
    static MLI: RemotePublisher<'static, [u32; 4]> = RemotePublisher::new(&MLP, &ML);
    static MLS: Subscriber<'static, [u32; 4], 32> = Subscriber::new();
    static MS: Topic<'static, [u32; 4], { pool_size(&[4], 1) }, 1> = Topic::new("scan", [0; 4]);
    static MSP: Publisher<'static, [u32; 4]> = Publisher::new(&MS, Class::NonRealTime);
    static MSI: RemotePublisher<'static, [u32; 4]> = RemotePublisher::new(&MSP, &MS);
    static MSS: Subscriber<'static, [u32; 4], 4> = Subscriber::new();
    L.subscribe(&LO).unwrap();
    S.subscribe(&SO).unwrap();
    ML.subscribe(&MLS).unwrap();
    MS.subscribe(&MSS).unwrap();
    let single = FreeSlots::Single;
    let mut m = VNode::new(config(1, "psu", Some(0), single), &NoParams).unwrap();
    let mut a = VNode::new(config(2, "a", None, single), &NoParams).unwrap();
    a.export(&LO).unwrap();
    a.export(&SO).unwrap();
    m.import(&MLI).unwrap();
    m.import(&MSI).unwrap();
    let mut rig = Rig::new(2, 2);
    rig.run(&mut [&mut m, &mut a], 200_000);
    assert!(matches!(m.import_state(1), Some(ImportState::Subscribed { .. })));

    let t = rig.bus.now() / 1_000 + 1;
    for k in 0..30 {
        LP.publish_with(|v| *v = [k; 4]).unwrap();
    }
    SP.publish_with(|v| *v = [7; 4]).unwrap();
    rig.run(&mut [&mut m, &mut a], t + Micros::from(SRT_DEADLINE_US));
    assert_eq!(MSS.try_recv().map(|v| v[0]), Some(7), "the scan arrived by its deadline");
    rig.run(&mut [&mut m, &mut a], t + 30_000);
    assert_eq!(a.stats().deadline_misses, 0);
    let logs = core::iter::from_fn(|| MLS.try_recv()).count();
    assert_eq!(logs, 30, "the log backlog still goes out, after");
}

/// The slot path of a module takes ~22 µs from the slot timer's clock read to the mailbox
/// request (QEMU slot-path bench, 72 MHz), so the master's sync starts that much after the
/// instant it decided to send it. Slaves anchor the cycle at the sync's start of frame; the
/// master must too (bxCAN's transmit stamp), or its slot grid runs ahead of everyone else's
/// and its HRT frames start early in their slot as the others see it.
#[test]
fn the_master_anchors_its_cycle_where_the_slaves_do_at_its_syncs_start_of_frame() {
    const LOAD_US: u64 = 22;
    let Parts { mut m, mut a, mut b, .. } = rig!(FreeSlots::Single);
    let mut rig = Rig::with_load_latency(3, 3, LOAD_US);
    rig.run(&mut [&mut m, &mut a, &mut b], 200_000);
    let sof = Seen::of(&rig.bus).cycles.last().expect("the master syncs").0;
    let now = rig.bus.now() / 1_000;
    for (name, node) in [("master", &m), ("slave a", &a), ("slave b", &b)] {
        let rtcan::cycle::ClockState::Running(p) = node.clock().state(now) else {
            panic!("{name}: no cycle")
        };
        // The cycle the last sync started, as each node's clock places it.
        let start = node.clock().slot_start(p.cycle, 0).expect("running");
        let slot1 = node.clock().slot_start(p.cycle, 1).expect("running");
        assert!(start <= now && now - start < CYCLE_US, "{name}: {start} {now}");
        assert_eq!(start, sof, "{name}: cycle start vs the sync's start of frame on the bus");
        assert_eq!(slot1, sof + SLOT_US, "{name}: slot 1");
    }
}
