//! Host-only property tests: random interleavings of publish, receive, clone and drop across
//! 1–8 subscribers with random queue lengths, checked against a model of the pool.

use std::boxed::Box;
use std::collections::{BTreeSet, VecDeque};
use std::vec;
use std::vec::Vec;

use proptest::prelude::*;

use crate::{pool_size, Class, Msg, MsgMut, Publisher, Sink, Subscriber, Topic, TopicInfo};

const SLOTS: usize = 80; // ≥ pool_size(&[8; 8], 1) = 73
const SUBS: usize = 8;

type T = Topic<'static, u32, SLOTS, SUBS>;

/// A subscriber of any queue length, behind one type.
trait AnySub<M = u32>: Sync {
    fn try_recv(&self) -> Option<Msg<'static, M>>;
    fn missed(&self) -> u32;
    fn len(&self) -> usize;
    fn sink(&'static self) -> &'static dyn Sink<'static, M>;
}

impl<M: Send + Sync, const Q: usize> AnySub<M> for Subscriber<'static, M, Q> {
    fn try_recv(&self) -> Option<Msg<'static, M>> {
        Subscriber::try_recv(self)
    }
    fn missed(&self) -> u32 {
        Subscriber::missed(self)
    }
    fn len(&self) -> usize {
        Subscriber::len(self)
    }
    fn sink(&'static self) -> &'static dyn Sink<'static, M> {
        self
    }
}

fn leak<X>(x: X) -> &'static X {
    Box::leak(Box::new(x))
}

