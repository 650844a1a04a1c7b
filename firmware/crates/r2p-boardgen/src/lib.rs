//! HAL board files: read them, check them, generate a module's `board.rs`.
//!
//! A board file (`firmware/boards/<module>.toml`, format in docs/board-files.md) is the single
//! source of a module's pin assignments. A module's `build.rs` calls [`build`], and the
//! firmware includes the result as its `board` module:
//!
//! ```ignore
//! // build.rs
//! fn main() { r2p_boardgen::build("../../../boards/psu.toml"); }
//! // main.rs
//! mod board { include!(concat!(env!("OUT_DIR"), "/board.rs")); }
//! let pins = board::take_pins!(p);      // moves the board's pins out of `Peripherals`
//! ```
//!
//! The Python pin checker (`scripts/check-pins`) reads the same files; both follow the format
//! document, and the checker compares them with the schematic.
#![warn(missing_docs)]

mod codegen;
mod model;

pub use codegen::generate;
pub use model::{Active, Board, BoardError, Mode, Pin, Pull};

use std::path::Path;

/// For `build.rs`: loads the board file at `path` (relative to the package), writes
/// `$OUT_DIR/board.rs`, and asks cargo to rerun when the file (or its base) changes.
/// Panics with the file, the key and what to do on a bad board file: a build script reports
/// errors by failing.
pub fn build(path: impl AsRef<Path>) {
    let path = path.as_ref();
    let board = Board::load(path).unwrap_or_else(|e| panic!("{e}"));
    for file in &board.files {
        println!("cargo:rerun-if-changed={}", file.display());
    }
    let out = std::env::var_os("OUT_DIR").expect("OUT_DIR: run from a build script");
    let dest = Path::new(&out).join("board.rs");
    std::fs::write(&dest, generate(&board))
        .unwrap_or_else(|e| panic!("writing {}: {e}", dest.display()));
}
