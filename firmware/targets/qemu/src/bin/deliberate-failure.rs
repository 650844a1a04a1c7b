//! A deliberately failing check, so the runner's own test (tests/test_qemu_runner.py) can prove
//! that a failure on the Cortex-M3 fails the run. scripts/qemu-test skips it.
#![no_std]
#![no_main]

use r2p_qemu_tests as _;
use r2p_testkit::Case;

fn passes() {
    assert_eq!(rtcan::FrameId::sync(7).sync_cycle(), Some(7));
}

fn fails_on_purpose() {
    let id = rtcan::FrameId::from_raw(63 << 23).unwrap();
    assert_eq!(id.class(), rtcan::FrameClass::Hrt, "deliberate failure: an NRT frame is not HRT");
}

#[cortex_m_rt::entry]
fn main() -> ! {
    r2p_qemu_tests::run(
        "deliberate-failure",
        &[&[
            Case { name: "runner::passes", run: passes },
            Case { name: "runner::fails_on_purpose", run: fails_on_purpose },
        ]],
    )
}
