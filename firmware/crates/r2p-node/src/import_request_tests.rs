//! An import asks a publisher once per advertisement it acts on (docs/middleware.md, "Remote
//! topics"): the same advertisement heard again while the request is pending (advertisements
//! repeat for late joiners) does not send a second SUBSCRIBE_REQUEST; only the request timeout
//! does.

use r2p_management::message::{BusClass, Message};
use r2p_middleware::{pool_size, Class, Publisher, Topic};
use rtcan::controller::CanController;
use rtcan::{Expect, Reassembler};

use crate::hrt_stream_tests::inject;
use crate::node::NodeConfig;
use crate::testbus::{run, uid, Bus, TestNode};
use crate::{NoParams, RemotePublisher, Wire};

#[test]
fn a_repeated_advertisement_does_not_repeat_a_pending_subscription_request() {
    static L: Topic<'static, u32, { pool_size(&[1], 1) }, 1> = Topic::new("speed", 0);
    static LP: Publisher<'static, u32> = Publisher::new(&L, Class::NonRealTime);
    static IN: RemotePublisher<'static, u32> = RemotePublisher::new(&LP, &L);
    let bus = Bus::<2>::new();
    let config = NodeConfig {
        heartbeat_period_us: 10_000,
        request_timeout_us: 30_000,
        ..NodeConfig::new(uid(1), "control")
    };
    let mut b = TestNode::new(config, &NoParams).unwrap();
    b.import(&IN).unwrap();
    run(&bus, &mut [&mut b], 5_000);
    // A publisher (node 0x40, not on the bus otherwise) advertises `speed` three times within
    // the request timeout; it never answers.
    let ad = Message::Advertise {
        topic: heapless::String::try_from("speed").unwrap(),
        type_hash: <u32 as Wire>::TYPE_HASH,
        size: <u32 as Wire>::SIZE as u16,
        index: 1,
        class: BusClass::Nrt,
    };
    let mut requests = 0;
    let mut r: Reassembler<4, 64> = Reassembler::new(1_000_000);
    for _ in 0..3 {
        inject(&bus, 0x40, &ad);
        let until = bus.now.get() + 5_000;
        run(&bus, &mut [&mut b], until);
        let mut port = bus.port(1);
        while let Some(rx) = port.try_receive() {
            if let Some(m) = r.accept(&rx.frame, rx.at, Expect::Any) {
                if matches!(Message::decode(m.data), Ok(Message::SubscribeRequest { .. })) {
                    requests += 1;
                }
            }
        }
    }
    assert_eq!(requests, 1, "one request for one publisher's advertisement");
}
