//! Start-of-frame timestamps from bxCAN's time-triggered communication mode (TTCM).
//!
//! With `CAN_MCR.TTCM` set, bxCAN runs a 16-bit counter that advances once per CAN bit time
//! and captures it at the sample point of every frame's start of frame, received
//! (`CAN_RDTxR.TIME`) or sent (`CAN_TDTxR.TIME`) (RM0008 §24.7.2). The counter cannot be read
//! directly, so it is related to the node's µs clock by the receive interrupt: the controller
//! declares a frame valid [`valid_at_bits`] bit times after its start of frame (one bit before
//! the end of its EOF), and the interrupt stamps the node's time then, a little later. Each frame gives
//! a sample of (node clock − counter) that is the true offset plus that interrupt's latency;
//! the smallest sample seen is the offset (both clocks come from the same crystal, so the
//! offset does not drift). A capture is then extended to the node's 64-bit µs by the time
//! elapsed since it, taken modulo 2¹⁶ bit times: exact as long as the frame is read within
//! 65 536 bit times of its start (65.5 ms at 1 Mbit/s; the node reads every slot).
//!
//! Scaling: one count is one bit time, 1 µs at 1 Mbit/s, 1 000 000 / `bit_rate` µs in general
//! (bit rates whose bit time is a whole number of µs); the node's clock is turned into bit
//! times as ⌊t / bit time⌋.

use crate::controller::Micros;
use crate::wire_bits::bits_to_eof_end;
use crate::Frame;

/// Counts of the 16-bit `TIME` counter before it wraps.
pub const TIME_COUNTER_MODULUS: u64 = 1 << 16;

/// Bit times before the end of EOF at which bxCAN declares a received frame valid and raises
/// its FIFO's message-pending interrupt: "no error until the last but one bit of the EOF
/// field" (RM0008 §24.7.3), so at the end of EOF's sixth bit.
pub const VALID_BEFORE_EOF_END_BITS: u32 = 1;

/// Bit times from a received frame's start of frame to the instant bxCAN declares it valid.
pub fn valid_at_bits(frame: &Frame) -> u32 {
    bits_to_eof_end(frame) - VALID_BEFORE_EOF_END_BITS
}

/// Relates bxCAN's 16-bit bit-time counter to the node's µs clock (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TimeCounter {
    /// µs per bit time.
    us_per_bit: u32,
    /// (node clock in bit times − counter) mod 2¹⁶, the smallest sample seen; none before the
    /// first received frame.
    offset: Option<u16>,
}

/// `t` / `d` for `d` < 2¹⁶ with 32-bit divisions only (the Cortex-M3 divides 32-bit numbers in
/// hardware; a 64-bit division would link ~900 bytes of software division into the image).
fn div_small(t: u64, d: u32) -> u64 {
    if d == 1 {
        return t;
    }
    let mut q = 0u64;
    let mut rem = 0u32;
    for shift in [48, 32, 16, 0] {
        let cur = rem << 16 | (t >> shift) as u32 & 0xffff;
        q = q << 16 | u64::from(cur / d);
        rem = cur % d;
    }
    q
}

impl TimeCounter {
    /// A counter of a bus at `bit_rate` bit/s, not yet related to the clock; `None` unless a
    /// bit time is a whole number of µs (1 Mbit/s, 500, 250, 125, 100, 50, 20, 10 kbit/s …).
    pub const fn new(bit_rate: u32) -> Option<Self> {
        if bit_rate == 0 || 1_000_000 % bit_rate != 0 || 1_000_000 / bit_rate >= 1 << 16 {
            return None;
        }
        Some(Self { us_per_bit: 1_000_000 / bit_rate, offset: None })
    }

    /// The node's time `t` in whole bit times.
    fn bits(&self, t: Micros) -> u64 {
        div_small(t, self.us_per_bit)
    }

    /// Bit times `b` in µs.
    fn micros(&self, b: u64) -> Micros {
        b * Micros::from(self.us_per_bit)
    }

    /// (node clock − counter) mod 2¹⁶ for a frame captured at `capture` and found valid
    /// `valid_bits` bit times later, at or before the node's time `stamped_at`.
    fn sample(&self, capture: u16, valid_bits: u32, stamped_at: Micros) -> u16 {
        (self.bits(stamped_at).wrapping_sub(u64::from(capture)).wrapping_sub(u64::from(valid_bits))
            % TIME_COUNTER_MODULUS) as u16
    }

    /// A received frame: `capture` its `TIME`, `stamped_at` the node's time the receive
    /// interrupt took at or after the frame became valid ([`valid_at_bits`]). Refines the offset (smallest sample wins;
    /// a sample is the offset plus that interrupt's latency, and latencies are far below
    /// 2¹⁵ bit times, so "smaller" is taken modulo 2¹⁶).
    pub fn observe(&mut self, frame: &Frame, capture: u16, stamped_at: Micros) {
        let s = self.sample(capture, valid_at_bits(frame), stamped_at);
        self.offset = Some(match self.offset {
            Some(o) if (s.wrapping_sub(o) as i16) >= 0 => o,
            _ => s,
        });
    }

    /// Whether a frame has related the counter to the node's clock.
    pub const fn is_related(&self) -> bool {
        self.offset.is_some()
    }

    /// The node's time of the start of frame captured as `capture`, read at `now` (at most
    /// 65 535 bit times after it); `None` before any frame was observed.
    pub fn start_of_frame(&self, capture: u16, now: Micros) -> Option<Micros> {
        let offset = u64::from(self.offset?);
        let now_bits = self.bits(now);
        let counter_now = now_bits.wrapping_sub(offset) % TIME_COUNTER_MODULUS;
        let elapsed = counter_now.wrapping_sub(u64::from(capture)) % TIME_COUNTER_MODULUS;
        Some(self.micros(now_bits.saturating_sub(elapsed)))
    }

