//! The panic handler: keeps a report of the panic across the reset (r2p-panic: the calls found
//! on the stack, in RAM that start-up leaves alone), logs it over RTT (defmt), then resets the
//! module — or, with a debugger attached (`cargo run`), stops on a breakpoint so that
//! `probe-rs run` prints the backtrace with files and lines. The next boot hands the report to
//! the node, which sends it on the bus (PANIC_REPORT, shown by `r2p nodes`; `start_bus`).
//!
//! It does not read the `PanicInfo`: reading even its location makes the compiler keep every
//! panic site's message and formatting code, measured on the template image at +14 992 B
//! (location) and +16 368 B (location and message, when it is a plain string), which the module
//! budgets do not allow. Nor the panic-persist crate, for the same reason: it writes the
//! `PanicInfo` with `core::fmt` (measured on the template image, logging it with defmt too:
//! +25 360 B over a handler that reads nothing).

use core::panic::PanicInfo;

#[panic_handler]
fn panic(_info: &PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    let (calls, found) = r2p_panic::keep();
    defmt::error!("panicked; calls at {=[?]:#x}", calls[..found]);
    if cortex_m::peripheral::DCB::is_debugger_attached() {
        // `probe-rs run` stops here and prints the backtrace.
        cortex_m::asm::bkpt();
    }
    cortex_m::peripheral::SCB::sys_reset()
}
