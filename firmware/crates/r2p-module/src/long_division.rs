//! A smaller 64-bit division for the bare-metal images than compiler-builtins': a module image
//! must fit a 55 KiB bootloader slot (docs/flashing.md, "The F103's room").
//!
//! On the Cortex-M3 and M4 LLVM compiles a `u64` division or remainder into a call of the ARM
//! run-time ABI's `__aeabi_uldivmod` (`i64`: `__aeabi_ldivmod`): the dividend in r1:r0, the
//! divisor in r3:r2, the quotient returned in r1:r0 and the remainder in r3:r2. compiler-builtins'
//! is a wrapper, `__udivmoddi4`, and a general `u64_div_rem` (934 B together), with shift-subtract
//! loops for a divisor of 2¹⁶ or more. Here the unsigned helper is 210 B of assembly (the signed one
//! 48 B more), and every case but one is shorter (docs/flashing.md, the sixth diet: the slot
//! path, whose divisions are rtcan's slot clock's, both operands below 2³², lost 265 instructions):
//!
//! - dividend and divisor below 2³²: one `UDIV`, 6 instructions;
//! - divisor below 2³², dividend not: the high word's quotient by `UDIV`, then the 64-by-32-bit
//!   division of what is left (its high word below the divisor) by the core below;
//! - divisor of 2³² or more (the quotient fits 32 bits): 0 when the dividend's high word is
//!   smaller; else the quotient estimated from the divisor's top 32 bits, normalised, and the
//!   dividend halved (the core below), at most one too small, corrected once (Hacker's Delight,
//!   2nd ed., §9-5, "Doubleword Division from Long Division").
//!
//! The core divides a 64-bit number by a 32-bit one whose quotient fits 32 bits: Knuth's
//! algorithm D (TAOCP vol. 2, §4.3.1) in two 16-bit digits, the divisor normalised (its top bit
//! set), each digit estimated by `UDIV` from the divisor's top half and corrected at most twice
//! (Hacker's Delight, §9-4, `divlu`). No step loops over bits: a division takes at most ~80
//! instructions.
//!
//! Division by zero: the quotient is 0 and the remainder the dividend, as with the Cortex-M's
//! `UDIV` (quotient 0), one of the behaviours the run-time ABI allows (IHI 0043, §4.3.2: a divmod
//! helper's quotient is what `__aeabi_ldiv0` returns, which may be a fixed value, and its
//! remainder 0 or the dividend). Rust checks the divisor before it divides, so no Rust code
//! reaches it (compiler-builtins leaves the case undefined). `i64::MIN / -1`, which Rust also
//! checks, wraps: quotient `i64::MIN`, remainder 0.
//!
//! compiler-builtins defines its helpers weak; these strong ones replace them at link time, on
//! bare metal only. `firmware/targets/qemu/src/bin/division.rs` checks them on a Cortex-M3
//! against a shift-subtract reference: edge cases and some 800 000 pseudo-random pairs of every
//! width, and the registers the ABI says a call keeps.

