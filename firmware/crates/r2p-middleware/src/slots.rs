//! The pool's slots and their lock-free state machine: every atomic operation and memory
//! ordering the handles of [`pool`](crate::pool) rely on, in one place, so that the loom tests
//! (`loom_tests.rs`, `make loom`) check exactly the code the modules run.
//!
//! Each slot carries its state in one atomic word, `refs`: **free** (`FREE`), **writing**
//! (`WRITING`: one draft refers to it) or **shared(n)** (`1 ≤ n < WRITING` message handles).
//! `take` moves free → writing with an `Acquire` compare-and-swap; `publish` stores the number
//! of handles with `Release`; `add_handle` adds one (`Relaxed`, like `Arc::clone`); `release`
//! subtracts with `Release` and the handle that brings the count to zero has freed the slot;
//! `abandon` (a draft dropped) swaps free back with `Release`. So every read through a handle
//! happens before the slot's next draft is written. A publisher waiting in `alloc` is woken by
//! `freed`: the `SeqCst` fences in `take` and `freed` make sure that a slot freed while the
//! publisher registers its waker is either seen by its second try or wakes it.

use core::mem::MaybeUninit;
use core::task::Context;

use crate::sync::{fence, AtomicBool, AtomicU32, DataCell, Ordering, WakerSlot};

#[cfg(all(test, loom))]
mod loom_tests;

/// `refs` of a free slot.
pub(crate) const FREE: u32 = 0;
/// `refs` of a slot held by a draft; also the bound on the number of handles of a message.
pub(crate) const WRITING: u32 = u32::MAX;

/// One message and its state (see the module docs). Its state first (`repr(C)`): at the same
/// place whatever `T`, so releasing a handle is the same code for every message type.
#[repr(C)]
pub(crate) struct Slot<T> {
    pub(crate) refs: AtomicU32,
    data: DataCell<MaybeUninit<T>>,
}

// SAFETY: the slot data is reached only through `Msg` (shared `&T`, possibly from several
// execution contexts at once: needs `T: Sync`) and `MsgMut` (exclusive `&mut T` in whatever
// context holds the draft, after which others read it: needs `T: Send`). The state in `refs`,
// changed only by the atomic operations below, guarantees that the two never overlap (module
// docs); their orderings are model-checked by the loom tests.
unsafe impl<T: Send + Sync> Sync for Slot<T> {}

impl<T> Slot<T> {
    /// A free slot holding `init`.
    #[cfg(not(loom))]
    const fn new(init: T) -> Self {
        Slot { refs: AtomicU32::new(FREE), data: DataCell::new(MaybeUninit::new(init)) }
    }
    #[cfg(loom)]
    fn new(init: T) -> Self {
        Slot { refs: AtomicU32::new(FREE), data: DataCell::new(MaybeUninit::new(init)) }
    }

    /// The message, for reading through a handle of a *shared* slot (or the draft's own
    /// handle of a *writing* one).
    #[inline(always)]
    pub(crate) fn read_ptr(&self) -> *const T {
        // `MaybeUninit<T>` is `repr(transparent)`: a pointer to it is a pointer to the `T`.
        self.data.read_ptr().cast::<T>()
    }

    /// The message, for writing through the draft of a *writing* slot.
    #[inline(always)]
    pub(crate) fn write_ptr(&self) -> *mut T {
        self.data.write_ptr().cast::<T>()
    }

    /// Writing → shared(`n`), or free if `n` is 0 (then returns `true`: call `freed`). `n` is
    /// below `WRITING` (the caller checks).
    #[inline]
    pub(crate) fn publish(&self, n: u32) -> bool {
        // Release: with the subscribers' queue locks, orders the draft's writes before any
        // read through a handle (and, for 0, before the slot's next draft).
        self.refs.store(n, Ordering::Release);
        n == 0
    }

    /// One more handle of a shared slot (a clone of an existing handle).
    #[inline]
    pub(crate) fn add_handle(&self) {
        // Relaxed, as for `Arc`: the new handle comes from an existing one, so the slot is
        // already shared and stays so.
        let before = self.refs.fetch_add(1, Ordering::Relaxed);
        assert!(before != FREE && before < WRITING - 1, "too many handles");
    }

