//! The master reserves a slot only for a stream of the node that asks (docs/rtcan.md, "HRT
//! registration"): a request for another node's stream, or for a management stream, is
//! answered `Conflict` and reserves nothing, so no node can take slots in another's name, nor
//! release them.

use r2p_management::message::{HrtResult, Message};
use r2p_management::NodeId;
use rtcan::controller::CanController;
use rtcan::failover::Role;
use rtcan::{Expect, Reassembler, SyncFrame};

use crate::hrt_stream_tests::inject;
use crate::tdma_tests::{tdma, CYCLE_US};
use crate::testbus::{run_slots, Bus, TestNode};
use crate::NoParams;

/// The master's HRT_GRANTs and the reservations of its last sync, seen on port 1.
pub(crate) fn grants_and_mask(bus: &Bus<2>) -> (std::vec::Vec<(u16, HrtResult)>, u64) {
    let mut r: Reassembler<4, 64> = Reassembler::new(1_000_000);
    let (mut grants, mut mask) = (std::vec::Vec::new(), 0);
    let mut port = bus.port(1);
    while let Some(rx) = port.try_receive() {
        if let Ok(sync) = SyncFrame::from_frame(&rx.frame) {
            mask = sync.reservations;
            continue;
        }
        if let Some(m) = r.accept(&rx.frame, rx.at, Expect::Any) {
            if let Ok(Message::HrtGrant { message_id, result, .. }) = Message::decode(m.data) {
                grants.push((message_id, result));
            }
        }
    }
    (grants, mask)
}

#[test]
fn the_master_reserves_slots_only_for_the_asking_nodes_own_streams() {
    let bus = Bus::<2>::slotted(crate::tdma_tests::CYCLE);
    let mut m = TestNode::new(tdma(1, "psu", Some(0)), &NoParams).unwrap();
    run_slots(&bus, &mut [&mut m], 20 * CYCLE_US);
    assert_eq!(m.role(), Role::Master);
    let (_, empty) = grants_and_mask(&bus);
    let (asker, other) = (NodeId::new(0x40).unwrap(), NodeId::new(0x41).unwrap());
    let request = |message: rtcan::MessageId| Message::HrtRequest {
        message_id: message.0,
        period_cycles: 1,
        frames: 1,
        size: 4,
    };

    for (stream, what) in [
        (other.message_id(1), "another node's stream"),
        (asker.management(), "a management stream"),
    ] {
        inject(&bus, asker.get(), &request(stream));
        let until = bus.now.get() + 3 * CYCLE_US;
        run_slots(&bus, &mut [&mut m], until);
        let (grants, mask) = grants_and_mask(&bus);
        assert_eq!(grants, [(stream.0, HrtResult::Conflict)], "{what}");
        assert_eq!(mask, empty, "{what}: nothing reserved");
    }
    let own = asker.message_id(1);
    inject(&bus, asker.get(), &request(own));
    let until = bus.now.get() + 3 * CYCLE_US;
    run_slots(&bus, &mut [&mut m], until);
    let (grants, mask) = grants_and_mask(&bus);
    assert_eq!(grants, [(own.0, HrtResult::Ok)]);
    assert_eq!((mask & !empty).count_ones(), 1, "one slot reserved");

    // A release (period 0) from another node leaves the reservation; its owner's frees it.
    let release = Message::HrtRequest { message_id: own.0, period_cycles: 0, frames: 1, size: 0 };
    inject(&bus, other.get(), &release);
    let until = bus.now.get() + 3 * CYCLE_US;
    run_slots(&bus, &mut [&mut m], until);
    assert_eq!(grants_and_mask(&bus).1, mask, "not released in another's name");
    assert_eq!(m.stats().hrt_released, 0);
    inject(&bus, asker.get(), &release);
    let until = bus.now.get() + 3 * CYCLE_US;
    run_slots(&bus, &mut [&mut m], until);
    assert_eq!(grants_and_mask(&bus).1, empty, "released by its owner");
    assert_eq!(m.stats().hrt_released, 1);
}
