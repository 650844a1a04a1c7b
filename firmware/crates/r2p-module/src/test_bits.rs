//! Test-only: the random bit patterns the float routines' tests draw (xorshift32 from a fixed
//! seed, so every run checks the same pairs).

/// Successive xorshift32 values from the tests' common seed.
pub(crate) fn xorshift32() -> impl FnMut() -> u32 {
    let mut x = 0x1234_5678u32;
    move || {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        x
    }
}
