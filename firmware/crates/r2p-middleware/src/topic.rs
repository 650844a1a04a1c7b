//! Named topics: a message pool plus the list of subscribers that published messages go to.

use core::cell::{Cell, RefCell};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;

use crate::pool::{Msg, MsgMut, Pool, Slot};
use crate::Error;

/// Where a topic delivers its messages: a local [`Subscriber`](crate::Subscriber) queue, a
/// [`Callback`](crate::Callback), or — later — a remote subscriber that hands the message to
/// the RTCAN transport.
///
/// This is the plug-in point for remote proxies: the topic calls [`deliver`](Sink::deliver)
/// once per published message, in the publisher's context, and must never be blocked by it.
pub trait Sink<'a, T>: Sync {
    /// Takes one handle to a just-published message. Returns `false` if the sink had no room
    /// (the message is missed by this sink only; the handle is dropped). Must not block.
    fn deliver(&self, msg: Msg<'a, T>) -> bool;

    /// How many messages the sink queues: the remote publisher of a topic buffers as many as
    /// the longest queue any subscriber asked for.
    fn queue_len(&self) -> usize;

    /// How many pool slots the sink may keep at once (queued plus being processed); the topic
    /// refuses a subscription that would exceed its pool (see [`pool_size`](crate::pool_size)).
    fn reserved_slots(&self) -> usize;
}

/// What a management protocol or transport needs to know about a topic without its type.
pub trait TopicInfo: Sync {
    /// The topic's name, as subscribers and remote modules ask for it.
    fn name(&self) -> &'static str;
    /// Size of one message in bytes (what the transport fragments).
    fn message_size(&self) -> usize;
    /// Number of slots in the topic's pool.
    fn capacity(&self) -> usize;
    /// Number of pool slots free now.
    fn free_slots(&self) -> usize;
    /// Slots promised to subscribers and publishers so far.
    fn reserved_slots(&self) -> usize;
    /// Number of subscribers (local, callback and remote).
    fn subscriber_count(&self) -> usize;
    /// The longest subscriber queue: the length a remote publisher of this topic must buffer.
    fn max_queue_len(&self) -> usize;
}

/// What one `publish` did: how many subscribers got the message and how many missed it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Delivery {
    /// Subscribers that accepted a handle.
    pub delivered: usize,
    /// Subscribers whose queue was full.
    pub missed: usize,
}

/// The typed face of a topic that publishers use, erasing its pool and list sizes.
pub(crate) trait TopicCore<'a, T>: TopicInfo {
    /// Publishes `draft`: one handle to each subscriber, each sink called outside the topic's
    /// lock (a callback may publish).
    fn publish(&self, draft: MsgMut<'a, T>) -> Delivery;
    fn reserve_publisher(&self) -> Result<(), Error>;
}

/// The subscriber list, under the topic's lock (`Cell`s: no borrow flag to check).
struct Links<'a, T, const SUBS: usize> {
    /// The first `count` are `Some`.
    sinks: Cell<[Option<&'a dyn Sink<'a, T>>; SUBS]>,
    count: Cell<usize>,
    reserved: Cell<usize>,
}

/// A named topic of messages of type `T`, with a pool of `SLOTS` messages and room for `SUBS`
/// subscribers. Declare it `static` (its constructor is `const`); size the pool with
/// [`pool_size`](crate::pool_size).
///
/// Publishers of the topic share its pool; every published message goes, by reference, to
/// every subscriber.
///
/// Its subscriber list comes before its pool (`repr(C)`): at the same place whatever `T` and
/// `SLOTS`, so publishing and the [`TopicInfo`] queries are the same code for every topic with
/// `SUBS` subscribers, which the compiler then keeps once.
#[repr(C)]
pub struct Topic<'a, T, const SLOTS: usize, const SUBS: usize> {
    name: &'static str,
    links: Mutex<CriticalSectionRawMutex, Links<'a, T, SUBS>>,
    pool: Pool<[Slot<T>; SLOTS]>,
}

impl<'a, T: Copy + Send + Sync, const SLOTS: usize, const SUBS: usize> Topic<'a, T, SLOTS, SUBS> {
    /// A topic called `name` whose pool slots all start as `init` (usually a zeroed message).
    pub const fn new(name: &'static str, init: T) -> Self {
        Topic {
            name,
            pool: Pool::new(init),
            links: Mutex::new(Links {
                sinks: Cell::new([None; SUBS]),
                count: Cell::new(0),
                reserved: Cell::new(0),
            }),
        }
    }

