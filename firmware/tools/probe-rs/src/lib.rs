//! Never built: this package only pins the `probe-rs` crate (see Cargo.toml).
