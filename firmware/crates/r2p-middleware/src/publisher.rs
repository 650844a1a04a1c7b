//! Typed publishers and their real-time classes (paper §3.4.5).

use core::cell::Cell;
use core::future::{poll_fn, Future};
use core::sync::atomic::{AtomicU32, Ordering};
use core::task::Poll;

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::signal::Signal;

use crate::pool::{MsgMut, Pool, Slot};
pub use crate::topic::Delivery;
use crate::topic::{Topic, TopicCore};
use crate::Error;

/// A publisher's real-time class: how it behaves when the pool is empty, and what the
/// transport must guarantee for its messages.
///
/// This is the traffic class an application names. The bus carries it in two other forms,
/// each with its own type because each knows less: the class a topic is advertised with
/// (`r2p_management::message::BusClass`, the period counted in the bus's cycles) and the class
/// a frame's identifier shows (`rtcan::FrameClass`, without period or deadline). This crate
/// depends on neither: a publisher's class means the same on a module without a bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// Never expires (logging, parameters): `alloc` waits for a free slot.
    NonRealTime,
    /// Time-triggered, every `period_us` microseconds (distributed control loops). Uses
    /// `try_alloc`/[`Publisher::publish_with`]; an empty pool is counted and signalled.
    SyncRealTime {
        /// Publication period, µs; the message's deadline is the next period.
        period_us: u32,
    },
    /// Event-triggered with a delivery deadline; misses are reported back by the transport.
    AsyncRealTime {
        /// Time from publication by which subscribers must have the message, µs.
        deadline_us: u32,
    },
}

impl Class {
    /// The delivery deadline the transport schedules by: the period for synchronous
    /// publishers (implicit deadline), the stated deadline for asynchronous ones, none for
    /// non-real-time.
    pub const fn deadline_us(self) -> Option<u32> {
        match self {
            Class::NonRealTime => None,
            Class::SyncRealTime { period_us } => Some(period_us),
            Class::AsyncRealTime { deadline_us } => Some(deadline_us),
        }
    }

    /// Whether the publisher must never wait for a slot.
    pub const fn is_real_time(self) -> bool {
        !matches!(self, Class::NonRealTime)
    }
}

/// Why a publishing node is signalled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// `try_alloc` found no free slot: the message was not published.
    PoolEmpty,
    /// The transport reported that a message missed its deadline.
    DeadlineMiss,
}

/// Counters a node or the management protocol reads to see how a publisher is doing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PublisherStats {
    /// Messages published.
    pub published: u32,
    /// Deliveries refused by full subscriber queues (one per subscriber that missed).
    pub missed_deliveries: u32,
    /// `try_alloc` calls that found the pool empty.
    pub pool_empty: u32,
    /// Deadline misses reported by the transport.
    pub deadline_misses: u32,
}

/// The counters of [`PublisherStats`], each an atomic so that publishing takes no lock for
/// them.
struct Counters {
    published: AtomicU32,
    missed_deliveries: AtomicU32,
    pool_empty: AtomicU32,
    deadline_misses: AtomicU32,
}

impl Counters {
    /// Adds `n` to `counter`, wrapping as the counters always have.
    #[inline(always)]
    fn add(counter: &AtomicU32, n: u32) {
        counter.fetch_add(n, Ordering::Relaxed);
    }
}

/// Counts a publisher's `fault` on `counter` and signals it. Not generic and out of line: every
/// message type's [`Publisher::try_alloc`] and [`Publisher::report_deadline_miss`] share it
/// (inlined, each carried its own copy of the signal's critical section, ~36 B).
#[inline(never)]
fn count_fault(counter: &AtomicU32, signal: &Signal<CriticalSectionRawMutex, Fault>, fault: Fault) {
    Counters::add(counter, 1);
    signal.signal(fault);
}

/// A typed publisher on one topic. Declare it `static` next to its topic, then
/// [`Topic::advertise`] it; all methods take `&self`, so a node and the transport can share it.
pub struct Publisher<'a, T> {
    topic: &'a dyn TopicCore<'a, T>,
    /// The topic's pool, reached without a virtual call (allocation and release).
    pool: &'a Pool<[Slot<T>]>,
    class: Class,
    counters: Counters,
    advertised: Mutex<CriticalSectionRawMutex, Cell<bool>>,
    fault: Signal<CriticalSectionRawMutex, Fault>,
}

