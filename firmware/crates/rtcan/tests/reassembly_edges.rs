//! Reassembly at the edges a real bus produces (docs/rtcan.md, "Fragmentation", "Duplicate or
//! new?"): a sender gives up a message midway (its deadline passed with frames still queued)
//! and starts the next, whose first counter may be the one a repeated frame would have; a frame
//! is lost; a last frame arrives whose start was never seen, or one too short for its message.
//! Only a frame equal, bit for bit, to the last one taken is a duplicate; a new message is
//! delivered, a given-up one never is, and a malformed frame does not end a good message.

use rtcan::{fragments, Expect, Frame, FrameId, Laxity, MessageId, Reassembler};

fn message(fill: u8, len: usize) -> Vec<Frame> {
    let template = FrameId { laxity: Laxity::NRT, message: MessageId(0x4302), fragment: 0 };
    fragments(template, &vec![fill; len]).unwrap().collect()
}

#[test]
fn a_new_message_right_after_a_given_up_one_is_delivered() {
    let mut r: Reassembler<1, 32> = Reassembler::new(10_000);
    let given_up = message(0xAA, 20); // counters 3, 2, 1
    let next = message(0x55, 10); // counters 2, 1
    assert_eq!((given_up[0].id().fragment, next[0].id().fragment), (3, 2));
    let mut delivered = Vec::new();
    let mut at = 0;
    for f in given_up[..2].iter().chain(&next) {
        at += 200;
        if let Some(m) = r.accept(f, at, Expect::Any) {
            delivered.push(m.data.to_vec());
        }
    }
    assert_eq!(delivered, [vec![0x55; 10]]);
    assert_eq!(r.stats().duplicate, 0);
}

#[test]
fn a_repeated_frame_is_still_a_duplicate() {
    let mut r: Reassembler<1, 32> = Reassembler::new(10_000);
    let m = message(0x42, 20);
    let mut delivered = 0;
    let mut at = 0;
    // CAN's double reception of each frame, the last one included.
    for f in [&m[0], &m[0], &m[1], &m[1], &m[2], &m[2]] {
        at += 200;
        delivered += usize::from(r.accept(f, at, Expect::Any).is_some());
    }
    assert_eq!((delivered, r.stats().duplicate), (1, 3));
}

#[test]
fn after_a_lost_frame_a_new_message_starting_at_the_same_counter_is_delivered() {
    // A's frame 3 is lost: the message is given up at frame 2 (Between{2}); the sender's next
    // message has two frames, so its first counter is 2 again, with other data.
    let mut r: Reassembler<1, 32> = Reassembler::new(10_000);
    let lost_one = message(0xAA, 30); // counters 4, 3, 2, 1
    let next = message(0x55, 10); // counters 2, 1
    let mut delivered = Vec::new();
    let mut at = 0;
    for f in [&lost_one[0], &lost_one[2], &next[0], &next[1]] {
        at += 200;
        if let Some(m) = r.accept(f, at, Expect::Any) {
            delivered.push(m.data.to_vec());
        }
    }
    assert_eq!(r.stats().out_of_order, 1);
    assert_eq!(delivered, [vec![0x55; 10]]);
}

#[test]
fn a_stray_last_frame_does_not_take_another_streams_history() {
    // One slot; stream 0x4302's message ends (its last frame kept for duplicate detection).
    // A last frame of stream 0x4303, whose start was never seen, is foreign and takes no slot:
    // the repeated last frame of 0x4302 (CAN's double reception) is still known as one.
    let mut r: Reassembler<1, 32> = Reassembler::new(10_000);
    let m = message(0x42, 20);
    let mut at = 0;
    for f in &m {
        at += 200;
        r.accept(f, at, Expect::Any);
    }
    let stray = FrameId { laxity: Laxity::NRT, message: MessageId(0x4303), fragment: 1 };
    assert!(r.accept(&Frame::new(stray, &[1, 2, 3]).unwrap(), at + 100, Expect::Any).is_none());
    assert!(r.accept(&m[2], at + 200, Expect::Any).is_none());
    assert_eq!((r.stats().completed, r.stats().foreign, r.stats().duplicate), (1, 1, 1));
}

#[test]
fn a_last_frame_too_short_for_its_message_is_dropped_and_the_message_goes_on() {
    // A 2-frame message carries at least 9 bytes and its CRC: 11 wire bytes, so its last frame
    // has at least 3. A 2-byte frame with counter 1 on the stream (another sender's, or a
    // misconfigured one) is refused for its length; the real last frame then completes it.
    let mut r: Reassembler<1, 32> = Reassembler::new(10_000);
    let m = message(0x42, 12); // counters 2, 1: 8 + 6 wire bytes
    let stray = Frame::new(FrameId { fragment: 1, ..m[1].id() }, &[0x42, 0x42]).unwrap();
    assert!(r.accept(&m[0], 100, Expect::Any).is_none());
    assert!(r.accept(&stray, 200, Expect::Any).is_none());
    assert_eq!(r.stats().bad_length, 1);
    assert_eq!(r.accept(&m[1], 300, Expect::Any).map(|d| d.data.to_vec()), Some(vec![0x42; 12]));
}

#[test]
fn a_fixed_size_stream_takes_only_single_frames_of_its_size() {
    // A topic of 4-byte messages (Expect::Exactly(4)): one frame, counter 0, 4 bytes.
    let id = |fragment| FrameId { laxity: Laxity::NRT, message: MessageId(0x4302), fragment };
    let mut r: Reassembler<1, 32> = Reassembler::new(10_000);
    assert!(r.accept(&Frame::new(id(0), &[1, 2, 3]).unwrap(), 100, Expect::Exactly(4)).is_none());
    assert!(r
        .accept(&Frame::new(id(2), &[1, 2, 3, 4]).unwrap(), 200, Expect::Exactly(4))
        .is_none());
    assert_eq!(r.stats().bad_length, 2);
    let m = r.accept(&Frame::new(id(0), &[1, 2, 3, 4]).unwrap(), 300, Expect::Exactly(4));
    assert_eq!(m.map(|m| m.data.to_vec()), Some(vec![1, 2, 3, 4]));
}
