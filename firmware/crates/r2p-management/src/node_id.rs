//! Choosing a node ID that no other module on the bus uses, with no configuration.
//!
//! The original R2P took a byte of the MCU's unique ID, so two modules could collide; here a
//! module starts from a hash of its 96-bit unique ID and claims the node ID by sending
//! heartbeats on that node's management stream. When it hears a heartbeat on the same stream
//! carrying a *different* unique ID, the module with the numerically smaller unique ID keeps
//! the node ID and the other moves to the next ID it has not seen in use. Every conflict is
//! settled by one comparison both sides make identically, so the bus converges; two modules
//! with the same name are no problem because names play no part.

use crate::ids::NodeId;
use crate::message::UID_LEN;

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

    /// Feeds a heartbeat heard on node `from`'s management stream with unique ID `uid`.
    /// Returns the new node ID if this module had to move (it must then re-advertise).
    pub fn on_heartbeat(&mut self, from: NodeId, uid: &[u8; UID_LEN]) -> Option<NodeId> {
        if *uid == self.uid {
            return None; // our own heartbeat echoed back (loopback, emulation)
        }
        self.mark_seen(from.get());
        if from != self.current || *uid > self.uid {
            return None; // no conflict, or we keep the ID: the other module moves
        }
        // Conflict and the other module wins: take the next ID not seen in use.
        let span = NodeId::MAX - NodeId::MIN + 1;
        let mut n = self.current.get();
        for _ in 0..span {
            n = if n == NodeId::MAX { NodeId::MIN } else { n + 1 };
            if !self.is_seen(n) {
                break;
            }
        }
        self.current = NodeId::new(n).unwrap_or(self.current);
        self.moves += 1;
        Some(self.current)
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
                    moved |= node.on_heartbeat(*id, u).is_some();
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
            assert_eq!(low.on_heartbeat(high.node_id(), &uid(2)), None);
            let moved = high.on_heartbeat(low.node_id(), &uid(1)).unwrap();
            assert_ne!(moved, low.node_id());
            assert_eq!(high.moves(), 1);
        }

        fn own_echo_is_not_a_conflict() {
            let mut a = NodeIdAllocator::new(uid(5));
            assert_eq!(a.on_heartbeat(a.node_id(), &uid(5)), None);
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
