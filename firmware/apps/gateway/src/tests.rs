//! The gateway's application on the host: the server over an in-memory stream, the bus tap on
//! a scripted controller, the status and the LEDs, the parameters.

use std::boxed::Box;
use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;
use std::string::String;
use std::vec::Vec;

use core::convert::Infallible;
use core::future::{poll_fn, Future};
use core::sync::atomic::Ordering::Relaxed;
use core::task::Poll;

use embassy_futures::block_on;
use embassy_futures::join::join;
use embassy_futures::yield_now;
use r2p_management::message::Value;
use r2p_middleware::{Subscriber, TopicInfo};
use r2p_module::leds::Status;
use r2p_node::{Node, ParamStore, RamParams};
use r2p_socketcand::CanFrame;
use rtcan::controller::{
    BusState, CanController, ErrorCounters, Filter, Received, StagedFrame, TxError, TxMode,
    TxOutcome, TxResult,
};
use rtcan::Frame;

use crate::endpoints::{SPARE_QUEUE, STATUS_TOPIC};
use crate::link::{LinkFrame, BUS, MAX_CLIENTS};
use crate::params::{self, Net};
use crate::server::{serve, Config, Ended};
use crate::{node_config, App, BusLink, BusTap, Endpoints, NetState, Sample};

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

// ---- an in-memory TCP connection ----

#[derive(Default)]
struct Wire {
    to_server: VecDeque<u8>,
    from_server: Vec<u8>,
    closed: bool,
}

/// The server's end of a connection; the test holds the other through the `Rc`.
struct Pipe(Rc<RefCell<Wire>>);

impl embedded_io_async::ErrorType for Pipe {
    type Error = Infallible;
}

impl embedded_io_async::Read for Pipe {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        poll_fn(|_| {
            let mut w = self.0.borrow_mut();
            if w.to_server.is_empty() {
                return if w.closed { Poll::Ready(Ok(0)) } else { Poll::Pending };
            }
            let n = buf.len().min(w.to_server.len());
            for b in buf.iter_mut().take(n) {
                *b = w.to_server.pop_front().unwrap();
            }
            Poll::Ready(Ok(n))
        })
        .await
    }
}

impl embedded_io_async::Write for Pipe {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.0.borrow_mut().from_server.extend_from_slice(buf);
        Ok(buf.len())
    }

    async fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// A timer that returns at once (the settle pause is not what these tests look at).
struct NoDelay;

impl embedded_hal_async::delay::DelayNs for NoDelay {
    async fn delay_ns(&mut self, _ns: u32) {}
}

/// The test's end of a connection.
#[derive(Clone)]
struct Client(Rc<RefCell<Wire>>);

impl Client {
    fn say(&self, text: &str) {
        self.0.borrow_mut().to_server.extend(text.bytes());
    }

    fn close(&self) {
        self.0.borrow_mut().closed = true;
    }

    /// The next message from the server, waiting (yielding to the server) for it.
    async fn next(&self) -> String {
        for _ in 0..10_000 {
            {
                let mut w = self.0.borrow_mut();
                if let Some(end) = w.from_server.iter().position(|&b| b == b'>') {
                    let msg: Vec<u8> = w.from_server.drain(..=end).collect();
                    return String::from_utf8(msg).unwrap().trim().into();
                }
            }
            yield_now().await;
        }
        panic!("no message from the server")
    }

    /// Nothing more from the server after letting it run a while.
    async fn nothing_more(&self) {
        for _ in 0..200 {
            yield_now().await;
        }
        let w = self.0.borrow();
        assert!(w.from_server.is_empty(), "{:?}", String::from_utf8_lossy(&w.from_server));
    }
}

const CONFIG: Config<'static> = Config { channel: "vcan0" };

/// Runs a server session on `link` against `script`, which drives the client's end.
fn session<F: Future<Output = ()>>(link: &BusLink, script: impl FnOnce(Client) -> F) -> Ended {
    let wire = Rc::new(RefCell::new(Wire::default()));
    let client = Client(wire.clone());
    let mut pipe = Pipe(wire);
    let done = client.clone();
    let (ended, ()) = block_on(join(serve(&mut pipe, link, &CONFIG, &mut NoDelay), async move {
        script(done.clone()).await;
        done.close();
    }));
    ended.unwrap()
}

fn ext(id: u32, data: &[u8]) -> CanFrame {
    CanFrame::extended(id, data).unwrap()
}

#[test]
fn a_raw_client_gets_the_bus_frames_as_socketcand_writes_them() {
    let link: &'static BusLink = leak(BusLink::new());
    let ended = session(link, |c| async move {
        assert_eq!(c.next().await, "< hi >");
        c.say("< open vcan0 >");
        assert_eq!(c.next().await, "< ok >");
        c.say("< rawmode >");
        assert_eq!(c.next().await, "< ok >");
        link.publish(LinkFrame {
            frame: ext(0x1234_5678, &[0xDE, 0xAD]),
            at_us: 1_500_002,
            from: BUS,
        });
        assert_eq!(c.next().await, "< frame 12345678 1.500002 DEAD >");
        link.publish(LinkFrame { frame: ext(0x1F, &[]), at_us: 3, from: BUS });
        assert_eq!(c.next().await, "< frame 0000001F 0.000003  >");
    });
    assert_eq!(ended, Ended::Closed);
    assert_eq!(link.stats.frames_to_clients.load(Relaxed), 2);
    assert_eq!(link.clients(), 0, "the client's number is free again");
}

#[test]
fn a_clients_frames_go_to_the_bus_and_not_back_to_it() {
    let link: &'static BusLink = leak(BusLink::new());
    session(link, |c| async move {
        c.next().await;
        c.say("< open vcan0 >< rawmode >< send 1FA80003 2 11 0 >");
        assert_eq!(c.next().await, "< ok >");
        assert_eq!(c.next().await, "< ok >");
        c.nothing_more().await;
        let queued = link.next_for_bus().expect("queued for the bus");
        assert_eq!(queued.frame, ext(0x1FA8_0003, &[0x11, 0]));
        // Once sent, the tap publishes it as this client's: not written back to it.
        link.publish(LinkFrame { from: queued.from, ..queued });
        c.nothing_more().await;
    });
}

#[test]
fn bad_input_is_answered_counted_and_the_session_goes_on() {
    let link: &'static BusLink = leak(BusLink::new());
    session(link, |c| async move {
        c.next().await;
        c.say("< send 1 0 >");
        assert_eq!(c.next().await, "< error no bus open >");
        c.say("< open can9 >");
        assert_eq!(c.next().await, "< error could not open bus >");
        c.say("< open vcan0 >");
        assert_eq!(c.next().await, "< ok >");
        c.say("garbage< echo >< send 1 2 3 >< nope >\u{ff}");
        assert_eq!(c.next().await, "< error data outside a message >");
        assert_eq!(c.next().await, "< echo >");
        assert_eq!(c.next().await, "< error usage send with DLC data bytes >");
        assert_eq!(c.next().await, "< error unknown command nope >");
        assert_eq!(c.next().await, "< error data outside a message >");
        c.say("< send 123 1 7 >");
        assert_eq!(
            c.next().await,
            "< error the R2P bus carries 29-bit identifiers only, frame dropped >"
        );
        c.say(&std::format!("<{}", "x".repeat(300)));
        assert_eq!(c.next().await, "< error message too long >");
        c.say("< echo >");
        assert_eq!(c.next().await, "< echo >");
    });
    assert_eq!(link.stats.client_errors.load(Relaxed), 8);
    assert!(link.next_for_bus().is_none(), "nothing reached the bus");
}

