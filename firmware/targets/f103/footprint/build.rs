//! Links with cortex-m-rt's script over the whole chip: the memory.x embassy-stm32's
//! `memory-x` feature would write (the workspace leaves it off, for the module images behind
//! the bootloader), written here.
fn main() {
    let out = std::env::var("OUT_DIR").expect("OUT_DIR");
    let memory = "MEMORY\n{\n    FLASH : ORIGIN = 0x08000000, LENGTH =  128K /* BANK_1 */\n    RAM   : ORIGIN = 0x20000000, LENGTH =   20K /* SRAM */\n}\n";
    std::fs::write(format!("{out}/memory.x"), memory).expect("writing memory.x");
    println!("cargo:rustc-link-search={out}");
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
}
