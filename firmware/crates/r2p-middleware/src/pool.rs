//! Message slots and the handles that own them: the crate's only `unsafe` code.
//!
//! A topic's `Pool` is a fixed array of message slots. Each slot carries its state in one
//! atomic word, `refs`:
//!
//! - **free** (`FREE`): nobody refers to it; `take` may hand it out;
//! - **writing** (`WRITING`): exactly one [`MsgMut`] (a draft being filled by a publisher)
//!   refers to it;
//! - **shared(n)** (`1 ≤ n < WRITING`): `n` [`Msg`] handles refer to it and nobody writes it.
//!
//! The transitions are atomic read-modify-writes (on a Cortex-M3, `LDREX`/`STREX`; no
//! critical section), all in `slots.rs`: `take` moves free → writing with a compare-and-swap,
//! so one slot goes to one draft; publishing stores the number of handles it is about to hand out, once;
//! `Msg::clone` adds one; dropping a handle subtracts one, and the handle that brings the
//! count to zero has freed the slot (like `Arc`). The count is exactly the number of live
//! handles at every moment, so a slot is free only when nobody can reach it.
//!
//! The slot data lives in `UnsafeCell`s beside the counts so that a message can be read and
//! written in place (zero copy) without a lock. The state machine is what makes the three
//! `unsafe` dereferences below sound: a `&mut T` exists only through the single `MsgMut` of a
//! *writing* slot, `&T`s only through `Msg`s of a *shared* slot, and a slot becomes *free*
//! only when its last handle is dropped, so the two kinds of access never overlap. Memory
//! ordering: every release is a `Release` RMW and `take`'s compare-and-swap is `Acquire`, so
//! all reads through the handles of a slot happen before the next draft of it is written; the
//! written draft reaches subscribers through their queues' locks. The loom tests of
//! `slots.rs` (`make loom`) check this and the waiting `alloc`'s wake-up under every
//! interleaving the orderings allow.

use core::fmt;
use core::mem::ManuallyDrop;
use core::ops::{Deref, DerefMut};
use core::task::Context;

use crate::publisher::Publisher;
use crate::slots::WRITING;
pub(crate) use crate::slots::{Pool, Slot};

/// A published message: a shared, reference-counted handle to a slot of its topic's pool.
///
/// Every subscriber that accepted the message holds its own `Msg`; nobody copies the message.
/// Dropping the last handle returns the slot to the pool (what the paper's `release()` did by
/// hand). `Clone` adds a handle (and keeps the slot out of the pool a little longer: see the
/// sizing rule in [`pool_size`](crate::pool_size)).
///
/// A handle is shared across execution contexts only if the message type allows it:
///
/// ```compile_fail
/// fn shared<X: Sync>() {}
/// shared::<r2p_middleware::Msg<'static, core::cell::Cell<u8>>>(); // `Cell` is not `Sync`
/// ```
// `repr(C)` here, on `Shares`, `MsgMut`, `Slot` and `Topic`: the same layout whatever `T`, so
// the code that handles messages without reading them (a handle's drop, a topic's publish, a
// remote subscriber's queue) compiles to the same instructions for every message type, and
// LLVM's function merging keeps one copy (−1.1 KB on the PSU's four topics).
#[repr(C)]
pub struct Msg<'a, T> {
    slot: &'a Slot<T>,
    origin: &'a Publisher<'a, T>,
}

impl<'a, T> Msg<'a, T> {
    /// The publisher that published this message: a remote subscriber (the transport) reads
    /// its [`Class`](crate::Class) for the deadline and reports misses back to it.
    #[inline]
    pub fn publisher(&self) -> &'a Publisher<'a, T> {
        self.origin
    }
}

impl<T> Deref for Msg<'_, T> {
    type Target = T;
    #[inline(always)]
    fn deref(&self) -> &T {
        // SAFETY: this handle keeps the slot *shared* (count ≥ 1) for as long as the returned
        // borrow of `self` lives; a shared slot is never written (only a *writing* slot has a
        // `MsgMut`) and every slot was initialised by `Pool::new`.
        unsafe { &*self.slot.read_ptr() }
    }
}

impl<T> Clone for Msg<'_, T> {
    #[inline]
    fn clone(&self) -> Self {
        self.slot.add_handle();
        Msg { slot: self.slot, origin: self.origin }
    }
}

impl<T> Drop for Msg<'_, T> {
    #[inline]
    fn drop(&mut self) {
        if self.slot.release(1) {
            self.origin.pool().freed();
        }
    }
}

impl<T: fmt::Debug> fmt::Debug for Msg<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("Msg").field(&**self).finish()
    }
}

/// The handles of a message being published: exactly as many as the count `share` set.
///
/// Each `next()` hands out one of them (nothing to count: the slot's count already includes
/// it); dropping the iterator early (a sink panicked) releases the ones not handed out.
#[repr(C)]
pub(crate) struct Shares<'a, T> {
    slot: &'a Slot<T>,
    origin: &'a Publisher<'a, T>,
    left: u32,
}

