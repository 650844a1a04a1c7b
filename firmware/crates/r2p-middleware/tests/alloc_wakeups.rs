//! A non-real-time publisher waiting in `alloc` on an empty pool is woken by every way a slot
//! comes back (docs/middleware.md): a message published to nobody, a draft dropped, the last
//! handle of a message dropped. A missed wake-up would leave it waiting for ever.

use core::future::Future;
use core::pin::{pin, Pin};
use core::task::{Context, Poll};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::task::{Wake, Waker};

use r2p_middleware::{Class, Publisher, Subscriber, Topic, TopicInfo};

/// An executor's view of a waiting task: its future and whether its waker was woken (an
/// executor polls a task again only then).
struct Task {
    woken: Arc<Flag>,
    waker: Waker,
}

struct Flag(AtomicBool);

impl Wake for Flag {
    fn wake(self: Arc<Self>) {
        self.0.store(true, Ordering::SeqCst);
    }
}

impl Task {
    fn new() -> Self {
        let woken = Arc::new(Flag(AtomicBool::new(false)));
        Task { waker: Waker::from(woken.clone()), woken }
    }

    fn poll<F: Future>(&self, f: Pin<&mut F>) -> Poll<F::Output> {
        self.woken.0.store(false, Ordering::SeqCst);
        f.poll(&mut Context::from_waker(&self.waker))
    }

    fn woken(&self) -> bool {
        self.woken.0.load(Ordering::SeqCst)
    }
}

const NRT: Class = Class::NonRealTime;

#[test]
fn publishing_to_no_subscriber_wakes_a_waiting_alloc() {
    // Nobody subscribed yet (a topic whose subscribers have not started): every publication
    // frees its slot at once and must hand it to the publisher that waits.
    static T: Topic<'static, u32, 2, 1> = Topic::new("t", 0);
    static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
    let held = P.try_alloc().unwrap();
    let mut last = P.try_alloc().unwrap();
    *last = 9;
    let task = Task::new();
    let mut waiting = pin!(P.alloc());
    assert!(task.poll(waiting.as_mut()).is_pending(), "the pool is empty");
    assert_eq!(P.publish(last).delivered, 0);
    assert!(task.woken(), "the publication to nobody woke the waiting alloc");
    match task.poll(waiting.as_mut()) {
        Poll::Ready(m) => assert_eq!(*m, 9, "the waiting alloc got the slot just published"),
        Poll::Pending => panic!("alloc still waiting after a publication to nobody freed a slot"),
    }
    drop(held);
}

#[test]
fn dropping_a_draft_wakes_a_waiting_alloc() {
    static T: Topic<'static, u32, 1, 1> = Topic::new("t", 0);
    static P: Publisher<'static, u32> = Publisher::new(&T, NRT);
    let draft = P.try_alloc().unwrap();
    let task = Task::new();
    let mut waiting = pin!(P.alloc());
    assert!(task.poll(waiting.as_mut()).is_pending());
    drop(draft);
    assert!(task.woken(), "the dropped draft woke the waiting alloc");
    assert!(task.poll(waiting.as_mut()).is_ready(), "the dropped draft's slot went to alloc");
}

#[test]
fn the_last_handle_dropped_wakes_a_waiting_alloc() {
    // Not advertised, so the drafts may take every slot the subscribers leave.
    static T2: Topic<'static, u32, 4, 2> = Topic::new("t", 0);
    static P2: Publisher<'static, u32> = Publisher::new(&T2, NRT);
    static A: Subscriber<'static, u32, 1> = Subscriber::new();
    static B: Subscriber<'static, u32, 1> = Subscriber::new();
    T2.subscribe(&A).unwrap();
    T2.subscribe(&B).unwrap();
    P2.publish_with(|m| *m = 1).unwrap();
    let drafts = [P2.try_alloc().unwrap(), P2.try_alloc().unwrap(), P2.try_alloc().unwrap()];
    assert_eq!(T2.free_slots(), 0);
    let task = Task::new();
    let mut waiting = pin!(P2.alloc());
    assert!(task.poll(waiting.as_mut()).is_pending());
    drop(A.try_recv().unwrap());
    assert!(!task.woken(), "B still holds the message: nothing to wake for");
    drop(B.try_recv().unwrap());
    assert!(task.woken(), "the last handle woke the waiting alloc");
    assert!(task.poll(waiting.as_mut()).is_ready(), "the last handle freed the slot for alloc");
    drop(drafts);
}
