//! A smaller `memcmp` for the bare-metal module images than compiler-builtins': 26 B of
//! Thumb-2 against its 116 B (unrolled four bytes a step, a frame of eight registers), for the
//! PSU's room (docs/flashing.md, "The F103's room").
//!
//! Rust calls `memcmp` to compare byte slices and strings: in a module image, topic names, the
//! node's UID in heartbeats, the module kind of an update, a repeated last frame in
//! reassembly, all a few to 16 bytes. One byte a step, six instructions per byte and none to
//! set up or restore: fewer instructions than the library's at every length (its four-byte
//! steps take seven and a quarter per byte, and its frame four more per call). The result is
//! the library's: the difference of the first two bytes that differ (as unsigned bytes), or 0.
//! compiler-builtins defines `memcmp` weak; this strong one replaces it at link time, on bare
//! metal only. Not in `mem_routines.rs`, which the bootloader includes: its image stays as
//! flashed.

// int memcmp(const void *a, const void *b, size_t n): r0 a, r1 b, r2 n.
#[cfg(all(target_arch = "arm", target_os = "none"))]
core::arch::global_asm!(
    ".section .text.memcmp,\"ax\",%progbits",
    ".global memcmp",
    ".type memcmp,%function",
    ".thumb_func",
    "memcmp:",
    "    movs r3, #0",
    "    cbz r2, 2f",
    "1:  ldrb r3, [r0], #1",
    "    ldrb r12, [r1], #1",
    "    subs r3, r3, r12",
    "    bne 2f",
    "    subs r2, r2, #1",
    "    bne 1b",
    "2:  mov r0, r3",
    "    bx lr",
    ".size memcmp, . - memcmp",
);
