//! A virtual CAN 2.0B bus for emulated R2P boards.
//!
//! Emulated boards run the same firmware core (RTCAN, the middleware, the node runtime) as the
//! modules; what replaces the bxCAN peripheral is a [`Port`] of this bus, which implements
//! [`rtcan::CanController`]. The bus is sans-IO and deterministic: virtual time (ns) advances
//! only when the caller says so ([`Bus::advance_to`], [`Bus::step`]), and a seed drives every
//! probabilistic fault, so the same seed and inputs give the same [event log](Bus::trace).
//!
//! Modelled (classic CAN 2.0B, extended data frames, default 1 Mbit/s):
//! - exact frame durations from the frame's bits: CRC-15, bit stuffing over SOF..CRC, CRC
//!   delimiter, ACK, EOF and intermission ([`bits`]);
//! - arbitration: requests pending when the bus goes idle start together, the lowest
//!   identifier wins, losers retry at the next idle; each port offers its oldest mailbox
//!   (transmit FIFO priority, as RTCAN sets bxCAN) or its lowest-ID one ([`TxOrder`]);
//! - delivery to every other active port on the segment at end of EOF (µs timestamps),
//!   acceptance filters, a bounded receive FIFO with overflows counted, transmit confirmation;
//! - error frames and fault confinement (TEC/REC, error passive, bus-off, recovery after
//!   128 × 11 recessive bits), a missing ACK when a sender is alone;
//! - fault injection: dropped or corrupted frames ([`FaultRule`]), babbling ports
//!   ([`Bus::babble`]), power cycling ([`Bus::power`]) and partitions ([`Bus::partition`]).
//!
//! ```
//! use r2p_vbus::{Bus, Config};
//! use rtcan::{CanController, Frame, FrameId};
//!
//! let bus = Bus::new(2, Config::default());
//! let (mut a, mut b) = (bus.port(0), bus.port(1));
//! a.try_transmit(&Frame::new(FrameId::sync(0), &[1, 2]).unwrap()).unwrap();
//! bus.run_until_idle(1_000_000);
//! let rx = b.try_receive().unwrap();
//! assert_eq!(rx.frame.payload(), &[1, 2]);
//! ```

pub mod bits;
mod bus;
pub mod bxcan;
mod rng;

pub use bits::FrameBits;
pub use bus::{
    Bus, Config, ErrorCause, Event, EventKind, FaultAction, FaultRule, Port, TxOrder, MAILBOXES,
};
pub use bxcan::BxCanPort;

#[cfg(test)]
mod tests {
    use super::bits::*;
    use rtcan::cycle::WORST_CASE_FRAME_BITS;

    fn bytes_to_bits(bytes: &[u8]) -> Vec<bool> {
        bytes.iter().flat_map(|b| (0..8).rev().map(move |i| b >> i & 1 == 1)).collect()
    }

    #[test]
    fn crc15_check_value() {
        // The CRC-15/CAN catalogue check value: CRC of ASCII "123456789".
        assert_eq!(crc15(bytes_to_bits(b"123456789")), 0x059e);
    }

    #[test]
    fn crc15_of_frame_leaves_zero_remainder() {
        let bits = unstuffed_bits(0x1abc_def0 & 0x1fff_ffff, &[0xde, 0xad, 0xbe, 0xef]);
        assert_eq!(crc15(bits.iter().copied()), 0);
        assert_eq!(bits.len(), 54 + 32);
    }

    #[test]
    fn all_zero_frame_hand_counted() {
        // SOF + 11 ID zeros: stuff after 5 and 10; SRR, IDE ones; then 18 ID + RTR, r1, r0 +
        // 4 DLC = 25 zeros: 5 stuff bits (the last a 1). CRC = 0x4610 = 100011000010000: the
        // stuff bit and its leading 1 make a run of 2, no run reaches 5. 54 + 7 + 10 + 3 = 74.
        let bits = unstuffed_bits(0, &[]);
        assert_eq!(crc15(bits[..39].iter().copied()), 0x4610);
        let b = FrameBits::of_raw(0, &[]);
        assert_eq!((b.stuffable, b.stuff), (54, 7));
        assert_eq!(b.total(), 74);
    }

    #[test]
    fn all_zero_data_stuffs_every_fifth_bit() {
        let zeros = FrameBits::of_raw(0, &[0; 8]);
        // 2 stuff bits in SOF+base ID, 4 in the 21 zeros after SRR/IDE; DLC 1000 then 64 data
        // zeros and the CRC's (0x3daf) leading 0 make 68 zeros: 13 more. 118 + 19 + 13 = 150.
        assert_eq!(crc15(unstuffed_bits(0, &[0; 8])[..103].iter().copied()), 0x3daf);
        assert_eq!((zeros.stuffable, zeros.stuff), (118, 19));
        assert_eq!(zeros.total(), 150);
        // Alternating data needs no stuffing in the data field.
        let alt = FrameBits::of_raw(0x155_5555, &[0x55; 8]);
        assert!(alt.stuff < zeros.stuff);
        assert!(zeros.total() <= WORST_CASE_FRAME_BITS);
    }

    #[test]
    fn runs_of_four_after_stuffing_approach_the_bound() {
        // 0000 0 [1] 1111 [0] 0000 [1] ... : a stuff bit every 4 bits after the first 5.
        let mut bits = vec![false; 5];
        for i in 0..28 {
            bits.extend([i % 2 == 0; 4]);
        }
        assert_eq!(stuff_count(&bits[..117]), (117 - 1) / 4);
    }

    #[test]
    fn exhaustive_small_never_exceeds_worst_case() {
        let mut max = 0;
        for id in (0..0x2000_0000u32).step_by(0x0012_3457) {
            for pattern in [0x00u8, 0xff, 0x0f, 0xf0, 0x3c, 0x87, 0x78, 0xe1, 0x1e] {
                for len in 0..=8 {
                    let b = FrameBits::of_raw(id, &vec![pattern; len]);
                    assert!(b.total() <= WORST_CASE_FRAME_BITS);
                    max = max.max(b.total());
                }
            }
        }
        assert!(max > 150);
    }
}
