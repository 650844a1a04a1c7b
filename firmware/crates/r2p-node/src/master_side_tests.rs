//! A node built without the bus master's side (`Node<…, MASTER = false>`, what a module image
//! that can never become master runs, 2 KB smaller): refuses a rank, and follows a bus exactly
//! as a node with the master's side and no rank does.

use r2p_middleware::{pool_size, Class, Publisher, Topic};

use crate::node::{HrtState, NodeError};
use crate::tdma_tests::{tdma, CYCLE_US};
use crate::testbus::{Bus, TestNode};
use crate::{NoParams, RemotePublisher, RemoteSubscriber};

/// [`TestNode`]'s capacities without the master's side.
type FollowerNode<'a> = crate::Node<'a, 2, 2, 24, 4, 64, false>;

#[test]
fn a_rank_is_refused_by_name() {
    let config = tdma(1, "motor", Some(3));
    assert_eq!(FollowerNode::new(config, &NoParams).err(), Some(NodeError::NotMasterCapable));
    assert!(FollowerNode::new(tdma(1, "motor", None), &NoParams).is_ok());
    assert!(TestNode::new(config, &NoParams).is_ok(), "with the master's side it is taken");
}

#[test]
fn it_follows_the_bus_as_a_follower_with_the_masters_side_does() {
    // A master, a follower with the master's side (A) and one without (F): each offers an HRT
    // stream every cycle, which B subscribes to; both are granted and send in their own slot,
    // none missed.
    static TA: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("a", 0);
    static PA: Publisher<'static, u8> =
        Publisher::new(&TA, Class::SyncRealTime { period_us: 4_000 });
    static OA: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&PA);
    static TF: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("f", 0);
    static PF: Publisher<'static, u8> =
        Publisher::new(&TF, Class::SyncRealTime { period_us: 4_000 });
    static OF: RemoteSubscriber<'static, u8, 1> = RemoteSubscriber::new(&PF);
    static LA: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("a", 0);
    static LPA: Publisher<'static, u8> = Publisher::new(&LA, Class::NonRealTime);
    static IA: RemotePublisher<'static, u8> = RemotePublisher::new(&LPA, &LA);
    static LF: Topic<'static, u8, { pool_size(&[1], 1) }, 1> = Topic::new("f", 0);
    static LPF: Publisher<'static, u8> = Publisher::new(&LF, Class::NonRealTime);
    static IF: RemotePublisher<'static, u8> = RemotePublisher::new(&LPF, &LF);
    TA.subscribe(&OA).unwrap();
    TF.subscribe(&OF).unwrap();

    let bus = Bus::<4>::slotted(crate::tdma_tests::CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    let mut a = TestNode::new(tdma(2, "a", None), &NoParams).unwrap();
    let mut f = FollowerNode::new(tdma(3, "f", None), &NoParams).unwrap();
    let mut b = TestNode::new(tdma(4, "b", None), &NoParams).unwrap();
    a.export(&OA).unwrap();
    f.export(&OF).unwrap();
    b.import(&IA).unwrap();
    b.import(&IF).unwrap();
    let step = u64::from(crate::tdma_tests::CYCLE.slot_us());
    let run = |[m, a, b]: [&mut TestNode; 3], f: &mut FollowerNode, until: u64| {
        while bus.now.get() < until {
            let now = bus.now.get();
            m.slot_tick(now, &mut bus.port(0));
            a.slot_tick(now, &mut bus.port(1));
            f.slot_tick(now, &mut bus.port(2));
            b.slot_tick(now, &mut bus.port(3));
            bus.arbitrate();
            bus.now.set(now + step);
        }
    };
    run([&mut m, &mut a, &mut b], &mut f, 200_000);
    let granted = |s: Option<HrtState>| matches!(s, Some(HrtState::Granted { .. }));
    assert!(granted(a.hrt_state(0)) && granted(f.hrt_state(0)), "both granted");
    bus.clear_hrt_log();
    for k in 0..10u8 {
        PA.publish_with(|v| *v = k).unwrap();
        PF.publish_with(|v| *v = k).unwrap();
        run([&mut m, &mut a, &mut b], &mut f, bus.now.get() + CYCLE_US);
    }
    let log = bus.hrt_log();
    let (ma, mf) = (a.node_id().message_id(1), f.node_id().message_id(1));
    let sent = |id| log.iter().filter(|s| s.message == id).count();
    assert_eq!((sent(ma), sent(mf)), (10, 10), "{log:?}");
    assert_eq!((a.stats().hrt_missed, f.stats().hrt_missed), (0, 0));
    assert_eq!(a.stats().hrt_sent, f.stats().hrt_sent);
    assert_eq!(bus.violations(), 0);
}
