//! Bare-metal test runner for QEMU's Cortex-M3 (lm3s6965evb).
//!
//! [`run`] prints one line per test as libtest does, then exits QEMU through semihosting
//! with status 0. A failing test panics; the panic handler prints where and why and exits
//! with status 1, so the failure reaches the shell and `make test`.
#![no_std]

use core::fmt::Write;
use core::sync::atomic::{AtomicUsize, Ordering};
use cortex_m_semihosting::{debug, hio};
use r2p_testkit::Case;

static PASSED: AtomicUsize = AtomicUsize::new(0);

fn out() -> hio::HostStream {
    hio::hstdout().unwrap_or_else(|_| exit(debug::EXIT_FAILURE))
}

/// Ends the QEMU process with `status`; semihosting never returns from it.
fn exit(status: debug::ExitStatus) -> ! {
    debug::exit(status);
    loop {
        cortex_m::asm::wfi();
    }
}

/// Runs every case of every suite, then exits QEMU: status 0 if all passed.
pub fn run(image: &str, suites: &[&[Case]]) -> ! {
    let mut o = out();
    let total: usize = suites.iter().map(|s| s.len()).sum();
    let _ = writeln!(o, "\nrunning {} tests ({} on cortex-m3)", total, image);
    for case in suites.iter().flat_map(|s| s.iter()) {
        let _ = write!(o, "test {} ... ", case.name);
        (case.run)();
        PASSED.fetch_add(1, Ordering::Relaxed);
        let _ = writeln!(o, "ok");
    }
    let _ = writeln!(o, "\ntest result: ok. {} passed; 0 failed", PASSED.load(Ordering::Relaxed));
    exit(debug::EXIT_SUCCESS)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    let mut o = out();
    let _ = writeln!(o, "FAILED\n\n{}", info);
    let _ =
        writeln!(o, "\ntest result: FAILED. {} passed; 1 failed", PASSED.load(Ordering::Relaxed));
    exit(debug::EXIT_FAILURE)
}

/// Counting instructions under QEMU's `-icount`, for the benchmark images (`bench`, `fusion`,
/// `slot-path`): virtual time advances a fixed amount per instruction, so SysTick (driven by
/// virtual time, counting down from [`icount::RELOAD`]) counts instructions in a fixed ratio,
/// which [`icount::ten_thousand_nops`] calibrates. The result does not depend on QEMU's clock
/// settings and repeats to the instruction.
pub mod icount {
    use cortex_m::peripheral::syst::SystClkSource;
    use cortex_m::peripheral::SYST;

    /// SysTick's reload: its whole 24-bit range.
    pub const RELOAD: u32 = 0x00FF_FFFF;

    /// Starts SysTick on the core clock, counting down from [`RELOAD`].
    pub fn start(syst: &mut SYST) {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(RELOAD);
        syst.clear_current();
        syst.enable_counter();
    }

    /// SysTick's count now.
    pub fn now() -> u32 {
        SYST::get_current()
    }

    /// Ticks `f` takes (less than one SysTick period).
    pub fn ticks(f: impl FnOnce()) -> u32 {
        let start = now();
        f();
        start.wrapping_sub(now()) & RELOAD
    }

    /// Exactly 10 000 instructions, for the calibration.
    #[inline(never)]
    pub fn ten_thousand_nops() {
        // SAFETY: only `nop`s.
        unsafe {
            core::arch::asm!(
                ".rept 10000",
                "nop",
                ".endr",
                options(nomem, nostack, preserves_flags)
            );
        }
    }
}
