//! Subscribers: a queue of message handles to wait on or poll, or a callback run on publish.

use core::cell::Cell;
use core::future::{poll_fn, Future};
use core::task::{Poll, Waker};

use embassy_futures::select::{select, Either};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;

use crate::pool::Msg;
use crate::topic::Sink;

/// Returned by [`Subscriber::recv_timeout`] when the timeout future finished first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timeout;

/// A subscriber with a queue of up to `Q` messages (handles into the publisher's pool, not
/// copies). Declare it `static`, then [`Topic::subscribe`](crate::Topic::subscribe) it.
///
/// **Full-queue policy:** when a message is published while the queue is full, *this*
/// subscriber misses the new message (its [`missed`](Self::missed) counter increments) and
/// keeps the older ones it has not read; the publisher and the other subscribers are not
/// affected. So a subscriber sees a subsequence of the publications, in publication order.
pub struct Subscriber<'a, T, const Q: usize> {
    queue: Mutex<CriticalSectionRawMutex, Queue<'a, T, Q>>,
}

/// A fixed ring of message handles, the missed counter and the waiting task: all a
/// subscriber's state, under one lock so that a delivery is one short critical section.
/// (`Cell`s: the lock gives shared access only, and no borrow flag is needed.)
struct Queue<'a, T, const Q: usize> {
    /// `len` handles from `head` on, wrapping around; the other entries are `None`.
    ring: [Cell<Option<Msg<'a, T>>>; Q],
    head: Cell<usize>,
    len: Cell<usize>,
    missed: Cell<u32>,
    /// The task waiting in `recv`, if any.
    waker: Cell<Option<Waker>>,
}

impl<'a, T, const Q: usize> Queue<'a, T, Q> {
    /// Appends `msg`, or gives it back if the queue is full.
    #[inline(always)]
    fn push(&self, msg: Msg<'a, T>) -> Result<(), Msg<'a, T>> {
        let len = self.len.get();
        if len >= Q {
            return Err(msg);
        }
        let mut i = self.head.get() + len;
        if i >= Q {
            i -= Q;
        }
        self.ring[i].set(Some(msg));
        self.len.set(len + 1);
        Ok(())
    }

    /// Registers the waker of a task waiting in `recv`, with embassy's `WakerRegistration`
    /// policy: a waker for the same task is kept; one for another task replaces it, and the
    /// task it replaced is woken so that it can register again.
    fn register(&self, w: &Waker) {
        match self.waker.take() {
            Some(old) if old.will_wake(w) => self.waker.set(Some(old)),
            old => {
                self.waker.set(Some(w.clone()));
                if let Some(old) = old {
                    old.wake();
                }
            }
        }
    }

    /// Wakes the task waiting in `recv`, if any.
    #[inline(always)]
    fn wake(&self) {
        if let Some(w) = self.waker.take() {
            w.wake();
        }
    }

    /// Takes the oldest handle.
    #[inline(always)]
    fn pop(&self) -> Option<Msg<'a, T>> {
        let len = self.len.get();
        if len == 0 {
            return None;
        }
        let head = self.head.get();
        let msg = self.ring[head].take();
        self.head.set(if head + 1 >= Q { 0 } else { head + 1 });
        self.len.set(len - 1);
        msg
    }
}

impl<'a, T, const Q: usize> Subscriber<'a, T, Q> {
    /// An empty subscriber.
    pub const fn new() -> Self {
        Subscriber {
            queue: Mutex::new(Queue {
                ring: [const { Cell::new(None) }; Q],
                head: Cell::new(0),
                len: Cell::new(0),
                missed: Cell::new(0),
                waker: Cell::new(None),
            }),
        }
    }

    #[inline(always)]
    fn with<R>(&self, f: impl FnOnce(&Queue<'a, T, Q>) -> R) -> R {
        self.queue.lock(f)
    }

    /// Waits for the next message. The future is cancel-safe: drop it (for instance because a
    /// timeout or another subscriber won an `embassy_futures::select`) and no message is lost.
    pub fn recv(&self) -> impl Future<Output = Msg<'a, T>> + '_ {
        // Holds nothing between polls: a message stays queued until a poll returns it.
        poll_fn(move |cx| {
            self.with(|q| match q.pop() {
                Some(msg) => Poll::Ready(msg),
                None => {
                    q.register(cx.waker());
                    Poll::Pending
                }
            })
        })
    }

    /// The next message if one is queued, without waiting (polling).
    #[inline]
    pub fn try_recv(&self) -> Option<Msg<'a, T>> {
        self.with(Queue::pop)
    }

