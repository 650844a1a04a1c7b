//! r2p-module's memory routines (`mem_routines.rs`: the copy every module image links instead
//! of compiler-builtins') on a Cortex-M3: every alignment of source and destination, every
//! length up to 72 bytes, through each entry point, against a byte-by-byte reference; bytes
//! around the destination untouched; the fill; the aligned clear at every length; the
//! comparison (`mem_compare.rs`) against a byte-by-byte reference.
#![no_std]
#![no_main]

use r2p_module as _; // links the routines under test, as the module images do
use r2p_qemu_tests as _;

extern "C" {
    fn memcpy(dest: *mut u8, src: *const u8, n: usize) -> *mut u8;
    fn __aeabi_memcpy(dest: *mut u8, src: *const u8, n: usize);
    fn __aeabi_memcpy4(dest: *mut u8, src: *const u8, n: usize);
    fn __aeabi_memcpy8(dest: *mut u8, src: *const u8, n: usize);
    fn __aeabi_memset(dest: *mut u8, n: usize, c: i32);
    fn __aeabi_memclr(dest: *mut u8, n: usize);
    fn __aeabi_memclr4(dest: *mut u8, n: usize);
    fn __aeabi_memclr8(dest: *mut u8, n: usize);
    fn memcmp(a: *const u8, b: *const u8, n: usize) -> i32;
}

/// What `memcmp` must return for `n` bytes at `a` and `b`: the difference of the first bytes
/// that differ, as unsigned bytes (compiler-builtins' result), or 0. Volatile reads: the
/// reference must not itself become a call to `memcmp`.
fn compare_reference(a: *const u8, b: *const u8, n: usize) -> i32 {
    for i in 0..n {
        // SAFETY: the caller's ranges are in bounds.
        let (x, y) = unsafe { (a.add(i).read_volatile(), b.add(i).read_volatile()) };
        if x != y {
            return i32::from(x) - i32::from(y);
        }
    }
    0
}

const LEN: usize = 72;

#[repr(align(8))]
struct Buf([u8; LEN + 16]);

/// A source pattern no two neighbouring bytes of which are equal.
fn pattern() -> Buf {
    let mut b = Buf([0; LEN + 16]);
    for (i, x) in b.0.iter_mut().enumerate() {
        *x = (i as u8).wrapping_mul(37).wrapping_add(11);
    }
    b
}

/// Copies `n` bytes from `src + so` to a fresh buffer at `do_` with `copy` and checks every
/// byte of the buffer: the copied ones equal, the others still the fill value (read with
/// volatile loads, so the check is not itself a call to the routine).
fn check(copy: unsafe extern "C" fn(*mut u8, *const u8, usize), so: usize, do_: usize, n: usize) {
    let src = pattern();
    let mut dst = Buf([0xA5; LEN + 16]);
    // SAFETY: both ranges lie inside their buffers (offsets < 8, n ≤ LEN) and do not overlap.
    unsafe { copy(dst.0.as_mut_ptr().add(do_), src.0.as_ptr().add(so), n) };
    for i in 0..dst.0.len() {
        // SAFETY: in bounds.
        let got = unsafe { core::ptr::read_volatile(dst.0.as_ptr().add(i)) };
        let want = if i >= do_ && i < do_ + n { src.0[so + i - do_] } else { 0xA5 };
        assert_eq!(got, want, "byte {} of a {}-byte copy, offsets {}/{}", i, n, so, do_);
    }
}

unsafe extern "C" fn via_memcpy(d: *mut u8, s: *const u8, n: usize) {
    // SAFETY: forwarded from `check`.
    let r = unsafe { memcpy(d, s, n) };
    assert_eq!(r, d, "memcpy returns its destination");
}

mod tests {
    use super::*;