impl<'a, T> Iterator for Shares<'a, T> {
    type Item = Msg<'a, T>;
    #[inline(always)]
    fn next(&mut self) -> Option<Msg<'a, T>> {
        if self.left == 0 {
            return None;
        }
        self.left -= 1;
        Some(Msg { slot: self.slot, origin: self.origin })
    }
}

impl<T> Drop for Shares<'_, T> {
    #[inline(always)]
    fn drop(&mut self) {
        if self.left > 0 && self.slot.release(self.left) {
            self.origin.pool().freed();
        }
    }
}

/// A message being written: exclusive access to one pool slot, from `alloc` to `publish`.
///
/// The slot holds whatever message last used it (every slot starts as the topic's initial
/// value): overwrite every field, or assign a whole value with `*draft = value`. Dropping a
/// draft without publishing it returns the slot to the pool.
#[repr(C)]
pub struct MsgMut<'a, T> {
    slot: &'a Slot<T>,
    origin: &'a Publisher<'a, T>,
}

impl<'a, T> MsgMut<'a, T> {
    /// Claims a free slot of `origin`'s pool; `None` if the pool is empty (then `cx`'s waker,
    /// if given, is woken when a slot is freed).
    #[inline]
    pub(crate) fn take(origin: &'a Publisher<'a, T>, cx: Option<&mut Context<'_>>) -> Option<Self> {
        origin.pool().take(cx).map(|slot| MsgMut { slot, origin })
    }

    /// The publisher this draft belongs to.
    #[inline(always)]
    pub(crate) fn origin(&self) -> &'a Publisher<'a, T> {
        self.origin
    }

    /// Publishes the draft as `n` handles: writing → shared(n) (or free if `n` is 0), in one
    /// store; the caller hands each handle to one subscriber.
    ///
    /// # Panics
    /// If `n` is `u32::MAX` or more (far beyond any topic's subscriber list).
    #[inline]
    pub(crate) fn share(self, n: usize) -> Shares<'a, T> {
        let this = ManuallyDrop::new(self);
        let (slot, origin) = (this.slot, this.origin);
        let n = match u32::try_from(n) {
            Ok(n) if n < WRITING => n,
            _ => panic!("too many handles"),
        };
        if slot.publish(n) {
            origin.pool().freed();
        }
        Shares { slot, origin, left: n }
    }
}

impl<T> Deref for MsgMut<'_, T> {
    type Target = T;
    #[inline(always)]
    fn deref(&self) -> &T {
        // SAFETY: the slot is *writing* and this draft is its only handle (see `deref_mut`);
        // the shared borrow of `self` excludes a concurrent `&mut` through it.
        unsafe { &*self.slot.read_ptr() }
    }
}

impl<T> DerefMut for MsgMut<'_, T> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut T {
        // SAFETY: `take` moved the slot from *free* to *writing* with a compare-and-swap and
        // gave it to this one `MsgMut` (not `Clone`); no `Msg` exists for a writing slot, and
        // the slot leaves *writing* only by consuming this draft (`share`) or dropping it. So
        // the `&mut` borrow of `self` is the only access to the slot while it lives.
        unsafe { &mut *self.slot.write_ptr() }
    }
}

impl<T> Drop for MsgMut<'_, T> {
    fn drop(&mut self) {
        self.slot.abandon();
        self.origin.pool().freed();
    }
}

