//! Frame-sized reservations (issue 22; `node/framed.rs`), what needs no other node: the
//! master refuses an HRT request that contradicts itself. The positions every node learns, and
//! the slot path that sends in them, run on the µs-exact virtual bus (this slot-granular test
//! bus cannot place a frame off the grid): `firmware/host/loadbench/tests/framed_positions.rs`
//! and `framed_slot_path.rs`.

use rtcan::failover::Role;
use rtcan::{Micros, SyncFrame};

use crate::node::{FramedLeads, NodeConfig};
use crate::tdma_tests::{tdma, CYCLE, CYCLE_US};
use crate::testbus::{run_slots, Bus, TestNode};
use crate::NoParams;

/// A node of a bus with frame-sized reservations in two blocks and room for four slots' time.
fn framed(n: u32, name: &'static str, rank: Option<u8>) -> NodeConfig {
    NodeConfig { hrt_slots: 4, hrt_blocks: 2, ..tdma(n, name, rank) }
}

#[test]
fn a_request_whose_size_is_not_its_frames_is_refused() {
    use crate::hrt_master_tests::grants_and_mask;
    use crate::hrt_stream_tests::inject;
    use r2p_management::message::{HrtResult, Message};
    use r2p_management::NodeId;

    let bus = Bus::<2>::slotted(CYCLE);
    let mut m = TestNode::new(framed(1, "psu", Some(0)), &NoParams).unwrap();
    run_slots(&bus, &mut [&mut m], 20 * CYCLE_US);
    grants_and_mask(&bus);
    let asker = NodeId::new(0x40).unwrap();
    let stream = asker.message_id(1);
    // 20 bytes are three frames, not one; 63 bytes are no HRT message at all. Then the truth.
    for (frames, size, result) in
        [(1, 20, HrtResult::Conflict), (8, 63, HrtResult::Conflict), (3, 20, HrtResult::Ok)]
    {
        let request = Message::HrtRequest { message_id: stream.0, period_cycles: 2, frames, size };
        inject(&bus, asker.get(), &request);
        let until = bus.now.get() + 3 * CYCLE_US;
        run_slots(&bus, &mut [&mut m], until);
        let want = if result == HrtResult::Ok { 3 } else { 1 };
        assert_eq!(grants_and_mask(&bus).0, std::vec![(stream.0, result); want], "{frames} {size}");
    }
    assert_eq!((1..64).filter(|&s| m.reservation(s).is_some()).count(), 3);
}

/// A frame-sized master loads its sync first, on a path shorter than its HRT frames' and with a
/// lead of its own (`NodeConfig::framed_leads`, `Node::tick_time`): its slot timer asks for the
/// sync's lead before the cycle's start, and that tick starts the cycle there, every cycle one
/// cycle after the last; no other tick loads a sync.
#[test]
fn a_frame_sized_master_times_its_sync_by_the_sync_lead() {
    let leads = FramedLeads { slot_us: 19, sync_us: 9 };
    let bus = Bus::<1>::slotted(CYCLE);
    let config = NodeConfig { framed_leads: leads, ..framed(1, "psu", Some(0)) };
    let mut m = TestNode::new(config, &NoParams).unwrap();
    run_slots(&bus, &mut [&mut m], 20 * CYCLE_US);
    assert_eq!(m.role(), Role::Master);
    // Its own timer from here on: each tick where it asks, the bus sending what it loaded.
    let mut t = m.next_slot_at(bus.now.get());
    let mut starts: std::vec::Vec<Micros> = std::vec::Vec::new();
    while t < 40 * CYCLE_US {
        bus.now.set(t);
        m.slot_tick(t, &mut bus.port(0));
        if bus.loaded(0).is_some_and(|f| SyncFrame::from_frame(&f).is_ok()) {
            let start = t + Micros::from(leads.sync_us);
            let cycle = m.clock().state(start);
            assert!(matches!(cycle, rtcan::cycle::ClockState::Running(p) if p.slot == 0), "{t}");
            starts.push(start);
        }
        bus.arbitrate();
        let next = m.next_slot_at(t);
        assert!(next > t, "the timer asks for a time after its tick: {t} → {next}");
        t = next;
    }
    assert!(starts.len() >= 19, "a sync every cycle: {starts:?}");
    for w in starts.windows(2) {
        assert_eq!(w[1] - w[0], CYCLE_US, "cycles start a cycle apart: {starts:?}");
    }
    // The clock's start of each cycle is the tick's time plus the sync's lead.
    let last = *starts.last().unwrap();
    let rtcan::cycle::ClockState::Running(p) = m.clock().state(last) else { panic!() };
    assert_eq!(m.clock().slot_start(p.cycle, 0), Some(last));
}