    /// Waits for the next message or until `timeout` completes, whichever is first.
    ///
    /// `timeout` is any future, so this crate needs no time driver: on a module pass
    /// `embassy_time::Timer::after(d)` (or wrap [`recv`](Self::recv) in
    /// `embassy_time::with_timeout`); a queued message wins over a timeout that is already due.
    pub async fn recv_timeout<F: Future>(&self, timeout: F) -> Result<Msg<'a, T>, Timeout> {
        match select(self.recv(), timeout).await {
            Either::First(m) => Ok(m),
            Either::Second(_) => Err(Timeout),
        }
    }

    /// Messages this subscriber missed because its queue was full.
    pub fn missed(&self) -> u32 {
        self.with(|q| q.missed.get())
    }

    /// Messages waiting in the queue.
    pub fn len(&self) -> usize {
        self.with(|q| q.len.get())
    }

    /// Whether no message is waiting.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl<T, const Q: usize> Default for Subscriber<'_, T, Q> {
    fn default() -> Self {
        Self::new()
    }
}

impl<'a, T: Send + Sync, const Q: usize> Sink<'a, T> for Subscriber<'a, T, Q> {
    #[inline]
    fn deliver(&self, msg: Msg<'a, T>) -> bool {
        let refused = self.with(|q| match q.push(msg) {
            Ok(()) => {
                q.wake();
                None
            }
            Err(msg) => {
                q.missed.set(q.missed.get().wrapping_add(1));
                Some(msg)
            }
        });
        // A refused handle drops here, outside the lock, releasing this subscriber's
        // reference to the slot.
        refused.is_none()
    }

    fn queue_len(&self) -> usize {
        Q
    }

    /// The queue plus the one message the node holds while it processes it.
    fn reserved_slots(&self) -> usize {
        Q + 1
    }
}

/// A subscriber whose function runs on every publication, in the publisher's context (task or
/// interrupt), before `publish` returns. Keep it short; it holds no slot afterwards.
///
/// `F` is usually a `fn(&T)`, so a callback subscriber can be a `static`.
pub struct Callback<F> {
    f: F,
}

impl<F> Callback<F> {
    /// A callback subscriber running `f`.
    pub const fn new(f: F) -> Self {
        Callback { f }
    }
}

impl<'a, T, F: Fn(&T) + Sync> Sink<'a, T> for Callback<F> {
    fn deliver(&self, msg: Msg<'a, T>) -> bool {
        (self.f)(&msg);
        true
    }

    fn queue_len(&self) -> usize {
        0
    }

