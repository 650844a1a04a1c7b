//! Laxity: how much time an SRT frame has left before its deadline, squeezed into 6 bits.
//!
//! Code 0 is HRT and 63 is NRT; SRT frames use 1..=62, smaller meaning more urgent, so CAN's
//! arbitration approximates earliest-deadline-first across the whole bus. A sender recomputes
//! the code each time it (re)queues a frame. Two encodings (docs/rtcan.md, "Laxity"):
//!
//! * **linear**: code = 1 + remaining ticks, saturating at 62 — uniform resolution, short range;
//! * **logarithmic**: code = 1 + ⌊4·log₂(1 + remaining ticks)⌋, saturating at 62 — a quarter
//!   octave per code, fine near the deadline and reaching ~39 000 ticks. It is defined by the
//!   integer table [`LOG_THRESHOLDS`], so every implementation encodes identically.

/// The traffic class of a frame: what its identifier's laxity field says, and all that a node
/// can tell about any frame on the wire. Distinct from a publisher's class
/// (`r2p_middleware::Class`, which carries the period or deadline the sender schedules by) and
/// from the class a topic is advertised with (`r2p_management::message::BusClass`, its period
/// in cycles of the bus).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameClass {
    /// Hard real-time: periodic, sent only in its reserved TDMA slot (laxity 0).
    Hrt,
    /// Soft real-time: deadline-driven, sent in free slots; laxity 1..=62.
    Srt,
    /// Non-real-time: best effort, lowest priority (laxity 63), never promoted.
    Nrt,
}

/// The 6-bit laxity field of an RTCAN identifier.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Laxity(u8);

/// Largest SRT laxity code (the least urgent SRT frame).
pub const SRT_MAX: u8 = 62;

impl Laxity {
    /// Hard real-time: all dominant.
    pub const HRT: Laxity = Laxity(0);
    /// Non-real-time: all recessive.
    pub const NRT: Laxity = Laxity(63);

    /// The laxity with this code; only the low 6 bits are kept.
    pub const fn from_code(code: u8) -> Self {
        Laxity(code & 0x3F)
    }

    /// The 6-bit code.
    pub const fn code(self) -> u8 {
        self.0
    }

    /// The traffic class the code stands for.
    pub const fn class(self) -> FrameClass {
        match self.0 {
            0 => FrameClass::Hrt,
            63 => FrameClass::Nrt,
            _ => FrameClass::Srt,
        }
    }
}

/// How remaining time maps to an SRT laxity code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LaxityEncoding {
    /// One code per tick of `tick_us` microseconds.
    Linear {
        /// Microseconds per tick.
        tick_us: u32,
    },
    /// A quarter octave of ticks of `tick_us` microseconds per code.
    Logarithmic {
        /// Microseconds per tick.
        tick_us: u32,
    },
}

/// `LOG_THRESHOLDS[c]` is the fewest remaining ticks that encode as code `c` or above
/// (index 0 unused): ⌈2^((c−1)/4)⌉ − 1, computed in Q16 fixed point.
pub const LOG_THRESHOLDS: [u32; SRT_MAX as usize + 1] = log_thresholds();

/// [`LOG_THRESHOLDS`] as the encoder reads it: every threshold is below 2¹⁶ (the largest,
/// code 62's, is 38 967), so half-words, which halve the table in flash (252 → 126 B) and load
/// in the same one instruction.
const THRESHOLDS_U16: [u16; SRT_MAX as usize + 1] = {
    let mut t = [0u16; SRT_MAX as usize + 1];
    let mut code = 0;
    while code <= SRT_MAX as usize {
        assert!(LOG_THRESHOLDS[code] <= u16::MAX as u32);
        t[code] = LOG_THRESHOLDS[code] as u16;
        code += 1;
    }
    t
};

const fn log_thresholds() -> [u32; SRT_MAX as usize + 1] {
    // 2^(k/4) for k = 0..3 in Q16, rounded to nearest.
    const FRAC_Q16: [u64; 4] = [65_536, 77_936, 92_682, 110_218];
    let mut t = [0u32; SRT_MAX as usize + 1];
    let mut code = 1;
    while code <= SRT_MAX as usize {
        let n = code - 1;
        let pow_q16 = FRAC_Q16[n % 4] << (n / 4);
        t[code] = (((pow_q16 + 0xFFFF) >> 16) - 1) as u32;
        code += 1;
    }
    t
}

impl LaxityEncoding {
    /// The SRT code for a frame whose deadline is `remaining_us` away, or `None` if the deadline
    /// has passed (`remaining_us == 0`): such a frame is not sent and the miss is reported.
    pub fn encode(self, remaining_us: u32) -> Option<Laxity> {
        if remaining_us == 0 {
            return None;
        }
        let code = match self {
            LaxityEncoding::Linear { tick_us } => {
                let ticks = remaining_us / tick_us.max(1);
                1 + ticks.min(SRT_MAX as u32 - 1) as u8
            }
            LaxityEncoding::Logarithmic { tick_us } => {
                let ticks = remaining_us / tick_us.max(1);
                // Largest code whose threshold is <= ticks; thresholds are non-decreasing.
                THRESHOLDS_U16[1..].partition_point(|&t| u32::from(t) <= ticks) as u8
            }
        };
        Some(Laxity(code))
    }

