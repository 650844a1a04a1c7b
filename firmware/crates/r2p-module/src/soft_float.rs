//! `f32` addition, subtraction, multiplication and division for the bare-metal images, smaller
//! than compiler-builtins' (a module image must fit a 55 KiB bootloader slot: docs/flashing.md,
//! "Flash map"), with the same results bit for bit.
//!
//! On the Cortex-M3 (no FPU) LLVM compiles `a + b` on `f32` into a call of `__aeabi_fadd`
//! (`fsub`, `fmul`, `fdiv` likewise). compiler-builtins' helpers are its generic code for every
//! float width, built at `opt-level = 3` in the Rust distribution: 1 280 B for the four on the
//! PSU. Here the three operations share one rounding step ([`round`]) and one unpacking of
//! operands ([`unpack`]), and the division finds its quotient one bit a step (27 steps, a few
//! hundred cycles against compiler-builtins' Newton-Raphson reciprocal: no helper is on the slot
//! path, and the applications divide a few times per millisecond).
//!
//! The results are IEEE 754's, rounded to nearest, ties to even, subnormals kept (as the
//! hardware of the host computes them), and where a NaN comes out it is compiler-builtins' NaN:
//! the first NaN operand made quiet (without its sign for addition and subtraction), or the
//! default `0x7FC0_0000` for `∞ − ∞`, `0 × ∞`, `0 / 0` and `∞ / ∞`. The tests check every
//! operation against compiler-builtins' own helpers, which the host's standard library links, on
//! special values and on millions of pseudo-random pairs.
//!
//! compiler-builtins defines its ARM helpers weak; these strong ones replace them at link time,
//! on soft-float bare metal only (the F407's FPU computes in hardware).

const SIGN: u32 = 0x8000_0000;
const MAGNITUDE: u32 = 0x7FFF_FFFF;
const INFINITY: u32 = 0x7F80_0000;
const QUIET: u32 = 0x0040_0000;
/// `0x7FC0_0000`: the NaN an invalid operation gives.
const DEFAULT_NAN: u32 = INFINITY | QUIET;
const FRACTION: u32 = 0x007F_FFFF;
/// The significand's leading one, as [`unpack`] gives it.
const ONE: u32 = 0x0080_0000;
/// Bits below the significand's last while computing: round, guard and sticky.
const EXTRA: u32 = 3;

/// A finite, non-zero operand's biased exponent and 24-bit significand (leading one at bit 23):
/// a subnormal's significand shifted up to it, its exponent then 0 or below.
#[inline(never)]
fn unpack(x: u32) -> (i32, u32) {
    let exponent = ((x & INFINITY) >> 23) as i32;
    let fraction = x & FRACTION;
    if exponent == 0 {
        let shift = fraction.leading_zeros() - 8;
        (1 - shift as i32, fraction << shift)
    } else {
        (exponent, fraction | ONE)
    }
}

/// `x >> shift`, its lowest bit set if any bit shifted out was (the sticky bit).
fn shift_sticky(x: u32, shift: u32) -> u32 {
    if shift >= 32 {
        u32::from(x != 0)
    } else {
        (x >> shift) | u32::from(x & ((1 << shift) - 1) != 0)
    }
}

/// The `f32` with `sign` (the bit in place) nearest to `significand / 2²⁶ × 2^(exponent − 127)`,
/// ties to even: `significand` in [2²⁶, 2²⁷), its lowest bit sticky (set if anything below was).
/// Too large a value is an infinity, too small a subnormal or zero.
#[inline(never)]
fn round(sign: u32, exponent: i32, significand: u32) -> u32 {
    if exponent >= 0xFF {
        return sign | INFINITY;
    }
    let (exponent, significand) = if exponent <= 0 {
        (0, shift_sticky(significand, (1 - exponent) as u32))
    } else {
        (exponent as u32, significand)
    };
    let bits = sign | exponent << 23 | (significand >> EXTRA) & FRACTION;
    let rest = significand & 0b111;
    // A carry out of the fraction raises the exponent: the next binade, or the infinity.
    bits + u32::from(rest > 0b100 || rest == 0b100 && bits & 1 == 1)
}

