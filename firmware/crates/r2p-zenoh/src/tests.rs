//! The session against a scripted router: the bytes a Zenoh 1.x router sends and expects.

use crate::codec::Writer;
use crate::matching::{interest_id, Matching, MAX_KEYS};
use crate::session::{Config, Declared, Event, Session, SessionError, State};
use std::string::String;
use std::vec;
use std::vec::Vec;

const ZID: [u8; 16] = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 0x80];

fn session() -> Session {
    Session::new(Config { zid: ZID, lease_ms: 10_000, rx_batch: 2048 })
}

fn framed(body: &[u8]) -> Vec<u8> {
    let mut v = (body.len() as u16).to_le_bytes().to_vec();
    v.extend_from_slice(body);
    v
}

/// An INIT ack from a router with a 4-byte ZID, size parameters (batch 1024) and an extension.
fn init_ack() -> Vec<u8> {
    let mut v = vec![
        0x01 | 0x20 | 0x40 | 0x80,
        0x09,
        3 << 4, /* ZID of 4 bytes, a router */
        0xAA,
        0xBB,
        0xCC,
        0xDD,
    ];
    v.extend_from_slice(&[0b1010, 0x00, 0x04]); // resolution, batch 1024
    v.extend_from_slice(&[3, b'c', b'k', b'y']); // cookie
    v.extend_from_slice(&[0x21, 0x05]); // a z64 extension (QoS), last
    v
}

fn open_ack() -> Vec<u8> {
    vec![0x02 | 0x20 | 0x40, 10, 0x2A] // lease 10 s, initial sn 42
}

fn opened() -> Session {
    let mut s = session();
    let mut out = [0u8; 512];
    s.start(0, &mut out).unwrap();
    s.receive(1, &init_ack(), &mut out, |_| {}).unwrap();
    let mut events = 0;
    s.receive(2, &open_ack(), &mut out, |e| {
        assert_eq!(e, Event::Opened);
        events += 1
    })
    .unwrap();
    assert_eq!((events, s.state()), (1, State::Open));
    s
}

#[test]
fn handshake_sends_init_then_open_with_the_cookie() {
    let mut s = session();
    let mut out = [0u8; 512];
    let n = s.start(0, &mut out).unwrap();
    let mut expect = vec![0x41, 0x09, 0xF2];
    expect.extend_from_slice(&ZID);
    expect.extend_from_slice(&[0x0A, 0x00, 0x08]);
    assert_eq!(&out[..n], &framed(&expect)[..]);
    assert_eq!(s.state(), State::InitSent);
    let n = s.receive(1, &init_ack(), &mut out, |_| panic!("no event yet")).unwrap();
    // OPEN: T flag (lease in s), lease 10, initial sn from the ZID (0x030201), cookie.
    assert_eq!(&out[..n], &framed(&[0x42, 10, 0x81, 0x84, 0x0C, 3, b'c', b'k', b'y'])[..]);
    assert_eq!(s.tx_batch(), 1024);
    let _ = opened();
}

#[test]
fn a_reply_that_is_not_an_ack_ends_the_handshake() {
    let mut s = session();
    let mut out = [0u8; 512];
    s.start(0, &mut out).unwrap();
    let mut bad = init_ack();
    bad[1] = 0x08; // another protocol version
    assert_eq!(s.receive(1, &bad, &mut out, |_| {}), Err(SessionError::Handshake));
    s.start(0, &mut out).unwrap();
    assert_eq!(s.receive(1, &[0x01, 0x09], &mut out, |_| {}), Err(SessionError::Handshake));
}