#[test]
fn a_full_queue_to_the_bus_refuses_and_says_so() {
    let link: &'static BusLink = leak(BusLink::new());
    session(link, |c| async move {
        c.next().await;
        c.say("< open vcan0 >");
        c.next().await;
        for i in 0..crate::link::FROM_CLIENTS + 1 {
            c.say(&std::format!("< send {:08X} 0 >", 0x1000 + i));
        }
        assert_eq!(c.next().await, "< error queue to the bus full, frame dropped >");
    });
    assert_eq!(link.stats.lost.load(Relaxed), 1);
}

#[test]
fn a_client_that_does_not_read_loses_the_oldest_frames_counted() {
    let link: &'static BusLink = leak(BusLink::new());
    session(link, |c| async move {
        c.next().await;
        c.say("< open vcan0 >< rawmode >");
        c.next().await;
        c.next().await;
        // The bus outpaces the client: more frames than the queue holds before it runs.
        for i in 0..crate::link::TO_CLIENTS as u32 + 10 {
            link.publish(LinkFrame { frame: ext(i, &[]), at_us: 0, from: BUS });
        }
        assert_eq!(c.next().await, "< frame 0000000A 0.000000  >", "the 10 oldest were lost");
    });
    assert_eq!(link.stats.lost.load(Relaxed), 10);
}

#[test]
fn clients_beyond_the_limit_are_told_and_closed() {
    let link: &'static BusLink = leak(BusLink::new());
    let taken: Vec<_> = (0..MAX_CLIENTS).map(|_| link.join().unwrap()).collect();
    assert_eq!(taken, [1, 2, 3, 4]);
    let ended = session(link, |c| async move {
        assert_eq!(c.next().await, "< error too many clients >");
    });
    assert_eq!(ended, Ended::Full);
    link.leave(2);
    assert_eq!(link.join(), Some(2));
}

#[test]
fn the_server_never_panics_on_arbitrary_input() {
    // A cheap deterministic fuzz: byte strings from a small alphabet, in a raw session.
    let alphabet = b"< >sendopraw0F9\xff\n";
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    for _ in 0..300 {
        let link: &'static BusLink = leak(BusLink::new());
        let mut input = String::from("< open vcan0 >");
        for _ in 0..(seed % 200) {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            input.push(alphabet[(seed % alphabet.len() as u64) as usize] as char);
        }
        session(link, |c| async move {
            c.next().await;
            c.say(&input);
            for _ in 0..100 {
                yield_now().await;
            }
        });
    }
}

// ---- the bus tap ----

/// A bxCAN as the tap sees it: three mailboxes whose frames finish when the test says.
#[derive(Default)]
struct Scripted {
    loaded: Vec<Frame>,
    results: VecDeque<TxResult>,
    received: VecDeque<Received>,
    filters: Vec<Filter>,
    /// What the node staged for the transmit interrupt, and how many it loaded since.
    staged: Vec<StagedFrame>,
    staged_in: usize,
}

impl Scripted {
    /// The transmit interrupt loads the staged frames.
    fn load_staged(&mut self) {
        self.loaded.extend(self.staged.iter().map(|s| s.frame));
        self.staged_in = core::mem::take(&mut self.staged).len();
    }

    fn finish(&mut self, outcome: TxOutcome) {
        let f = self.loaded.remove(0);
        self.results
            .push_back(TxResult { start_of_frame: Some(900), ..TxResult::new(f.id(), outcome) });
    }
}

impl CanController for Scripted {
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        if self.loaded.len() == 3 {
            return Err(TxError::MailboxesFull);
        }
        self.loaded.push(*frame);
        Ok(())
    }
    fn set_tx_mode(&mut self, _: TxMode) {}
    fn take_tx_result(&mut self) -> Option<TxResult> {
        self.results.pop_front()
    }
    fn try_receive(&mut self) -> Option<Received> {
        self.received.pop_front()
    }
    fn set_filters(&mut self, filters: &[Filter]) {
        self.filters = filters.to_vec();
    }
    fn abort_pending(&mut self) -> usize {
        0
    }
    fn bus_state(&self) -> BusState {
        BusState::ErrorActive
    }
    fn error_counters(&self) -> ErrorCounters {
        ErrorCounters::default()
    }
    fn stage(&mut self, frames: &[StagedFrame]) {
        self.staged = frames.to_vec();
    }
    fn staged_loaded(&mut self) -> usize {
        core::mem::take(&mut self.staged_in)
    }
}

fn rt(id: u32, data: &[u8]) -> Frame {
    Frame::from_raw(id, data).unwrap()
}

#[test]
fn the_clients_see_what_the_node_receives_and_sends() {
    let link: &'static BusLink = leak(BusLink::new());
    let mut sub = link.subscribe().unwrap();
    let mut tap = BusTap::new(link);
    let mut can = Scripted::default();
    can.received.push_back(Received { frame: rt(0x0123_4567, &[1]), at: 500 });
    let got = tap.run(1000, &mut can, |c| {
        c.set_filters(&[Filter { value: 0x100, mask: 0x1FF }]);
        let r = c.try_receive();
        c.try_transmit(&rt(0x0AAA_0001, &[2])).unwrap();
        r
    });
    assert_eq!(got.map(|r| r.frame), Some(rt(0x0123_4567, &[1])), "the node receives as before");
    assert_eq!(can.filters, [Filter::ACCEPT_ALL], "the clients see every frame");
    let f = sub.try_next_message_pure().unwrap();
    assert_eq!((f.frame, f.at_us, f.from), (ext(0x0123_4567, &[1]), 500, BUS));
    assert!(sub.try_next_message_pure().is_none(), "the node's frame is not sent yet");
    can.finish(TxOutcome::Sent);
    let result = tap.run(1100, &mut can, |c| c.take_tx_result());
    assert_eq!(result.map(|r| (r.id, r.sent())), Some((rt(0x0AAA_0001, &[]).id(), true)));
    let f = sub.try_next_message_pure().unwrap();
    assert_eq!(
        (f.frame, f.at_us, f.from),
        (ext(0x0AAA_0001, &[2]), 900, BUS),
        "stamped at its start of frame"
    );
}

