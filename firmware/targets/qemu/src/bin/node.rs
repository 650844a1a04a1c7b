//! The r2p-node crate's test suite on a Cortex-M3.
#![no_std]
#![no_main]

use r2p_qemu_tests as _;

#[cortex_m_rt::entry]
fn main() -> ! {
    r2p_qemu_tests::run("node", r2p_node::selftest::ALL)
}