    /// Drops `n ≥ 1` handles at once; `true` if they were the last (the slot is free now).
    #[inline(always)]
    pub(crate) fn release(&self, n: u32) -> bool {
        let before = self.refs.fetch_sub(n, Ordering::Release);
        if before == n {
            return true;
        }
        // Only a bug in this crate can get here (a handle outliving its count): stop before
        // anything reads or writes the slot. (A free slot that wrapped to `WRITING` is never
        // handed out again, so the pool is not corrupted further.)
        assert!(before > n && before != WRITING, "release: slot is already free");
        false
    }

    /// Writing → free: a draft dropped without publishing.
    #[inline]
    pub(crate) fn abandon(&self) {
        let before = self.refs.swap(FREE, Ordering::Release);
        assert_eq!(before, WRITING, "draft of a slot not being written");
    }
}

/// The non-real-time publisher waiting in `alloc` for a slot, if any.
struct Waiter {
    /// Set (under the lock) when a waker is registered: lets a release that frees a slot skip
    /// the lock when nobody waits, which is the normal case.
    waiting: AtomicBool,
    waker: WakerSlot,
}

/// A pool of message slots: `Pool<[Slot<T>; N]>` in a topic, seen as `Pool<[Slot<T>]>` by
/// publishers and handles, so they need not carry its size.
pub(crate) struct Pool<S: ?Sized> {
    waiter: Waiter,
    slots: S,
}

impl<T: Copy + Send + Sync, const N: usize> Pool<[Slot<T>; N]> {
    /// A pool whose slots all start as copies of `init` (so every slot is always initialised
    /// and a draft can be filled field by field, as in the paper's Listing 1).
    #[cfg(not(loom))]
    pub(crate) const fn new(init: T) -> Self {
        let mut slots =
            [const { Slot { refs: AtomicU32::new(FREE), data: DataCell::uninit() } }; N];
        let mut i = 0;
        while i < N {
            slots[i] = Slot::new(init);
            i += 1;
        }
        Pool { waiter: Waiter { waiting: AtomicBool::new(false), waker: WakerSlot::new() }, slots }
    }

    /// As above, at run time: loom's primitives have no `const` constructors.
    #[cfg(loom)]
    pub(crate) fn new(init: T) -> Self {
        Pool {
            waiter: Waiter { waiting: AtomicBool::new(false), waker: WakerSlot::new() },
            slots: core::array::from_fn(|_| Slot::new(init)),
        }
    }
}

impl<T> Pool<[Slot<T>]> {
    /// Free → writing for the first free slot, if any.
    #[inline]
    fn try_take(&self) -> Option<&Slot<T>> {
        self.slots.iter().find(|s| {
            s.refs.load(Ordering::Relaxed) == FREE
                && s.refs
                    .compare_exchange(FREE, WRITING, Ordering::Acquire, Ordering::Relaxed)
                    .is_ok()
        })
    }

    /// Free → writing; `None` if no slot is free (then registers `cx`'s waker, if given, to be
    /// woken when one is freed).
    #[inline]
    pub(crate) fn take(&self, cx: Option<&mut Context<'_>>) -> Option<&Slot<T>> {
        if let Some(slot) = self.try_take() {
            return Some(slot);
        }
        let cx = cx?;
        self.waiter.waker.with(|w| {
            w.register(cx.waker());
            self.waiter.waiting.store(true, Ordering::Relaxed);
        });
        // Pairs with the fence in `freed`: either that release sees `waiting` and wakes us,
        // or we see the slot it freed now (store-buffering with sequentially consistent
        // fences: the two cannot both miss).
        fence(Ordering::SeqCst);
        self.try_take()
    }

    /// Called after a slot became free: wakes the waiting `alloc`, if any.
    #[inline]
    pub(crate) fn freed(&self) {
        fence(Ordering::SeqCst);
        if self.waiter.waiting.load(Ordering::Relaxed) {
            self.waiter.waker.with(|w| {
                self.waiter.waiting.store(false, Ordering::Relaxed);
                w.wake();
            });
        }
    }

    /// Number of free slots now.
    #[cfg_attr(loom, allow(dead_code))]
    pub(crate) fn free(&self) -> usize {
        self.slots.iter().filter(|s| s.refs.load(Ordering::Relaxed) == FREE).count()
    }
}