#[test]
fn a_client_frame_waits_for_idle_mailboxes_is_sent_looped_back_and_kept_from_the_node() {
    let link: &'static BusLink = leak(BusLink::new());
    let mut sub = link.subscribe().unwrap();
    let mut tap = BusTap::new(link);
    let mut can = Scripted::default();
    link.send(2, ext(0x1FA8_0003, &[9])).unwrap();
    // The node has a frame in a mailbox: the client's waits.
    tap.run(0, &mut can, |c| c.try_transmit(&rt(0x0AAA_0001, &[])).unwrap());
    assert_eq!(can.loaded, [rt(0x0AAA_0001, &[])]);
    can.finish(TxOutcome::Sent);
    tap.run(100, &mut can, |c| assert!(c.take_tx_result().is_some()));
    assert_eq!(can.loaded, [rt(0x1FA8_0003, &[9])], "loaded once the node's went out");
    can.finish(TxOutcome::Sent);
    let (result, looped) = tap.run(200, &mut can, |c| (c.take_tx_result(), c.try_receive()));
    assert_eq!(result, None, "the client frame's result is not the node's");
    assert_eq!(looped.map(|r| r.frame), Some(rt(0x1FA8_0003, &[9])), "looped back to the node");
    let from: Vec<_> =
        core::iter::from_fn(|| sub.try_next_message_pure()).map(|f| f.from).collect();
    assert_eq!(from, [BUS, 2], "the node's frame, then the client's as the client's");
    assert_eq!(link.stats.frames_from_clients.load(Relaxed), 1);
}

#[test]
fn frames_the_transmit_interrupt_loaded_for_the_node_reach_the_clients_as_the_nodes() {
    let link: &'static BusLink = leak(BusLink::new());
    let mut sub = link.subscribe().unwrap();
    let mut tap = BusTap::new(link);
    let mut can = Scripted::default();
    link.send(2, ext(0x1FA8_0003, &[9])).unwrap();
    let staged = |raw, latest| StagedFrame { frame: rt(raw, &[1]), latest };
    tap.run(0, &mut can, |c| {
        c.try_transmit(&rt(0x0AAA_0001, &[])).unwrap();
        c.stage(&[staged(0x0AAA_0002, 500), staged(0x0AAA_0003, 600)]);
    });
    assert_eq!(can.staged.len(), 2, "handed on to the controller");
    // The node's frame goes out; the interrupt loads the staged ones at once.
    can.finish(TxOutcome::Sent);
    can.load_staged();
    let took = tap.run(100, &mut can, |c| c.staged_loaded());
    assert_eq!(took, 2);
    assert_eq!(can.loaded.len(), 2, "the client's frame waits: the node's are in flight");
    can.finish(TxOutcome::Sent);
    can.finish(TxOutcome::Sent);
    tap.run(200, &mut can, |c| while c.take_tx_result().is_some() {});
    let seen: Vec<_> = core::iter::from_fn(|| sub.try_next_message_pure())
        .map(|f| (f.frame.id(), f.from))
        .collect();
    let node = |raw: u32| (raw, BUS);
    assert_eq!(seen, [node(0x0AAA_0001), node(0x0AAA_0002), node(0x0AAA_0003)]);
    assert_eq!(can.loaded, [rt(0x1FA8_0003, &[9])], "the client's frame once they went");
}

#[test]
fn a_client_frame_that_keeps_losing_arbitration_is_tried_until_it_goes_out() {
    // The lowest-priority NRT frame of a tool loses to every frame of the burst after a sync:
    // more times than any small count of tries (the Triskar2 has 6 frames in that burst).
    let link: &'static BusLink = leak(BusLink::new());
    let mut sub = link.subscribe().unwrap();
    let mut tap = BusTap::new(link);
    let mut can = Scripted::default();
    link.send(1, ext(0x1FA8_0002, &[2])).unwrap();
    link.send(1, ext(0x1FA8_0001, &[1])).unwrap();
    tap.run(0, &mut can, |_| {});
    for t in 1..=10u64 {
        assert_eq!(can.loaded, [rt(0x1FA8_0002, &[2])], "try {t}: the first frame, again");
        let lost = if t % 2 == 0 { TxOutcome::Aborted } else { TxOutcome::LostArbitration };
        can.finish(lost);
        tap.run(t * 1000, &mut can, |c| assert_eq!(c.take_tx_result(), None));
    }
    can.finish(TxOutcome::Sent);
    tap.run(11_000, &mut can, |_| {});
    assert_eq!(can.loaded, [rt(0x1FA8_0001, &[1])], "then the next, in order");
    assert_eq!(link.stats.lost.load(Relaxed), 0);
    assert_eq!(link.stats.frames_from_clients.load(Relaxed), 1);
    let f = sub.try_next_message_pure().unwrap();
    assert_eq!((f.frame, f.from), (ext(0x1FA8_0002, &[2]), 1));
}

#[test]
fn a_client_frame_is_given_up_after_its_patience_or_its_error_tries() {
    let link: &'static BusLink = leak(BusLink::new());
    let mut tap = BusTap::new(link);
    let mut can = Scripted::default();
    // Withdrawn for longer than its patience: counted lost, and the next frame goes.
    link.send(1, ext(0x1FA8_0003, &[3])).unwrap();
    link.send(1, ext(0x1FA8_0004, &[4])).unwrap();
    tap.run(0, &mut can, |_| {});
    let patience = crate::tap::CLIENT_PATIENCE_US;
    can.finish(TxOutcome::LostArbitration);
    tap.run(patience - 1, &mut can, |_| {});
    assert_eq!(can.loaded, [rt(0x1FA8_0003, &[3])], "still within its patience");
    can.finish(TxOutcome::LostArbitration);
    tap.run(patience, &mut can, |_| {});
    assert_eq!(can.loaded, [rt(0x1FA8_0004, &[4])], "given up at its patience");
    assert_eq!(link.stats.lost.load(Relaxed), 1);
    // Error frames: CLIENT_TRIES tries in all, however soon.
    for t in 1..=crate::tap::CLIENT_TRIES as u64 {
        assert_eq!(can.loaded, [rt(0x1FA8_0004, &[4])], "error try {t}");
        can.finish(TxOutcome::Error);
        tap.run(patience + t, &mut can, |_| {});
    }
    assert!(can.loaded.is_empty(), "given up after its error tries");
    assert_eq!(link.stats.lost.load(Relaxed), 2);
    assert_eq!(link.stats.frames_from_clients.load(Relaxed), 0);
}

#[test]
fn a_frame_whose_result_never_comes_does_not_stop_the_clients_frames() {
    let link: &'static BusLink = leak(BusLink::new());
    let mut tap = BusTap::new(link);
    let mut can = Scripted::default();
    link.send(1, ext(0x1FA8_0003, &[1])).unwrap();
    tap.run(0, &mut can, |c| c.try_transmit(&rt(0x0AAA_0001, &[])).unwrap());
    // The controller is reset: the node's frame and its result are gone.
    can.loaded.clear();
    tap.run(50_000, &mut can, |_| {});
    assert!(can.loaded.is_empty(), "still waiting for the node's result");
    tap.run(50_000 + crate::tap::STALE_US + 1, &mut can, |_| {});
    assert_eq!(can.loaded, [rt(0x1FA8_0003, &[1])], "the client's frame goes out after all");
}

// ---- the application ----

fn rig() -> (
    App<'static>,
    &'static BusLink,
    &'static Subscriber<'static, r2p_msgs::GatewayStatus, SPARE_QUEUE>,
) {
    let link = leak(BusLink::new());
    let ep = Endpoints::leak();
    let sub = leak(Subscriber::new());
    ep.status.topic.subscribe(sub).unwrap();
    (App::new(ep, link), link, sub)
}

