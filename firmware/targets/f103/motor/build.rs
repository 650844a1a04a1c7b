//! Generates `board.rs` from the module's HAL board file and links with cortex-m-rt's script
//! plus `params.x`, which keeps the image out of the parameter pages at the end of flash.
use std::path::PathBuf;

fn main() {
    r2p_boardgen::build("../../../boards/motor.toml");
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR"));
    std::fs::copy("params.x", out.join("params.x")).expect("copy params.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=params.x");
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tparams.x");
}
