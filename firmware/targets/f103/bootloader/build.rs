//! The F103 bootloader's memory.x and key (../../shared/bootloader_build.rs): its partition of
//! the flash map, its RAM in the top 4 KiB of the 20 KiB, above every module image's statics
//! (their budget is 16 KiB), so a panic report kept in RAM survives it.

include!("../../shared/bootloader_build.rs");

fn main() {
    build_bootloader(&r2p_boot::layout::STM32F103CB, 0x2000_4000, 4 * 1024);
}