    fn reserved_slots(&self) -> usize {
        0
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;
    use crate::{Class, Publisher, Topic, TopicInfo};
    use core::pin::pin;
    use core::sync::atomic::{AtomicU32, Ordering};
    use core::task::Poll;
    use embassy_futures::{block_on, poll_once};
    use embassy_sync::signal::Signal;

    const NRT: Class = Class::NonRealTime;

    r2p_testkit::suite! {
        fn try_recv_polls_in_publication_order() {
            static T: Topic<'static, u32, 5, 1> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            static S: Subscriber<'static, u32, 3> = Subscriber::new();
            T.subscribe(&S).unwrap();
            assert!(S.try_recv().is_none());
            assert!(S.is_empty());
            for v in [10, 20, 30] {
                P.publish_with(|m| *m = v).unwrap();
            }
            assert_eq!(S.len(), 3);
            let got = [S.try_recv(), S.try_recv(), S.try_recv()].map(|m| *m.unwrap());
            assert_eq!(got, [10, 20, 30]);
            assert!(S.try_recv().is_none());
        }

        fn recv_waits_until_a_message_is_published() {
            static T: Topic<'static, u32, 3, 1> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            static S: Subscriber<'static, u32, 1> = Subscriber::new();
            T.subscribe(&S).unwrap();
            let mut r = pin!(S.recv());
            assert!(poll_once(r.as_mut()).is_pending());
            P.publish_with(|m| *m = 5).unwrap();
            match poll_once(r.as_mut()) {
                Poll::Ready(m) => assert_eq!(*m, 5),
                Poll::Pending => panic!("recv did not see the published message"),
            }
            P.publish_with(|m| *m = 6).unwrap();
            assert_eq!(*block_on(S.recv()), 6);
        }

        fn recv_timeout_returns_timeout_when_the_timer_fires_first() {
            static T: Topic<'static, u32, 3, 1> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            static S: Subscriber<'static, u32, 1> = Subscriber::new();
            static TIMER: Signal<CriticalSectionRawMutex, ()> = Signal::new();
            T.subscribe(&S).unwrap();
            // A controllable "timer": pending until signalled.
            let mut r = pin!(S.recv_timeout(TIMER.wait()));
            assert!(poll_once(r.as_mut()).is_pending());
            TIMER.signal(());
            assert!(matches!(poll_once(r.as_mut()), Poll::Ready(Err(Timeout))));
            // A message published before the wait wins over a timeout that is already due.
            P.publish_with(|m| *m = 8).unwrap();
            let got = block_on(S.recv_timeout(core::future::ready(())));
            assert_eq!(*got.unwrap(), 8);
            // And with a timer that never fires, a later message ends the wait.
            let mut r = pin!(S.recv_timeout(core::future::pending::<()>()));
            assert!(poll_once(r.as_mut()).is_pending());
            P.publish_with(|m| *m = 9).unwrap();
            assert!(matches!(poll_once(r.as_mut()), Poll::Ready(Ok(ref m)) if **m == 9));
        }

        fn waiting_on_two_subscribers_loses_no_message() {
            // Listing 2's `node.wait()`: select over several subscribers; the loser's
            // message stays queued.
            static OBST: Topic<'static, u32, 3, 1> = Topic::new("obstacle", 0);
            static VEL: Topic<'static, i16, 3, 1> = Topic::new("velocity", 0);
            static PO: Publisher<'static, u32> = Publisher::new(&OBST, NRT);
            static PV: Publisher<'static, i16> = Publisher::new(&VEL, NRT);
            static SO: Subscriber<'static, u32, 1> = Subscriber::new();
            static SV: Subscriber<'static, i16, 1> = Subscriber::new();
            OBST.subscribe(&SO).unwrap();
            VEL.subscribe(&SV).unwrap();
            PV.publish_with(|m| *m = -3).unwrap();
            match block_on(select(SO.recv(), SV.recv())) {
                Either::Second(v) => assert_eq!(*v, -3),
                Either::First(_) => panic!("no obstacle was published"),
            }
            PO.publish_with(|m| *m = 40).unwrap();
            PV.publish_with(|m| *m = 7).unwrap();
            match block_on(select(SO.recv(), SV.recv())) {
                Either::First(o) => assert_eq!(*o, 40),
                Either::Second(_) => panic!("select polls the first subscriber first"),
            }
            assert_eq!(*SV.try_recv().expect("the velocity was not lost"), 7);
            assert_eq!(OBST.free_slots(), 3);
            assert_eq!(VEL.free_slots(), 3);
        }

        fn callbacks_run_on_publish_and_keep_no_slot() {
            static SEEN: AtomicU32 = AtomicU32::new(0);
            fn on_obstacle(d: &u32) {
                SEEN.store(*d, Ordering::Relaxed);
            }
            static T: Topic<'static, u32, 1, 2> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            static CB: Callback<fn(&u32)> = Callback::new(on_obstacle);
            T.subscribe(&CB).unwrap();
            let d = P.publish_with(|m| *m = 77).unwrap();
            assert_eq!(SEEN.load(Ordering::Relaxed), 77, "ran before publish returned");
            assert_eq!((d.delivered, d.missed), (1, 0));
            assert_eq!(T.free_slots(), 1);
        }

        fn missed_counts_only_the_messages_a_full_queue_refused() {
            static T: Topic<'static, u32, 4, 1> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            static S: Subscriber<'static, u32, 2> = Subscriber::new();
            T.subscribe(&S).unwrap();
            for v in 0..5 {
                P.publish_with(|m| *m = v).unwrap();
            }
            assert_eq!(S.missed(), 3);
            assert_eq!(*S.try_recv().unwrap(), 0);
            P.publish_with(|m| *m = 5).unwrap();
            assert_eq!(S.missed(), 3);
            let rest = [S.try_recv(), S.try_recv()].map(|m| *m.unwrap());
            assert_eq!(rest, [1, 5]);
        }
    }
}

#[cfg(test)]
mod host_tests {
    use super::*;
    use crate::{Class, Publisher, Topic};
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    use std::task::{Context, Wake};

    struct Count(AtomicUsize);
    impl Wake for Count {
        fn wake(self: Arc<Self>) {
            self.0.fetch_add(1, Ordering::SeqCst);
        }
    }

    fn counter() -> (Arc<Count>, Waker) {
        let c = Arc::new(Count(AtomicUsize::new(0)));
        (c.clone(), Waker::from(c))
    }

    #[test]
    fn recv_wakes_its_task_once_per_delivery_and_hands_over_between_tasks() {
        static T: Topic<'static, u32, 4, 1> = Topic::new("t", 0);
        static P: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
        static S: Subscriber<'static, u32, 2> = Subscriber::new();
        T.subscribe(&S).unwrap();
        let ((a, wa), (b, wb)) = (counter(), counter());
        let mut first = std::pin::pin!(S.recv());
        let mut second = std::pin::pin!(S.recv());
        assert!(first.as_mut().poll(&mut Context::from_waker(&wa)).is_pending());
        assert!(first.as_mut().poll(&mut Context::from_waker(&wa)).is_pending());
        assert_eq!(a.0.load(Ordering::SeqCst), 0, "the same task registering again: no wake");
        // Another task waits on the same subscriber: it takes over and the first is woken so
        // that it can register again (embassy's WakerRegistration policy).
        assert!(second.as_mut().poll(&mut Context::from_waker(&wb)).is_pending());
        assert_eq!(a.0.load(Ordering::SeqCst), 1);
        P.publish_with(|m| *m = 1).unwrap();
        assert_eq!(b.0.load(Ordering::SeqCst), 1, "a delivery wakes the registered task");
        P.publish_with(|m| *m = 2).unwrap();
        assert_eq!(b.0.load(Ordering::SeqCst), 1, "woken once: the waker was consumed");
        let got = second.as_mut().poll(&mut Context::from_waker(&wb));
        assert!(matches!(got, Poll::Ready(ref m) if **m == 1));
        assert_eq!(*S.try_recv().unwrap(), 2);
    }
}
