//! The r2p-msgs crate (generated message types)'s test suite on a Cortex-M3.
#![no_std]
#![no_main]

use r2p_qemu_tests as _;

#[cortex_m_rt::entry]
fn main() -> ! {
    r2p_qemu_tests::run("msgs", r2p_msgs::selftest::ALL)
}
