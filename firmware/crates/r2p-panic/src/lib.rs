//! A module's panic, kept across the reset (docs/flashing.md, "When a module panics").
//!
//! A panic handler cannot read Rust's `PanicInfo` cheaply: reading even its location makes the
//! compiler keep every panic site's message and formatting code (measured +14 992 B on the
//! template image). What it can keep for free is where the panic happened as the stack shows
//! it: the first [`CALLS`] return addresses found there that follow a call instruction, innermost
//! first — the panic machinery's own calls (`panic_fmt`, `panic_bounds_check`, `unwrap_failed`
//! …), then the panic site and its callers. They are kept as the text [`report`] writes,
//! `panic, calls: 08002a1e 0800b3c2 …` (hexadecimal, the address of each call instruction),
//! which `arm-none-eabi-addr2line` turns into functions and lines with the image's ELF, and
//! which the node sends on the bus as PANIC_REPORT.
//!
//! The decoding here ([`is_call`], [`calls_in`], [`report`], [`addresses`]) is plain code,
//! tested on the host; [`keep`] and [`take_last`], on Cortex-M only, read the real stack and
//! keep the text in a static in cortex-m-rt's `.uninit` section, which start-up neither zeroes
//! nor initialises (a QEMU image, firmware/targets/qemu/src/bin/panic-report.rs, panics, resets
//! and reads its report back).
#![no_std]

#[cfg(all(target_arch = "arm", target_os = "none"))]
mod kept;
#[cfg(all(target_arch = "arm", target_os = "none"))]
pub use kept::{keep, take_last};

use core::ops::Range;

/// Calls kept.
pub const CALLS: usize = 5;
/// Bytes of RAM kept for the report (a magic word, a length, the text).
pub const KEPT_BYTES: usize = 72;
/// How a report starts.
pub const PREFIX: &str = "panic, calls:";

/// Whether the two halfwords just before a return address are a call: a 32-bit `BL` (first
/// halfword `11110…`, second `11x1…`) or, in the second, a 16-bit `BLX` register (`010001111…`).
pub fn is_call(first: u16, second: u16) -> bool {
    let bl = first & 0xF800 == 0xF000 && second & 0xD000 == 0xD000;
    let blx = second & 0xFF87 == 0x4780;
    bl || blx
}

/// If `word` is a return address into `text` (Thumb bit set) just after a call, the address of
/// that call instruction's last halfword (inside it, so that a line table maps it to the
/// call's line). `halfword(a)` reads the code at `a`.
pub fn call_before(word: u32, text: &Range<u32>, halfword: impl Fn(u32) -> u16) -> Option<u32> {
    if word & 1 == 0 {
        return None;
    }
    let ret = word - 1;
    if ret < text.start.saturating_add(4) || ret > text.end {
        return None;
    }
    is_call(halfword(ret - 4), halfword(ret - 2)).then_some(ret - 2)
}

/// The first [`CALLS`] calls among the `stack` words after the first `skip`, innermost (lowest
/// address) first, and how many were found.
pub fn calls_in(
    stack: impl IntoIterator<Item = u32>,
    text: &Range<u32>,
    halfword: impl Fn(u32) -> u16,
    skip: usize,
) -> ([u32; CALLS], usize) {
    let mut calls = [0; CALLS];
    let (mut found, mut skipped) = (0, 0);
    // A plain loop rather than `filter_map(..).skip(skip)`: `Skip` called `Iterator::nth`, an
    // out-of-line copy of the scan (~100 B of every image for a path that runs once, in a panic).
    for word in stack {
        let Some(call) = call_before(word, text, &halfword) else {
            continue;
        };
        if skipped < skip {
            skipped += 1;
            continue;
        }
        calls[found] = call;
        found += 1;
        if found == CALLS {
            break;
        }
    }
    (calls, found)
}

/// Writes the report of `calls` into `out` (cut to fit); returns its length.
pub fn report(calls: &[u32], out: &mut [u8]) -> usize {
    let mut n = 0;
    let mut put = |b: u8| {
        if let Some(slot) = out.get_mut(n) {
            *slot = b;
            n += 1;
        }
    };
    PREFIX.bytes().for_each(&mut put);
    for &call in calls {
        put(b' ');
        for shift in (0..8).rev() {
            put(b"0123456789abcdef"[(call >> (4 * shift)) as usize & 0xF]);
        }
    }
    n
}