impl<'a, T: Copy + Send + Sync + 'a> Publisher<'a, T> {
    /// A publisher of `class` on `topic`.
    pub const fn new<const SLOTS: usize, const SUBS: usize>(
        topic: &'a Topic<'a, T, SLOTS, SUBS>,
        class: Class,
    ) -> Self {
        Publisher {
            topic,
            pool: topic.pool(),
            class,
            counters: Counters {
                published: AtomicU32::new(0),
                missed_deliveries: AtomicU32::new(0),
                pool_empty: AtomicU32::new(0),
                deadline_misses: AtomicU32::new(0),
            },
            advertised: Mutex::new(Cell::new(false)),
            fault: Signal::new(),
        }
    }
}

impl<'a, T> Publisher<'a, T> {
    /// The pool of the topic this publisher publishes on.
    #[inline(always)]
    pub(crate) fn pool(&self) -> &'a Pool<[Slot<T>]> {
        self.pool
    }

    pub(crate) fn is_on<const SLOTS: usize, const SUBS: usize>(
        &self,
        topic: &Topic<'a, T, SLOTS, SUBS>,
    ) -> bool {
        core::ptr::addr_eq(self.topic, topic)
    }

    pub(crate) fn mark_advertised(&self) -> Result<(), Error> {
        // Lock order: publisher, then topic (nothing takes them the other way round).
        self.advertised.lock(|a| {
            if a.get() {
                return Err(Error::AlreadyAdvertised);
            }
            self.topic.reserve_publisher()?;
            a.set(true);
            Ok(())
        })
    }

    /// The name of the topic this publisher publishes on.
    pub fn topic_name(&self) -> &'static str {
        self.topic.name()
    }

    /// The real-time class given at construction, for the transport.
    pub fn class(&self) -> Class {
        self.class
    }

    /// A snapshot of the counters (each read atomically; a publication that runs meanwhile
    /// may show in some and not yet in others).
    pub fn stats(&self) -> PublisherStats {
        let c = &self.counters;
        PublisherStats {
            published: c.published.load(Ordering::Relaxed),
            missed_deliveries: c.missed_deliveries.load(Ordering::Relaxed),
            pool_empty: c.pool_empty.load(Ordering::Relaxed),
            deadline_misses: c.deadline_misses.load(Ordering::Relaxed),
        }
    }

    /// Non-real-time allocation: waits until a slot is free, then returns a draft.
    ///
    /// The future is cancel-safe (dropping it takes nothing). If several tasks wait on one
    /// topic they take turns being woken; real-time code uses [`try_alloc`](Self::try_alloc).
    pub fn alloc(&'a self) -> impl Future<Output = MsgMut<'a, T>> + 'a {
        poll_fn(move |cx| match MsgMut::take(self, Some(cx)) {
            Some(m) => Poll::Ready(m),
            None => Poll::Pending,
        })
    }

    /// Real-time allocation: a draft, or `None` at once when the pool is empty — which is
    /// counted ([`PublisherStats::pool_empty`]) and signalled ([`Fault::PoolEmpty`]).
    pub fn try_alloc(&'a self) -> Option<MsgMut<'a, T>> {
        let m = MsgMut::take(self, None);
        if m.is_none() {
            count_fault(&self.counters.pool_empty, &self.fault, Fault::PoolEmpty);
        }
        m
    }

    /// Publishes a draft: every subscriber gets a handle to the same slot, or misses the
    /// message if its queue is full. Never blocks.
    ///
    /// # Panics
    /// If `draft` was allocated by another publisher.
    pub fn publish(&self, draft: MsgMut<'a, T>) -> Delivery {
        assert!(core::ptr::eq(draft.origin(), self), "draft allocated by another publisher");
        let d = self.topic.publish(draft);
        Counters::add(&self.counters.published, 1);
        if d.missed > 0 {
            Counters::add(&self.counters.missed_deliveries, d.missed as u32);
        }
        d
    }

    /// The synchronous real-time step: `try_alloc`, let `fill` write the message in place,
    /// publish. `None` if the pool was empty. Call it from the node's periodic timer.
    pub fn publish_with(&'a self, fill: impl FnOnce(&mut T)) -> Option<Delivery> {
        let mut m = self.try_alloc()?;
        fill(&mut m);
        Some(self.publish(m))
    }

    /// Called by the transport when one of this publisher's messages missed its deadline:
    /// counted and signalled to the node ([`Fault::DeadlineMiss`]).
    pub fn report_deadline_miss(&self) {
        count_fault(&self.counters.deadline_misses, &self.fault, Fault::DeadlineMiss);
    }

    /// Waits for the next fault (the latest one if several happened since the last wait).
    pub fn fault(&self) -> impl Future<Output = Fault> + '_ {
        self.fault.wait()
    }

    /// The latest fault since the last `fault`/`take_fault`, without waiting.
    pub fn take_fault(&self) -> Option<Fault> {
        self.fault.try_take()
    }
}

