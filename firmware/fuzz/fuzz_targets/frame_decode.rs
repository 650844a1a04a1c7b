//! Any 4-byte identifier and any payload from the bus: decoding never panics, and whatever
//! decodes re-encodes to the same identifier.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rtcan::{Frame, FrameId};

fuzz_target!(|data: &[u8]| {
    if data.len() < 4 {
        return;
    }
    let raw = u32::from_le_bytes([data[0], data[1], data[2], data[3]]);
    let payload = &data[4..];
    match FrameId::from_raw(raw) {
        Ok(id) => {
            assert_eq!(id.to_raw(), raw);
            let _ = id.class();
            let _ = id.sync_cycle();
        }
        Err(_) => assert!(raw >= 1 << 29),
    }
    match Frame::from_raw(raw, payload) {
        Ok(frame) => {
            assert!(payload.len() <= 8);
            assert_eq!(frame.payload(), payload);
        }
        Err(_) => assert!(payload.len() > 8 || raw >= 1 << 29),
    }
});
