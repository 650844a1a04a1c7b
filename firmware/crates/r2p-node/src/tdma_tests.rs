//! Behaviour suite of the TDMA cycle: a master and two modules on the slotted loopback bus, in
//! virtual time (host and QEMU).

use r2p_management::message::{HrtResult, SubscribeResult};
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use rtcan::failover::Role;
use rtcan::{CycleConfig, Frame, FrameId, Micros};

use crate::node::{HrtState, ImportState, NodeConfig};
use crate::testbus::{run_slots, uid, Bus, TestNode};
use crate::{NoParams, RemotePublisher, RemoteSubscriber};

/// 4 ms cycles of 16 slots of 250 µs (250 bit times at 1 Mbit/s).
pub const CYCLE: CycleConfig = CycleConfig { bit_rate: 1_000_000, cycle_us: 4_000, slots: 16 };
pub const CYCLE_US: Micros = 4_000;

/// A node on the TDMA bus: fast protocol timers, the test cycle, two HRT slots as master.
pub fn tdma(n: u32, name: &'static str, rank: Option<u8>) -> NodeConfig {
    NodeConfig {
        heartbeat_period_us: 20_000,
        request_timeout_us: 30_000,
        cycle: CYCLE,
        rank,
        hrt_slots: 2,
        ..NodeConfig::new(uid(n), name)
    }
}

