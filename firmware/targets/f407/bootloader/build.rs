//! The F407 bootloader's memory.x and key (../../shared/bootloader_build.rs): its partition of
//! the flash map, its RAM in the top 16 KiB of SRAM (0x2001_C000), above the gateway image's
//! statics.

include!("../../shared/bootloader_build.rs");

fn main() {
    build_bootloader(&r2p_boot::layout::STM32F407VG, 0x2001_C000, 16 * 1024);
}
