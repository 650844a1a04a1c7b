//! Any sequence of frames, times and expiries into the reassembler: it never panics, never
//! returns more bytes than its buffer holds, and a stream of fixed-size messages only ever
//! yields messages of that size.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rtcan::fragment::MAX_MESSAGE_LEN;
use rtcan::{Expect, Frame, Reassembler};

fuzz_target!(|data: &[u8]| {
    let mut r: Reassembler<4, 256> = Reassembler::new(5_000);
    let mut now: u64 = 0;
    // Each record: 1 control byte, a 3-byte ID tail, 1 length byte, then up to 8 payload bytes.
    for rec in data.chunks(13) {
        if rec.len() < 5 {
            break;
        }
        now += u64::from(rec[0] & 0x0F) * 700;
        if rec[0] & 0x80 != 0 {
            r.expire(now);
        }
        // Few message IDs so that streams interleave and collide.
        let raw = u32::from_le_bytes([rec[1], rec[2] & 0x83, rec[3] & 0x01, 0]) & 0x1FFF_FFFF;
        let len = (rec[4] as usize % 9).min(rec.len() - 5);
        let Ok(frame) = Frame::from_raw(raw, &rec[5..5 + len]) else { continue };
        let expect = if rec[0] & 0x40 != 0 { Expect::Exactly(20) } else { Expect::Any };
        if let Some(msg) = r.accept(&frame, now, expect) {
            assert!(msg.data.len() <= MAX_MESSAGE_LEN.min(256));
            if let Expect::Exactly(n) = expect {
                assert_eq!(msg.data.len(), n);
            }
        }
    }
    let s = r.stats();
    let _ = (s.completed, s.duplicate, s.foreign, s.out_of_order, s.truncated, s.timed_out);
});
