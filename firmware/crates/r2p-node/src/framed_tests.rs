//! Frame-sized reservations (issue 22; `node/framed.rs`), what needs no other node: the
//! master refuses an HRT request that contradicts itself. The positions every node learns, and
//! the slot path that sends in them, run on the µs-exact virtual bus (this slot-granular test
//! bus cannot place a frame off the grid): `firmware/host/loadbench/tests/framed_positions.rs`
//! and `framed_slot_path.rs`.

use crate::node::NodeConfig;
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
