//! Smaller memory routines for the bare-metal images than compiler-builtins' (its are built
//! for speed; a module image must fit a 54 KiB bootloader slot, docs/flashing.md "Flash map").
//!
//! - `memmove`: compiler-builtins' is 1 586 B on the Cortex-M3 (word-at-a-time with shifts for
//!   every misalignment); this one is 60 B.
//! - `__aeabi_memcpy8` and `__aeabi_memclr8` (what LLVM calls for 8-byte aligned copies and
//!   clears): compiler-builtins has a word loop for each, a copy of its 4-byte aligned one
//!   (156 and 174 B); an 8-byte aligned pointer is 4-byte aligned, so these branch to those.
//!   Cost: one branch instruction (a few cycles: the pipeline refills) per such call.
//!
//! The images call `memmove` rarely and on short buffers (the motor image once, at boot, for
//! the 12-byte UID), so that speed buys nothing while the bytes count: a module image must fit
//! a 54 KiB bootloader slot (docs/flashing.md, "Flash map"). Copies that cannot overlap go to
//! `memcpy` (compiler-builtins', word-wise), so only a truly overlapping move runs a byte at a
//! time. compiler-builtins defines its `memmove` and the ARM EABI entry points weak; these
//! strong ones replace them at link time (the EABI ones too, because compiler-builtins' call its
//! own `memmove` by its mangled name), on bare metal only (`target_os = "none"`): a host build
//! keeps its C library's.

/// Copies `n` bytes from `src` to `dst`, which may overlap; returns `dst`.
///
/// # Safety
/// `src` must be valid for reads and `dst` for writes of `n` bytes.
#[cfg_attr(target_os = "none", no_mangle)]
pub unsafe extern "C" fn memmove(dst: *mut u8, src: *const u8, n: usize) -> *mut u8 {
    // SAFETY: the caller's promise is move_bytes'.
    unsafe { move_bytes(dst, src, n) };
    dst
}

/// The move itself, under a name the optimiser does not know: a call to a function named
/// `memmove`, even this file's, is taken for the C library's and turned back into a call to
/// `__aeabi_memmove` (measured: the entry points below then called themselves).
#[inline(never)]
unsafe fn move_bytes(dst: *mut u8, src: *const u8, n: usize) {
    let (d, s) = (dst as usize, src as usize);
    if d.abs_diff(s) >= n {
        // SAFETY: the ranges do not overlap; the caller vouches for both.
        unsafe { core::ptr::copy_nonoverlapping(src, dst, n) };
        return;
    }
    // Volatile, so that the optimiser cannot turn either loop into a call to `memmove` either.
    if d < s {
        for i in 0..n {
            // SAFETY: i < n; the caller vouches for both ranges.
            unsafe { dst.add(i).write_volatile(src.add(i).read_volatile()) };
        }
    } else {
        for i in (0..n).rev() {
            // SAFETY: as above; going down, every byte is read before it is overwritten.
            unsafe { dst.add(i).write_volatile(src.add(i).read_volatile()) };
        }
    }
}

/// The ARM EABI's `memmove` (what LLVM calls on ARM), any alignment.
///
/// # Safety
/// As [`memmove`].
#[cfg_attr(target_os = "none", no_mangle)]
pub unsafe extern "C" fn __aeabi_memmove(dst: *mut u8, src: *const u8, n: usize) {
    // SAFETY: the caller's promise is move_bytes'.
    unsafe { move_bytes(dst, src, n) };
}

/// The ARM EABI's `memmove` for 4-byte aligned pointers.
///
/// # Safety
/// As [`memmove`].
#[cfg_attr(target_os = "none", no_mangle)]
pub unsafe extern "C" fn __aeabi_memmove4(dst: *mut u8, src: *const u8, n: usize) {
    // SAFETY: the caller's promise is move_bytes'.
    unsafe { move_bytes(dst, src, n) };
}

/// The ARM EABI's `memmove` for 8-byte aligned pointers.
///
/// # Safety
/// As [`memmove`].
#[cfg_attr(target_os = "none", no_mangle)]
pub unsafe extern "C" fn __aeabi_memmove8(dst: *mut u8, src: *const u8, n: usize) {
    // SAFETY: the caller's promise is move_bytes'.
    unsafe { move_bytes(dst, src, n) };
}

// The ARM EABI's copy and clear for 8-byte aligned pointers, as a bare branch to
// compiler-builtins' (weak) 4-byte aligned ones: an 8-byte aligned pointer is 4-byte aligned and
// the arguments are the same registers. In assembly, because a Rust function here would save
// and restore a frame around the branch (measured: 4 instructions more per call).
#[cfg(all(target_arch = "arm", target_os = "none"))]
core::arch::global_asm!(
    ".section .text.__aeabi_memcpy8,\"ax\",%progbits",
    ".global __aeabi_memcpy8",
    ".type __aeabi_memcpy8,%function",
    ".thumb_func",
    "__aeabi_memcpy8:",
    "    b.w __aeabi_memcpy4",
    ".size __aeabi_memcpy8, . - __aeabi_memcpy8",
    ".section .text.__aeabi_memclr8,\"ax\",%progbits",
    ".global __aeabi_memclr8",
    ".type __aeabi_memclr8,%function",
    ".thumb_func",
    "__aeabi_memclr8:",
    "    b.w __aeabi_memclr4",
    ".size __aeabi_memclr8, . - __aeabi_memclr8",
);

#[cfg(test)]
mod tests {
    use super::memmove;

    /// Moves `n` bytes from offset `from` to `to` in a 0..32 pattern, by `memmove` and by the
    /// standard library, and compares.
    fn check(from: usize, to: usize, n: usize) {
        let mut ours: [u8; 32] = core::array::from_fn(|i| i as u8);
        let mut std = ours;
        std.copy_within(from..from + n, to);
        let base = ours.as_mut_ptr();
        // SAFETY: both ranges are inside the array.
        let ret = unsafe { memmove(base.add(to), base.add(from), n) };
        assert_eq!(ret, base.wrapping_add(to));
        assert_eq!(ours, std, "from {from} to {to}, {n} bytes");
    }

    #[test]
    fn moves_like_copy_within_whether_the_ranges_overlap_or_not() {
        for n in 0..=12 {
            for from in 0..=(32 - n) {
                for to in 0..=(32 - n) {
                    check(from, to, n);
                }
            }
        }
    }
}
