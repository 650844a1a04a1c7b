//! Node-ID claims as modules on one bus rely on them (docs/management.md): the first ID comes
//! from the unique ID by a formula any tool can repeat, and a module that loses a conflict
//! moves once, straight to an ID nobody was heard using.

use r2p_management::message::UID_LEN;
use r2p_management::node_id::{fnv1a, initial_node_id, NodeIdAllocator, TOOL_UID_PREFIX};
use r2p_management::NodeId;

fn uid(n: u32) -> [u8; UID_LEN] {
    let mut u = [0u8; UID_LEN];
    u[8..].copy_from_slice(&n.to_be_bytes());
    u
}

fn id(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

/// The module with unique ID `uid(1000)` (first ID 11) and that ID.
fn module_1000() -> (NodeIdAllocator, NodeId) {
    let a = NodeIdAllocator::new(uid(1000));
    let at = a.node_id();
    (a, at)
}

#[test]
fn the_first_id_is_one_plus_the_uids_fnv1a_modulo_254() {
    // Independent values (FNV-1a 32 of the 12 bytes, computed outside this crate): a tool that
    // knows a module's unique ID knows where it starts.
    for (n, hash, first) in [
        (0u32, 0xe23c_62b5u32, 140u8),
        (1, 0xe13c_6122, 237),
        (1000, 0xa03f_cc66, 11),
        (0xDEAD_BEEF, 0xb3ab_0d13, 130),
    ] {
        assert_eq!(fnv1a(&uid(n)), hash, "fnv1a of uid {n}");
        assert_eq!(initial_node_id(&uid(n)), id(first), "first ID of uid {n}");
        assert_eq!(NodeIdAllocator::new(uid(n)).node_id(), id(first));
    }
    let counting: [u8; UID_LEN] = core::array::from_fn(|i| i as u8);
    assert_eq!(initial_node_id(&counting), id(38));
}

#[test]
fn the_loser_of_a_conflict_skips_every_id_heard_in_use() {
    // uid(1000) starts at 11; uid(0) (smaller: it wins) claims 11 too; 12, 13 and 15 are in use.
    let (mut a, start) = module_1000();
    assert_eq!(start, id(11));
    for (n, other) in [(12u8, 77u32), (13, 78), (15, 79)] {
        assert_eq!(a.on_heartbeat(id(n), &uid(other), false, false), None, "no conflict on {n}");
    }
    assert_eq!(a.moves(), 0);
    assert_eq!(
        a.on_heartbeat(id(11), &uid(0), false, false),
        Some(id(14)),
        "first ID not heard in use"
    );
    assert_eq!((a.node_id(), a.moves()), (id(14), 1));
    // The winner of a conflict stays and does not count a move.
    let mut w = NodeIdAllocator::new(uid(0));
    let at = w.node_id();
    assert_eq!(w.on_heartbeat(at, &uid(5), false, false), None);
    assert_eq!((w.node_id(), w.moves()), (at, 0));
    // A second conflict: a second move.
    assert_eq!(a.on_heartbeat(id(14), &uid(1), false, false), Some(id(16)));
    assert_eq!(a.moves(), 2);
}

#[test]
fn moving_past_the_highest_id_wraps_to_the_lowest() {
    // Find a unique ID whose first choice is 253; 254 and 1 are in use: it moves to 2.
    let n = (0u32..).find(|&n| initial_node_id(&uid(n)) == id(253)).unwrap();
    let mut a = NodeIdAllocator::new(uid(n));
    a.on_heartbeat(id(NodeId::MAX), &uid(n + 1), false, false);
    a.on_heartbeat(id(NodeId::MIN), &uid(n + 2), false, false);
    let smaller = uid(0);
    assert!(smaller < uid(n));
    assert_eq!(a.on_heartbeat(id(253), &smaller, false, false), Some(id(2)));
}

#[test]
fn with_one_id_left_the_loser_finds_it_wherever_it_is() {
    // Every ID but 10 is heard in use (all 254 IDs with 11 the contested one): the search
    // goes all the way round to 10.
    let (mut a, start) = module_1000();
    for n in NodeId::MIN..=NodeId::MAX {
        if n != 10 && n != start.get() {
            a.on_heartbeat(id(n), &uid(100_000 + u32::from(n)), false, false);
        }
    }
    assert_eq!(a.on_heartbeat(start, &uid(0), false, false), Some(id(10)));
}

#[test]
fn with_no_id_left_the_loser_stays_where_it_is() {
    // Every ID heard in use (more modules than a bus can hold): the search goes once round and
    // ends where it started; the conflict stays visible in `moves`.
    let (mut a, start) = module_1000();
    for n in NodeId::MIN..=NodeId::MAX {
        if n != start.get() {
            a.on_heartbeat(id(n), &uid(100_000 + u32::from(n)), false, false);
        }
    }
    assert_eq!(a.on_heartbeat(start, &uid(0), false, false), Some(start));
    assert_eq!(a.moves(), 1);
}

#[test]
fn a_running_module_keeps_its_id_against_a_starting_one_whatever_their_unique_ids() {
    // uid(1000) runs on 11; uid(0) (smaller), plugged in later, claims 11 while starting.
    let (mut running, at) = module_1000();
    assert_eq!(running.on_heartbeat(at, &uid(0), true, false), None, "the running one keeps it");
    let mut newcomer = NodeIdAllocator::new(uid(0));
    let mine = newcomer.node_id();
    assert_eq!(newcomer.on_heartbeat(mine, &uid(1000), false, true), Some(id(mine.get() + 1)));
    // Both starting (a power-up), or both running: the smaller unique ID keeps it, as before.
    for (starting, me_starting) in [(true, true), (false, false)] {
        let (mut a, at) = module_1000();
        assert_eq!(a.on_heartbeat(at, &uid(0), starting, me_starting), Some(id(12)));
        let (mut b, at) = module_1000();
        assert_eq!(b.on_heartbeat(at, &uid(5000), starting, me_starting), None);
    }
}

#[test]
fn a_tool_yields_to_a_module_even_one_that_is_starting() {
    let mut tool_uid = uid(1);
    tool_uid[..2].copy_from_slice(&TOOL_UID_PREFIX);
    // A module rebooting (starting) onto the node ID a running tool holds: the tool moves.
    let mut tool = NodeIdAllocator::new(tool_uid);
    let at = tool.node_id();
    assert!(tool.on_heartbeat(at, &uid(1000), true, false).is_some(), "the tool moves");
    let (mut module, at) = module_1000();
    assert_eq!(module.on_heartbeat(at, &tool_uid, false, true), None, "the module keeps it");
}

#[test]
fn a_claim_after_listening_skips_the_ids_heard_in_use() {
    let (mut a, start) = module_1000();
    assert_eq!(a.claim(), None, "nothing heard: the first ID");
    for (n, other) in [(11u8, 77u32), (12, 78), (14, 79)] {
        a.heard(id(n), &uid(other));
    }
    a.heard(id(13), &uid(1000)); // its own heartbeat echoed: not a use
    assert_eq!(a.node_id(), start, "listening moves nothing");
    assert_eq!(a.claim(), Some(id(13)));
    assert_eq!((a.node_id(), a.moves()), (id(13), 0), "a claim is not a conflict's move");
    assert_eq!(a.claim(), None);
}