#[test]
fn frames_carry_declarations_and_puts_with_consecutive_sequence_numbers() {
    let mut s = opened();
    let mut out = [0u8; 512];
    let n = s
        .send(3, &mut out, |net| {
            net.declare_keyexpr(1, "0/odom/T/H");
            net.declare_token(2, "@ros2_lv/0/x");
            net.declare_subscriber(3, "0/cmd_vel/T/H");
        })
        .unwrap();
    let mut expect = vec![0x25, 0x81, 0x84, 0x0C];
    expect.extend_from_slice(&[0x1E, 0x20, 1, 0, 10]);
    expect.extend_from_slice(b"0/odom/T/H");
    expect.extend_from_slice(&[0x1E, 0x26, 2, 0, 12]);
    expect.extend_from_slice(b"@ros2_lv/0/x");
    expect.extend_from_slice(&[0x1E, 0x22, 3, 0, 13]);
    expect.extend_from_slice(b"0/cmd_vel/T/H");
    assert_eq!(&out[..n], &framed(&expect)[..]);
    let n = s.send(4, &mut out, |net| net.put(1, &[9, 8], Some(&[7]))).unwrap();
    // sn + 1; PUSH with the sender's mapping, id 1; PUT with an attachment extension.
    assert_eq!(
        &out[..n],
        &framed(&[0x25, 0x82, 0x84, 0x0C, 0x5D, 1, 0x81, 0x43, 1, 7, 2, 9, 8])[..]
    );
    assert_eq!(s.stats().frames_sent, 2);
    // A frame over the router's batch size (1024) is refused, and its sequence number not used.
    let big = [0u8; 1100];
    let mut out = [0u8; 2048];
    assert_eq!(s.send(5, &mut out, |net| net.put(1, &big, None)), Err(SessionError::Overflow));
    let n = s.send(6, &mut out, |net| net.put(1, &[], None)).unwrap();
    assert_eq!(&out[2..6], &[0x25, 0x83, 0x84, 0x0C]);
    assert!(n > 0);
}

fn push_frame(msgs: &[&[u8]]) -> Vec<u8> {
    let mut v = vec![0x25, 0x07];
    for m in msgs {
        v.extend_from_slice(m);
    }
    v
}

#[test]
fn puts_are_delivered_with_their_key_and_attachment() {
    let mut s = opened();
    let mut out = [0u8; 64];
    // The router declares key 9 = "0/cmd_vel/", then pushes: by its mapping with a suffix,
    // in full (scope 0) with a timestamp and an encoding; then one by this client's mapping
    // (id 5, what it publishes): not for it, skipped.
    let mut decl = vec![0x1E, 0x20, 9, 0, 10];
    decl.extend_from_slice(b"0/cmd_vel/");
    let mut by_router = vec![0x7D, 9, 3];
    by_router.extend_from_slice(b"T/H");
    by_router.extend_from_slice(&[0x81, 0x43, 2, 0xA1, 0xA2, 1, 0x55]);
    let mut full = vec![0x3D, 0, 4];
    full.extend_from_slice(b"0/xy");
    full.extend_from_slice(&[0x61, 0x85, 0x01, 1, 0x42, 0x04, 2, 1, 2]);
    let by_me = [0x1D, 5, 0x01, 0];
    let batch = push_frame(&[&decl, &by_router, &full, &by_me]);
    let mut got: Vec<(String, Vec<u8>, Option<Vec<u8>>)> = Vec::new();
    s.receive(4, &batch, &mut out, |e| {
        if let Event::Sample { key, payload, attachment } = e {
            got.push((
                std::format!("{}{}", key.prefix, key.suffix),
                payload.to_vec(),
                attachment.map(|a| a.to_vec()),
            ));
            assert!(key.is(&got.last().unwrap().0));
        }
    })
    .unwrap();
    assert_eq!(
        got,
        vec![
            ("0/cmd_vel/T/H".into(), vec![0x55], Some(vec![0xA1, 0xA2])),
            ("0/xy".into(), vec![1, 2], None),
        ]
    );
    assert_eq!((s.stats().samples, s.stats().malformed, s.stats().skipped), (2, 0, 1));
}

#[test]
fn malformed_batches_are_counted_and_dropped_and_the_session_goes_on() {
    let mut s = opened();
    let mut out = [0u8; 64];
    for bad in [
        &[0x25][..],                           // frame without its sequence number
        &[0x25, 0x07, 0x1D, 0x00, 0x01],       // push without its payload
        &[0x25, 0x07, 0x3D, 0x00, 0x09, b'a'], // suffix longer than the batch
        &[0x25, 0x07, 0x1D, 0x00, 0x81, 0x63], // a reserved extension encoding
        &[0x25, 0x07, 0x3D, 0x00, 0x02, 0xFF, 0xFE, 0x01, 0x00], // key not UTF-8
    ] {
        assert_eq!(s.receive(5, bad, &mut out, |_| panic!("nothing to deliver")), Ok(0));
    }
    assert_eq!(s.stats().malformed, 5);
    // A push on a key id nobody declared, and an interest: skipped.
    s.receive(6, &[0x25, 0x07, 0x1D, 0x33, 0x01, 0x00], &mut out, |_| panic!()).unwrap();
    s.receive(6, &[0x25, 0x07, 0x19, 0x00], &mut out, |_| panic!()).unwrap();
    assert_eq!(s.stats().skipped, 2);
    assert_eq!(s.state(), State::Open);
}