const UP: NetState =
    NetState { link_up: true, ip: Some([10, 0, 0, 7]), dhcp: true, ros_filtered: 0 };

#[test]
fn status_is_published_once_a_second_with_the_link_and_counters() {
    let (mut app, link, sub) = rig();
    link.stats.client_errors.store(3, Relaxed);
    let client = link.join().unwrap();
    let mut got = Vec::new();
    for ms in 0..2500u64 {
        // The ROS bridge's write filter count, as the board reports it beside the network's.
        let net = NetState { ros_filtered: 40 + ms as u32 / 1000, ..UP };
        app.step(ms * 1000, &Sample { net, ..Sample::default() });
        while let Some(m) = sub.try_recv() {
            got.push((ms, *m));
        }
    }
    assert_eq!(got.iter().map(|g| g.0).collect::<Vec<_>>(), [0, 1000, 2000]);
    let s = got[0].1;
    assert!(s.link_up && s.configured && s.dhcp);
    assert_eq!((s.ip, s.clients, s.client_errors), (0x0A00_0007, 1, 3));
    assert_eq!(got.iter().map(|g| g.1.ros_filtered).collect::<Vec<_>>(), [40, 41, 42]);
    link.leave(client);
    app.step(3_000_000, &Sample::default());
    let s = *sub.try_recv().unwrap();
    assert!(!s.link_up && !s.configured && s.ip == 0 && s.clients == 0);
    // The static address (DHCP gave none): configured, not from DHCP.
    app.step(4_000_000, &Sample { net: NetState { dhcp: false, ..UP }, ..Sample::default() });
    let s = *sub.try_recv().unwrap();
    assert!(s.configured && !s.dhcp && s.ip == 0x0A00_0007);
}

#[test]
fn the_link_led_shows_link_address_and_clients() {
    let (mut app, link, _) = rig();
    let lit = |app: &mut App<'static>, net: NetState| {
        (0..1000u64)
            .filter(|ms| app.step(ms * 1000, &Sample { net, ..Sample::default() }).led_link)
            .count()
    };
    assert_eq!(lit(&mut app, NetState::default()), 0, "no link: off");
    assert_eq!(lit(&mut app, NetState { ip: None, ..UP }), 500, "no address yet: blinking");
    assert_eq!(lit(&mut app, UP), 1000, "addressed: on");
    link.join().unwrap();
    assert_eq!(lit(&mut app, UP), 900, "a client: a short blink off each second");
    let s = app.step(0, &Sample { status: Status { fault: true, ..Status::default() }, net: UP });
    assert!(s.led_fault);
}

#[test]
fn the_node_exports_status_under_the_module_name() {
    let (app, _, _) = rig();
    let params = leak(RamParams::new(params::DEFAULTS));
    // The image's node: 10 imports (battery, the IMU's four and the mirrored topics).
    assert_eq!(crate::endpoints::IMPORTS, 10);
    let mut node: Node<'static, 4, 10, 8, 4, 64> =
        Node::new(node_config([1; 12], 168_000_000), params).unwrap();
    app.register(&mut node).unwrap();
    let mut small: Node<'static, 4, 9, 8, 4, 64> =
        Node::new(node_config([1; 12], 168_000_000), params).unwrap();
    assert!(app.register(&mut small).is_err(), "one import more than 9");
    assert_eq!(app.endpoints().status.topic.name(), STATUS_TOPIC);
    assert!(STATUS_TOPIC.starts_with(crate::NAME));
    let config = node_config([1; 12], 168_000_000);
    assert_eq!(config.rank, Some(1), "the standby sync master");
    // The F407's leads at 168 MHz: the grid's slot and sync from its own paths (1 834 and 679
    // instructions), the frame-sized ones from the Cortex-M3's (1 369 and 714).
    assert_eq!(
        (
            config.slot_lead_us,
            config.sync_lead_us,
            config.framed_leads.slot_us,
            config.framed_leads.sync_us
        ),
        (10, 4, 8, 4)
    );
}

// ---- parameters ----

#[test]
fn network_parameters_read_from_their_place_in_the_table() {
    let alone = RamParams::new(params::DEFAULTS);
    let net = Net::read(&alone, 0);
    assert_eq!(
        net,
        Net {
            dhcp: true,
            dhcp_wait_ms: 10_000,
            ip: [192, 168, 1, 50],
            prefix_len: 24,
            router: None,
            tcp_port: 29536,
            zenoh: None,
            ros_domain: 0,
        }
    );
    // Followed by another application's two parameters: the gateway's keep their indices.
    const JOINED: [r2p_node::Param; params::COUNT + 2] = params::followed_by([
        r2p_node::Param::u32("a", 1, 0, 9),
        r2p_node::Param::bool("b", false),
    ]);
    let joined = RamParams::new(JOINED);
    let other = params::Offset { store: &joined, first: params::COUNT as u16 };
    assert_eq!(other.get(0), Ok(Value::U32(1)));
    assert_eq!(joined.get(params::TCP_PORT), alone.get(params::TCP_PORT));
    joined.set(params::DHCP, Value::Bool(false)).unwrap();
    joined.set(params::IP, Value::U32(0x0A00_0002)).unwrap();
    joined.set(params::ROUTER, Value::U32(0x0A00_0001)).unwrap();
    joined.set(params::TCP_PORT, Value::U32(5000)).unwrap();
    let net = Net::read(&joined, 0);
    assert_eq!(
        (net.dhcp, net.ip, net.router, net.tcp_port),
        (false, [10, 0, 0, 2], Some([10, 0, 0, 1]), 5000)
    );
    assert!(joined.set(params::TCP_PORT, Value::U32(70_000)).is_err(), "ports end at 65535");
    // ROS 2 over Zenoh: off until a router is set; its port 7447 by default.
    assert_eq!(net.zenoh, None);
    joined.set(params::ZENOH_ROUTER, Value::U32(0x0A00_0009)).unwrap();
    joined.set(params::ROS_DOMAIN, Value::U32(42)).unwrap();
    let net = Net::read(&joined, 0);
    assert_eq!((net.zenoh, net.ros_domain), (Some(([10, 0, 0, 9], 7447)), 42));
    assert!(joined.set(params::ROS_DOMAIN, Value::U32(233)).is_err(), "ROS domains end at 232");
    assert!(joined.set(params::PREFIX_LEN, Value::U32(0)).is_err());
    // A table that starts elsewhere is read from there.
    let shifted = params::Offset { store: &joined, first: 2 };
    assert_eq!(Net::read(&shifted, 0), Net::read(&joined, 2));
    // The base controller: on unless another node runs it.
    assert!(params::base_controller(&joined, 0) && params::base_controller(&alone, 0));
    joined.set(params::BASE_CONTROLLER, Value::Bool(false)).unwrap();
    assert!(!params::base_controller(&joined, 0));
    assert_eq!(other.get(1), Ok(Value::Bool(false)), "the other application's, untouched");
}