    /// The least remaining time, in microseconds, that encodes as `laxity` (an SRT code).
    pub fn lower_bound_us(self, laxity: Laxity) -> u32 {
        let code = laxity.code().clamp(1, SRT_MAX) as u32;
        match self {
            LaxityEncoding::Linear { tick_us } => (code - 1) * tick_us,
            LaxityEncoding::Logarithmic { tick_us } => {
                u32::from(THRESHOLDS_U16[code as usize]).saturating_mul(tick_us)
            }
        }
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    const LIN: LaxityEncoding = LaxityEncoding::Linear { tick_us: 100 };
    const LOG: LaxityEncoding = LaxityEncoding::Logarithmic { tick_us: 100 };

    r2p_testkit::suite! {
        fn expired_deadlines_have_no_code() {
            assert_eq!(LIN.encode(0), None);
            assert_eq!(LOG.encode(0), None);
        }

        fn linear_is_one_code_per_tick_then_saturates() {
            assert_eq!(LIN.encode(1).unwrap().code(), 1);
            assert_eq!(LIN.encode(99).unwrap().code(), 1);
            assert_eq!(LIN.encode(100).unwrap().code(), 2);
            assert_eq!(LIN.encode(6_099).unwrap().code(), 61);
            assert_eq!(LIN.encode(6_100).unwrap().code(), 62);
            assert_eq!(LIN.encode(u32::MAX).unwrap().code(), 62);
        }

        fn log_table_matches_its_definition() {
            // Spot values of ceil(2^((c-1)/4)) - 1.
            assert_eq!(LOG_THRESHOLDS[1], 0);
            assert_eq!(LOG_THRESHOLDS[5], 1);
            assert_eq!(LOG_THRESHOLDS[9], 3);
            assert_eq!(LOG_THRESHOLDS[10], 4); // ceil(4.757) - 1
            assert_eq!(LOG_THRESHOLDS[41], 1_023);
            assert_eq!(LOG_THRESHOLDS[62], 38_967); // ceil(2^15.25 = 38967.5...) - 1
        }

        fn log_codes_are_monotonic_and_saturate() {
            let mut last = 0;
            let mut us = 1;
            while us < 10_000_000 {
                let code = LOG.encode(us).unwrap().code();
                assert!(code >= last && (1..=SRT_MAX).contains(&code));
                last = code;
                us += 1 + us / 64;
            }
            assert_eq!(last, SRT_MAX);
        }

        fn lower_bound_inverts_encode() {
            for enc in [LIN, LOG] {
                for code in 1..=SRT_MAX {
                    let lax = Laxity::from_code(code);
                    let floor = enc.lower_bound_us(lax).max(1);
                    let got = enc.encode(floor).unwrap().code();
                    // Codes that share a threshold collapse to the highest of them.
                    assert!(got >= code, "{:?} code {} -> {} us -> {}", enc, code, floor, got);
                    if floor > 1 {
                        assert!(enc.encode(floor - 1).unwrap().code() < got || got == 1);
                    }
                }
            }
        }

        fn closer_deadlines_never_lose_to_farther_ones() {
            for enc in [LIN, LOG] {
                let mut prev = enc.encode(1).unwrap();
                for us in (1..200_000).step_by(37) {
                    let lax = enc.encode(us).unwrap();
                    assert!(lax >= prev);
                    prev = lax;
                }
            }
        }
    }
}

/// The shared vectors every implementation must pass (tests/vectors/rtcan/laxity.json).
#[cfg(test)]
mod vectors {
    use super::*;
    use serde::Deserialize;
    use std::vec::Vec;

    #[derive(Deserialize)]
    struct Case {
        tick_us: u32,
        remaining_us: u32,
        linear: Option<u8>,
        logarithmic: Option<u8>,
    }

    #[derive(Deserialize)]
    struct Vectors {
        log_thresholds: Vec<u32>,
        cases: Vec<Case>,
    }

    #[test]
    fn laxity_vectors() {
        let v: Vectors =
            serde_json::from_str(include_str!("../../../../tests/vectors/rtcan/laxity.json"))
                .unwrap();
        assert_eq!(v.log_thresholds[1..], LOG_THRESHOLDS[1..]);
        for c in &v.cases {
            let lin = LaxityEncoding::Linear { tick_us: c.tick_us };
            let log = LaxityEncoding::Logarithmic { tick_us: c.tick_us };
            assert_eq!(
                lin.encode(c.remaining_us).map(Laxity::code),
                c.linear,
                "{:?}",
                c.remaining_us
            );
            assert_eq!(
                log.encode(c.remaining_us).map(Laxity::code),
                c.logarithmic,
                "{:?}",
                c.remaining_us
            );
        }
    }
}
