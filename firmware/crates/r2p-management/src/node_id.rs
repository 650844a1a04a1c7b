//! Choosing a node ID that no other module on the bus uses, with no configuration.
//!
//! The original R2P took a byte of the MCU's unique ID, so two modules could collide; here a
//! module starts from a hash of its 96-bit unique ID, listens for a while (the node: one
//! heartbeat period) marking the node IDs it hears in use, [claims](NodeIdAllocator::claim) its
//! ID or the next one not heard, and keeps it by sending heartbeats on that node's management
//! stream. When it hears a heartbeat on the same stream carrying a *different* unique ID, one
//! of the two keeps the node ID and the other moves to the next ID it has not seen in use:
//! - a module before a tool (a tool's unique ID starts with [`TOOL_UID_PREFIX`]);
//! - then a running module before a starting one (its heartbeats say `Starting`): a module
//!   plugged into a running robot never makes a running module move, even if it missed that
//!   module's heartbeat while it listened;
//! - then the numerically smaller unique ID (every module starting together: a power-up).
//!
//! Every conflict is settled by one comparison both sides make identically from what the
//! heartbeats say, so the bus converges; two modules with the same name are no problem because
//! names play no part.

use crate::ids::NodeId;
use crate::message::UID_LEN;

/// The first bytes of every tool's unique ID (the `r2p` CLI's): no MCU's starts with `FF FF`
/// (an STM32's begins with its die's X coordinate on the wafer, little-endian), so a tool always
/// yields a node ID to a module.
pub const TOOL_UID_PREFIX: [u8; 2] = [0xFF, 0xFF];

/// What a conflict over a node ID compares first: a module (0) before a tool (2), a running
/// module before a starting one (+1); equal standings fall back to the smaller unique ID (see
/// the module documentation).
fn standing(uid: &[u8; UID_LEN], starting: bool) -> u8 {
    2 * u8::from(uid[..2] == TOOL_UID_PREFIX) + u8::from(starting)
}

/// Node-ID claim state for one module.
#[derive(Clone, Debug)]
pub struct NodeIdAllocator {
    uid: [u8; UID_LEN],
    current: NodeId,
    /// Node IDs heard in use by other modules (bit n = node n).
    seen: [u32; 8],
    moves: u32,
}

/// FNV-1a, 32-bit: a small, well-known hash that spreads similar unique IDs (consecutive
/// serial numbers) over the node-ID range.
pub fn fnv1a(bytes: &[u8]) -> u32 {
    let mut h: u32 = 0x811C_9DC5;
    for &b in bytes {
        h ^= b as u32;
        h = h.wrapping_mul(0x0100_0193);
    }
    h
}

/// The node ID a module with unique ID `uid` tries first.
pub fn initial_node_id(uid: &[u8; UID_LEN]) -> NodeId {
    let span = (NodeId::MAX - NodeId::MIN + 1) as u32;
    NodeId::new(NodeId::MIN + (fnv1a(uid) % span) as u8).unwrap_or(NodeId::new(1).unwrap())
}

impl NodeIdAllocator {
    /// Starts claiming the node ID derived from `uid`.
    pub fn new(uid: [u8; UID_LEN]) -> Self {
        Self { current: initial_node_id(&uid), uid, seen: [0; 8], moves: 0 }
    }

    /// The node ID this module currently claims (its heartbeats go on its management stream).
    pub fn node_id(&self) -> NodeId {
        self.current
    }

    /// How many times a conflict made this module move.
    pub fn moves(&self) -> u32 {
        self.moves
    }

    fn mark_seen(&mut self, n: u8) {
        self.seen[(n / 32) as usize] |= 1 << (n % 32);
    }

    fn is_seen(&self, n: u8) -> bool {
        self.seen[(n / 32) as usize] & (1 << (n % 32)) != 0
    }