#[test]
fn the_servers_own_refusals_fit_an_error_message() {
    use crate::link::Refused;
    use r2p_socketcand::format::{write_error, TextBuf, MAX_ERROR_TEXT};
    for why in [Refused::QueueFull, Refused::StandardId] {
        write_error(&mut TextBuf::<MAX_ERROR_TEXT>::new(), &why).expect("fits");
    }
    write_error(&mut TextBuf::<MAX_ERROR_TEXT>::new(), &"too many clients").expect("fits");
}

// ---- ROS 2 over Zenoh ----

#[test]
fn the_ros_bridge_declares_its_node_and_publishes_only_what_it_has() {
    use crate::ros::{topic, zid_of, Latest, RosBridge, RosConfig};
    use r2p_zenoh::session::State;
    let mut b =
        RosBridge::new(&RosConfig { domain: 3, namespace: "/robot1/", zid: zid_of([5; 12]) })
            .expect("keys fit");
    assert!(b.key(topic::ODOM).starts_with("3/robot1/odom/nav_msgs::msg::dds_::Odometry_/RIHS01_"));
    let mut out = [0u8; 8192];
    let n = b.connect(0, &mut out).unwrap();
    assert_eq!(out[2], 0x41, "INIT");
    assert!(n > 0);
    // The router's INIT ack and OPEN ack (see r2p-zenoh's tests for their bytes).
    let ack = [0x21, 0x09, 0x00, 0xAA, 0x01, 0xCC];
    let n = b.receive(1, &ack, &mut out).unwrap();
    assert_eq!(out[2] & 0x1F, 0x02, "OPEN");
    assert!(n > 0);
    let n = b.receive(2, &[0x62, 10, 0], &mut out).unwrap();
    assert_eq!(b.state(), State::Open);
    let text = std::string::String::from_utf8_lossy(&out[..n]).into_owned();
    assert!(text.contains("/0/0/NN/%/%robot1/r2p_gateway"), "{text}");
    assert!(text
        .contains("/MS/%/%robot1/r2p_gateway/%robot1%cmd_vel/geometry_msgs::msg::dds_::Twist_/"));
    assert!(text.contains("/MP/%/%robot1/r2p_gateway/%robot1%odom/nav_msgs::msg::dds_::Odometry_/"));
    // The session's counters come with the bridge's: its declarations went in frames.
    let declarations = b.stats().session.frames_sent;
    assert!(declarations > 0);
    // Nothing to publish yet; then odometry only, at its rate.
    assert_eq!(b.poll(3, 0, &Latest::default(), &mut out), Ok(0));
    let latest = Latest { odom: Some(r2p_msgs::Odometry::default()), ..Latest::default() };
    assert!(b.poll(4, 0, &latest, &mut out).unwrap() > 724);
    assert_eq!(b.poll(5, 0, &latest, &mut out), Ok(0), "20 Hz: not again within 50 ms");
    assert!(b.poll(50_004, 0, &latest, &mut out).unwrap() > 724);
    assert_eq!(b.stats().published, 2);
    assert_eq!(b.stats().session.frames_sent, declarations + 2, "a frame per sample");
}

#[test]
fn cmd_vel_drives_until_its_watchdog_sends_one_stop() {
    use crate::ros::{zid_of, RosBridge, RosConfig, CMD_WATCHDOG_US};
    let mut b =
        RosBridge::new(&RosConfig { domain: 0, namespace: "", zid: zid_of([5; 12]) }).unwrap();
    let mut out = [0u8; 8192];
    b.connect(0, &mut out).unwrap();
    b.receive(1, &[0x21, 0x09, 0x00, 0xAA, 0x01, 0xCC], &mut out).unwrap();
    b.receive(2, &[0x62, 10, 0], &mut out).unwrap();
    // A PUT on /cmd_vel's key, in full: vx 0.5, wz -1.
    let key =
        std::format!("0/cmd_vel/geometry_msgs::msg::dds_::Twist_/{}", r2p_zenoh::types::TWIST.hash);
    let mut cdr = std::vec![0, 1, 0, 0];
    for v in [0.5f64, 0.0, 0.0, 0.0, 0.0, -1.0] {
        cdr.extend_from_slice(&v.to_le_bytes());
    }
    assert!(key.len() < 128, "one-byte zint length");
    // FRAME (reliable, sn 0), PUSH with a suffix, scope 0, the key, PUT, the payload.
    let mut batch = std::vec![0x25, 0x00, 0x3D, 0x00, key.len() as u8];
    batch.extend_from_slice(key.as_bytes());
    batch.extend_from_slice(&[0x01, cdr.len() as u8]);
    batch.extend_from_slice(&cdr);
    b.receive(1_000, &batch, &mut out).unwrap();
    assert_eq!(b.stats().cmd_vel, 1);
    assert!(b.driving());
    assert_eq!(b.take_cmd(1_000), Some(r2p_msgs::Twist2D { vx: 0.5, vy: 0.0, wz: -1.0 }));
    assert_eq!(b.take_cmd(2_000), None);
    assert_eq!(b.take_cmd(1_000 + CMD_WATCHDOG_US), None);
    assert_eq!(b.take_cmd(1_001 + CMD_WATCHDOG_US), Some(r2p_msgs::Twist2D::default()));
    assert_eq!(b.take_cmd(2_000_000), None, "one stop, not a stream of them");
    assert!(!b.driving());
    // Not a Twist: counted, dropped, no command.
    let mut bad = batch.clone();
    let len_at = bad.len() - cdr.len() - 1;
    bad[len_at] = 5;
    bad.truncate(len_at + 6);
    b.receive(3_000_000, &bad, &mut out).unwrap();
    assert_eq!((b.stats().cmd_vel, b.stats().bad_cmd_vel), (1, 1));
    assert_eq!(b.take_cmd(3_000_000), None);
}

mod demand {
    //! The imports follow the Zenoh subscribers (issue 22): [`Demand`]'s hold-off on its own,
    //! then a gateway on a bus with a PSU whose battery stream stops when the last Zenoh
    //! subscriber of `/battery_state` leaves and comes back when one declares.

    use r2p_middleware::{pool_size, Class};
    use r2p_module::OutboundCell;
    use r2p_msgs::Battery;
    use r2p_node::testbus::{uid, Bus};
    use r2p_node::{Export, ImportState, NoParams, Node, NodeConfig};
    use std::vec::Vec;

    use crate::demand::{Demand, Feed, Follower, GATEWAY_FEEDS, HOLD_OFF_US};
    use crate::ros::{topic, zid_of, Latest, RosBridge, RosConfig};
    use crate::{App, BusLink, Endpoints};

    use super::leak;

