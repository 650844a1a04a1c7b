// The bootloaders' build steps (included by targets/<mcu>/bootloader/build.rs): memory.x for the
// bootloader partition of the MCU's flash map (firmware/images.toml), with the API table at the
// partition's end and the RAM the caller gives; and the public key it trusts: the file named by
// R2P_BOOT_PUBLIC_KEY (as `r2p keygen` writes), or the development key.

use r2p_boot::api::API_LEN;
use r2p_boot::layout::FlashMap;
use std::{env, fs, path::PathBuf};

const FLASH_BASE: u32 = 0x0800_0000;

/// Writes memory.x and public_key.rs into OUT_DIR for a bootloader of `map`, its RAM
/// `ram_origin .. ram_origin + ram_len`.
fn build_bootloader(map: &FlashMap, ram_origin: u32, ram_len: u32) {
    let out = PathBuf::from(env::var("OUT_DIR").unwrap());
    let code = map.bootloader.size - API_LEN;
    let memory = format!(
        "MEMORY\n{{\n  FLASH : ORIGIN = {:#010x}, LENGTH = {code}\n  BOOT_API : ORIGIN = {:#010x}, LENGTH = {API_LEN}\n  RAM : ORIGIN = {ram_origin:#010x}, LENGTH = {ram_len}\n}}\n\
         SECTIONS\n{{\n  .boot_api : {{ KEEP(*(.boot_api)) }} > BOOT_API\n}} INSERT AFTER .rodata;\n",
        FLASH_BASE + map.bootloader.offset,
        FLASH_BASE + map.api_offset(),
    );
    fs::write(out.join("memory.x"), memory).unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");

    let key_file = match env::var("R2P_BOOT_PUBLIC_KEY") {
        Ok(p) => PathBuf::from(p),
        Err(_) => PathBuf::from(env::var("CARGO_MANIFEST_DIR").unwrap())
            .canonicalize()
            .unwrap()
            .join("../../../keys/development.pub"),
    };
    println!("cargo:rerun-if-env-changed=R2P_BOOT_PUBLIC_KEY");
    println!("cargo:rerun-if-changed={}", key_file.display());
    let text = fs::read_to_string(&key_file).unwrap_or_else(|e| panic!("{}: {e}", key_file.display()));
    let key = r2p_boot::sign::parse_key_file(&text).unwrap_or_else(|e| panic!("{}: {e}", key_file.display()));
    let bytes: Vec<String> = key.iter().map(|b| format!("{b:#04x}")).collect();
    fs::write(out.join("public_key.rs"), format!("[{}]", bytes.join(", "))).unwrap();
}
