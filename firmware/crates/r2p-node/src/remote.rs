//! The remote proxies: an ordinary [`Sink`] on the publishing module, an ordinary
//! [`Publisher`] on the subscribing one (docs/middleware.md, "Remote topics").
//!
//! [`RemoteSubscriber`] is subscribed to a local topic like any subscriber; it queues the
//! message handles (zero copy) while a remote module is subscribed and the [`Node`](crate::Node)
//! encodes them into the RTCAN transmit queue. [`RemotePublisher`] wraps the local
//! [`Publisher`] through which the node publishes what it reassembles from the bus, so local
//! subscribers cannot tell a remote message from a local one. The node sees both through the
//! type-erased [`Export`] and [`Import`] traits.

use core::cell::RefCell;

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use heapless::Deque;
use r2p_middleware::{Class, Delivery, Msg, Publisher, Sink, TopicInfo};
use rtcan::Micros;

use crate::wire::{Wire, WireError};

/// A local topic the node offers on the bus, without its type (implemented by
/// [`RemoteSubscriber`]). `Sync`: the application publishes into it while the node, on the bus's
/// interrupt executor, reads it; the bound lets the compiler check that a node may move there.
pub trait Export: Sync {
    /// The topic's name.
    fn topic(&self) -> &'static str;
    /// [`Wire::TYPE_HASH`] of its messages.
    fn type_hash(&self) -> u32;
    /// [`Wire::SIZE`] of its messages.
    fn size(&self) -> usize;
    /// The publisher's class (the bus class and deadline come from it).
    fn class(&self) -> Class;
    /// A remote module subscribed asking for a queue of `queue_len`: the queue becomes the
    /// longest length asked for (at least 1, at most the sink's capacity).
    fn activate(&self, queue_len: u8);
    /// Its last remote subscriber left (the node's liveness check): nothing more is queued until
    /// someone subscribes again (what is queued already may still go out).
    fn deactivate(&self);
    /// The queue length remote subscribers asked for (0: nobody subscribed, messages are not
    /// queued).
    fn active_len(&self) -> usize;
    /// Messages waiting to be encoded.
    fn pending(&self) -> usize;
    /// Encodes the oldest waiting message into `buf`: its length and the time it was published
    /// (if the sink has a clock). `None` if nothing waits. The message stays waiting: an HRT
    /// message goes out a frame per slot, and one published meanwhile must not replace it
    /// halfway.
    fn peek_encoded(&self, buf: &mut [u8]) -> Option<Result<(usize, Option<Micros>), WireError>>;
    /// Drops the oldest waiting message; false if none waited.
    fn drop_oldest(&self) -> bool;
    /// One of its messages missed its deadline on the bus: tell the publisher.
    fn report_deadline_miss(&self);
    /// Calls `wake` each time a message is queued for the bus, from the publisher's context
    /// (feature `framed-reservations`: the board's wake for the node's short path,
    /// [`Node::wake_on_release`](crate::Node::wake_on_release)).
    #[cfg(feature = "framed-reservations")]
    fn wake_on_release(&self, wake: fn()) {
        let _ = wake;
    }
}

impl dyn Export + '_ {
    /// Takes the oldest waiting message and encodes it into `buf` (as
    /// [`peek_encoded`](Export::peek_encoded)). One copy for every export type, on the trait
    /// object.
    pub fn pop_encoded(
        &self,
        buf: &mut [u8],
    ) -> Option<Result<(usize, Option<Micros>), WireError>> {
        let r = self.peek_encoded(buf)?;
        self.drop_oldest();
        Some(r)
    }
}

/// A remote topic the node subscribes to for a local topic, without its type (implemented by
/// [`RemotePublisher`]). `Sync` for the same reason as [`Export`].
pub trait Import: Sync {
    /// The topic's name (the same on both modules).
    fn topic(&self) -> &'static str;
    /// [`Wire::TYPE_HASH`] of the local type.
    fn type_hash(&self) -> u32;
    /// [`Wire::SIZE`] of the local type.
    fn size(&self) -> usize;
    /// The longest local subscriber queue: asked of the remote publisher (paper §3.4).
    fn queue_len(&self) -> usize;
    /// Decodes `bytes` and publishes the message locally.
    fn publish_bytes(&self, bytes: &[u8]) -> Result<Delivery, ImportError>;
}

