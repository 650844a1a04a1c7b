//! A reassembler with `BUF`-byte buffers (docs/rtcan.md, "Fragmentation"): a message of `BUF`
//! bytes is delivered; one whose first frame already shows it cannot fit (its counter is the
//! message's frame count, so it says how long the message is at least) is refused at that frame,
//! counted as too long and holding no slot while its other frames pass — a slot held by a
//! message that can never complete would starve the streams that can; and one byte more than
//! `BUF`, which the counter cannot tell from `BUF`, is refused when its bytes run over, never
//! delivered.

use rtcan::{fragments, Expect, FrameId, Laxity, MessageId, Reassembler};

const BUF: usize = 24;

fn frames(stream: u16, len: usize) -> Vec<rtcan::Frame> {
    let template = FrameId { laxity: Laxity::NRT, message: MessageId(stream), fragment: 0 };
    let bytes: Vec<u8> = (0..len).map(|i| i as u8).collect();
    fragments(template, &bytes).unwrap().collect()
}

#[test]
fn a_message_of_the_buffers_size_is_delivered_and_a_longer_one_never_is() {
    let mut r: Reassembler<1, BUF> = Reassembler::new(10_000);
    let mut at = 0;
    let mut delivered = Vec::new();
    for f in frames(0x0201, BUF) {
        at += 100;
        if let Some(m) = r.accept(&f, at, Expect::Any) {
            delivered.push(m.data.to_vec());
        }
    }
    assert_eq!(delivered, vec![(0..BUF).map(|i| i as u8).collect::<Vec<u8>>()]);

    // BUF + 8 bytes: one frame more than BUF needs, refused as soon as its first frame arrives;
    // the one slot stays free.
    let long = frames(0x0202, BUF + 8);
    at += 100;
    assert!(r.accept(&long[0], at, Expect::Any).is_none());
    assert_eq!(r.stats().too_long, 1, "refused at the first frame");
    assert_eq!(r.partial_messages(), 0, "no slot held by a message that cannot fit");
    // Meanwhile another stream's message is reassembled in the free slot.
    let other = frames(0x0203, 12);
    let mut got = None;
    for (k, f) in other.iter().enumerate() {
        at += 100;
        if let Some(m) = r.accept(f, at, Expect::Any) {
            got = Some(m.data.len());
        }
        if let Some(rest) = long.get(k + 1) {
            at += 100;
            assert!(r.accept(rest, at, Expect::Any).is_none(), "the long message's frames pass");
        }
    }
    assert_eq!(got, Some(12));
    assert_eq!((r.stats().too_long, r.stats().completed), (1, 2));

    for rest in &long[other.len() + 1..] {
        at += 100;
        assert!(r.accept(rest, at, Expect::Any).is_none(), "the long message's frames pass");
    }
    // BUF + 1 bytes: as many frames as BUF, so taken in; refused when its last bytes run over.
    for f in frames(0x0204, BUF + 1) {
        at += 100;
        assert!(r.accept(&f, at, Expect::Any).is_none(), "never delivered");
    }
    assert_eq!((r.stats().too_long, r.stats().completed), (2, 2), "{:?}", r.stats());
    assert_eq!(r.partial_messages(), 0, "its slot is free again");
}

/// Whether a `B`-byte reassembler refuses `first` at once (too long, no slot held).
fn refused_at_first<const B: usize>(first: &rtcan::Frame) -> bool {
    let mut r: Reassembler<1, B> = Reassembler::new(10_000);
    assert!(r.accept(first, 100, Expect::Any).is_none());
    assert_eq!(r.partial_messages() == 0, r.stats().too_long == 1);
    r.stats().too_long == 1
}

/// The fewest bytes a first frame with counter `c` announces: (c − 1) frames of 8 bytes and
/// one more wire byte, less the 2-byte CRC, and never fewer than 9 (a multi-frame message
/// carries more than one frame's 8).
#[test]
fn the_first_frame_tells_the_fewest_bytes_its_message_has() {
    let two = frames(0x0301, 9);
    assert_eq!(two.len(), 2);
    assert!(refused_at_first::<8>(&two[0]) && !refused_at_first::<9>(&two[0]));
    let three = frames(0x0302, 15);
    assert_eq!(three.len(), 3);
    assert!(refused_at_first::<14>(&three[0]) && !refused_at_first::<15>(&three[0]));
}