/// `a + b` (bit patterns).
pub fn add(a: u32, b: u32) -> u32 {
    let (a_mag, b_mag) = (a & MAGNITUDE, b & MAGNITUDE);
    if a_mag > INFINITY {
        return a_mag | QUIET;
    }
    if b_mag > INFINITY {
        return b_mag | QUIET;
    }
    if a_mag == INFINITY {
        return if b == a ^ SIGN { DEFAULT_NAN } else { a };
    }
    if b_mag == INFINITY {
        return b;
    }
    if b_mag == 0 {
        // a + 0 is a, and −0 + −0 is −0 but +0 whenever either zero is +0.
        return if a_mag == 0 { a & b } else { a };
    }
    if a_mag == 0 {
        return b;
    }
    // The larger magnitude first: the result has its sign.
    let (a, b) = if b_mag > a_mag { (b, a) } else { (a, b) };
    let ((a_exp, a_sig), (b_exp, b_sig)) = (unpack(a), unpack(b));
    let b_sig = shift_sticky(b_sig << EXTRA, (a_exp - b_exp) as u32);
    let mut exponent = a_exp;
    let mut sum =
        if (a ^ b) & SIGN == 0 { (a_sig << EXTRA) + b_sig } else { (a_sig << EXTRA) - b_sig };
    if sum == 0 {
        return 0; // x − x is +0
    }
    if sum >= ONE << (EXTRA + 1) {
        sum = shift_sticky(sum, 1);
        exponent += 1;
    } else {
        let shift = sum.leading_zeros() - (31 - 23 - EXTRA);
        sum <<= shift;
        exponent -= shift as i32;
    }
    round(a & SIGN, exponent, sum)
}

/// The sign of a product (`quotient` false) or quotient, or its result when an operand is a
/// NaN, an infinity or a zero. A divisor's zero acts as a factor's infinity (x / 0 = ∞ as
/// x × ∞) and its infinity as a factor's zero (x / ∞ = 0 as x × 0), so one rule serves both:
/// a "large" operand (an infinity; a zero divisor) gives ∞, a "small" one (a zero; an infinite
/// divisor) 0, one of each is invalid (0 × ∞, ∞ / ∞, 0 / 0). `Ok(sign)` when both are finite
/// and non-zero.
fn special(a: u32, b: u32, quotient: bool) -> Result<u32, u32> {
    let sign = (a ^ b) & SIGN;
    let (a_mag, b_mag) = (a & MAGNITUDE, b & MAGNITUDE);
    if a_mag > INFINITY {
        return Err(a | QUIET);
    }
    if b_mag > INFINITY {
        return Err(b | QUIET);
    }
    let (a_large, a_small) = (a_mag == INFINITY, a_mag == 0);
    let (b_large, b_small) =
        if quotient { (b_mag == 0, b_mag == INFINITY) } else { (b_mag == INFINITY, b_mag == 0) };
    if a_large && b_small || a_small && b_large {
        Err(DEFAULT_NAN)
    } else if a_large || b_large {
        Err(sign | INFINITY)
    } else if a_small || b_small {
        Err(sign)
    } else {
        Ok(sign)
    }
}

/// `a × b` (bit patterns).
pub fn mul(a: u32, b: u32) -> u32 {
    let sign = match special(a, b, false) {
        Ok(sign) => sign,
        Err(r) => return r,
    };
    let ((a_exp, a_sig), (b_exp, b_sig)) = (unpack(a), unpack(b));
    // Two 24-bit significands: a product in [2⁴⁶, 2⁴⁸), its leading one brought to bit 26.
    let product = u64::from(a_sig) * u64::from(b_sig);
    let top = (product >> 47) as u32; // 1 if the product is 2 or more
    let shift = 20 + top;
    let significand = (product >> shift) as u32 | u32::from(product & ((1 << shift) - 1) != 0);
    round(sign, a_exp + b_exp - 127 + top as i32, significand)
}