/// Why a message from the bus was not published locally.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImportError {
    /// The bytes are not a message of the local type.
    Decode(WireError),
    /// The local pool had no free slot (counted by the publisher as `pool_empty`).
    PoolEmpty,
}

struct Queue<'a, T, const Q: usize> {
    msgs: Deque<(Msg<'a, T>, Option<Micros>), Q>,
    /// Longest queue a remote subscriber asked for (≤ Q); 0 while nobody is subscribed.
    active: usize,
    missed: u32,
    /// Called once a message is queued ([`Export::wake_on_release`]).
    #[cfg(feature = "framed-reservations")]
    wake: Option<fn()>,
}

/// The remote subscriber of a local topic: a [`Sink`] that queues up to `Q` message handles for
/// the transport.
///
/// Declare it `static` next to the topic, subscribe it to the topic (it reserves `Q + 1` pool
/// slots, like a local subscriber with a queue of `Q`) and export it on the [`Node`](crate::Node):
///
/// ```
/// # use r2p_middleware::{pool_size, Class, Publisher, Topic};
/// # use r2p_node::{NoParams, Node, NodeConfig, RemoteSubscriber};
/// # static SPEED: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("speed", 0);
/// # static SPEED_PUB: Publisher<'static, u32> = Publisher::new(&SPEED, Class::NonRealTime);
/// # let mut node: Node<'static, 1, 1, 16, 2, 64> =
/// #     Node::new(NodeConfig::new([0; 12], "sensor"), &NoParams).unwrap();
/// static SPEED_OUT: RemoteSubscriber<'static, u32, 4> = RemoteSubscriber::new(&SPEED_PUB);
/// SPEED.subscribe(&SPEED_OUT).unwrap();
/// assert_eq!(node.export(&SPEED_OUT), Ok(1)); // stream 1: message ID = node ID << 8 | 1
/// ```
///
/// Until a remote module subscribes, published messages are not kept (`deliver` accepts and
/// drops them). Then the queue holds as many messages as the longest queue any remote subscriber
/// asked for (at most `Q`); when it is full the new message is missed, as for a local subscriber.
pub struct RemoteSubscriber<'a, T, const Q: usize> {
    publisher: &'a Publisher<'a, T>,
    clock: Option<fn() -> Micros>,
    queue: Mutex<CriticalSectionRawMutex, RefCell<Queue<'a, T, Q>>>,
}

impl<'a, T, const Q: usize> RemoteSubscriber<'a, T, Q> {
    /// The remote subscriber of `publisher`'s topic. The SRT deadline counts from when the node
    /// takes the message (its next `poll`); see [`with_clock`](Self::with_clock).
    pub const fn new(publisher: &'a Publisher<'a, T>) -> Self {
        Self {
            publisher,
            clock: None,
            queue: Mutex::new(RefCell::new(Queue {
                msgs: Deque::new(),
                active: 0,
                missed: 0,
                #[cfg(feature = "framed-reservations")]
                wake: None,
            })),
        }
    }

    /// As [`new`](Self::new), with a clock read at publication (e.g. embassy-time's
    /// `Instant::now().as_micros()`), so the SRT deadline counts from the publication itself.
    pub const fn with_clock(publisher: &'a Publisher<'a, T>, clock: fn() -> Micros) -> Self {
        let mut s = Self::new(publisher);
        s.clock = Some(clock);
        s
    }

    /// Messages missed because the queue was full.
    pub fn missed(&self) -> u32 {
        self.queue.lock(|q| q.borrow().missed)
    }
}