/// The addresses of a report ([`report`]'s text), in order; nothing if `text` is not one.
pub fn addresses(text: &str) -> impl Iterator<Item = u32> + '_ {
    text.strip_prefix(PREFIX)
        .unwrap_or("")
        .split(' ')
        .filter(|w| !w.is_empty())
        .map_while(|w| u32::from_str_radix(w, 16).ok())
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::collections::BTreeMap;

    use super::*;

    /// Code at 0x0800_0000..0x0800_1000: a `BL` ending at 0x100, a `BLX r3` at 0x202, a
    /// `push {r7, lr}` before 0x300 (no call), anything else zero.
    fn code() -> BTreeMap<u32, u16> {
        BTreeMap::from([
            (0x0800_00FC, 0xF000),
            (0x0800_00FE, 0xF9D8), // bl
            (0x0800_0200, 0x0000),
            (0x0800_0202, 0x4798), // blx r3
            (0x0800_02FE, 0xB580), // push {r7, lr}
        ])
    }

    #[test]
    fn bl_and_blx_are_calls_other_instructions_are_not() {
        assert!(is_call(0xF7FF, 0xFFEE)); // bl backwards
        assert!(is_call(0xF000, 0xF800));
        assert!(is_call(0x0000, 0x4798)); // blx r3
        assert!(!is_call(0x0000, 0x4770)); // bx lr
        assert!(!is_call(0xB580, 0xAF00)); // push, add
        assert!(!is_call(0xF000, 0x8000)); // a 32-bit branch that is not BL (b.w cond)
    }

    #[test]
    fn return_addresses_after_calls_are_found_innermost_first() {
        let m = code();
        let read = |a: u32| m.get(&a).copied().unwrap_or(0);
        let text = 0x0800_0000..0x0800_1000;
        let stack = [
            0x2000_4000, // a RAM address
            0x0800_0101, // returns after the BL: a call at 0x0800_00FE
            0x0800_0100, // no Thumb bit: data
            0x0800_0301, // after a push: a function pointer, not a return address
            0x0800_0205, // after the BLX r3 at 0x0800_0202 (ends at 0x204)
            0x0900_0101, // outside the code
            0x0800_0101, // the same call again (recursion)
            0x0800_0205,
            0x0800_0101,
        ];
        let (calls, n) = calls_in(stack, &text, read, 0);
        assert_eq!(
            (n, calls),
            (5, [0x0800_00FE, 0x0800_0202, 0x0800_00FE, 0x0800_0202, 0x0800_00FE])
        );
        let (calls, n) = calls_in(stack, &text, read, 1);
        assert_eq!(
            (n, &calls[..n]),
            (4, &[0x0800_0202, 0x0800_00FE, 0x0800_0202, 0x0800_00FE][..])
        );
        let (_, n) = calls_in(stack[..3].iter().copied(), &text, read, 0);
        assert_eq!(n, 1);
        // The first 4 bytes of the code cannot follow a call.
        assert_eq!(call_before(0x0800_0003, &text, read), None);
    }

    #[test]
    fn only_thumb_return_addresses_within_the_code_count() {
        // Code where every pair of halfwords is a BL: only the word itself decides.
        let bl = |a: u32| if a.is_multiple_of(4) { 0xF000 } else { 0xF800 };
        let text = 0x0800_0000..0x0800_1000;
        let at = |ret: u32| call_before(ret + 1, &text, bl);
        assert_eq!(at(0x0800_0004), Some(0x0800_0002), "the first place a call can end");
        assert_eq!(at(0x0800_0002), None, "before it: the call would start before the code");
        assert_eq!(at(0x07FF_FFF0), None);
        assert_eq!(at(0x0800_1000), Some(0x0800_0FFE), "a call ending the code");
        assert_eq!(at(0x0800_1002), None);
        // 0xF000 is a BL's first halfword and a valid second one: code that is calls everywhere.
        let calls = |_| 0xF000;
        assert_eq!(call_before(0x0800_0101, &text, calls), Some(0x0800_00FE));
        assert_eq!(
            call_before(0x0800_0100, &text, calls),
            None,
            "no Thumb bit: not a return address"
        );
    }

    #[test]
    fn a_report_reads_back_and_fits_a_panic_report_message() {
        let mut out = [0u8; 62]; // PANIC_TEXT_MAX, the longest PANIC_REPORT text
        let calls = [0x0800_2A1E, 0x0800_B3C2, 0x0800_4F16, 0x0800_0D5A, 0x0800_0120];
        let n = report(&calls, &mut out);
        let text = std::str::from_utf8(&out[..n]).unwrap();
        assert_eq!(text, "panic, calls: 08002a1e 0800b3c2 08004f16 08000d5a 08000120");
        assert!(n + 8 <= KEPT_BYTES, "the kept text and its 8-byte header fit");
        assert_eq!(addresses(text).collect::<std::vec::Vec<_>>(), calls);
        assert_eq!(addresses("index out of bounds").count(), 0);
        let mut short = [0u8; 20];
        assert_eq!(report(&calls, &mut short), 20, "cut to fit, never past the buffer");
    }
}
