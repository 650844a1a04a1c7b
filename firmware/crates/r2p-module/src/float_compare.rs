//! One comparison of two `f32` for the bare-metal images' six comparison helpers, instead of
//! compiler-builtins' six: a module image must fit a 55 KiB bootloader slot (docs/flashing.md,
//! "Flash map").
//!
//! On the Cortex-M3 (no FPU) LLVM compiles `a < b` on `f32` into a call of `__aeabi_fcmplt`,
//! and each predicate has its own helper (`eq`, `lt`, `le`, `gt`, `ge`, `un`): 390 B in an
//! image that uses them all, each a copy of the same comparison. Here each is a few
//! instructions around [`order`]. They return what the ARM run-time ABI says: 1 if the relation
//! holds, else 0; every relation but "unordered" is false when either operand is a NaN.
//! compiler-builtins defines its helpers weak; these strong ones replace them at link time, on
//! soft-float bare metal only (the F407's FPU compares in hardware).

use core::cmp::Ordering;

/// How `a` compares with `b` as IEEE 754 numbers (`+0 == -0`); `None` when either is a NaN.
/// Integer operations only, so it never calls a float helper itself.
#[inline(never)]
pub fn order(a: f32, b: f32) -> Option<Ordering> {
    const MAGNITUDE: u32 = 0x7FFF_FFFF;
    const INFINITY: u32 = 0x7F80_0000;
    let (a, b) = (a.to_bits(), b.to_bits());
    if a & MAGNITUDE > INFINITY || b & MAGNITUDE > INFINITY {
        return None;
    }
    // Sign and magnitude as one signed integer that orders as the numbers do (both zeros 0).
    let key = |x: u32| if x >> 31 == 1 { -((x & MAGNITUDE) as i32) } else { x as i32 };
    Some(key(a).cmp(&key(b)))
}

/// The six helpers, written once: exported under their ABI names on soft-float bare metal,
/// in the ABI's calling convention, and as plain functions in the tests, which check them against Rust's own comparisons.
#[cfg(any(test, all(target_arch = "arm", target_os = "none", not(target_abi = "eabihf"))))]
macro_rules! helpers {
    ($abi:literal $(, #[$export:meta])?) => {
        use super::order;
        use core::cmp::Ordering::{Equal, Greater, Less};

        $(#[$export])?
        pub extern $abi fn __aeabi_fcmpeq(a: f32, b: f32) -> i32 {
            matches!(order(a, b), Some(Equal)) as i32
        }
        $(#[$export])?
        pub extern $abi fn __aeabi_fcmplt(a: f32, b: f32) -> i32 {
            matches!(order(a, b), Some(Less)) as i32
        }
        $(#[$export])?
        pub extern $abi fn __aeabi_fcmple(a: f32, b: f32) -> i32 {
            matches!(order(a, b), Some(Less | Equal)) as i32
        }
        $(#[$export])?
        pub extern $abi fn __aeabi_fcmpgt(a: f32, b: f32) -> i32 {
            matches!(order(a, b), Some(Greater)) as i32
        }
        $(#[$export])?
        pub extern $abi fn __aeabi_fcmpge(a: f32, b: f32) -> i32 {
            matches!(order(a, b), Some(Greater | Equal)) as i32
        }
        $(#[$export])?
        pub extern $abi fn __aeabi_fcmpun(a: f32, b: f32) -> i32 {
            order(a, b).is_none() as i32
        }
    };
}

#[cfg(all(target_arch = "arm", target_os = "none", not(target_abi = "eabihf")))]
mod aeabi {
    helpers!("aapcs", #[unsafe(no_mangle)]);
}

#[cfg(test)]
mod tests {
    use super::order;
    use std::format;

    /// Zeros, subnormals, the smallest and largest normals, one, infinities and NaNs (quiet,
    /// signalling, with a payload), each with both signs.
    const SPECIAL: [u32; 11] = [
        0x0000_0000,
        0x0000_0001,
        0x007F_FFFF,
        0x0080_0000,
        0x3F80_0000,
        0x3F80_0001,
        0x7F7F_FFFF,
        0x7F80_0000,
        0x7FC0_0000,
        0x7F80_0001,
        0x7FFF_FFFF,
    ];

    mod helpers {
        helpers!("C");
    }

    fn check(a: f32, b: f32) {
        let what = format!("{a:e} ({:#010x}) vs {b:e} ({:#010x})", a.to_bits(), b.to_bits());
        assert_eq!(order(a, b), a.partial_cmp(&b), "{what}");
        let h = [
            helpers::__aeabi_fcmpeq,
            helpers::__aeabi_fcmplt,
            helpers::__aeabi_fcmple,
            helpers::__aeabi_fcmpgt,
            helpers::__aeabi_fcmpge,
            helpers::__aeabi_fcmpun,
        ]
        .map(|f| f(a, b));
        let rust = [a == b, a < b, a <= b, a > b, a >= b, a.is_nan() || b.is_nan()].map(i32::from);
        assert_eq!(h, rust, "eq lt le gt ge un: {what}");
    }

    #[test]
    fn orders_as_ieee_754_on_every_pair_of_special_values() {
        let all = SPECIAL.iter().flat_map(|&x| [x, x | 0x8000_0000]).map(f32::from_bits);
        for a in all.clone() {
            for b in all.clone() {
                check(a, b);
            }
        }
        assert_eq!(order(0.0, -0.0), Some(core::cmp::Ordering::Equal), "+0 == -0");
        assert_eq!(order(f32::NAN, f32::NAN), None);
    }

    #[test]
    fn orders_as_ieee_754_on_a_million_pairs_of_any_bits() {
        // xorshift32: any bit patterns (NaNs included), and pairs close to each other.
        let mut next = crate::test_bits::xorshift32();
        for _ in 0..1_000_000 {
            let (a, b) = (next(), next());
            check(f32::from_bits(a), f32::from_bits(b));
            check(f32::from_bits(a), f32::from_bits(a ^ (b & 0x8000_000F)));
        }
    }
}
