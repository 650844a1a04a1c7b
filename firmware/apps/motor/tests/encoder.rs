//! The 16-bit timer count extended to 32 bits, across many wraps in both directions.

use proptest::prelude::*;
use r2p_app_motor::encoder::{Encoder, Scale};

/// Feeds `steps` moves to an encoder reading a 16-bit counter and checks the extended count
/// against the true position (as a wrapping i32) after every read.
fn follow(moves: impl IntoIterator<Item = i32>) -> (i64, u32) {
    let mut enc = Encoder::new();
    let mut truth: i64 = 0;
    let mut wraps = 0u32;
    let start = 0x8000_i64; // the hardware counter starts anywhere
    enc.update(start as u16);
    for m in moves {
        let before = (start + truth).div_euclid(1 << 16);
        truth += i64::from(m);
        let raw = (start + truth).rem_euclid(1 << 16) as u16;
        wraps += (start + truth).div_euclid(1 << 16).abs_diff(before) as u32;
        assert_eq!(enc.update(raw), truth as i32, "after a move of {m} to {truth}");
    }
    (truth, wraps)
}

#[test]
fn the_count_follows_across_many_wraps_forward_and_back() {
    // 1000 steps of +30 000 counts (458 wraps), then 2000 of −30 000 (past zero, 916 wraps).
    let moves = std::iter::repeat_n(30_000, 1000).chain(std::iter::repeat_n(-30_000, 2000));
    let (end, wraps) = follow(moves);
    assert_eq!(end, -30_000_000);
    assert!(wraps >= 1370, "{wraps} wraps");
}

#[test]
fn the_largest_moves_one_step_can_tell_are_exact() {
    follow([32_767, 32_767, -32_768, -32_768, 32_767, -1, 1, 0, -32_768]);
}

#[test]
fn the_32_bit_count_wraps_and_speed_stays_right_across_it() {
    let mut enc = Encoder::new();
    enc.update(0);
    let mut raw = 0u16;
    let mut prev = enc.count();
    let scale = Scale::new(500, 19.0);
    // 70 000 steps of +32 000 counts: 2.24e9 counts, past i32::MAX.
    for _ in 0..70_000 {
        raw = raw.wrapping_add(32_000);
        let now = enc.update(raw);
        let w = scale.speed(prev, now, 0.001);
        assert!((w - 32_000.0 * scale.rad_per_count / 0.001).abs() < 1e-2, "{w}");
        prev = now;
    }
    assert!(prev < 0, "the 32-bit count wrapped: {prev}");
}

#[test]
fn scale_gives_output_shaft_radians() {
    let s = Scale::new(500, 19.0);
    // One output revolution is 4 × 500 × 19 counts.
    assert!((s.position(38_000) - core::f32::consts::TAU).abs() < 1e-5);
    assert!((s.position(-19_000) + core::f32::consts::PI).abs() < 1e-5);
    // 190 counts in 5 ms: 1/200 rev in 5 ms = 6.283 rad/s.
    assert!((s.speed(10, 200, 0.005) - 2.0 * core::f32::consts::PI).abs() < 1e-4);
}

proptest! {
    #[test]
    fn any_walk_of_legal_moves_is_followed(moves in prop::collection::vec(-32_767i32..=32_767, 1..2000)) {
        follow(moves);
    }
}
