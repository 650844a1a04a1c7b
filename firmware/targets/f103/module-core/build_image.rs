// The build script of every module image (included by <module>/build.rs): generates `board.rs`
// from the module's board file (the single source of its pins), writes memory.x from the F103's
// flash map (firmware/images.toml, through r2p-boot's layout), links with cortex-m-rt's script
// and defmt's (logs over RTT).

use r2p_boot::layout::STM32F103CB as MAP;
use r2p_boot::TRAILER_LEN;

/// Where an image is linked: as modules.toml's `slot` says (tests/test_probe_targets.py checks
/// that the two agree).
#[allow(dead_code)]
enum Link {
    /// In the active slot, behind the bootloader (`slot = "active"`): its last 128 bytes left
    /// for the signed image's trailer, so the linker refuses an image that does not fit a slot.
    ActiveSlot,
    /// From the flash base, flashed alone (no `slot`): the linker refuses an image that
    /// reaches the parameter pages.
    FlashBase,
}

/// Runs the image's build steps for the board file at `board` (relative to the image's crate).
fn build_image(board: &str, link: Link) {
    r2p_boardgen::build(board);
    println!("cargo:rerun-if-changed=../module-core/build_image.rs");
    const FLASH_BASE: u32 = 0x0800_0000;
    let (origin, length) = match link {
        Link::ActiveSlot => (MAP.active.offset, MAP.active.size - TRAILER_LEN as u32),
        Link::FlashBase => (0, MAP.params.offset),
    };
    // RAM: the whole 20 KiB. The bootloader's (its top 4 KiB) is free once it has jumped here;
    // the images' statics stay below it (tests/test_bootloader.py), so a panic report survives.
    let memory = format!(
        "MEMORY\n{{\n  FLASH : ORIGIN = {:#010x}, LENGTH = {length}\n  RAM : ORIGIN = 0x20000000, LENGTH = 20K\n}}\n",
        FLASH_BASE + origin
    );
    // The same choice for the image's code: `module_core::linked!()` reads it.
    let place = match link {
        Link::ActiveSlot => "active",
        Link::FlashBase => "base",
    };
    println!("cargo:rustc-env=R2P_IMAGE_LINK={place}");
    let out = std::env::var("OUT_DIR").expect("OUT_DIR");
    std::fs::write(format!("{out}/memory.x"), memory).expect("writing memory.x");
    println!("cargo:rustc-link-search={out}");
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    // Identical functions kept once (lld's code folding): the panic entry points, each a call of
    // the handler, default handlers and small trait methods alike for several types; 180 B of
    // the PSU. Code only (read-only data keeps its addresses), and nothing compares function
    // addresses; the slot path's instructions are the same (`r2ptools.slotpath`: only the names
    // of folded call targets differ).
    println!("cargo:rustc-link-arg-bins=--icf=all");
}
