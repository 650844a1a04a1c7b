//! When bxCAN declares a received frame valid (RM0008 §24.7.3: "no error until the last but
//! one bit of the EOF field"): one bit time before the end of its EOF. The node relates the
//! controller's start-of-frame counter to its clock from the receive interrupt that follows
//! (docs/rtcan.md, "Timestamps"), so an error of one bit here is a 1 µs error in every stamp.

use rtcan::time_counter::valid_at_bits;
use rtcan::wire_bits::{bits_to_eof_end, TAIL_BITS};
use rtcan::{Frame, FrameId, Laxity, MessageId};

#[test]
fn a_frame_is_valid_one_bit_before_the_end_of_its_eof() {
    let id = |m: u16| FrameId { laxity: Laxity::NRT, message: MessageId(m), fragment: 3 };
    for (m, data) in [(0x4301, &[][..]), (0x0000, &[0u8; 8][..]), (0xBEEF, &[0x55, 0xAA, 7][..])] {
        let f = Frame::new(id(m), data).unwrap();
        let end = bits_to_eof_end(&f);
        assert_eq!(valid_at_bits(&f), end - 1, "{f:?}");
        // At least the unstuffed bits of the frame up to the end of its EOF.
        assert!(valid_at_bits(&f) >= 54 + 8 * data.len() as u32 + TAIL_BITS - 1);
    }
}

#[test]
fn the_counter_is_related_to_the_clock_by_the_first_received_frame() {
    use rtcan::time_counter::TimeCounter;
    let mut tc = TimeCounter::new(1_000_000).unwrap();
    assert!(!tc.is_related() && tc.start_of_frame(100, 5_000).is_none());
    let f =
        Frame::new(FrameId { laxity: Laxity::NRT, message: MessageId(0x4301), fragment: 0 }, &[1])
            .unwrap();
    tc.observe(&f, 1_000, 1_000 + u64::from(valid_at_bits(&f)) + 3);
    assert!(tc.is_related());
}