impl<'a, T: Send + Sync, const Q: usize> Sink<'a, T> for RemoteSubscriber<'a, T, Q> {
    fn deliver(&self, msg: Msg<'a, T>) -> bool {
        let at = self.clock.map(|c| c());
        // The board's wake, read under the same lock, called after it.
        #[cfg(feature = "framed-reservations")]
        let mut wake = None;
        // The handle is dropped after the lock (dropping takes the pool's lock).
        let refused = self.queue.lock(|q| {
            let mut q = q.borrow_mut();
            if q.active == 0 {
                return Some((msg, true)); // nobody remote: nothing to keep
            }
            if q.msgs.len() >= q.active {
                q.missed = q.missed.wrapping_add(1);
                return Some((msg, false));
            }
            #[cfg(feature = "framed-reservations")]
            {
                wake = q.wake;
            }
            q.msgs.push_back((msg, at)).err().map(|(m, _)| (m, false))
        });
        match refused {
            None => {
                #[cfg(feature = "framed-reservations")]
                if let Some(wake) = wake {
                    wake();
                }
                true
            }
            Some((m, ok)) => {
                drop(m);
                ok
            }
        }
    }

    fn queue_len(&self) -> usize {
        self.queue.lock(|q| q.borrow().active)
    }

    /// The queue plus the message being encoded.
    fn reserved_slots(&self) -> usize {
        Q + 1
    }
}

impl<'a, T: Wire + Copy + Send + Sync, const Q: usize> Export for RemoteSubscriber<'a, T, Q> {
    fn topic(&self) -> &'static str {
        self.publisher.topic_name()
    }
    fn type_hash(&self) -> u32 {
        T::TYPE_HASH
    }
    fn size(&self) -> usize {
        T::SIZE
    }
    fn class(&self) -> Class {
        self.publisher.class()
    }
    fn activate(&self, queue_len: u8) {
        let want = usize::from(queue_len).clamp(1, Q.max(1)).min(Q);
        self.queue.lock(|q| {
            let mut q = q.borrow_mut();
            q.active = q.active.max(want);
        });
    }
    fn deactivate(&self) {
        // What is queued already still goes out (at most Q messages): clearing it here would
        // link the queue's drop loop into every image for nothing the bus would notice.
        self.queue.lock(|q| q.borrow_mut().active = 0);
    }
    fn active_len(&self) -> usize {
        self.queue.lock(|q| q.borrow().active)
    }
    fn pending(&self) -> usize {
        self.queue.lock(|q| q.borrow().msgs.len())
    }
    fn peek_encoded(&self, buf: &mut [u8]) -> Option<Result<(usize, Option<Micros>), WireError>> {
        // Encoded under the lock (interrupts off): a message a node exports is at most its
        // reassembly buffer (64 bytes on the modules), a few µs of copying. One encoder per
        // type serves both the SRT/NRT queue (`pop_encoded`) and the HRT frames.
        self.queue.lock(|q| q.borrow().msgs.front().map(|(m, at)| m.encode(buf).map(|n| (n, *at))))
    }
    fn drop_oldest(&self) -> bool {
        // The handle is dropped after the lock (dropping takes the pool's lock).
        self.queue.lock(|q| q.borrow_mut().msgs.pop_front()).is_some()
    }
    fn report_deadline_miss(&self) {
        self.publisher.report_deadline_miss();
    }
    #[cfg(feature = "framed-reservations")]
    fn wake_on_release(&self, wake: fn()) {
        self.queue.lock(|q| q.borrow_mut().wake = Some(wake));
    }
}

