//! Any bytes on a management stream: decoding never panics, and whatever decodes re-encodes
//! to exactly the same bytes (one encoding per message, so nodes agree on what they heard).
#![no_main]

use libfuzzer_sys::fuzz_target;
use r2p_management::message::{Message, ENCODED_MAX};

fuzz_target!(|data: &[u8]| {
    if let Ok(msg) = Message::decode(data) {
        let mut buf = [0u8; ENCODED_MAX];
        let n = msg.encode(&mut buf).expect("a decoded message fits ENCODED_MAX");
        assert_eq!(&buf[..n], data);
    }
});
