//! A module's topics on the bus, each written once: [`Outbound`] (a topic the module publishes
//! and the node exports) and [`Inbound`] (a topic the node imports and the application reads),
//! and the cells they are built in ([`OutboundCell`], [`InboundCell`]).
//!
//! Every module application has the same few objects per topic: the topic, the publisher, the
//! remote proxy the node sees and, for an imported topic, the application's subscriber. Their
//! names come from parameters (the `instance`), so they are made at boot rather than as
//! `const` statics: each cell is made once in place (no heap), a `static` on the MCU and a leaked
//! one per emulated board on the host, so two boards in one process never share a topic. An
//! application lists its topics as one field each of its `Endpoints` and its `Storage`.
//!
//! ```
//! use r2p_middleware::{pool_size, Class};
//! use r2p_module::{InboundCell, OutboundCell};
//! use r2p_node::Export;
//!
//! static SPEED: OutboundCell<u32, { pool_size(&[4], 1) }, 1, 4> = OutboundCell::new();
//! static LIMIT: InboundCell<u32, { pool_size(&[2], 1) }, 1, 2> = InboundCell::new();
//!
//! let speed = SPEED.build("speed", 0, Class::NonRealTime).unwrap();
//! let limit = LIMIT.build("limit", 0).unwrap();
//! speed.publisher.publish_with(|v| *v = 7).unwrap();
//! assert_eq!(speed.remote.active_len(), 0, "no remote subscriber yet: nothing queued");
//! limit.publisher.publish_with(|v| *v = 3).unwrap();
//! assert_eq!(*limit.subscriber.try_recv().unwrap(), 3);
//! ```

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, Ordering};

use r2p_middleware::{Class, Error, Publisher, Subscriber, Topic};
use r2p_node::{Export, Import, Node, NodeError, RemotePublisher, RemoteSubscriber};

/// A topic the module publishes on the bus: `SLOTS` pool slots, room for `SUBS` subscribers
/// (the remote one and local ones), a remote queue of up to `Q` messages.
pub struct Outbound<'a, T, const SLOTS: usize, const SUBS: usize, const Q: usize> {
    /// The topic (subscribe here to read it on the module).
    pub topic: &'a Topic<'a, T, SLOTS, SUBS>,
    /// The application's publisher, advertised.
    pub publisher: &'a Publisher<'a, T>,
    /// Its remote subscriber, subscribed: the node exports it.
    pub remote: &'a RemoteSubscriber<'a, T, Q>,
}

/// A topic the node imports from the bus: `SLOTS` pool slots, room for `SUBS` subscribers, the
/// application's subscriber with a queue of `QS`.
pub struct Inbound<'a, T, const SLOTS: usize, const SUBS: usize, const QS: usize> {
    /// The topic.
    pub topic: &'a Topic<'a, T, SLOTS, SUBS>,
    /// The publisher the node publishes received messages with (NRT, advertised; local code
    /// may publish with it too).
    pub publisher: &'a Publisher<'a, T>,
    /// The remote publisher: the node imports it.
    pub remote: &'a RemotePublisher<'a, T>,
    /// The application's subscriber, subscribed.
    pub subscriber: &'a Subscriber<'a, T, QS>,
}

// By hand: a derive would ask `T: Clone`, though only references are copied.
impl<T, const SLOTS: usize, const SUBS: usize, const Q: usize> Clone
    for Outbound<'_, T, SLOTS, SUBS, Q>
{
    fn clone(&self) -> Self {
        *self
    }
}
impl<T, const SLOTS: usize, const SUBS: usize, const Q: usize> Copy
    for Outbound<'_, T, SLOTS, SUBS, Q>
{
}
impl<T, const SLOTS: usize, const SUBS: usize, const QS: usize> Clone
    for Inbound<'_, T, SLOTS, SUBS, QS>
{
    fn clone(&self) -> Self {
        *self
    }
}
impl<T, const SLOTS: usize, const SUBS: usize, const QS: usize> Copy
    for Inbound<'_, T, SLOTS, SUBS, QS>
{
}

