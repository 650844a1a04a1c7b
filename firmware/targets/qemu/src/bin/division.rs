//! r2p-module's 64-bit division (`long_division.rs`: the `__aeabi_uldivmod` and
//! `__aeabi_ldivmod` every module image links instead of compiler-builtins') on a Cortex-M3:
//! edge cases (0, 1, powers of two and their neighbours, `u64::MAX`, divisors in the high word
//! only, a divisor larger than the dividend, division by zero) and pseudo-random pairs of every
//! width, against a shift-subtract reference that divides nothing itself; the quotient and
//! remainder in the registers the ABI names, and the registers it says a call keeps.
#![no_std]
#![no_main]

use core::hint::black_box;

use r2p_module as _; // links the routines under test, as the module images do
use r2p_qemu_tests as _;

extern "C" {
    fn __aeabi_uldivmod();
    fn __aeabi_ldivmod();
    /// Calls `f` with `args` in r0–r3 and r4–r11 set to known values; writes r0–r3 as `f`
    /// returned them to `out`, and returns a bit per register `f` should have kept and did not
    /// (bit 0 the stack pointer, bits 4–11 those registers).
    fn r2p_call_divmod(f: unsafe extern "C" fn(), args: *const [u32; 4], out: *mut [u32; 4])
        -> u32;
}

core::arch::global_asm!(
    ".section .text.r2p_call_divmod,\"ax\",%progbits",
    ".global r2p_call_divmod",
    ".type r2p_call_divmod,%function",
    ".thumb_func",
    "r2p_call_divmod:",
    "    push {{r4-r11, lr}}",
    "    sub sp, sp, #4",
    "    str r2, [sp]",
    "    mov r12, r0",
    "    ldm r1, {{r0-r3}}",
    "    mov r4, #0x44444444",
    "    mov r5, #0x55555555",
    "    mov r6, #0x66666666",
    "    mov r7, #0x77777777",
    "    mov r8, #0x88888888",
    "    mov r9, #0x99999999",
    "    mov r10, #0xAAAAAAAA",
    "    mov r11, sp",
    "    blx r12",
    "    movs r12, #0",
    "    cmp r11, sp",
    "    it ne",
    "    orrne r12, r12, #1",
    "    mov sp, r11",
    "    cmp r4, #0x44444444",
    "    it ne",
    "    orrne r12, r12, #0x10",
    "    cmp r5, #0x55555555",
    "    it ne",
    "    orrne r12, r12, #0x20",
    "    cmp r6, #0x66666666",
    "    it ne",
    "    orrne r12, r12, #0x40",
    "    cmp r7, #0x77777777",
    "    it ne",
    "    orrne r12, r12, #0x80",
    "    cmp r8, #0x88888888",
    "    it ne",
    "    orrne r12, r12, #0x100",
    "    cmp r9, #0x99999999",
    "    it ne",
    "    orrne r12, r12, #0x200",
    "    cmp r10, #0xAAAAAAAA",
    "    it ne",
    "    orrne r12, r12, #0x400",
    "    ldr r4, [sp]",
    "    stm r4, {{r0-r3}}",
    "    mov r0, r12",
    "    add sp, sp, #4",
    "    pop {{r4-r11, pc}}",
    ".size r2p_call_divmod, . - r2p_call_divmod",
);

/// `f(a, b)` through the ABI: the quotient from r1:r0 and the remainder from r3:r2.
fn call(f: unsafe extern "C" fn(), a: u64, b: u64) -> (u64, u64) {
    let args = [a as u32, (a >> 32) as u32, b as u32, (b >> 32) as u32];
    let mut out = [0u32; 4];
    // SAFETY: the wrapper saves and restores what it sets; `f` takes two 64-bit arguments.
    let damaged = unsafe { r2p_call_divmod(f, &args, &mut out) };
    assert_eq!(
        damaged, 0,
        "registers the call should keep (bit 0 sp, bit n rn): {:#x} / {:#x}",
        a, b
    );
    (out[0] as u64 | (out[1] as u64) << 32, out[2] as u64 | (out[3] as u64) << 32)
}

/// Quotient and remainder bit by bit, by shifts and subtractions only (no division: a `/` here
/// would call the routine under test). A zero divisor gives the routine's defined result.
fn reference(n: u64, d: u64) -> (u64, u64) {
    if d == 0 {
        return (0, n);
    }
    let (mut q, mut r) = (0u64, 0u64);
    for i in (0..64).rev() {
        let carry = r >> 63;
        r = (r << 1) | ((n >> i) & 1);
        if carry == 1 || r >= d {
            r = r.wrapping_sub(d);
            q |= 1 << i;
        }
    }
    (q, r)
}

/// The signed reference: magnitudes divided, the quotient truncated toward zero, the remainder
/// with the dividend's sign; `i64::MIN / -1` wraps.
fn reference_signed(n: i64, d: i64) -> (i64, i64) {
    let (q, r) = reference(n.unsigned_abs(), d.unsigned_abs());
    let q = if (n < 0) != (d < 0) { (q as i64).wrapping_neg() } else { q as i64 };
    let r = if n < 0 { (r as i64).wrapping_neg() } else { r as i64 };
    (q, r)
}

fn check(n: u64, d: u64) {
    let got = call(__aeabi_uldivmod, n, d);
    assert_eq!(got, reference(n, d), "{:#x} / {:#x} (quotient, remainder)", n, d);
}

