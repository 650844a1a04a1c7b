//! Links the bootloader into its partition of firmware/images.toml's F103 map, its RAM in the top
//! 4 KiB (the images' statics and their panic report stay below), the API table at the
//! partition's end, and the public key it trusts: R2P_BOOT_PUBLIC_KEY (a file as
//! firmware/keys/development.pub) or the development key.

use r2p_boot::api::API_LEN;
use r2p_boot::layout::STM32F103CB as MAP;
use std::{env, fs, path::PathBuf};

const FLASH_BASE: u32 = 0x0800_0000;
const RAM_BASE: u32 = 0x2000_0000;
const RAM_SIZE: u32 = 20 * 1024;
/// The bootloader's RAM: the top of the F103's 20 KiB, above every module image's statics
/// (their budget is 16 KiB).
const BOOT_RAM: u32 = 4 * 1024;

fn main() {
    let out = PathBuf::from(env::var("OUT_DIR").unwrap());
    let code = MAP.bootloader.size - API_LEN;
    let memory = format!(
        "MEMORY\n{{\n  FLASH : ORIGIN = {:#010x}, LENGTH = {code}\n  BOOT_API : ORIGIN = {:#010x}, LENGTH = {API_LEN}\n  RAM : ORIGIN = {:#010x}, LENGTH = {BOOT_RAM}\n}}\n\
         SECTIONS\n{{\n  .boot_api : {{ KEEP(*(.boot_api)) }} > BOOT_API\n}} INSERT AFTER .rodata;\n",
        FLASH_BASE,
        FLASH_BASE + MAP.api_offset(),
        RAM_BASE + RAM_SIZE - BOOT_RAM,
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
    let text =
        fs::read_to_string(&key_file).unwrap_or_else(|e| panic!("{}: {e}", key_file.display()));
    let hex: String =
        text.lines().filter(|l| !l.starts_with('#')).collect::<String>().trim().to_string();
    let ok = hex.len() == 64 && hex.bytes().all(|c| c.is_ascii_hexdigit());
    assert!(
        ok,
        "{}: expected 64 hexadecimal digits (an ed25519 public key), as `r2p keygen` writes",
        key_file.display()
    );
    let bytes: Vec<String> = (0..32).map(|i| format!("0x{}", &hex[2 * i..2 * i + 2])).collect();
    fs::write(out.join("public_key.rs"), format!("[{}]", bytes.join(", "))).unwrap();
}
