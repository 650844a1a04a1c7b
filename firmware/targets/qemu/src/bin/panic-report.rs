//! A panic's report kept across the reset, as a module keeps it (r2p-panic, docs/flashing.md):
//! the first boot panics in `explode` (an index out of bounds); the panic handler keeps the
//! calls found on the stack and resets the MCU (SYSRESETREQ, which QEMU performs); the second
//! boot reads the report back and checks that one of its calls lies in `explode`, the panic
//! site, and that it is read once. Exits through semihosting: status 0 if so, 1 if not.
//! Not built on this workspace's runner library: it has its own panic handler.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use cortex_m_semihosting::{debug, hprintln};

/// The boot count, kept across resets like the report (a magic word, then the count), so that
/// a report that never comes back fails instead of panicking forever.
#[link_section = ".uninit.boots"]
static mut BOOTS: MaybeUninit<[u32; 2]> = MaybeUninit::uninit();
const BOOTS_MAGIC: u32 = 0xB007_C0DE;

/// This boot's number: 1 after power-on, then one more at each reset.
fn boot_number() -> u32 {
    let b = addr_of_mut!(BOOTS).cast::<u32>();
    // SAFETY: one thread, at boot; plain integers, any bit pattern valid.
    unsafe {
        let n = if b.read_volatile() == BOOTS_MAGIC { b.add(1).read_volatile() + 1 } else { 1 };
        b.write_volatile(BOOTS_MAGIC);
        b.add(1).write_volatile(n);
        n
    }
}

/// The panic site: reads past the end of a table.
#[inline(never)]
fn explode(i: usize) -> ! {
    let table = core::hint::black_box([1u8, 2, 3]);
    let v = table[i];
    loop {
        core::hint::black_box(v);
    }
}

/// Reports as the other images do (libtest's lines, which scripts/qemu-test counts) and exits.
fn finish(ok: bool, why: &str) -> ! {
    hprintln!("\nrunning 1 tests (panic-report on cortex-m3)");
    hprintln!(
        "test r2p_panic::a_report_survives_the_reset ... {}",
        if ok { "ok" } else { "FAILED" }
    );
    hprintln!("{}", why);
    hprintln!(
        "\ntest result: {}. {} passed; {} failed",
        if ok { "ok" } else { "FAILED" },
        ok as u8,
        !ok as u8
    );
    debug::exit(if ok { debug::EXIT_SUCCESS } else { debug::EXIT_FAILURE });
    loop {
        cortex_m::asm::wfi();
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let boot = boot_number();
    let report = r2p_panic::take_last();
    match (boot, report) {
        (1, None) => {
            hprintln!("panic-report: boot 1, no report; panicking in explode()");
            explode(core::hint::black_box(7))
        }
        (2, Some(bytes)) => {
            let text = core::str::from_utf8(bytes).unwrap_or("");
            hprintln!("panic-report: boot 2 read {:?}", text);
            let start = explode as *const () as usize as u32 & !1;
            let in_explode =
                r2p_panic::addresses(text).any(|a| (start..start + 0x100).contains(&a));
            if !text.starts_with(r2p_panic::PREFIX) || r2p_panic::addresses(text).count() == 0 {
                finish(false, "not a report")
            } else if !in_explode {
                finish(false, "no call in explode(), the panic site")
            } else if r2p_panic::take_last().is_some() {
                finish(false, "the report was read twice")
            } else {
                finish(true, "a call in explode() kept across the reset, read once")
            }
        }
        (1, Some(_)) => finish(false, "a report after power-on"),
        (_, None) => finish(false, "no report after the panic's reset"),
        (n, Some(_)) => finish(false, if n > 2 { "more than one reset" } else { "?" }),
    }
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    r2p_panic::keep();
    cortex_m::peripheral::SCB::sys_reset()
}