#[test]
fn keep_alives_go_out_at_a_quarter_lease_and_a_silent_router_expires() {
    let mut s = opened();
    let mut out = [0u8; 16];
    assert_eq!(s.poll(2_499_999, &mut out), Ok(0));
    assert_eq!(s.poll(2_500_002, &mut out), Ok(3));
    assert_eq!(&out[..3], &[1, 0, 0x04]);
    assert_eq!(s.poll(2_600_000, &mut out), Ok(0));
    // A keep-alive from the router renews its lease (10 s from the open ack).
    s.receive(9_000_000, &[0x04], &mut out, |_| {}).unwrap();
    assert!(s.poll(19_000_000, &mut out).is_ok());
    assert_eq!(s.poll(19_000_001, &mut out), Err(SessionError::LeaseExpired));
    assert_eq!(s.state(), State::Closed);
}

#[test]
fn a_close_from_the_router_ends_the_session() {
    let mut s = opened();
    let mut out = [0u8; 16];
    assert_eq!(s.receive(3, &[0x23, 0x02], &mut out, |_| {}), Err(SessionError::ClosedByRouter(2)));
    assert_eq!(s.state(), State::Closed);
    let mut s = opened();
    let n = s.close(&mut out).unwrap();
    assert_eq!(&out[..n], &[2, 0, 0x23, 0]);
}

#[test]
fn writer_patch_out_of_range_is_an_overflow() {
    let mut buf = [0u8; 1];
    let mut w = Writer::new(&mut buf);
    w.patch_u16_le(0, 5);
    assert!(w.finish().is_err());
}

#[test]
fn an_interest_asks_for_current_and_future_subscribers_of_an_own_key() {
    let mut s = opened();
    let mut out = [0u8; 64];
    let n = s
        .send(3, &mut out, |net| {
            net.declare_keyexpr(1, "0/a");
            net.declare_interest(1, 1);
            net.declare_interest(300, 2);
        })
        .unwrap();
    // INTEREST (0x19), mode current + future (0b11 << 5); its id; options S | R | M (the
    // sender's mapping, no suffix); the key's id.
    let mut expect = vec![0x25, 0x81, 0x84, 0x0C, 0x1E, 0x20, 1, 0, 3];
    expect.extend_from_slice(b"0/a");
    expect.extend_from_slice(&[0x79, 1, 0x52, 1, 0x79, 0xAC, 0x02, 0x52, 2]);
    assert_eq!(&out[..n], &framed(&expect)[..]);
}

/// The events of one batch, with the keys of `Declared::Full` joined.
fn events(s: &mut Session, batch: &[u8]) -> Vec<std::string::String> {
    let mut out = [0u8; 64];
    let mut got = Vec::new();
    s.receive(7, batch, &mut out, |e| {
        got.push(match e {
            Event::Subscriber { id, key: Declared::Full(k) } => {
                std::format!("sub {id} {}{}", k.prefix, k.suffix)
            }
            Event::Subscriber { id, key: Declared::Own { expr_id, suffix } } => {
                std::format!("sub {id} own {expr_id}+{suffix}")
            }
            Event::Subscriber { id, key: Declared::Unknown } => std::format!("sub {id} ?"),
            Event::SubscriberGone { id } => std::format!("gone {id}"),
            Event::InterestFinal { id } => std::format!("final {id}"),
            e => std::format!("{e:?}"),
        })
    })
    .unwrap();
    got
}

