//! Events: what the protocol learns that the application may act on (a new node ID, a reboot
//! request, a subscriber, a parameter), queued because the node runs in a task of its own and
//! the application takes them when it is ready. The management protocol (`management.rs`)
//! queues them.

use r2p_management::message::{HrtResult, ParamFault, SubscribeResult, Value};
use r2p_management::NodeId;
use rtcan::MessageId;

#[cfg(doc)]
use crate::Node;

/// Events kept until the application takes them ([`Node::next_event`]).
pub const EVENT_QUEUE: usize = 8;

/// Something the application may act on, taken with [`Node::next_event`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// A node-ID conflict moved this module; its topics were re-advertised.
    NodeIdChanged(NodeId),
    /// A REBOOT for this module (or every module) arrived. [`Node::take_reboot_request`] also
    /// says so; rebooting is the application's business.
    RebootRequested {
        /// Who asked.
        from: NodeId,
    },
    /// A remote module subscribed to export `export`.
    RemoteSubscriber {
        /// Index of the export (order of [`Node::export`]).
        export: usize,
        /// The subscriber's node.
        from: NodeId,
        /// The queue length it asked for.
        queue_len: u8,
    },
    /// Import `import` is now received on `message`.
    Subscribed {
        /// Index of the import (order of [`Node::import`]).
        import: usize,
        /// The publisher's node.
        from: NodeId,
        /// The stream.
        message: MessageId,
    },
    /// Import `import` was refused (type mismatch, unknown topic, no HRT slot).
    SubscriptionRefused {
        /// Index of the import.
        import: usize,
        /// The publisher's node.
        from: NodeId,
        /// Why.
        result: SubscribeResult,
    },
    /// The publisher of import `import` went silent (`publishers.rs`): no message for two of
    /// the stream's periods (HRT: the stream stopped, or its slot was refused after a
    /// failover), or no heartbeat for the peer timeout (the module left; when its heartbeats
    /// return it is asked again). Raised once; messages arriving again end it.
    PublisherSilent {
        /// Index of the import.
        import: usize,
        /// The publisher's node.
        from: NodeId,
    },
    /// None of export `export`'s remote subscribers was heard for the peer timeout (their modules
    /// left; `subscribers.rs`), or the last of them unsubscribed: the export stopped — nothing
    /// more is queued for the bus, an HRT export gave its slot back — until someone subscribes.
    SubscribersLeft {
        /// Index of the export.
        export: usize,
    },
    /// The master refused HRT export `export`'s reservation (at its first registration, or when
    /// the node registered again for a new calendar after a failover): the stream sends
    /// nothing until a subscriber asks again, and its subscribers are answered `NoSlot` (one
    /// already subscribed learns it from `PublisherSilent`).
    StreamRefused {
        /// Index of the export.
        export: usize,
        /// The master's reason.
        result: HrtResult,
    },
    /// A PARAM_SET changed a local parameter (persist it if the module keeps parameters).
    ParamChanged {
        /// Parameter index.
        index: u16,
        /// New value.
        value: Value,
    },
    /// Answer to [`Node::get_param`] or [`Node::set_param`].
    ParamValue {
        /// The node that answered.
        from: NodeId,
        /// Parameter index.
        index: u16,
        /// Its value.
        value: Value,
    },
    /// Refusal of [`Node::get_param`] or [`Node::set_param`].
    ParamError {
        /// The node that answered.
        from: NodeId,
        /// Parameter index.
        index: u16,
        /// Why.
        fault: ParamFault,
    },
}