    /// Feeds a heartbeat heard on node `from`'s management stream with unique ID `uid`, saying
    /// `Starting` or not (`starting`); `me_starting`: whether this module's own heartbeats say
    /// `Starting` now. Returns the new node ID if this module had to move (it must then
    /// re-advertise).
    pub fn on_heartbeat(
        &mut self,
        from: NodeId,
        uid: &[u8; UID_LEN],
        starting: bool,
        me_starting: bool,
    ) -> Option<NodeId> {
        if *uid == self.uid {
            return None; // our own heartbeat echoed back (loopback, emulation)
        }
        self.mark_seen(from.get());
        let (mine, theirs) = (standing(&self.uid, me_starting), standing(uid, starting));
        if from != self.current || mine < theirs || (mine == theirs && self.uid < *uid) {
            return None; // no conflict, or we keep the ID: the other module moves
        }
        // Conflict and the other module wins.
        self.move_on();
        self.moves += 1;
        Some(self.current)
    }

    /// Notes a heartbeat heard on node `from`'s management stream with unique ID `uid` while
    /// listening, before the claim: that node ID is in use (unless the heartbeat is our own).
    pub fn heard(&mut self, from: NodeId, uid: &[u8; UID_LEN]) {
        if *uid != self.uid {
            self.mark_seen(from.get());
        }
    }

    /// Claims a node ID after listening: the current one unless it was heard in use, else the
    /// next one not heard. Returns the new node ID if it changed.
    pub fn claim(&mut self) -> Option<NodeId> {
        if !self.is_seen(self.current.get()) {
            return None;
        }
        self.move_on();
        Some(self.current)
    }

    /// Takes the next node ID not seen in use.
    fn move_on(&mut self) {
        let span = NodeId::MAX - NodeId::MIN + 1;
        let mut n = self.current.get();
        for _ in 0..span {
            n = if n == NodeId::MAX { NodeId::MIN } else { n + 1 };
            if !self.is_seen(n) {
                break;
            }
        }
        self.current = NodeId::new(n).unwrap_or(self.current);
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    fn uid(n: u32) -> [u8; UID_LEN] {
        let mut u = [0u8; UID_LEN];
        u[8..].copy_from_slice(&n.to_be_bytes());
        u
    }

    /// Runs heartbeat rounds among 20 modules (everyone hears everyone) until no one moves.
    fn settle(nodes: &mut [NodeIdAllocator; 20]) {
        for _ in 0..64 {
            let claims: [(NodeId, [u8; UID_LEN]); 20] =
                core::array::from_fn(|i| (nodes[i].node_id(), nodes[i].uid));
            let mut moved = false;
            for node in nodes.iter_mut() {
                for (id, u) in &claims {
                    moved |= node.on_heartbeat(*id, u, false, false).is_some();
                }
            }
            if !moved {
                return;
            }
        }
        panic!("node IDs did not settle in 64 rounds");
    }

    r2p_testkit::suite! {
        fn initial_ids_are_in_range_and_spread() {
            let a = initial_node_id(&uid(1000));
            let b = initial_node_id(&uid(1001));
            assert!(a != b, "consecutive serials should not collide");
            for n in 0..500 {
                let id = initial_node_id(&uid(n)).get();
                assert!((NodeId::MIN..=NodeId::MAX).contains(&id));
            }
        }

        fn smaller_uid_keeps_the_id() {
            let mut low = NodeIdAllocator::new(uid(1));
            let mut high = NodeIdAllocator::new(uid(2));
            // Force the collision.
            high.current = low.current;
            assert_eq!(low.on_heartbeat(high.node_id(), &uid(2), false, false), None);
            let moved = high.on_heartbeat(low.node_id(), &uid(1), false, false).unwrap();
            assert_ne!(moved, low.node_id());
            assert_eq!(high.moves(), 1);
        }

        fn own_echo_is_not_a_conflict() {
            let mut a = NodeIdAllocator::new(uid(5));
            assert_eq!(a.on_heartbeat(a.node_id(), &uid(5), false, false), None);
        }

        fn twenty_modules_all_on_one_id_settle_unique() {
            let mut nodes: [NodeIdAllocator; 20] = core::array::from_fn(|i| {
                let mut n = NodeIdAllocator::new(uid(i as u32 * 7 + 3));
                n.current = NodeId::new(200).unwrap();
                n
            });
            settle(&mut nodes);
            for i in 0..nodes.len() {
                for j in i + 1..nodes.len() {
                    assert_ne!(nodes[i].node_id(), nodes[j].node_id(), "{} and {}", i, j);
                }
            }
            // The smallest unique ID kept the contested ID.
            assert_eq!(nodes[0].node_id(), NodeId::new(200).unwrap());
        }
    }
}