// In assembly: a Rust function cannot return the quotient and the remainder in r0–r3.
#[cfg(all(target_arch = "arm", target_os = "none"))]
core::arch::global_asm!(
    ".section .text.__aeabi_uldivmod,\"ax\",%progbits",
    ".global __aeabi_uldivmod",
    ".type __aeabi_uldivmod,%function",
    ".thumb_func",
    "__aeabi_uldivmod:",
    "    cbnz r3, 3f",
    "    cbnz r1, 1f",
    // Both below 2³² (a zero divisor too: UDIV gives 0, the remainder is the dividend).
    "    udiv r12, r0, r2",
    "    mls r2, r12, r2, r0",
    "    mov r0, r12",
    "    bx lr",
    // Divisor below 2³², dividend not: the high word's quotient, then (rest:low) / divisor.
    "1:  cbz r2, 8f",
    "    udiv r3, r1, r2",
    "    mls r1, r3, r2, r1",
    "    push {{r3-r7, lr}}",
    "    bl 5f",
    "    mov r2, r1",
    "    movs r3, #0",
    "    pop {{r1, r4-r7, pc}}",
    // Divisor of 2³² or more: the quotient fits 32 bits, and is 0 if the high words say so.
    "3:  cmp r1, r3",
    "    bcc 8f",
    "    push {{r4-r7, lr}}",
    "    push {{r0-r3}}",
    "    clz r4, r3",
    "    lsls r3, r4",
    "    rsb r5, r4, #32",
    "    lsrs r2, r5",
    "    orrs r2, r3", // the divisor's top 32 bits, normalised (a shift by 32 gives 0)
    "    lsrs r1, r1, #1",
    "    rrx r0, r0", // the dividend halved, so its high word is below that
    "    bl 5f",
    "    pop {{r4-r7}}", // dividend r5:r4, divisor r7:r6
    "    clz r3, r7",
    "    rsb r3, r3, #31",
    "    lsrs r0, r0, r3", // the estimate, one too large at most; made one too small at most
    "    it ne",
    "    subne r0, r0, #1",
    "    umull r2, r3, r0, r6",
    "    mla r3, r0, r7, r3",
    "    subs r4, r4, r2",
    "    sbcs r5, r3", // the remainder, below twice the divisor
    "    subs r2, r4, r6",
    "    sbcs r3, r5, r7",
    "    itte cc", // below the divisor: the remainder; else one more, the divisor less
    "    movcc r2, r4",
    "    movcc r3, r5",
    "    addcs r0, r0, #1",
    "    movs r1, #0",
    "    pop {{r4-r7, pc}}",
    // Quotient 0, remainder the dividend (a dividend below the divisor, or a zero divisor).
    "8:  mov r2, r0",
    "    mov r3, r1",
    "    movs r0, #0",
    "    movs r1, #0",
    "    bx lr",
    // The core: r1:r0 / r2 with r1 < r2, the quotient in r0 and the remainder in r1; r2–r7,
    // r12 clobbered. Two 16-bit digits (b = 2¹⁶): R holds the partial remainder's two top
    // digits, r0 the dividend's digits still to bring down, the next at its top.
    "5:  push {{lr}}",
    "    clz r3, r2",  // s, the normalising shift
    "    lsls r2, r3", // v, its top bit set
    "    lsls r1, r3",
    "    rsb r5, r3, #32",
    "    lsr r5, r0, r5",
    "    orrs r1, r5", // R
    "    lsls r0, r3",
    "    lsrs r4, r2, #16",   // vn1, v's top digit (≥ 2¹⁵)
    "    uxth r12, r2",       // vn0
    "    movs r6, #1",        // the quotient, with a marker bit that leaves with the second digit
    "2:  udiv r7, r1, r4",    // q̂ = R / vn1: the digit, or up to 2 more
    "    mls r1, r7, r4, r1", // r̂ = R − q̂·vn1
    "    lsrs r5, r0, #16",
    "    orr r5, r5, r1, lsl #16", // r̂·b + the next digit (mod 2³², as r̂ grows)
    // q̂ ≤ b + 1 (R < v, vn1 ≥ b/2), so q̂·vn0 < 2³²; r̂ < b here, so r̂·b + digit is exact:
    // q̂·vn0 > r̂·b + digit exactly when q̂·v > R·b + digit, q̂ too large (no test of q̂ ≥ b).
    "6:  mul lr, r7, r12",
    "    cmp lr, r5",
    "    bls 9f",
    "    subs r7, r7, #1",
    "    add r1, r1, r4",
    "    add r5, r5, r4, lsl #16",
    "    cmp r1, #0x10000",
    "    bcc 6b",              // once r̂ ≥ b the test cannot fail again
    "9:  mls r1, r7, r12, r5", // R = r̂·b + digit − q̂·vn0, below v (so exact mod 2³²)
    "    lsls r0, r0, #16",
    "    lsls r6, r6, #16", // carry: the marker, so this was the second digit
    "    add r6, r7",       // (an ADD of two registers leaves the flags)
    "    bcc 2b",
    "    lsrs r1, r3",
    "    mov r0, r6",
    "    pop {{pc}}",
    ".size __aeabi_uldivmod, . - __aeabi_uldivmod",
    // The signed division, on the unsigned one: magnitudes divided, the quotient negated when
    // the signs differ, the remainder given the dividend's sign (both truncate toward zero).
    ".section .text.__aeabi_ldivmod,\"ax\",%progbits",
    ".global __aeabi_ldivmod",
    ".type __aeabi_ldivmod,%function",
    ".thumb_func",
    "__aeabi_ldivmod:",
    "    push {{r4, r5, r6, lr}}", // r6 for the stack's 8-byte alignment at the call
    "    asrs r4, r1, #31",        // the dividend's sign, 0 or −1
    "    eor r5, r4, r3, asr #31", // the quotient's
    "    eors r0, r0, r4",
    "    eors r1, r1, r4",
    "    subs r0, r0, r4",
    "    sbcs r1, r1, r4", // |dividend| (x ^ s) − s
    "    asrs r6, r3, #31",
    "    eors r2, r2, r6",
    "    eors r3, r3, r6",
    "    subs r2, r2, r6",
    "    sbcs r3, r3, r6", // |divisor|
    "    bl __aeabi_uldivmod",
    "    eors r0, r0, r5",
    "    eors r1, r1, r5",
    "    subs r0, r0, r5",
    "    sbcs r1, r1, r5",
    "    eors r2, r2, r4",
    "    eors r3, r3, r4",
    "    subs r2, r2, r4",
    "    sbcs r3, r3, r4",
    "    pop {{r4, r5, r6, pc}}",
    ".size __aeabi_ldivmod, . - __aeabi_ldivmod",
);