    /// Adds a subscriber; from now on it gets a handle to every published message.
    ///
    /// Fails, changing nothing, if the sink is already subscribed, the topic has `SUBS`
    /// subscribers, or the pool could not keep the promise of the sizing rule with it.
    pub fn subscribe(&self, sink: &'a dyn Sink<'a, T>) -> Result<(), Error> {
        let slots = sink.reserved_slots();
        self.links.lock(|l| {
            let (sinks, count) = (l.sinks.as_array_of_cells(), l.count.get());
            let subscribed =
                sinks[..count].iter().any(|s| s.get().is_some_and(|s| core::ptr::addr_eq(s, sink)));
            let needed = admit(subscribed, count, SUBS, l.reserved.get() + slots, SLOTS)?;
            sinks[count].set(Some(sink));
            l.count.set(count + 1);
            l.reserved.set(needed);
            Ok(())
        })
    }

    /// The pool, without its size, for the topic's publishers.
    pub(crate) const fn pool(&self) -> &Pool<[Slot<T>]> {
        &self.pool
    }
}

/// Whether a topic with `count` of its `subs` subscribers, and `needed` of its `capacity` pool
/// slots promised with the new one, takes a new subscriber (not `subscribed` already): the
/// slots then promised. Not generic, so each message type's [`Topic::subscribe`] shares it.
fn admit(
    subscribed: bool,
    count: usize,
    subs: usize,
    needed: usize,
    capacity: usize,
) -> Result<usize, Error> {
    if subscribed {
        Err(Error::AlreadySubscribed)
    } else if count == subs {
        Err(Error::TooManySubscribers)
    } else if needed > capacity {
        Err(Error::PoolTooSmall { needed, capacity })
    } else {
        Ok(needed)
    }
}

impl<T, const SLOTS: usize, const SUBS: usize> TopicInfo for Topic<'_, T, SLOTS, SUBS>
where
    T: Copy + Send + Sync,
{
    fn name(&self) -> &'static str {
        self.name
    }
    fn message_size(&self) -> usize {
        core::mem::size_of::<T>()
    }
    fn capacity(&self) -> usize {
        SLOTS
    }
    fn free_slots(&self) -> usize {
        self.pool().free()
    }
    fn reserved_slots(&self) -> usize {
        self.links.lock(|l| l.reserved.get())
    }
    fn subscriber_count(&self) -> usize {
        self.links.lock(|l| l.count.get())
    }
    fn max_queue_len(&self) -> usize {
        let sinks = self.links.lock(|l| l.sinks.get());
        sinks.iter().flatten().map(|s| s.queue_len()).max().unwrap_or(0)
    }
}

impl<'a, T, const SLOTS: usize, const SUBS: usize> TopicCore<'a, T> for Topic<'a, T, SLOTS, SUBS>
where
    T: Copy + Send + Sync,
{
    fn publish(&self, draft: MsgMut<'a, T>) -> Delivery {
        // The subscriber list as it is now (subscriptions only ever grow), copied so that the
        // sinks run outside the lock.
        let (sinks, count) = self.links.lock(|l| (l.sinks.get(), l.count.get()));
        // One handle per subscriber, counted into the slot at once: no per-subscriber clone.
        // A sink that refuses drops its handle, which takes it off the count again; a message
        // nobody accepted is free once the last sink has refused it.
        let mut d = Delivery::default();
        for (sink, msg) in sinks[..count].iter().zip(draft.share(count)) {
            // Always `Some` below `count`; were it not, `msg` would just be released.
            if let Some(sink) = sink {
                if sink.deliver(msg) {
                    d.delivered += 1;
                } else {
                    d.missed += 1;
                }
            }
        }
        d
    }

    fn reserve_publisher(&self) -> Result<(), Error> {
        self.links.lock(|l| {
            let needed = l.reserved.get() + 1;
            if needed > SLOTS {
                return Err(Error::PoolTooSmall { needed, capacity: SLOTS });
            }
            l.reserved.set(needed);
            Ok(())
        })
    }
}

/// A fixed-size directory of topics by name, for the management protocol and the transport
/// (which receive names from the bus). Static, like everything else.
pub struct Registry<'a, const N: usize> {
    topics: Mutex<CriticalSectionRawMutex, RefCell<[Option<&'a dyn TopicInfo>; N]>>,
}

impl<'a, const N: usize> Registry<'a, N> {
    /// An empty registry with room for `N` topics.
    pub const fn new() -> Self {
        Registry { topics: Mutex::new(RefCell::new([None; N])) }
    }

    /// Adds `topic`; fails if its name is taken or the registry is full.
    pub fn register(&self, topic: &'a dyn TopicInfo) -> Result<(), Error> {
        self.topics.lock(|t| {
            let mut t = t.borrow_mut();
            if t.iter().flatten().any(|x| x.name() == topic.name()) {
                return Err(Error::DuplicateName);
            }
            let free = t.iter_mut().find(|x| x.is_none()).ok_or(Error::RegistryFull)?;
            *free = Some(topic);
            Ok(())
        })
    }

    /// The topic called `name`, if registered.
    pub fn find(&self, name: &str) -> Option<&'a dyn TopicInfo> {
        self.topics.lock(|t| t.borrow().iter().flatten().find(|x| x.name() == name).copied())
    }

    /// Every registered topic, in registration order (for the management protocol's listing).
    pub fn for_each(&self, mut f: impl FnMut(&'a dyn TopicInfo)) {
        let topics = self.topics.lock(|t| *t.borrow());
        topics.iter().flatten().for_each(|t| f(*t));
    }
}

