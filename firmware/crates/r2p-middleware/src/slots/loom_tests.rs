//! Model checking of the slots' state machine with loom (`make loom`: `RUSTFLAGS="--cfg loom"`,
//! host only). Loom runs each scenario under every interleaving and every value the memory
//! orderings allow a load to see, and checks every access to a slot's message against the
//! happens-before edges the atomics create: a read through a handle that is not ordered before
//! the slot's next draft fails the test, as does a waiting `alloc` that is never woken (a
//! deadlock). The scenarios use the very methods the handles of `pool.rs` call; the hand-over
//! of a published message to a subscriber goes through a lock, as through its queue.

use std::sync::Arc;

use loom::sync::Mutex;
use loom::thread;

use super::{Pool, Slot};

type OnePool = Pool<[Slot<u32>; 1]>;

/// Takes a slot (spinning until one is free, as a real-time publisher retrying would) and
/// writes `value` into it.
fn draft(pool: &OnePool, value: u32) -> &Slot<u32> {
    let pool: &Pool<[Slot<u32>]> = pool;
    loop {
        if let Some(slot) = pool.take(None) {
            // SAFETY: `take` made the slot *writing* for this caller alone.
            unsafe { *slot.write_ptr() = value };
            return slot;
        }
        thread::yield_now();
    }
}

/// Waits until the "queue" holds a message, takes it.
fn receive(queue: &Mutex<bool>) {
    loop {
        let mut q = queue.lock().unwrap();
        if *q {
            *q = false;
            return;
        }
        drop(q);
        thread::yield_now();
    }
}

/// Drops `n` handles; the last frees the slot and wakes a waiting `alloc`.
fn drop_handles(pool: &OnePool, slot: &Slot<u32>, n: u32) -> bool {
    let pool: &Pool<[Slot<u32>]> = pool;
    let last = slot.release(n);
    if last {
        pool.freed();
    }
    last
}

#[test]
fn a_read_through_a_handle_happens_before_the_slots_next_draft() {
    loom::model(|| {
        let pool = Arc::new(OnePool::new(0));
        let queue = Arc::new(Mutex::new(false));
        let subscriber = {
            let (pool, queue) = (pool.clone(), queue.clone());
            thread::spawn(move || {
                receive(&queue);
                let slot = &pool.slots[0];
                // SAFETY: the handle keeps the slot *shared* until it is dropped below.
                let seen = unsafe { *slot.read_ptr() };
                assert_eq!(seen, 1, "the subscriber reads what the publisher wrote");
                assert!(drop_handles(&pool, slot, 1));
            })
        };
        let slot = draft(&pool, 1);
        assert!(!slot.publish(1));
        *queue.lock().unwrap() = true;
        // The next draft reuses the one slot: its write must come after the subscriber's read.
        let next = draft(&pool, 2);
        assert!(core::ptr::eq(next, slot));
        subscriber.join().unwrap();
    });
}

#[test]
fn of_two_handles_dropped_at_once_exactly_one_frees_the_slot() {
    loom::model(|| {
        let pool = Arc::new(OnePool::new(0));
        let slot = draft(&pool, 7);
        assert!(!slot.publish(1));
        slot.add_handle(); // a clone: two handles now
        let other = {
            let pool = pool.clone();
            thread::spawn(move || {
                let slot = &pool.slots[0];
                // SAFETY: this thread's handle keeps the slot shared until it drops it.
                assert_eq!(unsafe { *slot.read_ptr() }, 7);
                drop_handles(&pool, slot, 1)
            })
        };
        // SAFETY: as above, for this thread's handle.
        assert_eq!(unsafe { *slot.read_ptr() }, 7);
        let mine = drop_handles(&pool, slot, 1);
        let theirs = other.join().unwrap();
        assert!(mine != theirs, "exactly one handle was the last");
        // Free again, and both reads come before the next draft's write.
        draft(&pool, 8);
    });
}

/// A waker that records that it was woken.
struct Woken(loom::sync::atomic::AtomicBool);

impl std::task::Wake for Woken {
    fn wake(self: Arc<Self>) {
        self.0.store(true, loom::sync::atomic::Ordering::Relaxed);
    }
}

/// `alloc`'s poll on the empty one-slot pool while another thread frees the slot with
/// `free_it`: afterwards the poll either got the slot or its waker was woken (a lost wake-up
/// would leave the publisher waiting for ever with a free slot).
fn alloc_races_with(free_it: fn(&Pool<[Slot<u32>]>)) {
    loom::model(move || {
        let pool = Arc::new(OnePool::new(0));
        draft(&pool, 3);
        let freer = {
            let pool = pool.clone();
            thread::spawn(move || free_it(&*pool))
        };
        let woken = Arc::new(Woken(loom::sync::atomic::AtomicBool::new(false)));
        let waker = std::task::Waker::from(woken.clone());
        let p: &Pool<[Slot<u32>]> = &*pool;
        let got = p.take(Some(&mut std::task::Context::from_waker(&waker))).is_some();
        freer.join().unwrap();
        assert!(
            got || woken.0.load(loom::sync::atomic::Ordering::Relaxed),
            "the slot was freed, but the waiting alloc neither got it nor was woken"
        );
    });
}

#[test]
fn a_draft_dropped_while_alloc_registers_its_waker_is_never_lost() {
    alloc_races_with(|pool| {
        pool.slots[0].abandon();
        pool.freed();
    });
}

#[test]
fn a_message_published_to_nobody_is_never_lost_for_a_waiting_alloc() {
    alloc_races_with(|pool| {
        if pool.slots[0].publish(0) {
            pool.freed();
        }
    });
}

#[test]
fn the_last_handle_dropped_while_alloc_registers_its_waker_is_never_lost() {
    alloc_races_with(|pool| {
        let slot = &pool.slots[0];
        assert!(!slot.publish(1));
        if slot.release(1) {
            pool.freed();
        }
    });
}

#[test]
fn a_dropped_drafts_writes_happen_before_the_next_drafts() {
    loom::model(|| {
        let pool = Arc::new(OnePool::new(0));
        let abandon = |pool: &OnePool, value| {
            let slot = draft(pool, value);
            slot.abandon();
            let pool: &Pool<[Slot<u32>]> = pool;
            pool.freed();
        };
        let other = {
            let pool = pool.clone();
            thread::spawn(move || abandon(&pool, 5))
        };
        abandon(&pool, 6);
        other.join().unwrap();
    });
}