fn check_signed(n: i64, d: i64) {
    let (q, r) = call(__aeabi_ldivmod, n as u64, d as u64);
    assert_eq!((q as i64, r as i64), reference_signed(n, d), "{} / {} (quotient, remainder)", n, d);
}

/// 0, 1, 3, every power of two with its neighbours, the high word alone, and a few patterns.
fn edges() -> impl Iterator<Item = u64> {
    let patterns = [0, 3, 0xFFFF_FFFF_0000_0000, 0x8000_0000_FFFF_FFFF, 0x0001_0000_FFFF_0000];
    let powers = (0..64).flat_map(|k| {
        let p = 1u64 << k;
        [p - 1, p, p + 1]
    });
    patterns.into_iter().chain(powers).chain([u64::MAX - 1, u64::MAX])
}

/// A fixed-seed xorshift64 (Marsaglia), so every run checks the same pairs.
struct XorShift(u64);

impl XorShift {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// A number of random width (0 to 64 bits), so every path gets its share.
    fn any_width(&mut self) -> u64 {
        let shift = self.next() % 64; // a remainder by a power of two: a mask, not a division
        self.next() >> shift
    }
}

const PAIRS: u32 = 200_000;

mod tests {
    use super::*;

    r2p_testkit::suite! {
        fn every_pair_of_edge_values() {
            for n in edges() {
                for d in edges() {
                    check(n, d);
                }
            }
        }

        fn random_pairs_of_every_width() {
            let mut rng = XorShift(0x2545_F491_4F6C_DD1D);
            for _ in 0..PAIRS {
                let (n, d) = (rng.any_width(), rng.any_width());
                check(n, d);
            }
        }

        fn full_width_pairs_and_known_quotients() {
            let mut rng = XorShift(0x9E37_79B9_7F4A_7C15);
            for _ in 0..PAIRS / 4 {
                let (n, d) = (rng.next(), rng.next() >> (rng.next() % 64));
                check(n, d);
                // A dividend built from a quotient and a remainder below the divisor (when it
                // fits): the division must give them back exactly.
                let (q, r) = (rng.any_width(), rng.next());
                if d != 0 {
                    let r = if r >= d { r & (d >> 1) } else { r };
                    if let Some(n) = q.checked_mul(d).and_then(|x| x.checked_add(r)) {
                        assert_eq!(call(__aeabi_uldivmod, n, d), (q, r), "{:#x}·{:#x} + {:#x}", q, d, r);
                    }
                }
            }
        }

        fn divisors_whose_digit_estimates_run_over() {
            // Divisors normalised to 0x8000_xxxx or 0xFFFF_xxxx give the core's 16-bit digit
            // estimates their largest corrections; the dividends' high words are just below.
            let mut rng = XorShift(0xD1B5_4A32_D192_ED03);
            for _ in 0..PAIRS / 4 {
                let low = rng.next() & 0xFFFF;
                for d in [0x8000_0000 | low, 0x8000_FFFF - low, 0xFFFF_0000 | low, 0x0001_8000 | low] {
                    let d = d >> (rng.next() % 16);
                    let n = ((d - 1) << 32 | rng.next() & 0xFFFF_FFFF) >> (rng.next() % 8);
                    check(n, d);
                    check(n, d << 32 | rng.next() & 0xFFFF_FFFF);
                }
            }
        }

        fn division_by_zero_gives_quotient_zero_and_the_dividend() {
            for n in edges() {
                assert_eq!(call(__aeabi_uldivmod, n, 0), (0, n), "{:#x} / 0", n);
                assert_eq!(call(__aeabi_ldivmod, n, 0), (0, n), "{:#x} / 0 (signed)", n);
            }
        }

        fn signed_division_truncates_toward_zero() {
            for n in edges() {
                for d in edges() {
                    for (n, d) in [(n, d), (n.wrapping_neg(), d), (n, d.wrapping_neg())] {
                        check_signed(n as i64, d as i64);
                    }
                }
            }
            assert_eq!(call(__aeabi_ldivmod, i64::MIN as u64, -1i64 as u64), (i64::MIN as u64, 0));
            assert_eq!(call(__aeabi_ldivmod, -7i64 as u64, 2), (-3i64 as u64, -1i64 as u64));
            let mut rng = XorShift(0x5851_F42D_4C95_7F2D);
            for _ in 0..PAIRS / 4 {
                check_signed(rng.any_width() as i64, rng.any_width() as i64);
            }
        }

        fn rust_operators_call_it_as_the_images_do() {
            // What LLVM emits for `/` and `%` on u64 and i64: the same routines, one result each.
            let mut rng = XorShift(0x1405_7B7E_F767_814F);
            for _ in 0..PAIRS / 8 {
                let (n, d) = (rng.any_width(), rng.any_width() | 1);
                let (q, r) = reference(n, d);
                assert_eq!((black_box(n) / black_box(d), black_box(n) % black_box(d)), (q, r));
                let (n, d) = (n as i64, d as i64);
                let (q, r) = reference_signed(n, d);
                assert_eq!((black_box(n).wrapping_div(black_box(d)), black_box(n).wrapping_rem(black_box(d))), (q, r));
            }
        }
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    r2p_qemu_tests::run("division", &[tests::SUITE])
}
