//! Start-of-frame timestamps as a module gets them: the bxCAN model's counter captures and
//! interrupt stamps, corrected by the firmware's `rtcan::time_counter` (no harness correction).

use proptest::prelude::*;
use r2p_vbus::bxcan::MAX_RX_LATENCY_US;
use r2p_vbus::{Bus, BxCanPort, Config, EventKind, FrameBits};
use rtcan::wire_bits::bits_to_eof_end;
use rtcan::{CanController, Frame};

proptest! {
    /// The firmware's frame length (CRC-15 and stuffing computed on the MCU) is the bus's.
    #[test]
    fn firmware_frame_length_is_the_wire_length(
        raw in 0u32..(1 << 29),
        data in proptest::collection::vec(any::<u8>(), 0..=8),
    ) {
        let f = Frame::from_raw(raw, &data).unwrap();
        prop_assert_eq!(bits_to_eof_end(&f), FrameBits::of(&f).to_eof_end());
    }
}

/// 400 frames of varied lengths 0.3–20 ms apart (the 16-bit counter wraps every 65.5 ms at
/// 1 Mbit/s), each read at an irregular delay before the next one comes.
#[test]
fn received_frames_carry_their_start_of_frame() {
    let bus = Bus::new(2, Config::default());
    let mut tx = bus.port(0);
    let mut rx = BxCanPort::new(bus.port(1), 1_000_000);
    let mut got = Vec::new();
    let mut t = 1_006_000u64;
    for k in 0..400u64 {
        let h = k.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x6666;
        let len = (h >> 60) as usize % 9;
        let data: Vec<u8> = (0..len).map(|i| (h >> (8 * i)) as u8).collect();
        let f = Frame::from_raw((h >> 20) as u32 & 0x1FFF_FFFF, &data).unwrap();
        bus.advance_to(t);
        tx.try_transmit(&f).unwrap();
        let gap = 300_000 + (h >> 30) % 19_700_000;
        // Read somewhere between the frame's end and the next frame.
        bus.advance_to(t + 200_000 + (h >> 10) % (gap - 200_000));
        while let Some(r) = rx.try_receive() {
            got.push(r.at);
        }
        t += gap;
    }
    let starts: Vec<u64> = bus
        .trace()
        .into_iter()
        .filter_map(|e| match e.kind {
            EventKind::Sent { start_ns, .. } => Some(start_ns / 1_000),
            _ => None,
        })
        .collect();
    assert_eq!(got.len(), 400);
    assert_eq!(starts.len(), 400);
    assert!(starts.last().unwrap() - starts[0] > 40 * 65_536, "spans forty wraps");
    let mut exact_from = None;
    for (i, (&at, &sof)) in got.iter().zip(&starts).enumerate() {
        // Never early; late only by the smallest interrupt latency seen so far.
        assert!(at >= sof && at - sof <= MAX_RX_LATENCY_US, "frame {i}: {at} vs {sof}");
        if at != sof {
            assert!(exact_from.is_none(), "frame {i} inexact after an exact one");
        } else if exact_from.is_none() {
            exact_from = Some(i);
        }
    }
    println!("stamps exact from frame {exact_from:?} of {}", got.len());
    // The first two frames' interrupts were late (this start time makes them so): their stamps
    // are late by that; the first frame stamped with no latency relates the clocks for good.
    assert_eq!(exact_from, Some(2));
}
