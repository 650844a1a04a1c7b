//! Links with cortex-m-rt's script over the whole chip: the memory.x embassy-stm32's
//! `memory-x` feature would write (the workspace leaves it off, for the images behind the
//! bootloader), written here.
fn main() {
    let out = std::env::var("OUT_DIR").expect("OUT_DIR");
    let memory = "MEMORY\n{\n    FLASH : ORIGIN = 0x08000000, LENGTH = 1024K /* BANK_1_REGION_1 + BANK_1_REGION_2 + BANK_1_REGION_3 */\n    RAM   : ORIGIN = 0x20000000, LENGTH =  128K /* SRAM + SRAM2 */\n}";
    std::fs::write(format!("{out}/memory.x"), memory).expect("writing memory.x");
    println!("cargo:rustc-link-search={out}");
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
}