/// The remote publisher of a local topic: the node publishes what it receives from the bus
/// through `publisher` (an ordinary [`Publisher`] of the local topic, normally
/// [`Class::NonRealTime`]; the node only ever uses `try_alloc`, so it never waits).
///
/// ```
/// # use r2p_middleware::{pool_size, Class, Publisher, Topic};
/// # use r2p_node::{NoParams, Node, NodeConfig, RemotePublisher};
/// # static SPEED: Topic<'static, u32, { pool_size(&[4], 1) }, 1> = Topic::new("speed", 0);
/// # let mut node: Node<'static, 1, 1, 16, 2, 64> =
/// #     Node::new(NodeConfig::new([0; 12], "motor"), &NoParams).unwrap();
/// static SPEED_IN_PUB: Publisher<'static, u32> = Publisher::new(&SPEED, Class::NonRealTime);
/// static SPEED_IN: RemotePublisher<'static, u32> = RemotePublisher::new(&SPEED_IN_PUB, &SPEED);
/// SPEED.advertise(&SPEED_IN_PUB).unwrap();
/// assert_eq!(node.import(&SPEED_IN), Ok(0));
/// ```
pub struct RemotePublisher<'a, T> {
    publisher: &'a Publisher<'a, T>,
    topic: &'a (dyn TopicInfo + Sync),
}

impl<'a, T> RemotePublisher<'a, T> {
    /// Publishes on `topic` (the topic `publisher` was made for) what the bus brings.
    pub const fn new(publisher: &'a Publisher<'a, T>, topic: &'a (dyn TopicInfo + Sync)) -> Self {
        Self { publisher, topic }
    }
}

impl<'a, T: Wire + Copy + Send + Sync> Import for RemotePublisher<'a, T> {
    fn topic(&self) -> &'static str {
        self.topic.name()
    }
    fn type_hash(&self) -> u32 {
        T::TYPE_HASH
    }
    fn size(&self) -> usize {
        T::SIZE
    }
    fn queue_len(&self) -> usize {
        self.topic.max_queue_len()
    }
    fn publish_bytes(&self, bytes: &[u8]) -> Result<Delivery, ImportError> {
        let value = T::decode(bytes).map_err(ImportError::Decode)?;
        let mut draft = self.publisher.try_alloc().ok_or(ImportError::PoolEmpty)?;
        *draft = value;
        Ok(self.publisher.publish(draft))
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;
    use r2p_middleware::{pool_size, Subscriber, Topic};

    const SRT: Class = Class::AsyncRealTime { deadline_us: 1_000 };

    r2p_testkit::suite! {
        fn remote_subscriber_keeps_nothing_until_someone_subscribes() {
            static T: Topic<'static, u32, { pool_size(&[3], 1) }, 1> = Topic::new("speed", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, SRT);
            static R: RemoteSubscriber<'static, u32, 3> = RemoteSubscriber::new(&P);
            T.advertise(&P).unwrap();
            T.subscribe(&R).unwrap();
            assert_eq!(T.reserved_slots(), 5, "queue + 1, plus the publisher's draft");
            assert_eq!(R.queue_len(), 0);
            P.publish_with(|m| *m = 1).unwrap();
            assert_eq!(R.pending(), 0);
            assert_eq!(T.free_slots(), 5, "the slot went straight back");
            assert_eq!(P.stats().missed_deliveries, 0);
        }

        fn the_longest_requested_queue_decides_and_a_full_queue_misses_the_newest() {
            static T: Topic<'static, u32, { pool_size(&[3], 1) }, 1> = Topic::new("speed", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, SRT);
            static R: RemoteSubscriber<'static, u32, 3> = RemoteSubscriber::new(&P);
            T.subscribe(&R).unwrap();
            R.activate(1);
            R.activate(2);
            R.activate(1);
            assert_eq!(R.active_len(), 2);
            assert_eq!(T.max_queue_len(), 2);
            R.activate(200);
            assert_eq!(R.active_len(), 3, "capped at the sink's capacity");
            assert_eq!(R.missed(), 0);
            for v in 1..=4 {
                P.publish_with(|m| *m = v).unwrap();
            }
            assert_eq!(R.pending(), 3);
            assert_eq!(R.missed(), 1);
            assert_eq!(P.stats().missed_deliveries, 1);
            let mut buf = [0u8; 4];
            assert_eq!((&R as &dyn Export).pop_encoded(&mut buf), Some(Ok((4, None))));
            assert_eq!(u32::from_le_bytes(buf), 1, "oldest first");
            assert_eq!(T.free_slots(), 3, "encoding released the slot");
        }

        fn remote_publisher_publishes_like_a_local_one() {
            static T: Topic<'static, [u16; 2], { pool_size(&[2], 1) }, 1> = Topic::new("pair", [0; 2]);
            static P: Publisher<'static, [u16; 2]> = Publisher::new(&T, Class::NonRealTime);
            static S: Subscriber<'static, [u16; 2], 2> = Subscriber::new();
            static R: RemotePublisher<'static, [u16; 2]> = RemotePublisher::new(&P, &T);
            T.advertise(&P).unwrap();
            T.subscribe(&S).unwrap();
            assert_eq!((R.topic(), R.size(), R.queue_len()), ("pair", 4, 2));
            assert_eq!(R.publish_bytes(&[1, 0, 2, 0]).map(|d| d.delivered), Ok(1));
            assert_eq!(*S.try_recv().unwrap(), [1, 2]);
            assert_eq!(R.publish_bytes(&[1, 0, 2]), Err(ImportError::Decode(WireError::BadLength)));
        }
    }
}