impl<T: fmt::Debug> fmt::Debug for MsgMut<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("MsgMut").field(&**self).finish()
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use crate::{pool_size, Class, Publisher, Subscriber, Topic, TopicInfo};
    use core::pin::pin;
    use core::sync::atomic::Ordering;
    use core::task::Poll;
    use embassy_futures::poll_once;

    const NRT: Class = Class::NonRealTime;

    /// Handles counted in the slot `m` refers to.
    fn refs(m: &super::Msg<'_, u32>) -> u32 {
        m.slot.refs.load(Ordering::Relaxed)
    }

    r2p_testkit::suite! {
        fn publishing_counts_exactly_one_handle_per_accepting_subscriber() {
            static T: Topic<'static, u32, { pool_size(&[1; 4], 1) }, 4> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            static S: [Subscriber<'static, u32, 1>; 4] = [const { Subscriber::new() }; 4];
            T.advertise(&P).unwrap();
            for s in &S {
                T.subscribe(s).unwrap();
            }
            let d = P.publish_with(|m| *m = 1).unwrap();
            assert_eq!((d.delivered, d.missed), (4, 0));
            let first = S[2].try_recv().unwrap();
            assert_eq!(refs(&first), 4, "one per subscriber, none left over by publish");
            drop(S[3].try_recv());
            assert_eq!(refs(&first), 3);
            // S[0] and S[1] still queue the first message: they are full and refuse the second.
            let d = P.publish_with(|m| *m = 2).unwrap();
            assert_eq!((d.delivered, d.missed), (2, 2));
            let second = S[2].try_recv().unwrap();
            assert_eq!(*second, 2);
            assert_eq!(refs(&second), 2, "the refused handles were dropped, not counted");
            assert_eq!(refs(&first), 3, "the first message is untouched by the second");
            assert_eq!(S.each_ref().map(|s| s.missed()), [1, 1, 0, 0]);
            assert_eq!(P.stats().missed_deliveries, 2);
            assert_eq!(T.free_slots(), T.capacity() - 2);
            drop((first, second));
            for s in &S {
                while s.try_recv().is_some() {}
            }
            assert_eq!(T.free_slots(), T.capacity());
        }

        fn a_message_every_queue_refuses_is_free_at_once_for_a_waiting_alloc() {
            // Not advertised: the drafts may use the whole pool.
            static T: Topic<'static, u32, 4, 2> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            static A: Subscriber<'static, u32, 1> = Subscriber::new();
            static B: Subscriber<'static, u32, 1> = Subscriber::new();
            T.subscribe(&A).unwrap();
            T.subscribe(&B).unwrap();
            P.publish_with(|m| *m = 1).unwrap(); // both queues full now
            let held = [P.try_alloc().unwrap(), P.try_alloc().unwrap()];
            let mut last = P.try_alloc().unwrap();
            *last = 2;
            assert_eq!(T.free_slots(), 0);
            let mut waiting = pin!(P.alloc());
            assert!(poll_once(waiting.as_mut()).is_pending());
            let d = P.publish(last);
            assert_eq!((d.delivered, d.missed), (0, 2));
            assert_eq!(T.free_slots(), 1, "nobody took a handle: the slot is free again");
            match poll_once(waiting.as_mut()) {
                Poll::Ready(m) => assert_eq!(*m, 2, "the waiting alloc got that very slot"),
                Poll::Pending => panic!("alloc still waiting after the slot was freed"),
            }
            assert_eq!((A.missed(), B.missed()), (1, 1));
            assert_eq!(*A.try_recv().unwrap(), 1);
            drop(held);
        }

        fn slot_returns_to_pool_only_when_the_last_subscriber_drops_it() {
            static T: Topic<'static, u32, 5, 2> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            static A: Subscriber<'static, u32, 1> = Subscriber::new();
            static B: Subscriber<'static, u32, 1> = Subscriber::new();
            T.subscribe(&A).unwrap();
            T.subscribe(&B).unwrap();
            let mut m = P.try_alloc().unwrap();
            assert_eq!(T.free_slots(), 4);
            *m = 7;
            P.publish(m);
            assert_eq!(T.free_slots(), 4, "both queues refer to the slot");
            let a = A.try_recv().unwrap();
            drop(a);
            assert_eq!(T.free_slots(), 4, "B still refers to it");
            let b = B.try_recv().unwrap();
            assert_eq!(*b, 7);
            drop(b);
            assert_eq!(T.free_slots(), 5);
        }

        fn publishing_with_no_subscriber_frees_the_slot_at_once() {
            static T: Topic<'static, u32, 1, 1> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            for i in 0..3 {
                let mut m = P.try_alloc().expect("the slot came back");
                *m = i;
                assert_eq!(P.publish(m).delivered, 0);
                assert_eq!(T.free_slots(), 1);
            }
        }

        fn dropping_an_unpublished_draft_frees_its_slot() {
            static T: Topic<'static, u32, 2, 1> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            let a = P.try_alloc().unwrap();
            let b = P.try_alloc().unwrap();
            assert_eq!(T.free_slots(), 0);
            drop(a);
            assert_eq!(T.free_slots(), 1);
            drop(b);
            assert_eq!(T.free_slots(), 2);
        }

        fn clones_keep_the_slot_until_every_handle_is_dropped() {
            static T: Topic<'static, u32, 3, 1> = Topic::new("t", 0);
            static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
            static S: Subscriber<'static, u32, 1> = Subscriber::new();
            T.subscribe(&S).unwrap();
            P.publish_with(|m| *m = 3).unwrap();
            let m = S.try_recv().unwrap();
            let c = m.clone();
            let d = c.clone();
            drop(m);
            drop(c);
            assert_eq!(T.free_slots(), 2);
            assert_eq!(*d, 3);
            drop(d);
            assert_eq!(T.free_slots(), 3);
        }

        fn subscribers_share_the_one_slot_the_publisher_wrote() {
            static T: Topic<'static, [u8; 16], 5, 2> = Topic::new("t", [0; 16]);
            static P: Publisher<'static, [u8; 16]> = Publisher::new(&T, NRT);
            static A: Subscriber<'static, [u8; 16], 1> = Subscriber::new();
            static B: Subscriber<'static, [u8; 16], 1> = Subscriber::new();
            T.subscribe(&A).unwrap();
            T.subscribe(&B).unwrap();
            let mut m = P.try_alloc().unwrap();
            m[3] = 9;
            let written: *const [u8; 16] = &*m;
            P.publish(m);
            let (a, b) = (A.try_recv().unwrap(), B.try_recv().unwrap());
            assert!(core::ptr::eq(&*a, written), "zero copy: A reads the slot written");
            assert!(core::ptr::eq(&*b, written));
            assert_eq!(a[3], 9);
        }

        fn slots_start_as_the_initial_value_and_keep_the_last_message() {
            static T: Topic<'static, (u32, u32), 1, 1> = Topic::new("t", (5, 6));
            static P: Publisher<'static, (u32, u32)> = Publisher::new(&T, NRT);
            let mut m = P.try_alloc().unwrap();
            assert_eq!(*m, (5, 6));
            m.0 = 1;
            P.publish(m);
            let m = P.try_alloc().unwrap();
            assert_eq!(*m, (1, 6), "a draft holds the slot's previous message");
        }
    }
}