/// A node, whatever its sizes, as an application registers its topics on it: an
/// application's `register(&self, node: &mut impl TopicNode<'a>)` needs no const parameters.
pub trait TopicNode<'a> {
    /// Offers `topic` on the bus ([`Node::export`]).
    fn export(&mut self, topic: &'a dyn Export) -> Result<(), NodeError>;
    /// Subscribes to `topic` on the bus ([`Node::import`]).
    fn import(&mut self, topic: &'a dyn Import) -> Result<(), NodeError>;
}

impl<
        'a,
        const E: usize,
        const I: usize,
        const T: usize,
        const R: usize,
        const B: usize,
        const M: bool,
    > TopicNode<'a> for Node<'a, E, I, T, R, B, M>
{
    fn export(&mut self, topic: &'a dyn Export) -> Result<(), NodeError> {
        Node::export(self, topic).map(drop)
    }
    fn import(&mut self, topic: &'a dyn Import) -> Result<(), NodeError> {
        Node::import(self, topic).map(drop)
    }
}

/// Room for objects made once, in place (a `static`): what `static_cell::StaticCell` does, but
/// with the check that it is taken once in one function for every cell ([`take_once`]):
/// `StaticCell`'s, inlined into each cell's `build`, cost ~40 B a topic.
struct Once<T> {
    taken: AtomicBool,
    value: UnsafeCell<MaybeUninit<T>>,
}

// SAFETY: the value is reached only through `take`, once (`take_once`), by whoever takes it;
// `T: Send` because that may be another thread than the one that made the cell.
unsafe impl<T: Send> Sync for Once<T> {}

impl<T> Once<T> {
    const fn new() -> Self {
        Self { taken: AtomicBool::new(false), value: UnsafeCell::new(MaybeUninit::uninit()) }
    }

    /// The room, uninitialised (its parts are `MaybeUninit`s, written by the caller).
    ///
    /// # Panics
    /// If taken before.
    // A `&mut` from `&self`, as `StaticCell::uninit` gives: sound because `take_once` lets it
    // happen once per cell.
    #[allow(clippy::mut_from_ref)]
    fn take(&'static self) -> &'static mut T
    where
        T: AllUninit,
    {
        take_once(&self.taken);
        // SAFETY: `take_once` returned, so this is the one taking of the cell: no other
        // reference to its value exists; `T` is made of `MaybeUninit`s (`AllUninit`), which
        // need no initialisation.
        unsafe { (*self.value.get()).assume_init_mut() }
    }
}

/// Tuples of `MaybeUninit`s: valid whatever their bytes.
trait AllUninit {}
impl<A, B, C> AllUninit for (MaybeUninit<A>, MaybeUninit<B>, MaybeUninit<C>) {}
impl<A, B, C, D> AllUninit for (MaybeUninit<A>, MaybeUninit<B>, MaybeUninit<C>, MaybeUninit<D>) {}

/// Marks a cell taken; panics if it was (a cell's `build` called twice: a bug of the image).
#[inline(never)]
fn take_once(taken: &AtomicBool) {
    assert!(!taken.swap(true, Ordering::AcqRel), "an endpoint cell is built once");
}

/// Room for one [`Outbound`]: one cell for its three objects.
pub struct OutboundCell<T: 'static, const SLOTS: usize, const SUBS: usize, const Q: usize>(
    #[allow(clippy::type_complexity)]
    Once<(
        MaybeUninit<Topic<'static, T, SLOTS, SUBS>>,
        MaybeUninit<Publisher<'static, T>>,
        MaybeUninit<RemoteSubscriber<'static, T, Q>>,
    )>,
);

/// Room for one [`Inbound`]: one cell for its four objects.
pub struct InboundCell<T: 'static, const SLOTS: usize, const SUBS: usize, const QS: usize>(
    #[allow(clippy::type_complexity)]
    Once<(
        MaybeUninit<Topic<'static, T, SLOTS, SUBS>>,
        MaybeUninit<Publisher<'static, T>>,
        MaybeUninit<RemotePublisher<'static, T>>,
        MaybeUninit<Subscriber<'static, T, QS>>,
    )>,
);

impl<T, const SLOTS: usize, const SUBS: usize, const Q: usize> OutboundCell<T, SLOTS, SUBS, Q>
where
    T: Copy + Send + Sync + 'static,
{
    /// Empty room.
    pub const fn new() -> Self {
        Self(Once::new())
    }

    /// Makes the topic `name` (its slots start as `init`), its publisher of `class` and its
    /// remote subscriber; advertises the one and subscribes the other. An error means `SLOTS`
    /// or `SUBS` is too small for them (a bug of the application's sizing, found at boot).
    ///
    /// # Panics
    /// If called twice on one cell.
    pub fn build(
        &'static self,
        name: &'static str,
        init: T,
        class: Class,
    ) -> Result<Outbound<'static, T, SLOTS, SUBS, Q>, Error> {
        let (topic, publisher, remote) = self.0.take();
        let topic = &*topic.write(Topic::new(name, init));
        let publisher = &*publisher.write(Publisher::new(topic, class));
        let remote = &*remote.write(RemoteSubscriber::new(publisher));
        topic.advertise(publisher)?;
        topic.subscribe(remote)?;
        Ok(Outbound { topic, publisher, remote })
    }
}

