// The build script of every module image (included by <module>/build.rs): generates `board.rs`
// from the module's board file (the single source of its pins), links with cortex-m-rt's script
// (embassy-stm32's `memory-x` feature provides memory.x), and adds a linker check that the image
// ends below the parameter pages; links defmt's script (logs over RTT).

include!("src/flash_layout.rs");

/// Runs the image's build steps for the board file at `board` (relative to the image's crate).
fn build_image(board: &str) {
    r2p_boardgen::build(board);
    println!("cargo:rerun-if-changed=../module-core/src/flash_layout.rs");
    println!("cargo:rerun-if-changed=../module-core/build_image.rs");
    let out = std::env::var("OUT_DIR").expect("OUT_DIR");
    let check = format!(
        "ASSERT(__sidata + (__edata - __sdata) <= ORIGIN(FLASH) + {PARAMS_BASE:#x}, \
         \"the image reaches the parameter pages at flash offset {PARAMS_BASE:#x} (flash_layout.rs)\");\n"
    );
    std::fs::write(format!("{out}/params.x"), check).expect("writing params.x");
    println!("cargo:rustc-link-search={out}");
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tparams.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
