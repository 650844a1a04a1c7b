//! The sizing rule's promise (docs/middleware.md, `pool_size`): a topic accepts subscribers and
//! publishers while the pool covers what they may hold, to the last slot, and refuses the one
//! that would need a single slot more, saying how many it would need.

use r2p_middleware::{pool_size, Class, Error, Publisher, Subscriber, Topic, TopicInfo};

#[test]
fn a_pool_of_exactly_the_rules_size_takes_everyone_and_one_slot_short_refuses() {
    // Queues of 3 and 1 and one publisher: 4 + 2 + 1 = 7 slots.
    static EXACT: Topic<'static, u32, { pool_size(&[3, 1], 1) }, 2> = Topic::new("exact", 0);
    static A: Subscriber<'static, u32, 3> = Subscriber::new();
    static B: Subscriber<'static, u32, 1> = Subscriber::new();
    static P: Publisher<'static, u32> = Publisher::new(&EXACT, Class::NonRealTime);
    assert_eq!(EXACT.capacity(), 7);
    EXACT.subscribe(&A).unwrap();
    EXACT.subscribe(&B).unwrap();
    EXACT.advertise(&P).unwrap();
    assert_eq!(EXACT.reserved_slots(), 7, "every slot promised, none over");

    // One slot short: the subscriber that needs 2 more than the 5 left is refused (needs 6 of 5
    // for the queue of 1, 7 of 6 for the publisher).
    static SHORT: Topic<'static, u32, 6, 2> = Topic::new("short", 0);
    static C: Subscriber<'static, u32, 3> = Subscriber::new();
    static D: Subscriber<'static, u32, 1> = Subscriber::new();
    static Q: Publisher<'static, u32> = Publisher::new(&SHORT, Class::NonRealTime);
    SHORT.subscribe(&C).unwrap();
    SHORT.subscribe(&D).unwrap();
    assert_eq!(SHORT.advertise(&Q), Err(Error::PoolTooSmall { needed: 7, capacity: 6 }));
    assert_eq!(SHORT.reserved_slots(), 6, "the refusal reserved nothing");

    static SHORT2: Topic<'static, u32, 5, 2> = Topic::new("short2", 0);
    static E: Subscriber<'static, u32, 3> = Subscriber::new();
    static F: Subscriber<'static, u32, 1> = Subscriber::new();
    SHORT2.subscribe(&E).unwrap();
    assert_eq!(SHORT2.subscribe(&F), Err(Error::PoolTooSmall { needed: 6, capacity: 5 }));
    assert_eq!((SHORT2.subscriber_count(), SHORT2.reserved_slots()), (1, 4));
}
