//! Smaller 8-byte aligned copy and clear for the bare-metal images than compiler-builtins': a
//! module image must fit a 55 KiB bootloader slot (docs/flashing.md, "Flash map"), and the F103's
//! bootloader, which includes this file, its 14 KiB partition.
//!
//! `__aeabi_memcpy8` and `__aeabi_memclr8` (what LLVM calls for 8-byte aligned copies and
//! clears): compiler-builtins has a word loop for each, a copy of its 4-byte aligned one (156 and
//! 174 B); an 8-byte aligned pointer is 4-byte aligned, so these branch to those. Cost: one
//! branch instruction (a few cycles: the pipeline refills) per such call. compiler-builtins
//! defines them weak; these strong ones replace them at link time, on bare metal only.
//!
//! `__aeabi_memclr4` (what LLVM calls to zero 4-byte aligned memory: structs made with
//! `Default`, buffers; `__aeabi_memclr8` branches to it): a word loop and a byte tail, 28 B
//! against compiler-builtins' 174 (issue 22's babbler guard needed the room on the PSU).
//! The clears are of a few words; the library's unrolled stores saved a few cycles on each.
//!
//! `__aeabi_memset` (and its 4- and 8-byte aligned forms): the update receiver pads a write unit
//! with erased bytes (0xFF), a fill LLVM turns into a call; compiler-builtins' general memset
//! and its aligned variant are 404 B, this byte loop 12 B. The fills are of a few bytes.
//!
//! (A 60-byte `memmove` once stood here too, against compiler-builtins' 1 586 B one; no image
//! calls `memmove` since issue 17's shared start-up, so it saved nothing, and its overlapping
//! path copied a byte at a time: the library's is kept.)

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
    // void __aeabi_memclr4(void *dest, size_t n): r0 dest (4-byte aligned), r1 n.
    ".section .text.__aeabi_memclr4,\"ax\",%progbits",
    ".global __aeabi_memclr4",
    ".type __aeabi_memclr4,%function",
    ".thumb_func",
    "__aeabi_memclr4:",
    "    movs r2, #0",
    "    subs r1, r1, #4",
    "    bcc 2f",
    "1:  str r2, [r0], #4",
    "    subs r1, r1, #4",
    "    bcs 1b",
    "2:  adds r1, r1, #4",
    "    beq 4f",
    "3:  strb r2, [r0], #1",
    "    subs r1, r1, #1",
    "    bne 3b",
    "4:  bx lr",
    ".size __aeabi_memclr4, . - __aeabi_memclr4",
    // void __aeabi_memset(void *dest, size_t n, int c): r0 dest, r1 n, r2 c.
    ".section .text.__aeabi_memset,\"ax\",%progbits",
    ".global __aeabi_memset",
    ".global __aeabi_memset4",
    ".global __aeabi_memset8",
    ".type __aeabi_memset,%function",
    ".type __aeabi_memset4,%function",
    ".type __aeabi_memset8,%function",
    ".thumb_func",
    "__aeabi_memset:",
    ".thumb_func",
    "__aeabi_memset4:",
    ".thumb_func",
    "__aeabi_memset8:",
    "    cbz r1, 2f",
    "1:  strb r2, [r0], #1",
    "    subs r1, r1, #1",
    "    bne 1b",
    "2:  bx lr",
    ".size __aeabi_memset, . - __aeabi_memset",
    // void __aeabi_memcpy(void *dest, const void *src, size_t n) and memcpy: r0 dest, r1 src,
    // r2 n; returns dest. Words while both pointers share their alignment (bytes up to a word
    // boundary first); bytes otherwise and for the tail.
    ".section .text.__aeabi_memcpy,\"ax\",%progbits",
    ".global __aeabi_memcpy",
    ".global __aeabi_memcpy4",
    ".global memcpy",
    ".type __aeabi_memcpy,%function",
    ".type __aeabi_memcpy4,%function",
    ".type memcpy,%function",
    ".thumb_func",
    "__aeabi_memcpy:",
    ".thumb_func",
    "__aeabi_memcpy4:",
    ".thumb_func",
    "memcpy:",
    "    mov r12, r0",
    "    eor r3, r0, r1",
    "    lsls r3, r3, #30",
    "    bne 3f",
    // Same alignment: bytes up to a word boundary, then words, then the tail's bytes.
    "1:  tst r0, #3",
    "    beq 2f",
    "    cbz r2, 5f",
    "    ldrb r3, [r1], #1",
    "    strb r3, [r0], #1",
    "    subs r2, r2, #1",
    "    b 1b",
    "2:  subs r2, r2, #4",
    "    bcc 4f",
    "6:  ldr r3, [r1], #4",
    "    str r3, [r0], #4",
    "    subs r2, r2, #4",
    "    bcs 6b",
    "4:  adds r2, r2, #4",
    "3:  cbz r2, 5f",
    "7:  ldrb r3, [r1], #1",
    "    strb r3, [r0], #1",
    "    subs r2, r2, #1",
    "    bne 7b",
    "5:  mov r0, r12",
    "    bx lr",
    ".size __aeabi_memcpy, . - __aeabi_memcpy",
);
