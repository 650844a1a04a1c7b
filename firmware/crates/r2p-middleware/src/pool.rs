//! Message slots and the handles that own them: the crate's only `unsafe` code.
//!
//! A topic's `Pool` is a fixed array of message slots. Each slot is in one of three states,
//! kept in a table behind a critical-section mutex:
//!
//! - **free**: nobody refers to it; `take` may hand it out;
//! - **writing**: exactly one [`MsgMut`] (a draft being filled by a publisher) refers to it;
//! - **shared(n)**: `n > 0` [`Msg`] handles refer to it and nobody writes it.
//!
//! The slot data lives in `UnsafeCell`s outside the mutex so that a message can be read and
//! written in place (zero copy) without holding a lock. The state machine is what makes the
//! three `unsafe` blocks below sound: a `&mut T` exists only through the single `MsgMut` of a
//! *writing* slot, `&T`s only through `Msg`s of a *shared* slot, and a slot becomes *free*
//! only when its last handle is dropped, so the two kinds of access never overlap.

use core::cell::{RefCell, UnsafeCell};
use core::fmt;
use core::mem::MaybeUninit;
use core::ops::{Deref, DerefMut};
use core::task::Context;

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::waitqueue::WakerRegistration;

use crate::publisher::Publisher;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SlotState {
    Free,
    Writing,
    Shared(u32),
}

struct State<const N: usize> {
    slots: [SlotState; N],
    free: usize,
    /// The non-real-time publisher waiting in `alloc` for a slot, if any.
    waiter: WakerRegistration,
}

/// The type-erased face of a [`Pool`], so handles need not carry its size.
///
/// Every method takes a slot index that the caller owns in the state the method expects;
/// violating that is a bug in this crate and panics (it never corrupts memory).
pub(crate) trait RawPool<T>: Sync {
    /// Free → writing; `None` if no slot is free (then registers `cx`'s waker, if given).
    fn take(&self, cx: Option<&mut Context<'_>>) -> Option<usize>;
    /// Writing → shared(1): the draft becomes a published message.
    fn share(&self, index: usize);
    /// Shared(n) → shared(n + 1): one more handle.
    fn retain(&self, index: usize);
    /// Shared(n) → shared(n - 1), or free when n was 1; writing → free (unpublished draft).
    fn release(&self, index: usize);
    /// Where slot `index`'s message lives.
    fn slot(&self, index: usize) -> *mut T;
    /// Number of free slots now.
    fn free(&self) -> usize;
}

/// `N` message slots of type `T`, every one initialised, plus their state table.
pub(crate) struct Pool<T, const N: usize> {
    state: Mutex<CriticalSectionRawMutex, RefCell<State<N>>>,
    data: [UnsafeCell<MaybeUninit<T>>; N],
}

// SAFETY: the slot data is reached only through `Msg` (shared `&T`, possibly from several
// execution contexts at once: needs `T: Sync`) and `MsgMut` (exclusive `&mut T` in whatever
// context holds the draft, after which others read it: needs `T: Send`). The state table,
// updated under a critical section, guarantees that the two never overlap (module docs).
unsafe impl<T: Send + Sync, const N: usize> Sync for Pool<T, N> {}

impl<T: Copy, const N: usize> Pool<T, N> {
    /// A pool whose slots all start as copies of `init` (so every slot is always initialised
    /// and a draft can be filled field by field, as in the paper's Listing 1).
    pub(crate) const fn new(init: T) -> Self {
        let mut data = [const { UnsafeCell::new(MaybeUninit::uninit()) }; N];
        let mut i = 0;
        while i < N {
            data[i] = UnsafeCell::new(MaybeUninit::new(init));
            i += 1;
        }
        Pool {
            state: Mutex::new(RefCell::new(State {
                slots: [SlotState::Free; N],
                free: N,
                waiter: WakerRegistration::new(),
            })),
            data,
        }
    }
}

impl<T, const N: usize> Pool<T, N> {
    fn with<R>(&self, f: impl FnOnce(&mut State<N>) -> R) -> R {
        self.state.lock(|s| f(&mut s.borrow_mut()))
    }
}

impl<T: Send + Sync, const N: usize> RawPool<T> for Pool<T, N> {
    fn take(&self, cx: Option<&mut Context<'_>>) -> Option<usize> {
        self.with(|s| match s.slots.iter().position(|&x| x == SlotState::Free) {
            Some(i) => {
                s.slots[i] = SlotState::Writing;
                s.free -= 1;
                Some(i)
            }
            None => {
                if let Some(cx) = cx {
                    s.waiter.register(cx.waker());
                }
                None
            }
        })
    }

    fn share(&self, index: usize) {
        self.with(|s| {
            assert_eq!(s.slots[index], SlotState::Writing, "share: slot not being written");
            s.slots[index] = SlotState::Shared(1);
        })
    }

    fn retain(&self, index: usize) {
        self.with(|s| match s.slots[index] {
            SlotState::Shared(n) => {
                s.slots[index] = SlotState::Shared(n.checked_add(1).expect("too many handles"))
            }
            other => panic!("retain: slot {index} is {other:?}"),
        })
    }

    fn release(&self, index: usize) {
        self.with(|s| {
            s.slots[index] = match s.slots[index] {
                SlotState::Shared(n) if n > 1 => SlotState::Shared(n - 1),
                SlotState::Shared(_) | SlotState::Writing => {
                    s.free += 1;
                    s.waiter.wake();
                    SlotState::Free
                }
                SlotState::Free => panic!("release: slot {index} is already free"),
            }
        })
    }

