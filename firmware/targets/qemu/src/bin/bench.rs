//! Cortex-M3 benchmark under QEMU (run by `scripts/bench`, not by the test suite): instructions
//! per publish → deliver → release round trip for 1–8 subscribers, R2P middleware next to
//! embassy-sync's `PubSubChannel`.
//!
//! QEMU runs with `-icount`, so virtual time advances a fixed amount per instruction and SysTick
//! (driven by virtual time) counts instructions in a fixed ratio. That ratio is calibrated on a
//! block of exactly 10 000 `nop`s, which makes the result independent of QEMU's clock settings
//! and repeatable to the instruction.
#![no_std]
#![no_main]

use core::fmt::Write;
use cortex_m_semihosting::{debug, hio};
use r2p_bench::{embassy_round, expected_checksum, r2p_round, SUBSCRIBERS};
use r2p_qemu_tests::icount::{self, ten_thousand_nops, ticks};

const MESSAGES: u32 = 2_000;

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut p = cortex_m::Peripherals::take().unwrap();
    icount::start(&mut p.SYST);
    let mut out = hio::hstdout().unwrap();

    // Ticks per instruction: 10 nop blocks minus the cost of calling an empty block.
    let nops = ticks(|| (0..10).for_each(|_| ten_thousand_nops()));
    let insn_per_tick = 100_000.0f64 / nops as f64;
    let _ = writeln!(out, "{{\"bench\":\"calibration\",\"ticks_per_100k_insn\":{}}}", nops);

    for n in SUBSCRIBERS {
        let mut sums = [0u32; 2];
        let r = ticks(|| sums[0] = r2p_round(n, MESSAGES));
        let e = ticks(|| sums[1] = embassy_round(n, MESSAGES));
        if sums != [expected_checksum(n, MESSAGES); 2] {
            let _ = writeln!(out, "bench: wrong checksum with {} subscribers", n);
            debug::exit(debug::EXIT_FAILURE);
        }
        let per_msg = |t: u32| t as f64 * insn_per_tick / MESSAGES as f64;
        let _ = writeln!(
            out,
            "{{\"bench\":\"cortex_m3_pubsub\",\"subscribers\":{},\"r2p_insn_per_msg\":{:.0},\"embassy_sync_insn_per_msg\":{:.0}}}",
            n,
            per_msg(r),
            per_msg(e)
        );
    }
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}
