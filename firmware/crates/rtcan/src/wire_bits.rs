//! A frame's exact length on the wire, stuff bits included, computed on the MCU.
//!
//! The receive side needs it to relate the CAN controller's time counter to the node's clock
//! ([`crate::time_counter`]): the receive interrupt fires a known number of bit times after
//! the start of frame, and that number depends on the frame's bits (CRC-15 and stuffing), not
//! only on its length. No heap: the bits are generated and counted as they go.

use crate::Frame;

/// CRC-15 generator polynomial of ISO 11898-1 (x¹⁵+x¹⁴+x¹⁰+x⁸+x⁷+x⁴+x³+1, without x¹⁵).
const CRC15_POLY: u16 = 0x4599;

/// Unstuffed bits after the CRC sequence up to the end of EOF: CRC delimiter, ACK slot, ACK
/// delimiter, 7 EOF bits.
pub const TAIL_BITS: u32 = 1 + 2 + 7;

/// Counts the bits of an extended data frame from SOF to the end of the CRC sequence, as the
/// transmitter sends them: the running CRC-15 and the stuff bits (one after every 5 equal bits,
/// the stuff bit starting the next run).
struct Counter {
    crc: u16,
    bits: u32,
    stuff: u32,
    /// The last bit sent (0 or 1), [`NO_BIT`] before the first: a word, not an
    /// `Option<bool>`, so the per-bit comparison needs no byte extension.
    last: u32,
    run: u32,
}

/// `Counter::last` before the first bit.
const NO_BIT: u32 = 2;

impl Counter {
    fn bit(&mut self, bit: bool, in_crc: bool) {
        if !in_crc {
            let feedback = bit ^ (self.crc & 0x4000 != 0);
            self.crc = (self.crc << 1) & 0x7fff;
            if feedback {
                self.crc ^= CRC15_POLY;
            }
        }
        self.bits += 1;
        if self.last == u32::from(bit) {
            self.run += 1;
        } else {
            self.last = u32::from(bit);
            self.run = 1;
        }
        if self.run == 5 {
            self.stuff += 1;
            self.last = u32::from(!bit);
            self.run = 1;
        }
    }

    fn field(&mut self, value: u32, width: u32) {
        for i in (0..width).rev() {
            self.bit(value >> i & 1 == 1, false);
        }
    }
}

/// Bit times of `frame` (29-bit identifier, data) from its start of frame to the end of its
/// EOF, stuff bits included: when receivers take it and its sender is done.
pub fn bits_to_eof_end(frame: &Frame) -> u32 {
    let raw = frame.id().to_raw();
    let data = frame.payload();
    let mut c = Counter { crc: 0, bits: 0, stuff: 0, last: NO_BIT, run: 0 };
    // SOF (0), the identifier's 11 high bits, SRR (1), IDE (1) and its 18 low bits: 32 bits,
    // one field; then RTR (0: a data frame), r1, r0 (0) and the 4-bit DLC. Two fields instead
    // of nine: one copy of the bit loop each (the image's code) and fewer loops to run.
    c.field((raw >> 18 & 0x7ff) << 20 | 0b11 << 18 | (raw & 0x3_ffff), 32);
    c.field(data.len() as u32, 7);
    for &b in data {
        c.field(u32::from(b), 8);
    }
    let crc = c.crc;
    for i in (0..15).rev() {
        c.bit(crc >> i & 1 == 1, true);
    }
    c.bits + c.stuff + TAIL_BITS
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    r2p_testkit::suite! {
        fn lengths_of_known_frames() {
            // The empty NRT frame 0x1F80_8000: 54 unstuffed bits to the CRC's end, plus stuffing.
            let f = Frame::from_raw(0x1F80_8000, &[]).unwrap();
            let n = bits_to_eof_end(&f);
            assert!((54 + TAIL_BITS..=54 + 13 + TAIL_BITS).contains(&n), "{n}");
            // 8 data bytes: 118 unstuffed bits + tail; never more than the worst case.
            let f = Frame::from_raw(0x0000_2280, &[0; 8]).unwrap();
            let n = bits_to_eof_end(&f);
            assert!(n >= 118 + TAIL_BITS);
            assert!(n <= crate::cycle::WORST_CASE_FRAME_BITS - crate::cycle::INTERFRAME_BITS);
            // All-zero data stuffs once per 4 bits after the first 5.
            let zeros = Frame::from_raw(0, &[0; 8]).unwrap();
            assert!(bits_to_eof_end(&zeros) > bits_to_eof_end(&f) - 10);
        }

        fn exact_lengths_stay_those_of_the_field_by_field_count() {
            // Computed with the count written field by field (SOF, 11 identifier bits, SRR,
            // IDE, 18 bits, RTR, r1, r0, DLC), before the header became two fields; the two
            // agreed on 3 million random frames.
            for (raw, data, bits) in [
                (0x1F80_8000, &[][..], 71),
                (0x0000_2280, &[0u8; 8][..], 145),
                (0, &[0u8; 8][..], 147),
                (0x1FFF_FFFF, &[0xffu8; 8][..], 146),
                (0x0123_4567, &[1u8, 2, 3][..], 95),
            ] {
                assert_eq!(bits_to_eof_end(&Frame::from_raw(raw, data).unwrap()), bits, "{raw:#x}");
            }
        }
    }
}
