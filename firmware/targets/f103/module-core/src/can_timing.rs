//! The bxCAN's bit timing for [`BIT_RATE`](crate::BIT_RATE), computed when the image is built.
//!
//! embassy-stm32's `set_bitrate` computes it at boot (`can::util::calc_can_timings`): 160 B of
//! code in every module image, and a panic at boot for a clock it cannot divide. The clock is a
//! board file constant, so the same computation, as a `const fn`, gives the same register
//! values with no code, and a board whose clock cannot make the bit rate fails to build.

use core::num::{NonZeroU16, NonZeroU8};

use embassy_stm32::can::util::NominalBitTiming;

/// embassy-stm32 0.6's `calc_can_timings`, step for step (the most time quanta per bit up to
/// 10 at 1 Mbit/s, 17 below, that divide the clock; the sample point near 87.5 %; one quantum of
/// resynchronisation jump), so that the bxCAN is programmed exactly as `set_bitrate` did.
///
/// # Panics
/// At compile time, when `periph_hz` cannot make `bitrate` exactly.
pub const fn bit_timing(periph_hz: u32, bitrate: u32) -> NominalBitTiming {
    const BS1_MAX: u8 = 16;
    const BS2_MAX: u8 = 8;
    const MAX_SAMPLE_POINT_PERMILL: u16 = 900;
    assert!(bitrate >= 1000, "CAN bit rate too low");
    let max_quanta_per_bit: u8 = if bitrate >= 1_000_000 { 10 } else { 17 };
    let prescaler_bs = periph_hz / bitrate;
    let mut bs1_bs2_sum = max_quanta_per_bit - 1;
    while !prescaler_bs.is_multiple_of(1 + bs1_bs2_sum as u32) {
        assert!(bs1_bs2_sum > 2, "board file: no CAN bit timing for this clock");
        bs1_bs2_sum -= 1;
    }
    let prescaler = prescaler_bs / (1 + bs1_bs2_sum as u32);
    assert!(prescaler >= 1 && prescaler <= 1024, "board file: CAN prescaler out of range");
    let mut bs1 = ((7 * bs1_bs2_sum - 1) + 4) / 8;
    let mut bs2 = bs1_bs2_sum - bs1;
    // As embassy computes it: the ratio in integers (so 0), the rounding to zero never taken.
    let sample_point_permill = 1000 * ((1 + bs1) / (1 + bs1 + bs2)) as u16;
    if sample_point_permill > MAX_SAMPLE_POINT_PERMILL {
        bs1 = (7 * bs1_bs2_sum - 1) / 8;
        bs2 = bs1_bs2_sum - bs1;
    }
    assert!(bs1 >= 1 && bs1 <= BS1_MAX && bs2 >= 1 && bs2 <= BS2_MAX, "CAN segments out of range");
    assert!(
        periph_hz / (prescaler * (1 + bs1 + bs2) as u32) == bitrate,
        "board file: the clock cannot make the CAN bit rate exactly"
    );
    match (
        NonZeroU16::new(prescaler as u16),
        NonZeroU8::new(bs1),
        NonZeroU8::new(bs2),
        NonZeroU8::new(1),
    ) {
        (Some(prescaler), Some(seg1), Some(seg2), Some(sync_jump_width)) => {
            NominalBitTiming { prescaler, seg1, seg2, sync_jump_width }
        }
        _ => panic!("unreachable: every value checked above"),
    }
}