    /// One feed of `/odom` (bit 0) and one of the four ranges (bits 2-5).
    const FEEDS: [Feed<'static>; 2] =
        [Feed { topic: "odom", ros: 1 << topic::ODOM }, Feed { topic: "ranges", ros: 0b11_1100 }];

    fn update(d: &mut Demand, now: u64, m: [Option<bool>; 6]) -> u32 {
        d.update(now, |i| m.get(i).copied().flatten());
        d.wanted() & 0b11
    }

    #[test]
    fn a_feed_is_given_up_after_the_hold_off_without_subscribers_and_wanted_again_at_once() {
        let (t, f, n) = (Some(true), Some(false), None);
        let mut d = Demand::new(&FEEDS);
        assert_eq!(update(&mut d, 0, [n; 6]), 0b11, "all wanted while nothing is known");
        // Nobody on /odom from t = 1 s: still wanted until the hold-off has passed.
        assert_eq!(update(&mut d, 1_000_000, [f, n, t, f, f, f]), 0b11);
        assert_eq!(update(&mut d, 1_000_000 + HOLD_OFF_US - 1, [f, n, t, f, f, f]), 0b11);
        assert_eq!(update(&mut d, 1_000_000 + HOLD_OFF_US, [f, n, t, f, f, f]), 0b10);
        assert_eq!(d.stats().unsubscribes, 1);
        // A subscriber: wanted at once.
        assert_eq!(update(&mut d, 9_000_000, [t, n, t, f, f, f]), 0b11);
        assert_eq!(d.stats().resubscribes, 1);
        // The ranges: wanted while any of the four has one; all four without for the hold-off.
        assert_eq!(update(&mut d, 10_000_000, [t, n, f, f, f, t]), 0b11);
        assert_eq!(update(&mut d, 11_000_000, [t, n, f, f, f, f]), 0b11);
        assert_eq!(update(&mut d, 11_000_000 + HOLD_OFF_US, [t, n, f, f, f, f]), 0b01);
        assert_eq!((d.stats().unsubscribes, d.stats().resubscribes), (2, 1));
    }

    #[test]
    fn a_subscriber_back_within_the_hold_off_or_no_information_changes_nothing() {
        let (t, f, n) = (Some(true), Some(false), None);
        let mut d = Demand::new(&FEEDS);
        // A ROS node restarting: gone for 4 s, back, gone again: the hold-off starts over.
        update(&mut d, 0, [f, n, t, t, t, t]);
        update(&mut d, HOLD_OFF_US - 1_000_000, [t, n, t, t, t, t]);
        update(&mut d, HOLD_OFF_US, [f, n, t, t, t, t]);
        assert_eq!(update(&mut d, 2 * HOLD_OFF_US - 1, [f, n, t, t, t, t]), 0b11);
        // The session lost (nothing known) halfway: the count starts over when it is back.
        let at = 3 * HOLD_OFF_US;
        update(&mut d, at - 1, [t, n, t, t, t, t]);
        update(&mut d, at, [f, n, t, t, t, t]);
        update(&mut d, at + HOLD_OFF_US / 2, [n, n, n, n, n, n]);
        assert_eq!(update(&mut d, at + HOLD_OFF_US, [f, n, t, t, t, t]), 0b11);
        assert_eq!(update(&mut d, at + 2 * HOLD_OFF_US - 1, [f, n, t, t, t, t]), 0b11);
        // One of the ranges not known and none matched: left as it is, however long.
        let at = 10 * HOLD_OFF_US;
        update(&mut d, at, [t, n, f, f, f, n]);
        assert_eq!(update(&mut d, at + 3 * HOLD_OFF_US, [t, n, f, f, f, n]), 0b11);
        assert_eq!(d.stats().unsubscribes, 0);
        // And a feed given up stays so while nothing is known.
        update(&mut d, at + 4 * HOLD_OFF_US, [f, n, t, t, t, t]);
        assert_eq!(update(&mut d, at + 5 * HOLD_OFF_US, [f, n, t, t, t, t]), 0b10);
        assert_eq!(update(&mut d, at + 9 * HOLD_OFF_US, [n; 6]), 0b10);
    }

    #[test]
    fn each_gateway_feed_names_the_ros_topic_its_import_becomes() {
        let b =
            RosBridge::new(&RosConfig { domain: 0, namespace: "", zid: zid_of([5; 12]) }).unwrap();
        let ros_name = |topic: &'static str| match topic {
            "psu/battery" => "battery_state",
            "imu" => "imu/data",
            "imu/baro" => "imu/pressure",
            "imu/gnss" => "gnss/fix",
            other => other, // imu/mag and the mirrored topics keep their names
        };
        for f in GATEWAY_FEEDS {
            assert_eq!(f.ros.count_ones(), 1, "{}", f.topic);
            let i = f.ros.trailing_zeros() as usize;
            let want = std::format!("0/{}/", ros_name(f.topic));
            assert!(b.key(i).starts_with(&want), "{} feeds {}", f.topic, b.key(i));
        }
        let r = crate::RemoteBase::leak("proximity/ranges");
        let [odom, ranges] = r.feeds();
        assert!(b.key(odom.ros.trailing_zeros() as usize).starts_with("0/odom/"));
        assert_eq!(ranges.ros.count_ones(), 4);
        for i in (0..32).filter(|i| ranges.ros & (1 << i) != 0) {
            assert!(b.key(i).starts_with("0/range_"), "{}", b.key(i));
        }
    }