/// Advertising is the publisher's registration with its topic; it lives here so that the topic
/// module does not depend on publishers (topic.rs knows pools and sinks only).
impl<'a, T: Copy + Send + Sync, const SLOTS: usize, const SUBS: usize> Topic<'a, T, SLOTS, SUBS> {
    /// Registers `publisher` (made with [`Publisher::new`] on this topic): reserves the slot
    /// its draft occupies, so the sizing rule covers it. Mirrors the paper's
    /// `node.advertise(&pub)`.
    pub fn advertise(&self, publisher: &Publisher<'a, T>) -> Result<(), Error> {
        if !publisher.is_on(self) {
            return Err(Error::WrongTopic);
        }
        publisher.mark_advertised()
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;
    use crate::{pool_size, Subscriber, TopicInfo};
    use core::pin::pin;
    use embassy_futures::poll_once;

    const NRT: Class = Class::NonRealTime;
    const SRT: Class = Class::AsyncRealTime { deadline_us: 10_000 };

    r2p_testkit::suite! {
        fn try_alloc_on_an_empty_pool_fails_at_once_counted_and_signalled() {
            static T: Topic<'static, u32, 1, 1> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, SRT);
            let held = P.try_alloc().unwrap();
            assert!(P.take_fault().is_none());
            assert!(P.try_alloc().is_none());
            assert!(P.try_alloc().is_none());
            assert_eq!(P.stats().pool_empty, 2);
            assert_eq!(P.take_fault(), Some(Fault::PoolEmpty));
            assert_eq!(P.take_fault(), None, "taken");
            drop(held);
            assert!(P.try_alloc().is_some());
            assert_eq!(P.stats().pool_empty, 2);
        }

        fn alloc_waits_for_a_slot_and_gets_it_when_the_last_handle_drops() {
            // Not advertised, so no slot is reserved for the draft: the subscriber can hold
            // the whole pool (one message in hand, one queued).
            static T: Topic<'static, u32, 2, 1> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            static S: Subscriber<'static, u32, 1> = Subscriber::new();
            T.subscribe(&S).unwrap();
            let mut m = embassy_futures::block_on(P.alloc());
            *m = 1;
            P.publish(m);
            let held = S.try_recv().unwrap();
            P.publish(embassy_futures::block_on(P.alloc()));
            assert_eq!(T.free_slots(), 0);
            let mut waiting = pin!(P.alloc());
            assert!(poll_once(waiting.as_mut()).is_pending());
            assert!(poll_once(waiting.as_mut()).is_pending(), "still no slot");
            drop(held);
            match poll_once(waiting.as_mut()) {
                core::task::Poll::Ready(m) => assert_eq!(*m, 1, "the slot that was freed"),
                core::task::Poll::Pending => panic!("alloc still waiting after a slot was freed"),
            }
            assert_eq!(P.stats().pool_empty, 0, "waiting is not a fault");
        }

        fn a_full_subscriber_misses_the_message_and_nobody_else_does() {
            static T: Topic<'static, u32, 8, 2> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, SRT);
            static SLOW: Subscriber<'static, u32, 1> = Subscriber::new();
            static FAST: Subscriber<'static, u32, 4> = Subscriber::new();
            T.subscribe(&SLOW).unwrap();
            T.subscribe(&FAST).unwrap();
            for i in 0..3 {
                let d = P.publish_with(|m| *m = i).expect("a slot is free");
                let expect = if i == 0 { (2, 0) } else { (1, 1) };
                assert_eq!((d.delivered, d.missed), expect);
                let got = FAST.try_recv().unwrap();
                assert_eq!(*got, i, "the fast subscriber gets every message");
            }
            assert_eq!(SLOW.missed(), 2);
            assert_eq!(FAST.missed(), 0);
            assert_eq!(*SLOW.try_recv().unwrap(), 0, "the slow one keeps its oldest message");
            assert_eq!(P.stats().published, 3);
            assert_eq!(P.stats().missed_deliveries, 2);
            assert_eq!(T.free_slots(), 8, "missed messages went back to the pool");
        }

        fn the_sizing_rule_is_exact() {
            // Two queued subscribers holding all they may, in distinct slots: queues full plus
            // one message each in hand. One publisher draft still fits; a second does not.
            static T: Topic<'static, u32, { pool_size(&[2, 3], 1) }, 2> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, SRT);
            static A: Subscriber<'static, u32, 2> = Subscriber::new();
            static B: Subscriber<'static, u32, 3> = Subscriber::new();
            T.advertise(&P).unwrap();
            T.subscribe(&A).unwrap();
            T.subscribe(&B).unwrap();
            assert_eq!(T.capacity(), 8);
            let publish = |v| P.publish_with(|m| *m = v).expect("pool empty within the rule");
            publish(1);
            let a_held = A.try_recv().unwrap();
            drop(B.try_recv());
            publish(2);
            publish(3); // A's queue is now full
            while B.try_recv().is_some() {}
            publish(4); // A misses it
            let b_held = B.try_recv().unwrap();
            for v in 5..=7 {
                assert_eq!(publish(v).missed, 1, "A is full");
            }
            assert_eq!((A.len(), B.len()), (2, 3));
            assert_eq!((*a_held, *b_held), (1, 4));
            assert_eq!(T.free_slots(), 1, "seven distinct slots held");
            let draft = P.try_alloc().expect("the publisher's own slot");
            assert!(P.try_alloc().is_none(), "a second draft is beyond the rule");
            drop(draft);
            assert!(P.try_alloc().is_some());
        }

        fn class_metadata_is_kept_for_the_transport() {
            static T: Topic<'static, u32, 3, 1> = Topic::new("t", 0);
            static P: Publisher<'static, u32> =
                Publisher::new(&T, Class::SyncRealTime { period_us: 5_000 });
            static S: Subscriber<'static, u32, 1> = Subscriber::new();
            T.subscribe(&S).unwrap();
            assert_eq!(P.class().deadline_us(), Some(5_000));
            assert!(P.class().is_real_time());
            assert_eq!(SRT.deadline_us(), Some(10_000));
            assert_eq!(NRT.deadline_us(), None);
            assert!(!NRT.is_real_time());
            P.publish_with(|m| *m = 1).unwrap();
            // The transport (a sink) finds the publisher from the message.
            let m = S.try_recv().unwrap();
            assert!(core::ptr::eq(m.publisher(), &P));
            assert_eq!(m.publisher().class(), Class::SyncRealTime { period_us: 5_000 });
        }

        fn deadline_misses_reported_by_the_transport_reach_the_node() {
            static T: Topic<'static, u32, 3, 1> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, SRT);
            P.report_deadline_miss();
            P.report_deadline_miss();
            assert_eq!(P.stats().deadline_misses, 2);
            assert_eq!(embassy_futures::block_on(P.fault()), Fault::DeadlineMiss);
            assert!(P.take_fault().is_none());
        }

        fn a_topic_can_have_several_publishers_sharing_its_pool() {
            static T: Topic<'static, u32, { pool_size(&[4], 2) }, 1> = Topic::new("t", 0);
            static P1: Publisher<'static, u32> = Publisher::new(&T, NRT);
            static P2: Publisher<'static, u32> = Publisher::new(&T, SRT);
            static S: Subscriber<'static, u32, 4> = Subscriber::new();
            T.advertise(&P1).unwrap();
            T.advertise(&P2).unwrap();
            T.subscribe(&S).unwrap();
            P1.publish_with(|m| *m = 1).unwrap();
            P2.publish_with(|m| *m = 2).unwrap();
            let (a, b) = (S.try_recv().unwrap(), S.try_recv().unwrap());
            assert_eq!((*a, *b), (1, 2));
            assert!(core::ptr::eq(a.publisher(), &P1));
            assert!(core::ptr::eq(b.publisher(), &P2));
        }
    }
}

#[cfg(test)]
mod host_tests {
    use super::*;
    use crate::{Subscriber, TopicInfo};
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    use std::task::{Context, Wake, Waker};