r2p_testkit::suite! {
    fn with_its_leads_the_timer_fires_that_early_and_the_node_acts_for_the_boundary() {
        // A master alone, driven as its slot timer would: at the times `next_slot_at` asks for,
        // with the modules' own leads: the sync's, shorter (it is loaded first in its tick),
        // before each cycle, the slot lead before every other boundary.
        let (lead, sync_lead) = (crate::MODULE_SLOT_LEAD_US, crate::MODULE_SYNC_LEAD_US);
        assert!(0 < sync_lead && sync_lead < lead, "{sync_lead} µs, {lead} µs");
        let bus = Bus::<1>::slotted(CYCLE);
        let config =
            NodeConfig { slot_lead_us: lead, sync_lead_us: sync_lead, ..tdma(1, "psu", Some(0)) };
        let mut m = TestNode::new(config, &NoParams).unwrap();
        let mut t: Micros = 0;
        let (mut ticks, mut on_grid) = (0u32, 0u32);
        let (mut syncs, mut last_start) = (0u32, None::<Micros>);
        while t < 60_000 {
            bus.now.set(t);
            // (The tick that takes over loads its first sync after its timers, at the slot lead.)
            let was_master = m.role() == Role::Master;
            m.slot_tick(t, &mut bus.port(0));
            let sync = bus.loaded(0).is_some_and(|f| rtcan::SyncFrame::from_frame(&f).is_ok());
            bus.arbitrate();
            if was_master {
                // Every tick is its lead before a slot boundary of the master's own cycle; the
                // sync's tick before the cycle's start, where the sync then starts it.
                let acts_for = t + Micros::from(if sync { sync_lead } else { lead });
                let rtcan::cycle::ClockState::Running(p) = m.clock().state(acts_for) else {
                    panic!("the master's clock runs")
                };
                ticks += 1;
                if m.clock().slot_start(p.cycle, p.slot) == Some(acts_for) {
                    on_grid += 1;
                }
                if sync {
                    assert_eq!(p.slot, 0, "a sync at {acts_for} µs starts its cycle");
                    if let Some(last) = last_start {
                        assert_eq!(acts_for - last, CYCLE_US, "cycles start a cycle apart");
                    }
                    (syncs, last_start) = (syncs + 1, Some(acts_for));
                }
            }
            t = m.next_slot_at(t).max(t + 1);
        }
        assert!(ticks >= 4 * u32::from(CYCLE.slots), "{ticks} ticks as master");
        assert_eq!(on_grid, ticks, "ticks {lead} µs (syncs {sync_lead} µs) before a boundary");
        assert!(syncs >= 10, "a sync every cycle: {syncs}");
        // Without a lead the same node ticks on the boundaries themselves.
        let bus = Bus::<1>::slotted(CYCLE);
        let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
        let mut t: Micros = 0;
        while t < 60_000 {
            bus.now.set(t);
            m.slot_tick(t, &mut bus.port(0));
            bus.arbitrate();
            if let (Role::Master, rtcan::cycle::ClockState::Running(p)) = (m.role(), m.clock().state(t)) {
                assert_eq!(m.clock().slot_start(p.cycle, p.slot), Some(t));
            }
            t = m.next_slot_at(t).max(t + 1);
        }
    }

    fn a_node_takes_in_only_the_streams_it_subscribed_to_and_the_bus_protocol() {
        // A publishes `setpoint` (to B) and `odometry` (to M); B must not see odometry's frames:
        // its controller's filters keep them out (r2p_node::hw_filters), so nothing reaches it
        // that it would have to count as unknown.
        static A_S: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("setpoint", 0);
        static A_SP: Publisher<'static, u32> = Publisher::new(&A_S, Class::NonRealTime);
        static A_SO: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&A_SP);
        static A_O: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("odometry", 0);
        static A_OP: Publisher<'static, u32> = Publisher::new(&A_O, Class::NonRealTime);
        static A_OO: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&A_OP);
        static B_S: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("setpoint", 0);
        static B_SP: Publisher<'static, u32> = Publisher::new(&B_S, Class::NonRealTime);
        static B_SI: RemotePublisher<'static, u32> = RemotePublisher::new(&B_SP, &B_S);
        static B_SS: Subscriber<'static, u32, 4> = Subscriber::new();
        static M_O: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("odometry", 0);
        static M_OP: Publisher<'static, u32> = Publisher::new(&M_O, Class::NonRealTime);
        static M_OI: RemotePublisher<'static, u32> = RemotePublisher::new(&M_OP, &M_O);
        static M_OS: Subscriber<'static, u32, 4> = Subscriber::new();
        A_S.advertise(&A_SP).unwrap();
        A_S.subscribe(&A_SO).unwrap();
        A_O.advertise(&A_OP).unwrap();
        A_O.subscribe(&A_OO).unwrap();
        B_S.advertise(&B_SP).unwrap();
        B_S.subscribe(&B_SS).unwrap();
        M_O.advertise(&M_OP).unwrap();
        M_O.subscribe(&M_OS).unwrap();

        let bus = Bus::<3>::slotted(CYCLE);
        let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
        let mut a = TestNode::new(tdma(2, "motor", None), &NoParams).unwrap();
        let mut b = TestNode::new(tdma(3, "control", None), &NoParams).unwrap();
        a.export(&A_SO).unwrap();
        a.export(&A_OO).unwrap();
        b.import(&B_SI).unwrap();
        m.import(&M_OI).unwrap();
        run_slots(&bus, &mut [&mut m, &mut a, &mut b], 150_000);
        assert!(matches!(b.import_state(0), Some(ImportState::Subscribed { .. })));
        assert!(matches!(m.import_state(0), Some(ImportState::Subscribed { .. })));
        let end = bus.now.get() + 40 * CYCLE_US;
        let mut k = 0u32;
        while bus.now.get() < end {
            let _ = A_SP.publish_with(|v| *v = k);
            let _ = A_OP.publish_with(|v| *v = k);
            k += 1;
            run_slots(&bus, &mut [&mut m, &mut a, &mut b], bus.now.get() + CYCLE_US);
            while M_OS.try_recv().is_some() {}
            while B_SS.try_recv().is_some() {}
        }
        assert!(m.stats().published >= 30, "M took odometry in: {:?}", m.stats());
        assert!(b.stats().published >= 30, "B took setpoints in: {:?}", b.stats());
        assert_eq!(b.stats().unknown_frames, 0, "B saw odometry's frames: {:?}", b.stats());
    }

    fn an_hrt_topic_reaches_the_subscriber_in_its_slot_every_second_cycle() {
        // A publishes `setpoint` every 2 cycles (8 ms, HRT); B subscribes; M is the master.
        static A_T: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("setpoint", 0);
        static A_PUB: Publisher<'static, u32> = Publisher::new(&A_T, Class::SyncRealTime { period_us: 8_000 });
        static A_OUT: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&A_PUB);
        static B_T: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("setpoint", 0);
        static B_PUB: Publisher<'static, u32> = Publisher::new(&B_T, Class::NonRealTime);
        static B_IN: RemotePublisher<'static, u32> = RemotePublisher::new(&B_PUB, &B_T);
        static B_SUB: Subscriber<'static, u32, 4> = Subscriber::new();
        A_T.advertise(&A_PUB).unwrap();
        A_T.subscribe(&A_OUT).unwrap();
        B_T.advertise(&B_PUB).unwrap();
        B_T.subscribe(&B_SUB).unwrap();

        let bus = Bus::<3>::slotted(CYCLE);
        let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
        let mut a = TestNode::new(tdma(2, "motor", None), &NoParams).unwrap();
        let mut b = TestNode::new(tdma(3, "control", None), &NoParams).unwrap();
        assert_eq!(a.export(&A_OUT), Ok(1));
        assert_eq!(b.import(&B_IN), Ok(0));
        assert_eq!(a.hrt_state(0), Some(HrtState::Idle), "no subscriber yet: nothing reserved");
        run_slots(&bus, &mut [&mut m, &mut a, &mut b], 150_000);

        assert_eq!((m.role(), a.role(), b.role()), (Role::Master, Role::Slave, Role::Slave));
        let Some(HrtState::Granted { slots }) = a.hrt_state(0) else {
            panic!("not granted: {:?}", a.hrt_state(0))
        };
        let phase = slots.first();
        assert!(phase.offset < 2 && (1..=2).contains(&phase.slot));
        let message = a.node_id().message_id(1);
        assert_eq!(b.import_state(0), Some(ImportState::Subscribed { from: a.node_id(), message }));

        // A garbage sync (wrong length) on the way: counted, not fatal.
        bus.inject(Frame::new(FrameId::sync(3), &[1, 2, 3]).unwrap());
        bus.clear_hrt_log();
        let mut got: heapless::Vec<u32, 8> = heapless::Vec::new();
        for k in 0..8u32 {
            A_PUB.publish_with(|v| *v = k).unwrap();
            let until = bus.now.get() + 2 * CYCLE_US;
            run_slots(&bus, &mut [&mut m, &mut a, &mut b], until);
            got.extend(core::iter::from_fn(|| B_SUB.try_recv()).map(|v| *v));
        }
        assert_eq!(got.as_slice(), &[0, 1, 2, 3, 4, 5, 6, 7]);
        let log = bus.hrt_log();
        assert_eq!(log.len(), 8);
        for (k, seen) in log.iter().enumerate() {
            assert_eq!((seen.message, seen.first, seen.slot), (message, k as u8, phase.slot));
            assert_eq!(seen.cycle % 2, u32::from(phase.offset), "in the granted cycles");
        }
        for w in log.windows(2) {
            // Zero jitter in slot terms: exactly one period apart, at the slot's start.
            assert_eq!((w[1].at - w[0].at, w[1].cycle - w[0].cycle), (2 * CYCLE_US, 2));
        }
        assert_eq!(bus.violations(), 0, "nothing but HRT in reserved slots, no HRT elsewhere");
        for n in [&m, &a, &b] {
            assert_eq!(n.stats().bad_syncs, 1);
        }
        assert_eq!((a.stats().hrt_sent, a.stats().hrt_missed), (8, 0));
        assert_eq!(A_PUB.stats().deadline_misses, 0);
        assert!(m.stats().syncs_sent > 30);
        // The slot timer's next boundary: one slot on (the bus's time is a slot boundary).
        let now = bus.now.get();
        assert_eq!((a.next_slot_at(now), b.next_slot_at(now + 100)), (now + 250, now + 250));
        assert_eq!(bus.overflow.get(), 0);
    }

    fn a_stream_the_master_cannot_admit_yields_no_slot() {
        // One HRT slot on the master; A offers two streams of 1 cycle: the second does not fit.
        static T1: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("fast1", 0);
        static P1: Publisher<'static, u8> = Publisher::new(&T1, Class::SyncRealTime { period_us: 4_000 });
        static O1: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P1);
        static T2: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("fast2", 0);
        static P2: Publisher<'static, u8> = Publisher::new(&T2, Class::SyncRealTime { period_us: 4_000 });
        static O2: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&P2);
        static L1: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("fast1", 0);
        static LP1: Publisher<'static, u8> = Publisher::new(&L1, Class::NonRealTime);
        static I1: RemotePublisher<'static, u8> = RemotePublisher::new(&LP1, &L1);
        static L2: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("fast2", 0);
        static LP2: Publisher<'static, u8> = Publisher::new(&L2, Class::NonRealTime);
        static I2: RemotePublisher<'static, u8> = RemotePublisher::new(&LP2, &L2);
        T1.subscribe(&O1).unwrap();
        T2.subscribe(&O2).unwrap();

        let bus = Bus::<3>::slotted(CYCLE);
        let mut m = TestNode::new(NodeConfig { hrt_slots: 1, ..tdma(1, "psu", Some(0)) }, &NoParams).unwrap();
        let mut a = TestNode::new(tdma(2, "a", None), &NoParams).unwrap();
        let mut b = TestNode::new(tdma(3, "b", None), &NoParams).unwrap();
        a.export(&O1).unwrap();
        a.export(&O2).unwrap();
        b.import(&I1).unwrap();
        b.import(&I2).unwrap();
        run_slots(&bus, &mut [&mut m, &mut a, &mut b], 200_000);

        let states = [b.import_state(0), b.import_state(1)];
        let from = a.node_id();
        let refused = Some(ImportState::Refused { from, result: SubscribeResult::NoSlot });
        assert!(states.contains(&refused), "{:?}", states);
        assert!(states.iter().any(|s| matches!(s, Some(ImportState::Subscribed { .. }))));
        let hrt = [a.hrt_state(0), a.hrt_state(1)];
        assert!(hrt.contains(&Some(HrtState::Refused(HrtResult::Full))), "{:?}", hrt);
        assert_eq!(a.stats().hrt_refused, 1);
        // The publisher is told which stream and why (issue 22: a refused stream no longer
        // stops silently on the publisher's side).
        let refused = (0..2).find(|&i| a.hrt_state(i) == Some(HrtState::Refused(HrtResult::Full)));
        let mut told = heapless::Vec::<crate::Event, 8>::new();
        while let Some(e) = a.next_event() {
            if let crate::Event::StreamRefused { .. } = e {
                told.push(e).unwrap();
            }
        }
        assert_eq!(
            told[..],
            [crate::Event::StreamRefused { export: refused.unwrap(), result: HrtResult::Full }]
        );
        assert_eq!(bus.violations(), 0);
    }
}