/// The release wake (feature `framed-reservations`, which the QEMU suite leaves out).
#[cfg(all(test, feature = "framed-reservations"))]
mod release_wake_tests {
    use super::*;
    use r2p_middleware::{pool_size, Topic};

    const SRT: Class = Class::AsyncRealTime { deadline_us: 1_000 };

    #[test]
    fn a_queued_message_wakes_the_board_and_a_dropped_one_does_not() {
        use core::sync::atomic::{AtomicU32, Ordering};
        static T: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("scan", 0);
        static P: Publisher<'static, u32> = Publisher::new(&T, SRT);
        static R: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&P);
        static WOKEN: AtomicU32 = AtomicU32::new(0);
        T.subscribe(&R).unwrap();
        (&R as &dyn Export).wake_on_release(|| {
            WOKEN.fetch_add(1, Ordering::Relaxed);
        });
        P.publish_with(|m| *m = 1).unwrap();
        assert_eq!(WOKEN.load(Ordering::Relaxed), 0, "nobody remote: nothing queued");
        R.activate(1);
        P.publish_with(|m| *m = 2).unwrap();
        assert_eq!(WOKEN.load(Ordering::Relaxed), 1, "queued: the board is woken");
        P.publish_with(|m| *m = 3).unwrap();
        assert_eq!((R.pending(), R.missed()), (1, 1));
        assert_eq!(WOKEN.load(Ordering::Relaxed), 1, "the queue was full: missed");
    }

    #[test]
    fn the_node_wakes_on_its_exports_and_on_those_added_later() {
        use crate::{NoParams, Node, NodeConfig};
        use core::sync::atomic::{AtomicU32, Ordering};
        static A: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("a", 0);
        static A_PUB: Publisher<'static, u32> = Publisher::new(&A, SRT);
        static A_OUT: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&A_PUB);
        static B: Topic<'static, u32, { pool_size(&[2], 1) }, 1> = Topic::new("b", 0);
        static B_PUB: Publisher<'static, u32> = Publisher::new(&B, SRT);
        static B_OUT: RemoteSubscriber<'static, u32, 2> = RemoteSubscriber::new(&B_PUB);
        static WOKEN: AtomicU32 = AtomicU32::new(0);
        A.subscribe(&A_OUT).unwrap();
        B.subscribe(&B_OUT).unwrap();
        let mut node: Node<'static, 2, 1, 16, 2, 64> =
            Node::new(NodeConfig::new([0; 12], "sensor"), &NoParams).unwrap();
        node.export(&A_OUT).unwrap();
        node.wake_on_release(|| {
            WOKEN.fetch_add(1, Ordering::Relaxed);
        });
        node.export(&B_OUT).unwrap();
        A_OUT.activate(1);
        B_OUT.activate(1);
        A_PUB.publish_with(|m| *m = 1).unwrap();
        B_PUB.publish_with(|m| *m = 2).unwrap();
        assert_eq!(WOKEN.load(Ordering::Relaxed), 2);
        assert_eq!(node.releases_waiting(), 2);
    }
}