    struct Count(AtomicUsize);
    impl Wake for Count {
        fn wake(self: Arc<Self>) {
            self.0.fetch_add(1, Ordering::SeqCst);
        }
    }

    #[test]
    #[should_panic(expected = "another publisher")]
    fn publishing_another_publishers_draft_panics() {
        static T: Topic<'static, u32, 2, 1> = Topic::new("t", 0);
        static P: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
        static Q: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
        let m = P.try_alloc().unwrap();
        Q.publish(m);
    }

    #[test]
    fn a_waiting_alloc_is_woken_when_every_subscriber_refuses_the_message() {
        static T: Topic<'static, u32, 2, 1> = Topic::new("t", 0);
        static P: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
        static S: Subscriber<'static, u32, 1> = Subscriber::new();
        T.subscribe(&S).unwrap();
        P.publish_with(|m| *m = 1).unwrap(); // S is full
        let draft = P.try_alloc().unwrap();
        let count = Arc::new(Count(AtomicUsize::new(0)));
        let waker = Waker::from(count.clone());
        let mut cx = Context::from_waker(&waker);
        let mut fut = std::pin::pin!(P.alloc());
        assert!(fut.as_mut().poll(&mut cx).is_pending());
        assert_eq!(P.publish(draft).missed, 1);
        assert_eq!(count.0.load(Ordering::SeqCst), 1, "the refused message's slot woke alloc");
        assert!(fut.as_mut().poll(&mut cx).is_ready());
        // With nobody waiting, freeing a slot wakes nobody (and takes no lock).
        drop(S.try_recv());
        assert_eq!(count.0.load(Ordering::SeqCst), 1);
    }

