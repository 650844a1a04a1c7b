//! The limits of `export` and `import` are inclusive (docs/middleware.md, "Remote topics"): a
//! message of exactly the largest size goes through (one frame for HRT, the node's buffer
//! otherwise), one byte more is refused, and an HRT period must be a whole power-of-two
//! number of cycles; a topic name has 1 to 32 characters.

use r2p_middleware::{Class, Publisher, Topic};

use crate::node::{NodeConfig, NodeError};
use crate::testbus::{uid, TestNode};
use crate::{NoParams, RemotePublisher, RemoteSubscriber};

/// The test node's encoding buffer (`TestNode`'s `BUF`).
const BUF: usize = 64;

fn node() -> TestNode<'static> {
    TestNode::new(NodeConfig::new(uid(1), "a"), &NoParams).unwrap()
}

#[test]
fn the_largest_messages_are_taken_and_one_byte_more_is_refused() {
    static HRT8: Topic<'static, [u8; 8], 2, 1> = Topic::new("hrt8", [0; 8]);
    static HRT8_PUB: Publisher<'static, [u8; 8]> =
        Publisher::new(&HRT8, Class::SyncRealTime { period_us: 20_000 });
    static HRT8_OUT: RemoteSubscriber<'static, [u8; 8], 1> = RemoteSubscriber::new(&HRT8_PUB);
    static FULL: Topic<'static, [u8; BUF], 2, 1> = Topic::new("full", [0; BUF]);
    static FULL_PUB: Publisher<'static, [u8; BUF]> = Publisher::new(&FULL, Class::NonRealTime);
    static FULL_OUT: RemoteSubscriber<'static, [u8; BUF], 1> = RemoteSubscriber::new(&FULL_PUB);
    static FULL_IN: RemotePublisher<'static, [u8; BUF]> = RemotePublisher::new(&FULL_PUB, &FULL);
    static OVER: Topic<'static, [u8; BUF + 1], 2, 1> = Topic::new("over", [0; BUF + 1]);
    static OVER_PUB: Publisher<'static, [u8; BUF + 1]> = Publisher::new(&OVER, Class::NonRealTime);
    static OVER_IN: RemotePublisher<'static, [u8; BUF + 1]> =
        RemotePublisher::new(&OVER_PUB, &OVER);

    let mut a = node();
    assert_eq!(a.export(&HRT8_OUT), Ok(1), "an HRT message of one full frame");
    assert_eq!(a.export(&FULL_OUT), Ok(2), "a message of the whole buffer");
    let mut b = node();
    assert_eq!(b.import(&FULL_IN), Ok(0), "a message of the whole buffer");
    assert_eq!(b.import(&OVER_IN), Err(NodeError::TooLarge { size: BUF + 1, max: BUF }));
}

#[test]
fn an_hrt_period_between_powers_of_two_of_the_cycle_is_refused() {
    // 1.5 cycles of the default 10 ms: not whole, although its whole part (1) is a power of two.
    static T: Topic<'static, u32, 2, 1> = Topic::new("setpoint", 0);
    static P: Publisher<'static, u32> =
        Publisher::new(&T, Class::SyncRealTime { period_us: 15_000 });
    static OUT: RemoteSubscriber<'static, u32, 1> = RemoteSubscriber::new(&P);
    static P2: Publisher<'static, u32> =
        Publisher::new(&T, Class::SyncRealTime { period_us: 20_000 });
    static OUT2: RemoteSubscriber<'static, u32, 1> = RemoteSubscriber::new(&P2);
    let mut a = node();
    assert_eq!(a.export(&OUT), Err(NodeError::HrtPeriod { period_us: 15_000, cycle_us: 10_000 }));
    assert_eq!(a.export(&OUT2), Ok(1), "two cycles");
}

#[test]
fn topic_names_of_one_to_32_characters_are_taken() {
    const LONGEST: &str = "robot/base/wheel_left/speed_rpm1"; // 32
    const TOO_LONG: &str = "robot/base/wheel_left/speed_rpm12"; // 33
    static A: Topic<'static, u32, 2, 1> = Topic::new(LONGEST, 0);
    static A_PUB: Publisher<'static, u32> = Publisher::new(&A, Class::NonRealTime);
    static A_OUT: RemoteSubscriber<'static, u32, 1> = RemoteSubscriber::new(&A_PUB);
    static A_IN: RemotePublisher<'static, u32> = RemotePublisher::new(&A_PUB, &A);
    static B: Topic<'static, u32, 2, 1> = Topic::new(TOO_LONG, 0);
    static B_PUB: Publisher<'static, u32> = Publisher::new(&B, Class::NonRealTime);
    static B_OUT: RemoteSubscriber<'static, u32, 1> = RemoteSubscriber::new(&B_PUB);
    static B_IN: RemotePublisher<'static, u32> = RemotePublisher::new(&B_PUB, &B);
    static E: Topic<'static, u32, 2, 1> = Topic::new("", 0);
    static E_PUB: Publisher<'static, u32> = Publisher::new(&E, Class::NonRealTime);
    static E_OUT: RemoteSubscriber<'static, u32, 1> = RemoteSubscriber::new(&E_PUB);
    assert_eq!((LONGEST.len(), TOO_LONG.len()), (32, 33));
    let mut a = node();
    assert_eq!(a.export(&A_OUT), Ok(1));
    assert_eq!(a.export(&B_OUT), Err(NodeError::BadTopicName));
    assert_eq!(a.export(&E_OUT), Err(NodeError::BadTopicName));
    let mut b = node();
    assert_eq!(b.import(&A_IN), Ok(0));
    assert_eq!(b.import(&B_IN), Err(NodeError::BadTopicName));
}