    /// A node that records what it is told.
    struct Told(Vec<(&'static str, usize)>);

    impl crate::demand::Imports for Told {
        fn import_index(&self, topic: &str) -> Option<usize> {
            ["odom", "x", "ranges"].iter().position(|t| *t == topic)
        }
        fn unsubscribe(&mut self, import: usize) -> Result<(), r2p_node::NodeError> {
            self.0.push(("unsubscribe", import));
            Ok(())
        }
        fn resubscribe(&mut self, import: usize) -> Result<(), r2p_node::NodeError> {
            self.0.push(("resubscribe", import));
            Ok(())
        }
    }

    #[test]
    fn the_node_is_told_of_changes_only_and_only_for_imports_it_has() {
        let feeds = [FEEDS[0], Feed { topic: "not imported", ros: 2 }, FEEDS[1]];
        let mut node = Told(Vec::new());
        let mut f = Follower::bind(&feeds, &node);
        f.apply(u32::MAX, &mut node);
        assert!(node.0.is_empty(), "all wanted, all subscribed");
        f.apply(!0b111, &mut node);
        assert_eq!(node.0, [("unsubscribe", 0), ("unsubscribe", 2)], "not the one it lacks");
        node.0.clear();
        f.apply(!0b111, &mut node);
        assert!(node.0.is_empty(), "told once");
        f.apply(!0b011, &mut node);
        assert_eq!(node.0, [("resubscribe", 2)]);
    }

    /// FRAME (reliable) with network messages.
    fn frame(msgs: &[&[u8]]) -> Vec<u8> {
        let mut v = std::vec![0x25, 0x00];
        msgs.iter().for_each(|m| v.extend_from_slice(m));
        v
    }

    type Gateway = Node<'static, 2, 12, 32, 4, 64>;
    type Psu = Node<'static, 2, 2, 24, 4, 64>;

    struct Rig {
        bus: &'static Bus<3>,
        psu: Psu,
        gw: Gateway,
        app: App<'static>,
        bridge: RosBridge,
        follower: Follower,
        battery: &'static r2p_middleware::Publisher<'static, Battery>,
        remote: &'static dyn Export,
        /// Frames of the battery's stream seen on the bus, by the ms they were seen at.
        seen: Vec<u64>,
        /// What the bridge sent when the session opened: its declarations.
        declared: Vec<u8>,
    }

    impl Rig {
        /// Runs 1 ms steps until `until` µs: the PSU publishes its battery every 10 ms, the
        /// router keeps the session alive once a second.
        fn run(&mut self, until: u64) {
            let mut out = [0u8; 8192];
            let stream = self.psu.node_id().message_id(1);
            while self.bus.now.get() < until {
                let now = self.bus.now.get();
                if now.is_multiple_of(10_000) {
                    let _ = self.battery.publish_with(|b| b.voltage = 24.0);
                }
                if now.is_multiple_of(1_000_000) {
                    self.bridge.receive(now, &[0x04], &mut out).unwrap();
                }
                self.psu.poll(now, &mut self.bus.port(0));
                self.gw.poll(now, &mut self.bus.port(1));
                self.app.step(now, &crate::Sample::default());
                self.bridge.poll(now, 0, &Latest::default(), &mut out).unwrap();
                self.follower.apply(self.bridge.wanted(), &mut self.gw);
                while let Some(r) = rtcan::CanController::try_receive(&mut self.bus.port(2)) {
                    if r.frame.id().message == stream {
                        self.seen.push(now);
                    }
                }
                self.bus.now.set(now + 1_000);
            }
        }

        fn router(&mut self, batch: &[u8]) {
            let mut out = [0u8; 8192];
            self.bridge.receive(self.bus.now.get(), batch, &mut out).unwrap();
        }

        fn frames_between(&self, from: u64, to: u64) -> usize {
            self.seen.iter().filter(|&&t| t >= from && t < to).count()
        }
    }

    fn rig() -> Rig {
        let bus: &'static Bus<3> = leak(Bus::new());
        let config = |n, name| NodeConfig {
            heartbeat_period_us: 20_000,
            request_timeout_us: 30_000,
            ..NodeConfig::new(uid(n), name)
        };
        let mut psu = Psu::new(config(1, "psu"), &NoParams).unwrap();
        let cell: &'static OutboundCell<Battery, { pool_size(&[2], 1) }, 1, 2> =
            leak(OutboundCell::new());
        let out = cell.build("psu/battery", Battery::default(), Class::NonRealTime).unwrap();
        psu.export(out.remote).unwrap();
        let mut gw = Gateway::new(config(2, "gateway"), &NoParams).unwrap();
        let app = App::new(Endpoints::leak(), leak(BusLink::new()));
        app.register(&mut gw).unwrap();
        let follower = Follower::bind(&GATEWAY_FEEDS, &gw);
        let mut bridge =
            RosBridge::new(&RosConfig { domain: 0, namespace: "", zid: zid_of([5; 12]) }).unwrap();
        bridge.follow(&GATEWAY_FEEDS);
        let mut rig = Rig {
            bus,
            psu,
            gw,
            app,
            bridge,
            follower,
            battery: out.publisher,
            remote: out.remote,
            seen: Vec::new(),
            declared: Vec::new(),
        };
        // The session: INIT ack, OPEN ack (r2p-zenoh's tests have their bytes).
        let mut buf = [0u8; 8192];
        rig.bridge.connect(0, &mut buf).unwrap();
        rig.router(&[0x21, 0x09, 0x00, 0xAA, 0x01, 0xCC]);
        let n = rig.bridge.receive(0, &[0x62, 10, 0], &mut buf).unwrap();
        rig.declared = buf[..n].to_vec();
        rig
    }

    /// A Zenoh integer (LEB128) at `at`, and the index after it.
    fn zint(b: &[u8], at: usize) -> (u64, usize) {
        let (mut v, mut i) = (0, at);
        while b[i] & 0x80 != 0 {
            v |= u64::from(b[i] & 0x7F) << (7 * (i - at));
            i += 1;
        }
        (v | u64::from(b[i]) << (7 * (i - at)), i + 1)
    }

    /// The key expression id `declared` gives `key` (a DECLARE KEYEXPR: id, no prefix, the
    /// key's length and bytes).
    fn declared_id(declared: &[u8], key: &str) -> u64 {
        let at = declared.windows(key.len()).position(|w| w == key.as_bytes()).unwrap();
        assert_eq!((declared[at - 2], usize::from(declared[at - 1])), (0, key.len()));
        u64::from(declared[at - 3])
    }

    /// The PUTs in the bridge's output, one per FRAME as it sends them: the key expression id
    /// each names and the sequence number of its attachment (rmw_zenoh's, which subscribers
    /// read gaps in).
    fn puts(out: &[u8]) -> Vec<(u64, i64)> {
        let (mut got, mut at) = (Vec::new(), 0);
        while at < out.len() {
            let end = at + 2 + usize::from(u16::from_le_bytes([out[at], out[at + 1]]));
            // FRAME (reliable), its sequence number, PUSH on a declared key, PUT with an
            // attachment: its extension header and 33 bytes.
            if out[at + 2] == 0x25 {
                let (_, i) = zint(out, at + 3);
                assert_eq!(out[i], 0x5D, "PUSH by a declared key");
                let (expr, i) = zint(out, i + 1);
                assert_eq!((out[i], out[i + 2]), (0x81, 33), "PUT with its attachment");
                got.push((expr, i64::from_le_bytes(out[i + 3..i + 11].try_into().unwrap())));
            }
            at = end;
        }
        got
    }

    #[test]
    fn the_battery_stream_stops_when_its_last_zenoh_subscriber_leaves_and_comes_back_with_one() {
        let mut r = rig();
        r.run(300_000);
        let battery = r.gw.import_index("psu/battery").unwrap();
        assert!(matches!(r.gw.import_state(battery), Some(ImportState::Subscribed { .. })));
        // The router answers the interests: a subscriber on /battery_state's own key (id 2,
        // interest 2), nobody on the rest.
        let sub = [0x3E, 2, 0x02, 5, 2];
        let finals: Vec<[u8; 3]> = (1..=topic::COUNT as u8).map(|i| [0x3E, i, 0x1A]).collect();
        let mut msgs: Vec<&[u8]> = std::vec![&sub];
        msgs.extend(finals.iter().map(|f| &f[..]));
        r.router(&frame(&msgs));
        assert_eq!(r.bridge.matched(topic::BATTERY), Some(true));
        assert_eq!(r.bridge.matched(topic::IMU), Some(false));
        // The IMU's imports (nobody publishes them here) are given up after the hold-off; the
        // battery is not.
        let t0 = r.bus.now.get();
        r.run(t0 + HOLD_OFF_US + 100_000);
        let imu = r.gw.import_index("imu").unwrap();
        assert_eq!(r.gw.import_state(imu), Some(ImportState::Unsubscribed { publisher: None }));
        assert!(matches!(r.gw.import_state(battery), Some(ImportState::Subscribed { .. })));
        assert_eq!(r.bridge.stats().demand.unsubscribes, 9);

        // The subscriber goes: the stream runs on through the hold-off, then stops.
        let gone = r.bus.now.get();
        r.router(&frame(&[&[0x1E, 0x03, 5]]));
        assert_eq!(r.bridge.matched(topic::BATTERY), Some(false));
        r.run(gone + HOLD_OFF_US + 200_000);
        assert!(r.frames_between(gone + HOLD_OFF_US - 500_000, gone + HOLD_OFF_US) >= 40);
        let stopped = gone + HOLD_OFF_US + 100_000;
        assert_eq!(r.frames_between(stopped, r.bus.now.get()), 0, "no battery frame on the bus");
        assert!(matches!(r.gw.import_state(battery), Some(ImportState::Unsubscribed { .. })));
        assert_eq!(r.remote.active_len(), 0, "the PSU's export stopped");
        assert_eq!(r.bridge.stats().demand.unsubscribes, 10);

        // A plain Zenoh subscriber on `0/**` comes: the stream is back within 100 ms.
        let back = r.bus.now.get();
        r.router(&frame(&[&[0x1E, 0x22, 6, 0, 4, b'0', b'/', b'*', b'*']]));
        r.run(back + 200_000);
        assert!(r.frames_between(back, back + 100_000) > 0, "back within 100 ms");
        assert!(r.frames_between(back + 100_000, back + 200_000) >= 8, "and flowing");
        assert!(matches!(r.gw.import_state(battery), Some(ImportState::Subscribed { .. })));
        assert_eq!(r.bridge.stats().demand.resubscribes, 10, "all ten, on a wildcard");
        assert_eq!(r.bridge.stats().matching.declared, 2);
    }

    #[test]
    fn a_subscriber_that_comes_back_within_the_hold_off_keeps_the_stream_running() {
        let mut r = rig();
        r.run(300_000);
        let sub = [0x3E, 2, 0x02, 5, 2];
        let finals: Vec<[u8; 3]> = (1..=topic::COUNT as u8).map(|i| [0x3E, i, 0x1A]).collect();
        let mut msgs: Vec<&[u8]> = std::vec![&sub];
        msgs.extend(finals.iter().map(|f| &f[..]));
        r.router(&frame(&msgs));
        // A ROS node restarting: its subscriber gone, back 3 s later, gone, back again.
        let t0 = r.bus.now.get();
        for k in 0..3 {
            r.router(&frame(&[&[0x1E, 0x03, 5]]));
            r.run(t0 + (2 * k + 1) * 3_000_000);
            r.router(&frame(&[&[0x1E, 0x02, 5, 2]]));
            r.run(t0 + (2 * k + 2) * 3_000_000);
        }
        let end = r.bus.now.get();
        let per_second = (0..(end - t0) / 1_000_000)
            .map(|s| r.frames_between(t0 + s * 1_000_000, t0 + (s + 1) * 1_000_000));
        assert!(per_second.clone().all(|n| n >= 90), "{:?}", per_second.collect::<Vec<_>>());
        let battery = r.gw.import_index("psu/battery").unwrap();
        assert!(matches!(r.gw.import_state(battery), Some(ImportState::Subscribed { .. })));
    }

    /// Polls the bridge alone every 10 ms from now to `until` with a battery sample to
    /// publish (the router's keep-alive once a second); the PUTs it sent ([`puts`]).
    fn publish_battery(r: &mut Rig, until: u64) -> Vec<(u64, i64)> {
        let latest = Latest { battery: Some(Battery::default()), ..Latest::default() };
        let (mut out, mut sent) = ([0u8; 8192], Vec::new());
        while r.bus.now.get() < until {
            let now = r.bus.now.get();
            if now.is_multiple_of(1_000_000) {
                r.bridge.receive(now, &[0x04], &mut out).unwrap();
            }
            let n = r.bridge.poll(now, 0, &latest, &mut out).unwrap();
            sent.extend(puts(&out[..n]));
            r.bus.now.set(now + 10_000);
        }
        sent
    }

    /// Whether `puts` are all on key expression `id`, numbered on from `next`, one by one.
    fn numbered_from(puts: &[(u64, i64)], id: u64, next: i64) -> bool {
        puts.iter().zip(next..).all(|(&(e, s), n)| e == id && s == n)
    }

    #[test]
    fn no_put_leaves_for_a_key_nobody_subscribes_and_puts_resume_with_a_subscriber() {
        let mut r = rig();
        let stats = |r: &Rig| (r.bridge.stats().published, r.bridge.stats().filtered);
        // The battery's PUTs name the key the session declared for /battery_state.
        let battery = declared_id(&r.declared, r.bridge.key(topic::BATTERY));
        // No answer to the interests yet: the battery goes out (fail-safe).
        let first = publish_battery(&mut r, 2_000_000);
        let (sent, filtered) = stats(&r);
        assert!(sent > 0 && filtered == 0, "{sent} {filtered}");
        assert!(first.len() == sent as usize && numbered_from(&first, battery, 1), "{first:?}");
        // The router answers: nobody subscribes to anything. No PUT leaves, each is counted.
        let finals: Vec<[u8; 3]> = (1..=topic::COUNT as u8).map(|i| [0x3E, i, 0x1A]).collect();
        r.router(&frame(&finals.iter().map(|f| &f[..]).collect::<Vec<_>>()));
        assert_eq!(publish_battery(&mut r, 4_000_000), [], "no PUT for an unsubscribed key");
        let (held, filtered) = stats(&r);
        assert_eq!(held, sent);
        assert!(filtered > 0);
        // A subscriber declared on /battery_state's key: the next due sample goes, numbered
        // next to the last one sent (a sample held back is no gap a subscriber would see).
        r.router(&frame(&[&[0x1E, 0x02, 5, 2]]));
        let at = r.bus.now.get();
        let mut out = [0u8; 8192];
        let latest = Latest { battery: Some(Battery::default()), ..Latest::default() };
        let n = r.bridge.poll(at, 0, &latest, &mut out).unwrap();
        assert_eq!(puts(&out[..n]), [(battery, i64::from(sent) + 1)], "at once");
        assert_eq!(stats(&r), (held + 1, filtered));
        let then = publish_battery(&mut r, 6_000_000);
        assert!(numbered_from(&then, battery, i64::from(sent) + 2), "{then:?}");
        assert!(stats(&r).0 > held + 1 && stats(&r).1 == filtered);
        // It leaves: held back again at once, also while demand's hold-off keeps the import.
        r.router(&frame(&[&[0x1E, 0x03, 5]]));
        let (before, f) = stats(&r);
        assert_eq!(publish_battery(&mut r, 6_000_000 + HOLD_OFF_US / 2), []);
        assert_eq!(stats(&r).0, before);
        assert!(stats(&r).1 > f);
        let feed = GATEWAY_FEEDS.iter().position(|f| f.topic == "psu/battery").unwrap();
        assert_ne!(r.bridge.wanted() & 1 << feed, 0, "the import is kept within the hold-off");
        // A new session: unknown again, the battery goes.
        r.bridge.connect(r.bus.now.get(), &mut out).unwrap();
        r.router(&[0x21, 0x09, 0x00, 0xAA, 0x01, 0xCC]);
        r.router(&[0x62, 10, 0]);
        let (before, f) = stats(&r);
        let until = r.bus.now.get() + 2_000_000;
        publish_battery(&mut r, until);
        assert!(stats(&r).0 > before && stats(&r).1 == f);
    }
}
