//! Turns the flash maps of firmware/images.toml (`[mcu.<chip>.partitions]`) into `layout.rs`'s
//! constants, so the bootloader, the images and the tools read one table.

use std::{env, fs, path::PathBuf};

const PARTITIONS: [&str; 5] = ["bootloader", "state", "active", "dfu", "params"];

fn main() {
    // Through targets/*/crates symlinks the manifest dir is not under firmware/: resolve it.
    let crate_dir = PathBuf::from(env::var("CARGO_MANIFEST_DIR").unwrap()).canonicalize().unwrap();
    let path = crate_dir.join("../../images.toml").canonicalize().unwrap();
    println!("cargo:rerun-if-changed={}", path.display());
    let text = fs::read_to_string(&path).unwrap();
    let doc: toml::Table = text.parse().unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut out = String::new();
    let mcus = doc["mcu"].as_table().expect("images.toml: [mcu.*] tables");
    for (chip, mcu) in mcus {
        let Some(parts) = mcu.get("partitions").and_then(|p| p.as_table()) else { continue };
        let flash = mcu["flash"].as_integer().unwrap();
        out += &format!(
            "/// {chip}'s flash map ({} KiB).\npub const {}: FlashMap = FlashMap {{\n",
            flash / 1024,
            chip.replace('-', "_")
        );
        out += &format!("    flash_size: {flash},\n");
        for name in PARTITIONS {
            let p = parts.get(name).and_then(|p| p.as_table()).unwrap_or_else(|| {
                panic!("{}: [mcu.{chip}.partitions] has no `{name}` (add `{name} = {{ offset = …, size = … }}`)", path.display())
            });
            let field = |k: &str| {
                p.get(k).and_then(|v| v.as_integer()).unwrap_or_else(|| {
                    panic!(
                        "{}: [mcu.{chip}.partitions].{name} has no integer `{k}`",
                        path.display()
                    )
                })
            };
            out += &format!(
                "    {name}: Partition {{ offset: {:#x}, size: {:#x} }},\n",
                field("offset"),
                field("size")
            );
        }
        out += "};\n";
    }
    let dest = PathBuf::from(env::var("OUT_DIR").unwrap()).join("flash_maps.rs");
    fs::write(dest, out).unwrap();
}
