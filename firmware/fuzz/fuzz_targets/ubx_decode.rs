//! Any bytes from the GNSS receiver's UART (NMEA, UBX, noise, a baud-rate mismatch): the UBX
//! decoder never panics and accounts for every byte (in a returned frame, dropped, or held for
//! the frame in progress); the boot configuration at any rate byte is refused or decodes as its
//! four CFG frames.
#![no_main]

use libfuzzer_sys::fuzz_target;
use r2p_drivers::ubx::{self, Decoder, Error, Message};

fuzz_target!(|data: &[u8]| {
    let mut d = Decoder::new();
    let mut in_frames = 0usize;
    for &b in data {
        let held = d.held();
        if let Some(m) = d.push(b) {
            in_frames += held + 1;
            if let Message::Ack(..) | Message::Nak(..) = m {
                assert_eq!(held + 1, 10, "an ACK frame is 10 bytes");
            }
        }
        assert!(d.held() < ubx::MAX_FRAME);
    }
    assert_eq!(in_frames + d.stats().dropped_bytes as usize + d.held(), data.len());

    if let Some(&rate) = data.first() {
        let mut out = [0u8; ubx::BOOT_CONFIG_LEN];
        match ubx::boot_config(rate, &mut out) {
            Ok(n) => {
                let mut d = Decoder::new();
                let frames = out[..n].iter().filter_map(|&b| d.push(b)).count();
                assert_eq!((frames, d.stats().dropped_bytes), (4, 0));
            }
            Err(e) => assert_eq!(e, Error::Rate(rate)),
        }
    }
});
