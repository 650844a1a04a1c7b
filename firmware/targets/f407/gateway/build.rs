//! Generates `board.rs` from the gateway's board file (the single source of its pins), links
//! with cortex-m-rt's script (embassy-stm32's `memory-x` provides memory.x) and adds a linker
//! check that the image ends below the parameter sectors.

include!("src/flash_layout.rs");

fn main() {
    r2p_boardgen::build("../../../boards/gateway.toml");
    println!("cargo:rerun-if-changed=src/flash_layout.rs");
    let out = std::env::var("OUT_DIR").expect("OUT_DIR");
    let check = format!(
        "ASSERT(__sidata + (__edata - __sdata) <= ORIGIN(FLASH) + {PARAMS_BASE:#x}, \
         \"the image reaches the parameter sectors at flash offset {PARAMS_BASE:#x} (flash_layout.rs)\");\n"
    );
    std::fs::write(format!("{out}/params.x"), check).expect("writing params.x");
    println!("cargo:rustc-link-search={out}");
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tparams.x");
}
