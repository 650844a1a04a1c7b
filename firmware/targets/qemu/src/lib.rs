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
