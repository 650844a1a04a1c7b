//! The session against a scripted router: the bytes a Zenoh 1.x router sends and expects.

use crate::codec::Writer;
use crate::session::{Config, Event, Session, SessionError, State};
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