#[cfg(test)]
mod host_tests {
    use super::*;
    use crate::{Callback, Class, Subscriber, Topic, TopicInfo};
    use core::sync::atomic::Ordering;

    #[test]
    #[should_panic(expected = "already free")]
    fn releasing_a_free_slot_panics_instead_of_corrupting_the_pool() {
        let pool: Pool<[Slot<u32>; 2]> = Pool::new(0);
        let pool: &Pool<[Slot<u32>]> = &pool;
        let slot = pool.take(None).unwrap();
        slot.refs.store(1, Ordering::Relaxed);
        assert!(slot.release(1), "the last handle frees the slot");
        slot.release(1);
    }

    #[test]
    #[should_panic(expected = "not being written")]
    fn dropping_a_draft_of_a_shared_slot_panics() {
        static T: Topic<'static, u32, 2, 1> = Topic::new("t", 0);
        static P: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
        let draft = P.try_alloc().unwrap();
        let slot = draft.slot;
        drop(draft.share(1)); // nobody took the handle: released, the slot is free again
        slot.refs.store(1, Ordering::Relaxed); // pretend a handle exists
        drop(MsgMut { slot, origin: &P });
    }

    #[test]
    #[should_panic(expected = "too many handles")]
    fn sharing_a_draft_as_u32_max_handles_panics_instead_of_marking_it_written() {
        // `u32::MAX` is the *writing* state: a count that reached it would let a draft and
        // handles meet. No topic has that many subscribers, but the bound is the guard.
        static T: Topic<'static, u32, 1, 1> = Topic::new("t", 0);
        static P: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
        let draft = P.try_alloc().unwrap();
        let shares = draft.share(u32::MAX as usize);
        core::mem::forget(shares);
    }

    #[test]
    fn take_hands_out_each_slot_once() {
        let pool: Pool<[Slot<u32>; 3]> = Pool::new(0);
        let pool: &Pool<[Slot<u32>]> = &pool;
        let mut got = [pool.take(None), pool.take(None), pool.take(None)]
            .map(|s| s.unwrap() as *const Slot<u32> as usize);
        got.sort();
        got.windows(2).for_each(|w| assert_ne!(w[0], w[1]));
        assert!(pool.take(None).is_none());
        assert_eq!(pool.free(), 0);
    }

    #[test]
    fn a_panicking_sink_leaves_the_count_exact() {
        // A callback that panics mid-publish: the handles not yet handed out are released when
        // the unwinding drops them, so the slot is neither leaked nor freed early.
        fn boom(_: &u32) {
            panic!("callback failed");
        }
        static T: Topic<'static, u32, 4, 3> = Topic::new("t", 0);
        static P: Publisher<'static, u32> = Publisher::new(&T, Class::NonRealTime);
        static A: Subscriber<'static, u32, 1> = Subscriber::new();
        static CB: Callback<fn(&u32)> = Callback::new(boom);
        static B: Subscriber<'static, u32, 1> = Subscriber::new();
        T.subscribe(&A).unwrap();
        T.subscribe(&CB).unwrap();
        T.subscribe(&B).unwrap();
        let r = std::panic::catch_unwind(|| P.publish_with(|m| *m = 5));
        assert!(r.is_err());
        let a = A.try_recv().expect("A got its handle before the panic");
        assert!(B.try_recv().is_none(), "B's handle was never handed out");
        assert_eq!(a.slot.refs.load(Ordering::Relaxed), 1, "only A's handle is counted");
        assert_eq!(T.free_slots(), 3);
        drop(a);
        assert_eq!(T.free_slots(), 4);
    }
}
