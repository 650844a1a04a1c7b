//! Node IDs and how message IDs are derived from them, so no two streams ever collide.
//!
//! A 16-bit RTCAN message ID is `node ID << 8 | stream index`. Node IDs are unique on the bus
//! (see [`crate::node_id`]), so message IDs are too without any central registry. Node 0 is
//! the sync frames' range (`rtcan::id::SYNC_MESSAGE_IDS`); stream index 0 of every node is its
//! management stream; indices 1–255 are the node's published topics in advertisement order.

use rtcan::MessageId;

/// A node's bus address, 1–254. Chosen from the MCU's unique ID and made unique on the bus by
/// [`crate::NodeIdAllocator`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct NodeId(u8);

/// Stream index of a node's management stream.
pub const MANAGEMENT_INDEX: u8 = 0;

impl NodeId {
    /// Smallest assignable node ID (0 is the sync range).
    pub const MIN: u8 = 1;
    /// Largest assignable node ID (255 is reserved for "every node" in requests).
    pub const MAX: u8 = 254;
    /// "Every node", as a request's target.
    pub const BROADCAST: u8 = 255;

    /// The node ID `n`, if it is assignable.
    pub const fn new(n: u8) -> Option<Self> {
        if n >= Self::MIN && n <= Self::MAX {
            Some(NodeId(n))
        } else {
            None
        }
    }

    /// The raw value.
    pub const fn get(self) -> u8 {
        self.0
    }

    /// The message ID of this node's stream `index`.
    pub const fn message_id(self, index: u8) -> MessageId {
        MessageId(((self.0 as u16) << 8) | index as u16)
    }

    /// This node's management stream.
    pub const fn management(self) -> MessageId {
        self.message_id(MANAGEMENT_INDEX)
    }

    /// The node that owns a message ID, if it belongs to a node (not the sync range).
    pub const fn of(message: MessageId) -> Option<(NodeId, u8)> {
        match NodeId::new((message.0 >> 8) as u8) {
            Some(n) => Some((n, message.0 as u8)),
            None => None,
        }
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    r2p_testkit::suite! {
        fn message_ids_carry_node_and_index() {
            let n = NodeId::new(0x12).unwrap();
            assert_eq!(n.message_id(3), MessageId(0x1203));
            assert_eq!(n.management(), MessageId(0x1200));
            assert_eq!(NodeId::of(MessageId(0x1203)), Some((n, 3)));
        }

        fn sync_range_and_reserved_ids_are_not_nodes() {
            assert_eq!(NodeId::new(0), None);
            assert_eq!(NodeId::new(255), None);
            assert_eq!(NodeId::of(MessageId(0x0045)), None);
            assert_eq!(NodeId::of(MessageId(0xFF01)), None);
            // Every node's streams sit above the sync range.
            assert!(!NodeId::new(1).unwrap().management().is_reserved_for_sync());
        }
    }
}
