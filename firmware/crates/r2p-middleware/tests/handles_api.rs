//! What application code sees of handles and subscribers beyond the data: `Debug` shows the
//! message (for logs and assertions), a subscriber says whether messages wait.

use r2p_middleware::{Class, Publisher, Subscriber, Topic};

#[test]
fn handles_print_as_their_message_and_subscribers_say_whether_messages_wait() {
    static T: Topic<'static, (u8, i16), 4, 1> = Topic::new("t", (0, 0));
    static P: Publisher<'static, (u8, i16)> = Publisher::new(&T, Class::NonRealTime);
    static S: Subscriber<'static, (u8, i16), 2> = Subscriber::new();
    T.subscribe(&S).unwrap();
    assert!(S.is_empty());
    let mut draft = P.try_alloc().unwrap();
    *draft = (7, -3);
    assert_eq!(format!("{draft:?}"), "MsgMut((7, -3))");
    P.publish(draft);
    assert!(!S.is_empty(), "one message waits");
    assert_eq!(S.len(), 1);
    let m = S.try_recv().unwrap();
    assert_eq!(format!("{m:?}"), "Msg((7, -3))");
    assert!(S.is_empty());
}
