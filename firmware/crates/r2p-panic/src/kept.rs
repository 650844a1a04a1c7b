//! The report in RAM across the reset (Cortex-M, cortex-m-rt).

use core::mem::MaybeUninit;
use core::ptr::{addr_of, addr_of_mut};

use crate::{calls_in, report, CALLS, KEPT_BYTES};

/// Marks a kept report; anything else (a power-on's random RAM, a report already read) is none.
const MAGIC: u32 = 0x0FAC_ADE0;
const TEXT: usize = KEPT_BYTES - 8;
/// How far up the stack to look, in words.
const SCAN_WORDS: usize = 256;

#[repr(C)]
struct Kept {
    magic: u32,
    len: u32,
    text: [u8; TEXT],
}

/// In cortex-m-rt's `.uninit` section: start-up neither zeroes nor initialises it, so what
/// [`keep`] writes survives a reset (not a power cycle).
#[link_section = ".uninit.r2p_panic"]
static mut KEPT: MaybeUninit<Kept> = MaybeUninit::uninit();

extern "C" {
    static __stext: u8;
    static __etext: u8;
    static _stack_start: u8;
}

/// From a panic handler, with interrupts off: finds the calls on the stack and keeps their
/// report for the next boot. Returns the calls (for a log). The caller then resets. The first
/// call found, the handler's own call of this function, is left out.
#[inline(never)]
pub fn keep() -> ([u32; CALLS], usize) {
    let sp: usize;
    // SAFETY: reads the stack pointer; no memory is touched.
    unsafe { core::arch::asm!("mov {}, sp", out(reg) sp, options(nomem, nostack)) };
    let text = addr_of!(__stext) as u32..addr_of!(__etext) as u32;
    let top = (addr_of!(_stack_start) as usize).min(sp + 4 * SCAN_WORDS);
    // SAFETY: words of the stack, between the stack pointer and the stack's top; halfwords
    // of the code, which `call_before` reads only within `text`.
    let stack = (sp & !3..top).step_by(4).map(|a| unsafe { (a as *const u32).read_volatile() });
    let (calls, found) =
        calls_in(stack, &text, |a| unsafe { (a as *const u16).read_volatile() }, 1);
    let kept = addr_of_mut!(KEPT).cast::<Kept>();
    let mut buf = [0u8; TEXT];
    let len = report(&calls[..found], &mut buf);
    // SAFETY: called with interrupts off from a handler that never returns, so nothing else
    // touches KEPT; raw pointers only (no reference to the uninitialised static); the length
    // is written before the magic word that makes it valid.
    unsafe {
        addr_of_mut!((*kept).text).cast::<[u8; TEXT]>().write_volatile(buf);
        addr_of_mut!((*kept).len).write_volatile(len as u32);
        addr_of_mut!((*kept).magic).write_volatile(MAGIC);
    }
    (calls, found)
}

/// The report of the panic that preceded this boot, once: it is forgotten as it is read.
/// `None` after a power-on or a reset without a panic. Call it once, at boot, before anything
/// can panic.
pub fn take_last() -> Option<&'static [u8]> {
    let kept = addr_of_mut!(KEPT).cast::<Kept>();
    // SAFETY: at boot nothing else touches KEPT; its words are read as plain integers (any bit
    // pattern is valid) and the text only up to a length checked against its size. The text
    // is not written again before the next panic, which resets: the slice stays valid.
    unsafe {
        if addr_of!((*kept).magic).read_volatile() != MAGIC {
            return None;
        }
        addr_of_mut!((*kept).magic).write_volatile(0);
        let len = addr_of!((*kept).len).read_volatile() as usize;
        (len <= TEXT).then(|| core::slice::from_raw_parts(addr_of!((*kept).text).cast::<u8>(), len))
    }
}
