//! `ranger_curves.rs` stays `no_std`: compile it alone as a `#![no_std]` library, as the
//! proximity firmware will.

use std::path::Path;
use std::process::Command;

#[test]
fn ranger_curves_compile_without_std() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/ranger_curves.rs");
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("no_std_curves");
    std::fs::create_dir_all(&dir).unwrap();
    let root = dir.join("lib.rs");
    std::fs::write(
        &root,
        format!("#![no_std]\n#![deny(warnings)]\n#[path = {:?}]\npub mod ranger_curves;\n", src),
    )
    .unwrap();
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let out = Command::new(rustc)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["--edition", "2021", "--crate-type", "rlib", "--crate-name", "curves"])
        .arg("--out-dir")
        .arg(&dir)
        .arg(&root)
        .output()
        .expect("run rustc");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}
