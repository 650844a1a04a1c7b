//! `__aeabi_memclr` for the bare-metal module images: a branch to `mem_routines`' byte fill
//! with zero (6 B), against compiler-builtins' 208 B.
//!
//! LLVM calls it to zero memory it cannot prove word-aligned. In a module image that is the
//! node's reassembler at boot (its free slots are all zero bytes: rtcan's `fragment.rs`), a
//! clear made once, so the byte loop costs nothing that matters. compiler-builtins defines
//! `__aeabi_memclr` weak; this strong one replaces it at link time, on bare metal only. Not in
//! `mem_routines.rs`, which the bootloader includes: its image stays as flashed.

// void __aeabi_memclr(void *dest, size_t n): r0 dest (any alignment), r1 n; then
// __aeabi_memset(dest, n, 0) with the arguments in the same registers.
#[cfg(all(target_arch = "arm", target_os = "none"))]
core::arch::global_asm!(
    ".section .text.__aeabi_memclr,\"ax\",%progbits",
    ".global __aeabi_memclr",
    ".type __aeabi_memclr,%function",
    ".thumb_func",
    "__aeabi_memclr:",
    "    movs r2, #0",
    "    b.w __aeabi_memset",
    ".size __aeabi_memclr, . - __aeabi_memclr",
);