#[test]
fn the_routers_subscriber_declarations_and_undeclarations_are_events() {
    let mut s = opened();
    // What a Zenoh 1.x router answers an interest with (zenoh's hat: DECLARE with the interest
    // id and the DECLARE QoS extension for the current ones, then DECLARE FINAL; later ones
    // without the id): a subscriber on this client's own key 1 (the router names it by this
    // client's mapping), one on `0/**` in full, then the final.
    let current = push_frame(&[
        &[0xBE, 1, 0x21, 0x05, 0x02, 7, 1],
        &[0xBE, 1, 0x21, 0x05, 0x22, 8, 0, 4, b'0', b'/', b'*', b'*'],
        &[0xBE, 1, 0x21, 0x05, 0x1A],
    ]);
    assert_eq!(events(&mut s, &current), ["sub 7 own 1+", "sub 8 0/**", "final 1"]);
    // Later: one by the router's own mapping (key 9 = "0/"), then one on a prefix it never
    // declared; subscriber 7 undeclared, then 8 with its key expression as an extension
    // (WireExprExt, id 0x0F, mandatory, ZBUF: flags N, scope 0, "0/**").
    let mut decl = vec![0x1E, 0x20, 9, 0, 2];
    decl.extend_from_slice(b"0/");
    let later = push_frame(&[
        &decl,
        &[0x1E, 0x62, 10, 9, 1, b'b'],
        &[0x1E, 0x42, 11, 77],
        &[0x1E, 0x03, 7],
        &[0x1E, 0x83, 8, 0x5F, 7, 0x01, 0, 4, b'0', b'/', b'*', b'*'],
    ]);
    assert_eq!(events(&mut s, &later), ["sub 10 0/b", "sub 11 ?", "gone 7", "gone 8"]);
    // A DECLARE FINAL without an interest id answers nothing of this client's: skipped.
    let skipped = s.stats().skipped;
    assert!(events(&mut s, &push_frame(&[&[0x1E, 0x1A]])).is_empty());
    assert_eq!(s.stats().skipped, skipped + 1);
    assert_eq!(s.stats().malformed, 0);
}

#[test]
fn an_interest_from_the_router_is_read_past_and_the_frame_goes_on() {
    let mut s = opened();
    // INTEREST id 5, current + future, options S | R | N with the key "a", a QoS extension;
    // a final INTEREST (no options); one for all key expressions (S only), one restricted to a
    // key id without a suffix (S | R); then a subscriber declaration.
    let batch = push_frame(&[
        &[0xF9, 5, 0x32, 0, 1, b'a', 0x01],
        &[0x19, 6],
        &[0x79, 7, 0x02],
        &[0x79, 8, 0x12, 5],
        &[0x1E, 0x22, 3, 0, 1, b'a'],
    ]);
    assert_eq!(events(&mut s, &batch), ["sub 3 a"]);
    assert_eq!((s.stats().skipped, s.stats().malformed), (4, 0));
    // Another node's token (named, with an extension) and its undeclaration, a key
    // expression undeclared: read past, each with its extension; then a subscriber.
    let batch = push_frame(&[
        &[0x1E, 0xA6, 9, 0, 1, b't', 0x01],
        &[0x1E, 0x87, 9, 0x01],
        &[0x1E, 0x81, 3, 0x01],
        &[0x1E, 0x02, 4, 1],
    ]);
    assert_eq!(events(&mut s, &batch), ["sub 4 own 1+"]);
    assert_eq!((s.stats().skipped, s.stats().malformed), (6, 0));
}

#[test]
fn declarations_without_a_suffix_or_extensions_are_read_exactly() {
    let mut s = opened();
    // The router declares key 9 = "0/"; key 5 = key 9 (no suffix, no extension); undeclares a
    // key 3 it never declared; another node's token and its undeclaration, without a suffix or
    // extensions; then subscribers by keys 9 and 5, and a push by this client's own id 9 (not
    // the router's key 9: not for it).
    let mut decl = vec![0x1E, 0x20, 9, 0, 2];
    decl.extend_from_slice(b"0/");
    let batch = push_frame(&[
        &decl,
        &[0x1E, 0x00, 5, 9],
        &[0x1E, 0x01, 3],
        &[0x1E, 0x06, 10, 1],
        &[0x1E, 0x07, 10],
        &[0x1E, 0x62, 11, 9, 1, b'x'],
        &[0x1E, 0x42, 12, 5],
        &[0x1D, 9, 0x01, 1, 0x55],
    ]);
    assert_eq!(events(&mut s, &batch), ["sub 11 0/x", "sub 12 0/"]);
    assert_eq!((s.stats().samples, s.stats().malformed), (0, 0));
}

