//! Receivers that count messages rather than frames (the load benchmark's metrics, a bus
//! monitor) find a message's end by its fragment counter (docs/rtcan.md, "Fragmentation"):
//! exactly one frame of every message is its last, and it is the last one sent.

use rtcan::{FrameId, Laxity, MessageId};

#[test]
fn the_last_frame_of_a_message_is_the_one_fragments_ends_with() {
    use rtcan::fragment::is_last_frame;
    use rtcan::fragments;
    for len in [0, 1, 8, 9, 20, 61] {
        let template = FrameId { laxity: Laxity::NRT, message: MessageId(0x4301), fragment: 0 };
        let payload = [0xA5u8; 61];
        let frames: Vec<_> = fragments(template, &payload[..len]).unwrap().collect();
        let last: Vec<_> = frames.iter().map(|f| is_last_frame(f.id().fragment)).collect();
        assert_eq!(last.iter().filter(|&&l| l).count(), 1, "{len} bytes: one last frame");
        assert!(last[last.len() - 1], "{len} bytes: the last one");
    }
}
