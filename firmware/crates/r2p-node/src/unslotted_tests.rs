//! A node driven by `poll` alone (no slot timer: a tool on the bus, a module on a bus without a
//! cycle) counts the syncs it hears but does not follow them (docs/middleware.md, "Remote
//! topics: the node runtime"): its clock stays unsynced, so it never acts on a cycle it does
//! not run.

use rtcan::cycle::ClockState;
use rtcan::SyncFrame;

use crate::node::NodeConfig;
use crate::testbus::{run, uid, Bus, TestNode};
use crate::NoParams;

#[test]
fn a_polled_node_counts_syncs_without_following_them() {
    let bus = Bus::<1>::new();
    let mut n = TestNode::new(NodeConfig::new(uid(1), "tool"), &NoParams).unwrap();
    for k in 0..5u32 {
        bus.inject(SyncFrame::new(k, 0b110, false).to_frame());
        let until = bus.now.get() + 10_000;
        run(&bus, &mut [&mut n], until);
    }
    assert_eq!((n.stats().sync_frames, n.stats().bad_syncs), (5, 0));
    assert_eq!(n.clock().state(bus.now.get()), ClockState::Unsynced);
}