#[test]
fn malformed_subscriber_declarations_are_counted_and_dropped() {
    let mut s = opened();
    for bad in [
        &[0x25, 0x07, 0x1E, 0x02][..],                              // no id
        &[0x25, 0x07, 0x1E, 0x22, 3, 0, 5, b'a'],                   // suffix past the end
        &[0x25, 0x07, 0x1E, 0x02, 0x80, 0x80, 0x80, 0x80, 0x10, 1], // id over 32 bits
        &[0x25, 0x07, 0x3E, 0x80, 0x80, 0x80, 0x80, 0x10, 0x1A],    // interest id over 32 bits
        &[0x25, 0x07, 0x1E, 0x83, 8, 0x5F, 9, 1],                   // extension past the end
        &[0x25, 0x07, 0xF9, 5, 0x32, 0, 9],                         // an interest's suffix too
    ] {
        assert!(events(&mut s, bad).is_empty(), "{bad:?}");
    }
    assert_eq!(s.stats().malformed, 6);
    assert_eq!(s.state(), State::Open);
}

const KEYS: [&str; 3] = ["0/odom/T/H", "0/battery_state/T/H", "0/imu/data/T/H"];

/// A session and a matching table fed from the same batches.
fn matching_after(batches: &[Vec<u8>]) -> Matching<4> {
    let mut s = opened();
    let mut m = Matching::<4>::new();
    let mut out = [0u8; 64];
    for b in batches {
        s.receive(7, b, &mut out, |e| m.on_event(&e, &KEYS)).unwrap();
    }
    m
}

fn matched(m: &Matching<4>) -> [Option<bool>; 3] {
    [m.matched(0), m.matched(1), m.matched(2)]
}

#[test]
fn a_key_is_matched_while_a_subscriber_on_it_is_declared() {
    // Nothing known until each interest's answer is complete.
    let mut m = matching_after(&[]);
    assert_eq!(matched(&m), [None, None, None]);
    // Interest 2 (battery) complete with nothing; interest 1 (odom) gets a subscriber on the
    // own key 1 before its final; interest 3 stays open.
    let answer = push_frame(&[&[0x3E, 2, 0x1A], &[0x3E, 1, 0x02, 7, 1], &[0x3E, 1, 0x1A]]);
    m = matching_after(core::slice::from_ref(&answer));
    assert_eq!(matched(&m), [Some(true), Some(false), None]);
    assert_eq!((m.count(0), m.count(1)), (1, 0));
    // A subscriber on `0/**` matches all three; declared again (for another interest) it
    // counts once; one on another domain matches none and is not kept.
    let wide = push_frame(&[
        &[0x1E, 0x22, 8, 0, 4, b'0', b'/', b'*', b'*'],
        &[0x3E, 3, 0x22, 8, 0, 4, b'0', b'/', b'*', b'*'],
        &[0x1E, 0x22, 9, 0, 4, b'1', b'/', b'*', b'*'],
        &[0x3E, 3, 0x1A],
    ]);
    m = matching_after(&[answer.clone(), wide.clone()]);
    assert_eq!(matched(&m), [Some(true), Some(true), Some(true)]);
    assert_eq!((m.count(0), m.count(1), m.count(2)), (2, 1, 1));
    assert_eq!((m.count(3), m.count(MAX_KEYS)), (0, 0), "no such key");
    assert_eq!((m.stats().declared, m.stats().unmatched), (3, 1));
    // The wide one goes: the battery and the IMU have nobody; then the odom's goes too.
    m = matching_after(&[answer.clone(), wide.clone(), push_frame(&[&[0x1E, 0x03, 8]])]);
    assert_eq!(matched(&m), [Some(true), Some(false), Some(false)]);
    let gone = push_frame(&[&[0x1E, 0x03, 8], &[0x1E, 0x03, 7], &[0x1E, 0x03, 9]]);
    m = matching_after(&[answer, wide, gone]);
    assert_eq!(matched(&m), [Some(false), Some(false), Some(false)]);
    assert_eq!(m.stats().undeclared, 2, "9 was never kept");
    // A new session starts over.
    m.reset();
    assert_eq!(matched(&m), [None, None, None]);
}

