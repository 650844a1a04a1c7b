//! The R2P publish/subscribe middleware: named typed topics with zero-copy message passing
//! (docs/middleware.md is the specification).
//!
//! A [`Topic`] owns a pool of message slots. A [`Publisher`] takes a slot (a [`MsgMut`]
//! draft), fills it in place and publishes it: each subscriber gets a reference-counted handle
//! ([`Msg`]) to the same slot, and the slot returns to the pool when the last handle is
//! dropped. Subscribers queue handles ([`Subscriber`]: wait, poll or wait with a timeout) or
//! run a function on publication ([`Callback`]). A subscriber whose queue is full misses the
//! message; nobody else waits for it. Remote proxies plug in as ordinary [`Sink`]s and
//! publishers.
//!
//! `no_std`, no heap: everything is declared `static` with `const` constructors.
//!
//! ```
//! use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
//!
//! #[derive(Clone, Copy)]
//! struct Proximity { distance: f32 }
//!
//! const AVOID_QUEUE: usize = 4;
//! const LOG_QUEUE: usize = 2;
//!
//! // A topic with two subscribers and one publisher; the pool holds exactly what they can keep.
//! static PROXIMITY: Topic<'static, Proximity, { pool_size(&[AVOID_QUEUE, LOG_QUEUE], 1) }, 2> =
//!     Topic::new("proximity", Proximity { distance: 0.0 });
//! static PROXIMITY_PUB: Publisher<'static, Proximity> =
//!     Publisher::new(&PROXIMITY, Class::AsyncRealTime { deadline_us: 10_000 });
//! static AVOID: Subscriber<'static, Proximity, AVOID_QUEUE> = Subscriber::new();
//! static LOG: Subscriber<'static, Proximity, LOG_QUEUE> = Subscriber::new();
//!
//! PROXIMITY.advertise(&PROXIMITY_PUB).unwrap();
//! PROXIMITY.subscribe(&AVOID).unwrap();
//! PROXIMITY.subscribe(&LOG).unwrap();
//!
//! // Listing 1: allocate (real-time: never waits), fill in place, publish.
//! if let Some(mut m) = PROXIMITY_PUB.try_alloc() {
//!     m.distance = 0.42;
//!     PROXIMITY_PUB.publish(m);
//! }
//!
//! // Both subscribers see the same slot; it is free again once both handles are dropped.
//! let a = embassy_futures::block_on(AVOID.recv());
//! let b = LOG.try_recv().unwrap();
//! assert_eq!(a.distance, 0.42);
//! assert!(core::ptr::eq(&*a, &*b));
//! ```
#![no_std]
#![warn(missing_docs)]

#[cfg(test)]
extern crate std;

// Under `--cfg loom` (host only, `make loom`) the crate is the slots' state machine on loom's
// primitives and its model-checking tests; everything else needs `const` constructors.
#[cfg(not(loom))]
pub mod pool;
#[cfg(not(loom))]
pub mod publisher;
mod slots;
#[cfg(not(loom))]
pub mod subscriber;
mod sync;
#[cfg(not(loom))]
pub mod topic;

#[cfg(all(test, not(loom)))]
mod proptests;

#[cfg(not(loom))]
pub use pool::{Msg, MsgMut};
#[cfg(not(loom))]
pub use publisher::{Class, Fault, Publisher, PublisherStats};
#[cfg(not(loom))]
pub use subscriber::{Callback, Subscriber, Timeout};
#[cfg(not(loom))]
pub use topic::{Delivery, Registry, Sink, Topic, TopicInfo};

/// Why a topic or registry refused a subscription, advertisement or registration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error {
    /// The topic already has as many subscribers as it has room for.
    TooManySubscribers,
    /// This sink is already subscribed to the topic.
    AlreadySubscribed,
    /// This publisher was already advertised.
    AlreadyAdvertised,
    /// The publisher was made for another topic.
    WrongTopic,
    /// The pool cannot cover what subscribers and publishers may hold (see [`pool_size`]).
    PoolTooSmall {
        /// Slots the topic would need with this subscriber or publisher.
        needed: usize,
        /// Slots the pool has.
        capacity: usize,
    },
    /// The registry is full.
    RegistryFull,
    /// Another topic with this name is registered.
    DuplicateName,
}

/// The pool size at which a publisher never finds its pool empty: the sizing rule.
///
/// Every slot that is not free is either a publisher's draft (at most one per publisher) or
/// referenced by a subscriber: from its queue (at most `queue_len` per subscriber) or as the
/// message the node is processing (one per subscriber). So
/// `Σ (queue_len + 1) + publishers` slots suffice; pass the queue lengths of the queued
/// subscribers (callback subscribers hold no slot). A node that keeps more handles than that
/// (clones, or several received messages at once) eats into the margin: then `alloc` waits
/// and `try_alloc` fails (and is counted) instead of anything breaking.
pub const fn pool_size(queue_lens: &[usize], publishers: usize) -> usize {
    let mut n = publishers;
    let mut i = 0;
    while i < queue_lens.len() {
        n += queue_lens[i] + 1;
        i += 1;
    }
    n
}

/// The crate's test suite, compiled in for bare-metal runners (feature `selftest`).
#[cfg(all(any(test, feature = "selftest"), not(loom)))]
pub mod selftest {
    /// Every suite of the crate, in the order a runner should run them.
    pub const ALL: &[&[r2p_testkit::Case]] = &[
        crate::tests::SUITE,
        crate::pool::tests::SUITE,
        crate::topic::tests::SUITE,
        crate::publisher::tests::SUITE,
        crate::subscriber::tests::SUITE,
    ];
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    r2p_testkit::suite! {
        fn pool_size_is_queues_plus_one_each_plus_publishers() {
            assert_eq!(pool_size(&[], 1), 1);
            assert_eq!(pool_size(&[4], 1), 6);
            assert_eq!(pool_size(&[4, 2], 1), 9);
            assert_eq!(pool_size(&[1, 1, 1], 2), 8);
        }
    }
}

#[cfg(all(test, not(loom)))]
mod host_tests {
    use super::*;

    /// The auto traits are part of the API: handles, publishers and subscribers of any message
    /// type a topic can carry (`Topic::new` asks `T: Send + Sync`) are `Send + Sync`, so they
    /// move between contexts (the `Msg` docs show that a type that is not `Sync` makes them
    /// not `Sync`: the pool's `unsafe impl Sync` is bounded by what it relies on).
    #[test]
    fn handles_publishers_and_subscribers_are_send_and_sync_for_every_message_type() {
        fn send_sync<X: Send + Sync>() {}
        #[derive(Clone, Copy)]
        struct Pose {
            _xy: [f32; 2],
            _stamp: u64,
        }
        send_sync::<Msg<'static, Pose>>();
        send_sync::<MsgMut<'static, Pose>>();
        send_sync::<Publisher<'static, Pose>>();
        send_sync::<Subscriber<'static, Pose, 2>>();
        send_sync::<Topic<'static, u32, 2, 1>>();
    }
}