fn subscriber(q: usize) -> &'static dyn AnySub {
    match q {
        1 => leak(Subscriber::<'static, u32, 1>::new()),
        2 => leak(Subscriber::<'static, u32, 2>::new()),
        3 => leak(Subscriber::<'static, u32, 3>::new()),
        4 => leak(Subscriber::<'static, u32, 4>::new()),
        5 => leak(Subscriber::<'static, u32, 5>::new()),
        6 => leak(Subscriber::<'static, u32, 6>::new()),
        7 => leak(Subscriber::<'static, u32, 7>::new()),
        8 => leak(Subscriber::<'static, u32, 8>::new()),
        _ => unreachable!(),
    }
}

#[derive(Clone, Debug)]
enum Op {
    Publish,
    Recv(usize),
    DropHeld(usize, usize),
    CloneHeld(usize),
    Draft,
    DropDraft,
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        4 => Just(Op::Publish),
        4 => any::<usize>().prop_map(Op::Recv),
        3 => (any::<usize>(), any::<usize>()).prop_map(|(s, k)| Op::DropHeld(s, k)),
        1 => any::<usize>().prop_map(Op::CloneHeld),
        1 => Just(Op::Draft),
        1 => Just(Op::DropDraft),
    ]
}

struct Model {
    q: Vec<usize>,
    queued: Vec<VecDeque<u32>>,
    held: Vec<Vec<Msg<'static, u32>>>,
    missed: Vec<u32>,
    drafts: Vec<MsgMut<'static, u32>>,
}

impl Model {
    /// Slots in use: distinct messages queued or held, plus drafts (the ballast included).
    fn live(&self, ballast: usize) -> usize {
        let mut seqs = BTreeSet::new();
        for q in &self.queued {
            seqs.extend(q.iter().copied());
        }
        for h in &self.held {
            seqs.extend(h.iter().map(|m| **m));
        }
        seqs.len() + self.drafts.len() + ballast
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn random_interleavings_never_lose_reorder_or_block(
        queue_lens in proptest::collection::vec(1usize..=8, 1..=8),
        ops in proptest::collection::vec(op(), 0..200),
    ) {
        let topic: &'static T = leak(Topic::new("prop", 0));
        let publisher: &'static Publisher<'static, u32> =
            leak(Publisher::new(topic, Class::SyncRealTime { period_us: 1000 }));
        topic.advertise(publisher).unwrap();
        let subs: Vec<&'static dyn AnySub> = queue_lens.iter().map(|&q| subscriber(q)).collect();
        for s in &subs {
            topic.subscribe(s.sink()).unwrap();
        }
        // Take the slots beyond the sizing rule out of play, so the pool is exactly
        // pool_size(queue_lens, 1) and the rule itself is under test.
        let rule = pool_size(&queue_lens, 1);
        prop_assert_eq!(topic.reserved_slots(), rule);
        let ballast: Vec<_> = (0..SLOTS - rule).map(|_| publisher.try_alloc().unwrap()).collect();

        let n = subs.len();
        let mut m = Model {
            q: queue_lens.clone(),
            queued: vec![VecDeque::new(); n],
            held: (0..n).map(|_| Vec::new()).collect(),
            missed: vec![0; n],
            drafts: Vec::new(),
        };
        let mut seq = 0u32;
        let mut published = 0u32;
        for op in ops {
            let free_before = SLOTS - m.live(ballast.len());
            prop_assert_eq!(topic.free_slots(), free_before);
            match op {
                Op::Publish | Op::Draft => {
                    let within_rule = m.drafts.is_empty() && m.held.iter().all(|h| h.len() <= 1);
                    let draft = publisher.try_alloc();
                    prop_assert_eq!(draft.is_some(), free_before > 0);
                    if within_rule {
                        prop_assert!(draft.is_some(), "pool empty although the sizing rule holds");
                    }
                    let Some(mut d) = draft else { continue };
                    if let Op::Draft = op {
                        m.drafts.push(d);
                        continue;
                    }
                    seq += 1;
                    *d = seq;
                    let delivery = publisher.publish(d);
                    published += 1;
                    let mut expect = (0, 0);
                    for i in 0..n {
                        if m.queued[i].len() < m.q[i] {
                            m.queued[i].push_back(seq);
                            expect.0 += 1;
                        } else {
                            m.missed[i] += 1;
                            expect.1 += 1;
                        }
                    }
                    prop_assert_eq!((delivery.delivered, delivery.missed), expect);
                }
                Op::Recv(i) => {
                    let i = i % n;
                    let got = subs[i].try_recv();
                    prop_assert_eq!(got.as_deref().copied(), m.queued[i].pop_front());
                    if let Some(msg) = got {
                        m.held[i].push(msg);
                    }
                }
                Op::DropHeld(i, k) => {
                    let h = &mut m.held[i % n];
                    if !h.is_empty() {
                        let len = h.len();
                        h.remove(k % len);
                    }
                }
                Op::CloneHeld(i) => {
                    let h = &mut m.held[i % n];
                    if let Some(c) = h.last().cloned() {
                        h.push(c);
                    }
                }
                Op::DropDraft => {
                    m.drafts.pop();
                }
            }
            for (i, s) in subs.iter().enumerate() {
                prop_assert_eq!(s.missed(), m.missed[i]);
                prop_assert_eq!(s.len(), m.queued[i].len());
            }
        }
        prop_assert_eq!(publisher.stats().published, published);

        // Everything dropped or drained: every slot is back, none twice (a double free panics).
        drop(m.held);
        drop(m.drafts);
        drop(ballast);
        for (i, s) in subs.iter().enumerate() {
            // Publication order, exactly the messages the model says were queued.
            while let Some(msg) = s.try_recv() {
                prop_assert_eq!(Some(*msg), m.queued[i].pop_front(), "subscriber {}", i);
            }
            prop_assert!(m.queued[i].is_empty());
        }
        prop_assert_eq!(topic.free_slots(), SLOTS);
        // And the pool still works: every slot can be drafted again.
        let all: Vec<_> = (0..SLOTS).map(|_| publisher.try_alloc()).collect();
        prop_assert!(all.iter().all(Option::is_some));
        prop_assert!(publisher.try_alloc().is_none());
    }
}

/// Real concurrency on the host: two publishers and three consuming threads on one topic. The
/// slot counts are atomics touched from every thread at once; nothing may be lost, freed twice
/// or reordered per publisher, and every slot is back at the end.
#[test]
fn threads_publishing_and_receiving_at_once_lose_no_slot() {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::thread;

    static TOPIC: Topic<'static, (u32, u32), { pool_size(&[2, 3, 4], 2) }, 3> =
        Topic::new("threads", (0, 0));
    static P: [Publisher<'static, (u32, u32)>; 2] =
        [Publisher::new(&TOPIC, Class::NonRealTime), Publisher::new(&TOPIC, Class::NonRealTime)];
    static A: Subscriber<'static, (u32, u32), 2> = Subscriber::new();
    static B: Subscriber<'static, (u32, u32), 3> = Subscriber::new();
    static C: Subscriber<'static, (u32, u32), 4> = Subscriber::new();
    static DONE: AtomicBool = AtomicBool::new(false);
    const N: u32 = 20_000;
    for p in &P {
        TOPIC.advertise(p).unwrap();
    }
    let subs: [&'static dyn AnySub<(u32, u32)>; 3] = [&A, &B, &C];
    for s in subs {
        TOPIC.subscribe(s.sink()).unwrap();
    }

    let consumers: Vec<_> = subs
        .into_iter()
        .map(|s| {
            thread::spawn(move || {
                let mut last = [None::<u32>; 2];
                let mut got = 0u32;
                let mut kept = None; // one message in hand, as the sizing rule allows
                loop {
                    let done = DONE.load(Ordering::Acquire);
                    match s.try_recv() {
                        Some(m) => {
                            let (p, seq) = *m;
                            let p = p as usize;
                            assert!(last[p].is_none_or(|l| l < seq), "publisher {p} reordered");
                            last[p] = Some(seq);
                            got += 1;
                            if seq % 3 == 0 {
                                kept = Some(m.clone()); // a clone replacing the held one
                            }
                        }
                        None if done => break,
                        None => thread::yield_now(),
                    }
                }
                drop(kept);
                got
            })
        })
        .collect();
    let publishers: Vec<_> = (0..2u32)
        .map(|id| {
            thread::spawn(move || {
                let p = &P[id as usize];
                let mut delivered = 0;
                for seq in 0..N {
                    let mut m = embassy_futures::block_on(p.alloc());
                    *m = (id, seq);
                    delivered += p.publish(m).delivered as u32;
                }
                delivered
            })
        })
        .collect();
    let delivered: u32 = publishers.into_iter().map(|t| t.join().unwrap()).sum();
    DONE.store(true, Ordering::Release);
    let received: u32 = consumers.into_iter().map(|t| t.join().unwrap()).sum();
    assert_eq!(received, delivered, "every accepted handle reached its subscriber");
    let missed: u32 = P.iter().map(|p| p.stats().missed_deliveries).sum();
    assert_eq!(delivered + missed, 2 * N * 3);
    assert_eq!(missed, A.missed() + B.missed() + C.missed());
    assert_eq!(TOPIC.free_slots(), TOPIC.capacity(), "every slot came back");
}
