//! Declares `cfg(loom)` (the pool on loom's primitives, model-checked by `make loom`) so that
//! every workspace that builds this crate knows the name.
fn main() {
    println!("cargo::rustc-check-cfg=cfg(loom)");
}