    #[test]
    fn a_waiting_alloc_is_woken_when_a_slot_is_freed_not_before() {
        static T: Topic<'static, u32, 2, 1> = Topic::new("t", 0);
        static P: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
        static S: Subscriber<'static, u32, 1> = Subscriber::new();
        T.subscribe(&S).unwrap();
        P.publish_with(|m| *m = 1).unwrap();
        let held = S.try_recv().unwrap();
        P.publish_with(|m| *m = 2).unwrap();
        let count = Arc::new(Count(AtomicUsize::new(0)));
        let waker = Waker::from(count.clone());
        let mut cx = Context::from_waker(&waker);
        let mut fut = std::pin::pin!(P.alloc());
        assert!(fut.as_mut().poll(&mut cx).is_pending());
        assert_eq!(count.0.load(Ordering::SeqCst), 0);
        let queued = S.try_recv().unwrap();
        assert_eq!(count.0.load(Ordering::SeqCst), 0, "a dequeued message still holds its slot");
        drop(queued);
        assert_eq!(count.0.load(Ordering::SeqCst), 1, "freeing the slot woke the publisher");
        let draft = fut.as_mut().poll(&mut cx);
        assert!(draft.is_ready());
        assert_eq!(T.free_slots(), 0, "the draft took the freed slot");
        drop((draft, held));
        assert_eq!(T.free_slots(), 2);
    }
}