#[test]
fn each_keys_interest_completes_that_key_and_no_other() {
    for i in 0..KEYS.len() {
        let id = interest_id(i);
        assert!(id > 0 && id < 0x80, "one-byte zint");
        let m = matching_after(&[push_frame(&[&[0x3E, id as u8, 0x1A]])]);
        let want: [Option<bool>; 3] = core::array::from_fn(|k| (k == i).then_some(false));
        assert_eq!(matched(&m), want, "interest {id}");
    }
    // An interest of no key (one past the last), and keys past the table: nothing known.
    let m = matching_after(&[push_frame(&[&[0x3E, interest_id(KEYS.len()) as u8, 0x1A]])]);
    assert_eq!(matched(&m), [None, None, None]);
    assert_eq!((m.matched(KEYS.len()), m.matched(MAX_KEYS), m.count(MAX_KEYS)), (None, None, 0));
}

#[test]
fn a_declaration_that_cannot_be_followed_counts_every_key_as_matched() {
    let finals = push_frame(&[&[0x3E, 1, 0x1A], &[0x3E, 2, 0x1A], &[0x3E, 3, 0x1A]]);
    assert_eq!(matched(&matching_after(core::slice::from_ref(&finals))), [Some(false); 3]);
    // A prefix the router declared but the session does not know; an own key id this client
    // never declared; more subscribers than the table holds (4).
    for bad in [
        push_frame(&[&[0x1E, 0x42, 11, 77]]),
        push_frame(&[&[0x1E, 0x02, 12, 9]]),
        push_frame(&[
            &[0x1E, 0x02, 1, 1],
            &[0x1E, 0x02, 2, 2],
            &[0x1E, 0x02, 3, 3],
            &[0x1E, 0x22, 4, 0, 4, b'0', b'/', b'*', b'*'],
            &[0x1E, 0x22, 5, 0, 2, b'*', b'*'],
        ]),
    ] {
        let m = matching_after(&[finals.clone(), bad]);
        assert_eq!(matched(&m), [Some(true); 3]);
        assert_eq!(m.stats().unresolved, 1);
    }
    // A key too long to join: also.
    let mut long = vec![0x1E, 0x62, 13, 9, 0x81, 0x02];
    long.extend_from_slice(&[b'a'; 257]);
    let mut decl = vec![0x1E, 0x20, 9, 0, 2];
    decl.extend_from_slice(b"0/");
    let m = matching_after(&[finals, push_frame(&[&decl, &long])]);
    assert_eq!(matched(&m), [Some(true); 3]);
}

#[test]
fn the_write_filter_holds_back_only_keys_known_to_have_no_subscriber() {
    let sends = |m: &Matching<4>| [m.sends(0), m.sends(1), m.sends(2)];
    // No answer yet: everything goes.
    assert_eq!(sends(&matching_after(&[])), [true; 3]);
    // Odom has a subscriber, battery's answer is complete with none, IMU's is not answered.
    let answer = push_frame(&[&[0x3E, 2, 0x1A], &[0x3E, 1, 0x02, 7, 1], &[0x3E, 1, 0x1A]]);
    let mut m = matching_after(core::slice::from_ref(&answer));
    assert_eq!(sends(&m), [true, false, true]);
    // Keys past the table are never followed: they send.
    assert!(m.sends(KEYS.len()) && m.sends(MAX_KEYS) && m.sends(usize::MAX));
    // A subscriber declared on the battery's key: it goes at once; undeclared: held again.
    let battery = push_frame(&[&[0x1E, 0x02, 8, 2]]);
    m = matching_after(&[answer.clone(), battery.clone()]);
    assert_eq!(sends(&m), [true, true, true]);
    m = matching_after(&[answer.clone(), battery, push_frame(&[&[0x1E, 0x03, 8]])]);
    assert_eq!(sends(&m), [true, false, true]);
    // A declaration that cannot be followed: everything goes.
    m = matching_after(&[answer.clone(), push_frame(&[&[0x1E, 0x42, 11, 77]])]);
    assert_eq!(sends(&m), [true; 3]);
    // A new session: unknown again, everything goes.
    m = matching_after(core::slice::from_ref(&answer));
    m.reset();
    assert_eq!(sends(&m), [true; 3]);
}