/// `a / b` (bit patterns).
pub fn div(a: u32, b: u32) -> u32 {
    let sign = match special(a, b, true) {
        Ok(sign) => sign,
        Err(r) => return r,
    };
    let ((a_exp, mut rest), (b_exp, divisor)) = (unpack(a), unpack(b));
    let mut exponent = a_exp - b_exp + 127;
    if rest < divisor {
        rest <<= 1; // the quotient in [1, 2)
        exponent -= 1;
    }
    // 27 quotient bits, one a step (restoring division): the leading one, 23 more, then the
    // round and guard bits; the remainder is the sticky bit.
    let mut quotient = 0;
    for _ in 0..24 + EXTRA {
        quotient <<= 1;
        if rest >= divisor {
            rest -= divisor;
            quotient |= 1;
        }
        rest <<= 1;
    }
    round(sign, exponent, quotient | u32::from(rest != 0))
}

/// The four helpers, written once: exported under their ABI names on soft-float bare metal, in
/// the ABI's calling convention, and as plain functions in the tests.
#[cfg(any(test, all(target_arch = "arm", target_os = "none", not(target_abi = "eabihf"))))]
macro_rules! helpers {
    ($abi:literal $(, #[$export:meta])?) => {
        $(#[$export])?
        pub extern $abi fn __aeabi_fadd(a: f32, b: f32) -> f32 {
            f32::from_bits($crate::soft_float::add(a.to_bits(), b.to_bits()))
        }
        $(#[$export])?
        pub extern $abi fn __aeabi_fsub(a: f32, b: f32) -> f32 {
            f32::from_bits($crate::soft_float::add(a.to_bits(), b.to_bits() ^ $crate::soft_float::SIGN))
        }
        $(#[$export])?
        pub extern $abi fn __aeabi_fmul(a: f32, b: f32) -> f32 {
            f32::from_bits($crate::soft_float::mul(a.to_bits(), b.to_bits()))
        }
        $(#[$export])?
        pub extern $abi fn __aeabi_fdiv(a: f32, b: f32) -> f32 {
            f32::from_bits($crate::soft_float::div(a.to_bits(), b.to_bits()))
        }
    };
}

#[cfg(all(target_arch = "arm", target_os = "none", not(target_abi = "eabihf")))]
mod aeabi {
    helpers!("aapcs", #[unsafe(no_mangle)]);
}

#[cfg(test)]
mod tests {
    use std::format;

    mod helpers {
        helpers!("C");
    }

    // compiler-builtins' helpers, which the host's standard library links: the reference.
    extern "C" {
        fn __addsf3(a: f32, b: f32) -> f32;
        fn __subsf3(a: f32, b: f32) -> f32;
        fn __mulsf3(a: f32, b: f32) -> f32;
        fn __divsf3(a: f32, b: f32) -> f32;
    }

    /// Zeros, the smallest and largest subnormals, the smallest and largest normals, one and
    /// its neighbours, infinities and NaNs (quiet, signalling, with a payload).
    const SPECIAL: [u32; 15] = [
        0x0000_0000,
        0x0000_0001,
        0x0000_0003,
        0x0040_0000,
        0x007F_FFFF,
        0x0080_0000,
        0x0080_0001,
        0x3F7F_FFFF,
        0x3F80_0000,
        0x3F80_0001,
        0x7F7F_FFFF,
        0x7F80_0000,
        0x7FC0_0000,
        0x7F80_0001,
        0x7FFF_FFFF,
    ];

    fn check(a: u32, b: u32) {
        let (x, y) = (f32::from_bits(a), f32::from_bits(b));
        let ours = [
            helpers::__aeabi_fadd(x, y),
            helpers::__aeabi_fsub(x, y),
            helpers::__aeabi_fmul(x, y),
            helpers::__aeabi_fdiv(x, y),
        ]
        .map(f32::to_bits);
        // SAFETY: compiler-builtins' helpers take and return plain `f32`s.
        let reference = unsafe { [__addsf3(x, y), __subsf3(x, y), __mulsf3(x, y), __divsf3(x, y)] }
            .map(f32::to_bits);
        assert_eq!(
            ours.map(|r| format!("{r:#010x}")),
            reference.map(|r| format!("{r:#010x}")),
            "add sub mul div of {a:#010x} and {b:#010x}"
        );
        // And the host's hardware, where the result is a number.
        let hardware = [x + y, x - y, x * y, x / y].map(f32::to_bits);
        for (o, h) in ours.iter().zip(hardware) {
            if !f32::from_bits(h).is_nan() {
                assert_eq!(*o, h, "{a:#010x} and {b:#010x} against the hardware");
            }
        }
    }

    #[test]
    fn every_pair_of_special_values_as_compiler_builtins_computes_it() {
        let all = SPECIAL.iter().flat_map(|&x| [x, x | super::SIGN]);
        for a in all.clone() {
            for b in all.clone() {
                check(a, b);
            }
        }
    }

    #[test]
    fn millions_of_pairs_as_compiler_builtins_computes_them() {
        // xorshift32: any bit patterns (NaNs and subnormals included), then operands of close
        // magnitudes (cancellation, ties), then results near the subnormal and overflow edges.
        let mut next = crate::test_bits::xorshift32();
        for _ in 0..1_000_000 {
            let (a, b) = (next(), next());
            check(a, b);
            check(a, a ^ (b & 0x8000_00FF));
            check(a & 0x807F_FFFF | 0x0080_0000, b & 0x80FF_FFFF | 0x3000_0000);
            check(a & 0x87FF_FFFF | 0x3800_0000, b & 0x87FF_FFFF | 0x4000_0000);
            check(a & 0x80FF_FFFF | 0x7E00_0000, b & 0x80FF_FFFF | 0x4000_0000);
        }
    }

    #[test]
    fn exact_values() {
        let f = |x: f32| x.to_bits();
        assert_eq!(super::add(f(1.5), f(2.25)), f(3.75));
        assert_eq!(super::add(f(1.0), f(-1.0)), 0, "x - x is +0");
        assert_eq!(super::add(f(-0.0), f(-0.0)), f(-0.0));
        assert_eq!(super::mul(f(-3.0), f(0.5)), f(-1.5));
        assert_eq!(super::div(f(1.0), f(3.0)), f(1.0 / 3.0));
        // Equal significands: the quotient is exactly a power of two (no pre-shift; pre-shifting
        // would give 1.11…1 with a sticky remainder, which rounds to the same value).
        assert_eq!(super::div(f(3.0), f(1.5)), f(2.0));
        assert_eq!(super::div(f(-7.5), f(3.75)), f(-2.0));
        assert_eq!(super::div(f(1.0), f(1.0)), f(1.0));
        assert_eq!(super::div(f(1.0), f(0.0)), f(f32::INFINITY));
        assert_eq!(super::div(f(-1.0), f(f32::INFINITY)), f(-0.0));
        assert_eq!(super::mul(f(0.0), f(f32::INFINITY)), super::DEFAULT_NAN);
        assert_eq!(super::mul(0x7F7F_FFFF, f(2.0)), super::INFINITY, "overflow");
        assert_eq!(super::mul(0x0080_0000, f(0.5)), 0x0040_0000, "a subnormal result");
        assert_eq!(super::mul(0x0000_0001, f(0.5)), 0, "half the smallest subnormal, to even");
        assert_eq!(super::mul(0x0000_0003, f(0.5)), 0x0000_0002, "1.5 ulp rounds to even");
    }
}