impl<const N: usize> Default for Registry<'_, N> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;
    use crate::{pool_size, Callback, Class, Publisher, Subscriber};

    const NRT: Class = Class::NonRealTime;

    r2p_testkit::suite! {
        fn subscribe_enforces_the_sizing_rule() {
            // Room for a queue of 2 (3 slots) and a queue of 1 (2 slots), not one slot more.
            static T: Topic<'static, u32, { pool_size(&[2, 1], 0) }, 4> = Topic::new("t", 0);
            static A: Subscriber<'static, u32, 2> = Subscriber::new();
            static B: Subscriber<'static, u32, 1> = Subscriber::new();
            static C: Subscriber<'static, u32, 1> = Subscriber::new();
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            T.subscribe(&A).unwrap();
            T.subscribe(&B).unwrap();
            assert_eq!(T.reserved_slots(), 5);
            assert_eq!(T.subscribe(&C), Err(Error::PoolTooSmall { needed: 7, capacity: 5 }));
            assert_eq!(T.advertise(&P), Err(Error::PoolTooSmall { needed: 6, capacity: 5 }));
            assert_eq!(T.subscriber_count(), 2, "a refused subscription changes nothing");
            assert_eq!(T.reserved_slots(), 5);
        }

        fn subscribe_refuses_duplicates_and_a_full_list() {
            static T: Topic<'static, u32, 20, 2> = Topic::new("t", 0);
            static A: Subscriber<'static, u32, 1> = Subscriber::new();
            static B: Subscriber<'static, u32, 1> = Subscriber::new();
            static C: Subscriber<'static, u32, 1> = Subscriber::new();
            T.subscribe(&A).unwrap();
            assert_eq!(T.subscribe(&A), Err(Error::AlreadySubscribed));
            T.subscribe(&B).unwrap();
            assert_eq!(T.subscribe(&C), Err(Error::TooManySubscribers));
        }

        fn callbacks_reserve_no_slot() {
            fn ignore(_: &u32) {}
            static T: Topic<'static, u32, 1, 2> = Topic::new("t", 0);
            static CB: Callback<fn(&u32)> = Callback::new(ignore);
            T.subscribe(&CB).unwrap();
            assert_eq!(T.reserved_slots(), 0);
            assert_eq!(T.max_queue_len(), 0);
        }

        fn advertise_reserves_one_slot_once_and_checks_the_topic() {
            static T: Topic<'static, u32, 4, 1> = Topic::new("t", 0);
            static OTHER: Topic<'static, u32, 4, 1> = Topic::new("other", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            assert_eq!(OTHER.advertise(&P), Err(Error::WrongTopic));
            T.advertise(&P).unwrap();
            assert_eq!(T.reserved_slots(), 1);
            assert_eq!(T.advertise(&P), Err(Error::AlreadyAdvertised));
            assert_eq!(T.reserved_slots(), 1);
            assert_eq!(P.topic_name(), "t");
        }

        fn topic_info_reports_what_the_transport_needs() {
            static T: Topic<'static, [u16; 5], 12, 3> = Topic::new("imu", [0; 5]);
            static A: Subscriber<'static, [u16; 5], 2> = Subscriber::new();
            static B: Subscriber<'static, [u16; 5], 6> = Subscriber::new();
            T.subscribe(&A).unwrap();
            T.subscribe(&B).unwrap();
            let info: &dyn TopicInfo = &T;
            assert_eq!(info.name(), "imu");
            assert_eq!(info.message_size(), 10);
            assert_eq!(info.capacity(), 12);
            assert_eq!(info.free_slots(), 12);
            assert_eq!(info.subscriber_count(), 2);
            assert_eq!(info.max_queue_len(), 6, "the longest queue decides the remote buffer");
        }

        fn registry_finds_topics_by_name() {
            static A: Topic<'static, u32, 1, 1> = Topic::new("proximity", 0);
            static B: Topic<'static, u8, 1, 1> = Topic::new("obstacle", 0);
            static C: Topic<'static, u8, 1, 1> = Topic::new("velocity", 0);
            static DUP: Topic<'static, u8, 1, 1> = Topic::new("obstacle", 0);
            static R: Registry<'static, 2> = Registry::new();
            R.register(&A).unwrap();
            R.register(&B).unwrap();
            assert_eq!(R.register(&DUP), Err(Error::DuplicateName));
            assert_eq!(R.register(&C), Err(Error::RegistryFull));
            assert_eq!(R.find("obstacle").unwrap().message_size(), 1);
            assert_eq!(R.find("proximity").unwrap().message_size(), 4);
            assert!(R.find("velocity").is_none());
            let mut n = 0;
            R.for_each(|_| n += 1);
            assert_eq!(n, 2);
        }
    }
}
