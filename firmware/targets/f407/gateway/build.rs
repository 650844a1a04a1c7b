//! Generates `board.rs` from the gateway's board file (the single source of its pins) and links
//! the image into the active slot of the F407's flash map (firmware/images.toml, through
//! r2p-boot's layout), behind the bootloader: its last 128 bytes left for the signed image's
//! trailer; its RAM below the bootloader's top 16 KiB of SRAM.

use r2p_boot::layout::STM32F407VG as MAP;
use r2p_boot::TRAILER_LEN;

const FLASH_BASE: u32 = 0x0800_0000;

fn main() {
    r2p_boardgen::build("../../../boards/gateway.toml");
    let out = std::env::var("OUT_DIR").expect("OUT_DIR");
    let memory = format!(
        "MEMORY\n{{\n  FLASH : ORIGIN = {:#010x}, LENGTH = {}\n  RAM : ORIGIN = 0x20000000, LENGTH = 112K\n}}\n",
        FLASH_BASE + MAP.active.offset,
        MAP.active.size - TRAILER_LEN as u32
    );
    std::fs::write(format!("{out}/memory.x"), memory).expect("writing memory.x");
    println!("cargo:rustc-link-search={out}");
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
}
