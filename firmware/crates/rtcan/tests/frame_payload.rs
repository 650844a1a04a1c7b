//! A frame's payload as tools read it (the CLI's monitor, the pcap writer): its length, and
//! whether it is empty (a remote request or an event with no data).

use rtcan::{Frame, FrameId, Laxity, MessageId};

#[test]
fn a_frame_knows_its_payload_length() {
    let id = FrameId { laxity: Laxity::NRT, message: MessageId(0x4301), fragment: 0 };
    let empty = Frame::new(id, &[]).unwrap();
    let three = Frame::new(id, &[1, 2, 3]).unwrap();
    assert!(empty.is_empty() && empty.payload().is_empty());
    assert!(!three.is_empty());
    assert_eq!((three.len(), three.payload()), (3, &[1u8, 2, 3][..]));
}