    r2p_testkit::suite! {
        fn memcpy_every_alignment_and_length() {
            for so in 0..4 {
                for d in 0..4 {
                    for n in 0..=LEN {
                        check(via_memcpy, so, d, n);
                        check(__aeabi_memcpy, so, d, n);
                    }
                }
            }
        }

        fn aligned_entry_points_copy_whole_and_partial_words() {
            for (so, d) in [(0, 0), (4, 0), (0, 4), (4, 4)] {
                for n in 0..=LEN {
                    check(__aeabi_memcpy4, so, d, n);
                }
            }
            for n in 0..=LEN {
                check(__aeabi_memcpy8, 0, 0, n);
                check(__aeabi_memcpy8, 8, 8, n);
            }
        }

        fn memclr_clears_exactly_its_bytes() {
            for d in [0, 4, 8] {
                for n in 0..=LEN {
                    let mut b = pattern();
                    let before = pattern();
                    // SAFETY: in bounds (d + n ≤ LEN + 8); `d` keeps the 4-byte alignment.
                    unsafe {
                        if d == 8 {
                            __aeabi_memclr8(b.0.as_mut_ptr().add(d), n)
                        } else {
                            __aeabi_memclr4(b.0.as_mut_ptr().add(d), n)
                        }
                    };
                    for i in 0..b.0.len() {
                        // SAFETY: in bounds.
                        let got = unsafe { core::ptr::read_volatile(b.0.as_ptr().add(i)) };
                        let want = if i >= d && i < d + n { 0 } else { before.0[i] };
                        assert_eq!(got, want, "byte {} of a {}-byte clear at {}", i, n, d);
                    }
                }
            }
        }

        fn memcmp_is_the_byte_by_byte_difference() {
            // Equal ranges at every alignment and length, then one byte changed at every
            // position to values below and above the original (0x00 and 0xFF among them, so
            // the bytes compare unsigned) and a second difference after it, which must not count.
            let a = pattern();
            for (ao, bo) in [(0, 0), (1, 0), (0, 3), (2, 1), (3, 3)] {
                for n in 0..=LEN {
                    let mut b = Buf([0; LEN + 16]);
                    b.0[bo..bo + n].copy_from_slice(&a.0[ao..ao + n]);
                    let (pa, pb) = (a.0[ao..].as_ptr(), b.0[bo..].as_mut_ptr());
                    // SAFETY: n bytes from each offset are in bounds.
                    assert_eq!(unsafe { memcmp(pa, pb, n) }, 0, "{n} equal bytes, {ao}/{bo}");
                    for at in 0..n {
                        let was = a.0[ao + at];
                        for v in [0x00, 0xFF, was.wrapping_add(1), was.wrapping_sub(1), was ^ 0x80] {
                            if v == was {
                                continue;
                            }
                            b.0[bo + at] = v;
                            if at + 1 < n {
                                b.0[bo + at + 1] ^= 0x55;
                            }
                            let want = compare_reference(pa, pb, n);
                            assert_eq!(want, i32::from(was) - i32::from(v));
                            // SAFETY: as above.
                            let got = unsafe { memcmp(pa, pb, n) };
                            assert_eq!(got, want, "{n} bytes, {ao}/{bo}, byte {at} = {v:#x}");
                            if at + 1 < n {
                                b.0[bo + at + 1] ^= 0x55;
                            }
                        }
                        b.0[bo + at] = was;
                    }
                }
            }
        }

        fn unaligned_memclr_clears_exactly_its_bytes() {
            for d in 0..4 {
                for n in 0..=LEN {
                    let mut b = pattern();
                    let before = pattern();
                    // SAFETY: in bounds (d + n ≤ LEN + 3); any alignment is allowed.
                    unsafe { __aeabi_memclr(b.0.as_mut_ptr().add(d), n) };
                    for i in 0..b.0.len() {
                        // SAFETY: in bounds.
                        let got = unsafe { core::ptr::read_volatile(b.0.as_ptr().add(i)) };
                        let want = if i >= d && i < d + n { 0 } else { before.0[i] };
                        assert_eq!(got, want, "byte {} of a {}-byte clear at {}", i, n, d);
                    }
                }
            }
        }

        fn memset_fills_exactly_its_bytes() {
            for d in 0..4 {
                for n in 0..20 {
                    let mut b = Buf([0; LEN + 16]);
                    // SAFETY: in bounds.
                    unsafe { __aeabi_memset(b.0.as_mut_ptr().add(d), n, 0x1FF) };
                    for (i, &x) in b.0.iter().enumerate() {
                        assert_eq!(x, if i >= d && i < d + n { 0xFF } else { 0 }, "{} {} {}", d, n, i);
                    }
                }
            }
        }
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    r2p_qemu_tests::run("mem", &[tests::SUITE])
}
