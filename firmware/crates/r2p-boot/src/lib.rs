//! Signed firmware images for the bootloader's A/B slots (docs/flashing.md, "Updates").
//!
//! - [`layout`]: each MCU's flash map (bootloader, embassy-boot's state, the active and DFU
//!   slots, the parameter pages), from firmware/images.toml;
//! - [`Trailer`]: 128 bytes after an image saying its kind, MCU, version and signer, and its
//!   ed25519 signature;
//! - [`verify_slot`] / [`verify_file`]: the checks before an image may run, in flash or in a
//!   file, each failure a [`Refusal`] with its message;
//! - [`api`]: the table by which the bootloader lends its check to the image it runs;
//! - [`transfer`] and [`sender`]: moving a signed image into a module's DFU slot over a lossy
//!   link (go-back-N, resumable);
//! - [`trial`]: when a new image confirms itself, or gives up and is rolled back;
//! - [`boot_state`]: the image's side of embassy-boot's state (on trial? confirm);
//! - `sign` (feature `std`): signing and key derivation on the host.
//!
//! The swap itself, power-cut safe with rollback, is embassy-boot's; tests/power_cuts.rs drives
//! it over these maps on an emulated F103 flash, cutting the power at every step.
#![no_std]

pub mod api;
pub mod boot_state;
pub mod layout;
mod refusal;
pub mod sender;
#[cfg(feature = "std")]
pub mod sign;
mod trailer;
pub mod transfer;
pub mod trial;
mod verify;

pub use refusal::Refusal;
pub use trailer::{
    image_digest, key_id, Name, Trailer, Version, FORMAT, MAGIC, NAME_LEN, SIGNED_LEN, TRAILER_LEN,
};
pub use verify::{verify_file, verify_slot, Expect};