    /// A received frame's start of frame: observes it, then extends its capture.
    pub fn stamp_received(
        &mut self,
        frame: &Frame,
        capture: u16,
        stamped_at: Micros,
        now: Micros,
    ) -> Micros {
        self.observe(frame, capture, stamped_at);
        self.start_of_frame(capture, now).unwrap_or(stamped_at)
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    /// The counter as bxCAN runs it: started at an arbitrary phase.
    fn counter_at(t: Micros, phase: u64, bit_rate: u64) -> u16 {
        ((u128::from(t) * u128::from(bit_rate) / 1_000_000 + u128::from(phase))
            % u128::from(TIME_COUNTER_MODULUS)) as u16
    }

    fn sync() -> Frame {
        Frame::from_raw(0x0000_2280, &[6, 0, 0, 0, 0, 0, 0, 0]).unwrap()
    }

    r2p_testkit::suite! {
        fn captures_across_the_wrap_extend_exactly() {
            let f = sync();
            let len = Micros::from(valid_at_bits(&f));
            let phase = 0xFFF0;
            let mut tc = TimeCounter::new(1_000_000).unwrap();
            assert_eq!(tc.start_of_frame(0, 0), None);
            // A frame stamped without delay relates the clocks; later ones are 3 µs late.
            tc.observe(&f, counter_at(500, phase, 1_000_000), 500 + len);
            // Frames whose start lies 20 µs before, at and after the counter's wrap, read up
            // to 65 ms later; the node's clock far past 2^16 and 2^32 µs.
            for base in [1_000u64, 1 << 16, 1 << 32, (1 << 40) + 7] {
                let wrap = base + (TIME_COUNTER_MODULUS - (base + phase) % TIME_COUNTER_MODULUS);
                for sof in [wrap - 20, wrap - 1, wrap, wrap + 1, wrap + 300] {
                    let cap = counter_at(sof, phase, 1_000_000);
                    let isr = sof + len + 3;
                    for read in [isr, isr + 1_000, sof + 65_535] {
                        assert_eq!(tc.stamp_received(&f, cap, isr, read), sof, "{sof} {read}");
                    }
                }
            }
        }

        fn the_smallest_interrupt_latency_sets_the_offset() {
            let f = sync();
            let len = Micros::from(valid_at_bits(&f));
            let mut tc = TimeCounter::new(1_000_000).unwrap();
            // First frame stamped 9 µs late: its start of frame reads 9 µs late.
            let cap = counter_at(1_000, 77, 1_000_000);
            assert_eq!(tc.stamp_received(&f, cap, 1_000 + len + 9, 2_000), 1_009);
            // A frame stamped without delay corrects it, for every later frame too.
            let cap = counter_at(5_000, 77, 1_000_000);
            assert_eq!(tc.stamp_received(&f, cap, 5_000 + len, 6_000), 5_000);
            let cap = counter_at(9_000, 77, 1_000_000);
            assert_eq!(tc.stamp_received(&f, cap, 9_000 + len + 40, 9_500), 9_000);
        }

        fn bit_rates_without_a_whole_us_bit_time_are_refused() {
            assert!(TimeCounter::new(800_000).is_none());
            assert!(TimeCounter::new(0).is_none());
            assert!(TimeCounter::new(15).is_none());
            assert!(TimeCounter::new(20).is_some());
            // The 32-bit long division agrees with the 64-bit one.
            for t in [0u64, 1, 65_535, 1 << 32, (1 << 40) + 12_345, u64::MAX] {
                for d in [1u32, 2, 8, 10, 1_000, 50_000] {
                    assert_eq!(div_small(t, d), t / u64::from(d), "{t} / {d}");
                }
            }
        }

        fn other_bit_rates_scale_by_the_bit_time() {
            // 125 kbit/s: one count is 8 µs; the counter wraps every 524 ms.
            let f = sync();
            let len = Micros::from(valid_at_bits(&f)) * 8;
            let mut tc = TimeCounter::new(125_000).unwrap();
            for sof in [8 * 65_530, 8 * 65_536, 8 * 65_541, 8 * 1_000_003] {
                let cap = counter_at(sof, 12_345, 125_000);
                assert_eq!(tc.stamp_received(&f, cap, sof + len, sof + 400_000), sof);
            }
        }
    }

    #[cfg(test)]
    mod props {
        use super::*;
        use proptest::prelude::*;

        proptest! {
            /// Any start of frame, counter phase, interrupt latency (an earlier frame stamped
            /// promptly is the one to beat) and read under 2^16 bit times after the start of
            /// frame: exact at 1 Mbit/s.
            #[test]
            fn extension_is_exact_within_the_counter_range(
                sof in 0u64..(1 << 48),
                phase in 0u64..TIME_COUNTER_MODULUS,
                delay in 0u64..65_000,
                latency in 0u64..2_000,
                earlier in 1u64..1_000_000,
            ) {
                let f = sync();
                let len = Micros::from(valid_at_bits(&f));
                let mut tc = TimeCounter::new(1_000_000).unwrap();
                // An earlier frame stamped promptly relates the clocks.
                let t0 = sof.saturating_sub(earlier);
                tc.observe(&f, counter_at(t0, phase, 1_000_000), t0 + len);
                let cap = counter_at(sof, phase, 1_000_000);
                let isr = sof + len + latency;
                let read = (isr + delay).min(sof + 65_535);
                prop_assert_eq!(tc.stamp_received(&f, cap, isr, read), sof);
            }
        }
    }
}