impl<T, const SLOTS: usize, const SUBS: usize, const QS: usize> InboundCell<T, SLOTS, SUBS, QS>
where
    T: Copy + Send + Sync + 'static,
{
    /// Empty room.
    pub const fn new() -> Self {
        Self(Once::new())
    }

    /// Makes the topic `name` (its slots start as `init`), the node's publisher (NRT), the
    /// remote publisher and the application's subscriber; advertises the publisher and
    /// subscribes the subscriber. An error means `SLOTS` or `SUBS` is too small for them.
    ///
    /// # Panics
    /// If called twice on one cell.
    pub fn build(
        &'static self,
        name: &'static str,
        init: T,
    ) -> Result<Inbound<'static, T, SLOTS, SUBS, QS>, Error> {
        let (topic, publisher, remote, subscriber) = self.0.take();
        let topic = &*topic.write(Topic::new(name, init));
        let publisher = &*publisher.write(Publisher::new(topic, Class::NonRealTime));
        let remote = &*remote.write(RemotePublisher::new(publisher, topic));
        let subscriber = &*subscriber.write(Subscriber::new());
        topic.advertise(publisher)?;
        topic.subscribe(subscriber)?;
        Ok(Inbound { topic, publisher, remote, subscriber })
    }
}

impl<T, const SLOTS: usize, const SUBS: usize, const Q: usize> Default
    for OutboundCell<T, SLOTS, SUBS, Q>
where
    T: Copy + Send + Sync + 'static,
{
    fn default() -> Self {
        Self::new()
    }
}

impl<T, const SLOTS: usize, const SUBS: usize, const QS: usize> Default
    for InboundCell<T, SLOTS, SUBS, QS>
where
    T: Copy + Send + Sync + 'static,
{
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use r2p_middleware::{pool_size, TopicInfo};
    use r2p_node::{Export, Import};
    use std::boxed::Box;

    const SRT: Class = Class::AsyncRealTime { deadline_us: 5_000 };

    fn leak<T>(x: T) -> &'static T {
        Box::leak(Box::new(x))
    }

    #[test]
    fn an_outbound_topic_reaches_its_remote_subscriber_under_its_name_and_class() {
        let cell: &'static OutboundCell<u32, { pool_size(&[2], 1) }, 1, 2> =
            leak(OutboundCell::new());
        let out = cell.build("m/state", 9, SRT).unwrap();
        assert_eq!(out.topic.name(), "m/state");
        assert_eq!(out.remote.topic(), "m/state", "the node exports it under the topic's name");
        assert_eq!(out.remote.class(), SRT, "with the publisher's class");
        assert!(core::ptr::eq(out.publisher.topic_name(), out.topic.name()));
        assert_eq!(out.topic.advertise(out.publisher), Err(Error::AlreadyAdvertised));
        assert_eq!(out.topic.subscribe(out.remote), Err(Error::AlreadySubscribed));

        out.remote.activate(2); // a remote module subscribed
        out.publisher.publish_with(|v| *v = 0x0102_0304).unwrap();
        assert_eq!(out.remote.pending(), 1, "the remote subscriber got the message");
        let mut buf = [0u8; 4];
        let remote: &dyn r2p_node::Export = out.remote;
        assert_eq!(remote.pop_encoded(&mut buf), Some(Ok((4, None))));
        assert_eq!(buf, 0x0102_0304u32.to_le_bytes());
        assert_eq!(out.topic.free_slots(), pool_size(&[2], 1), "its slot is free again");
    }

    #[test]
    fn an_inbound_topic_delivers_what_the_bus_brings_to_the_application() {
        let cell: &'static InboundCell<u32, { pool_size(&[3], 1) }, 1, 3> =
            leak(InboundCell::new());
        let inb = cell.build("m/setpoint", 0).unwrap();
        assert_eq!(inb.remote.topic(), "m/setpoint", "the node imports it under its name");
        assert_eq!(inb.remote.queue_len(), 3, "asking for the application's queue");
        assert_eq!(inb.publisher.class(), Class::NonRealTime);
        assert_eq!(inb.topic.advertise(inb.publisher), Err(Error::AlreadyAdvertised));

        inb.remote.publish_bytes(&7u32.to_le_bytes()).unwrap();
        assert_eq!(*inb.subscriber.try_recv().unwrap(), 7);
        assert!(inb.subscriber.try_recv().is_none());
    }

    #[test]
    fn a_pool_too_small_for_the_endpoints_is_an_error_not_a_silent_loss() {
        // The remote queue of 2 needs 3 slots and the publisher's draft one more.
        let out: &'static OutboundCell<u32, 3, 1, 2> = leak(OutboundCell::new());
        assert_eq!(
            out.build("x", 0, Class::NonRealTime).err(),
            Some(Error::PoolTooSmall { needed: 4, capacity: 3 })
        );
        let inb: &'static InboundCell<u32, 2, 1, 2> = leak(InboundCell::new());
        assert_eq!(inb.build("y", 0).err(), Some(Error::PoolTooSmall { needed: 4, capacity: 2 }));
    }

    #[test]
    #[should_panic]
    fn a_cell_is_built_once() {
        let cell: &'static OutboundCell<u32, 4, 1, 2> = leak(OutboundCell::new());
        let _ = cell.build("a", 0, Class::NonRealTime);
        let _ = cell.build("a", 0, Class::NonRealTime);
    }
}