    fn slot(&self, index: usize) -> *mut T {
        // `MaybeUninit<T>` is `repr(transparent)`: a pointer to it is a pointer to the `T`.
        self.data[index].get().cast::<T>()
    }

    fn free(&self) -> usize {
        self.with(|s| s.free)
    }
}

/// A published message: a shared, reference-counted handle to a slot of its topic's pool.
///
/// Every subscriber that accepted the message holds its own `Msg`; nobody copies the message.
/// Dropping the last handle returns the slot to the pool (what the paper's `release()` did by
/// hand). `Clone` adds a handle (and keeps the slot out of the pool a little longer: see the
/// sizing rule in [`pool_size`](crate::pool_size)).
pub struct Msg<'a, T> {
    pool: &'a dyn RawPool<T>,
    origin: &'a Publisher<'a, T>,
    index: usize,
}

impl<'a, T> Msg<'a, T> {
    /// The publisher that published this message: a remote subscriber (the transport) reads
    /// its [`Class`](crate::Class) for the deadline and reports misses back to it.
    pub fn publisher(&self) -> &'a Publisher<'a, T> {
        self.origin
    }
}

impl<T> Deref for Msg<'_, T> {
    type Target = T;
    fn deref(&self) -> &T {
        // SAFETY: this handle keeps the slot *shared* (count ≥ 1) for as long as the returned
        // borrow of `self` lives; a shared slot is never written (only a *writing* slot has a
        // `MsgMut`) and every slot was initialised by `Pool::new`.
        unsafe { &*self.pool.slot(self.index) }
    }
}

impl<T> Clone for Msg<'_, T> {
    fn clone(&self) -> Self {
        self.pool.retain(self.index);
        Msg { pool: self.pool, origin: self.origin, index: self.index }
    }
}

impl<T> Drop for Msg<'_, T> {
    fn drop(&mut self) {
        self.pool.release(self.index);
    }
}

impl<T: fmt::Debug> fmt::Debug for Msg<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("Msg").field(&**self).finish()
    }
}

/// A message being written: exclusive access to one pool slot, from `alloc` to `publish`.
///
/// The slot holds whatever message last used it (every slot starts as the topic's initial
/// value): overwrite every field, or assign a whole value with `*draft = value`. Dropping a
/// draft without publishing it returns the slot to the pool.
pub struct MsgMut<'a, T> {
    pool: &'a dyn RawPool<T>,
    origin: &'a Publisher<'a, T>,
    index: usize,
}

impl<'a, T> MsgMut<'a, T> {
    /// Claims a free slot of `pool` for `origin`; `None` if the pool is empty.
    pub(crate) fn take(
        pool: &'a dyn RawPool<T>,
        origin: &'a Publisher<'a, T>,
        cx: Option<&mut Context<'_>>,
    ) -> Option<Self> {
        pool.take(cx).map(|index| MsgMut { pool, origin, index })
    }

    /// The publisher this draft belongs to.
    pub(crate) fn origin(&self) -> &'a Publisher<'a, T> {
        self.origin
    }

    /// Turns the draft into the first handle of the published message.
    pub(crate) fn share(self) -> Msg<'a, T> {
        let this = core::mem::ManuallyDrop::new(self);
        this.pool.share(this.index);
        Msg { pool: this.pool, origin: this.origin, index: this.index }
    }
}

impl<T> Deref for MsgMut<'_, T> {
    type Target = T;
    fn deref(&self) -> &T {
        // SAFETY: the slot is *writing* and this draft is its only handle (see `deref_mut`);
        // the shared borrow of `self` excludes a concurrent `&mut` through it.
        unsafe { &*self.pool.slot(self.index) }
    }
}

impl<T> DerefMut for MsgMut<'_, T> {
    fn deref_mut(&mut self) -> &mut T {
        // SAFETY: `take` moved the slot from *free* to *writing* under the pool's lock and gave
        // it to this one `MsgMut` (not `Clone`); no `Msg` exists for a writing slot, and the
        // slot leaves *writing* only by consuming this draft (`share`) or dropping it. So the
        // `&mut` borrow of `self` is the only access to the slot while it lives.
        unsafe { &mut *self.pool.slot(self.index) }
    }
}

impl<T> Drop for MsgMut<'_, T> {
    fn drop(&mut self) {
        self.pool.release(self.index);
    }
}

impl<T: fmt::Debug> fmt::Debug for MsgMut<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("MsgMut").field(&**self).finish()
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use crate::{Class, Publisher, Subscriber, Topic, TopicInfo};

    const NRT: Class = Class::NonRealTime;

    r2p_testkit::suite! {
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

    #[test]
    #[should_panic(expected = "already free")]
    fn releasing_a_free_slot_panics_instead_of_corrupting_the_pool() {
        let pool: Pool<u32, 2> = Pool::new(0);
        let i = pool.take(None).unwrap();
        pool.release(i);
        pool.release(i);
    }

    #[test]
    #[should_panic(expected = "not being written")]
    fn sharing_a_slot_twice_panics() {
        let pool: Pool<u32, 2> = Pool::new(0);
        let i = pool.take(None).unwrap();
        pool.share(i);
        pool.share(i);
    }

    #[test]
    fn take_hands_out_each_slot_once() {
        let pool: Pool<u32, 3> = Pool::new(0);
        let mut got = [pool.take(None), pool.take(None), pool.take(None)].map(Option::unwrap);
        got.sort();
        assert_eq!(got, [0, 1, 2]);
        assert_eq!(pool.take(None), None);
        assert_eq!(pool.free(), 0);
    }
}
