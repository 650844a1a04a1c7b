//! What every R2P module application shares, `no_std` and without a HAL so the same code runs
//! on the MCU and on an emulated board:
//!
//! - [`FlashParams`]: the module's parameters, set over the bus and kept in flash across
//!   reboots (an append-only log in two erase pages, power-loss safe);
//! - [`RamFlash`]: a NOR flash in RAM with the real part's rules (erase to `0xFF`, program only
//!   erased bytes), for emulated boards and tests, with a power cut at a chosen byte;
//! - [`dfu_sink`]: the module's side of a firmware update over the bus (into the DFU slot,
//!   checked, marked for the bootloader's swap);
//! - [`endpoints`]: a topic on the bus, written once: [`Outbound`] (published and exported),
//!   [`Inbound`] (imported and subscribed), built at boot in a cell taken once;
//! - [`filters`]: median and first-order low-pass filters for sensor channels;
//! - [`leds`]: the status LED patterns every module shows the same way;
//! - [`long_division`]: a smaller 64-bit division than compiler-builtins' (the ABI's helpers);
//! - [`mem_clear`]: a smaller unaligned clear (`__aeabi_memclr`) than compiler-builtins';
//! - [`mem_compare`]: a smaller `memcmp` than compiler-builtins';
//! - [`mem_routines`]: smaller 8-byte aligned copy/clear than compiler-builtins';
//! - [`soft_float`]: smaller `f32` add, subtract, multiply and divide than compiler-builtins';
//! - [`param_doc`]: what each parameter means, for the README;
//! - [`trig`]: sine, cosine and tangent in `f32` only (libm's pull in `f64` soft float);
//! - `readme` (feature `std`): what the READMEs' generated sections share.
//!
//! Not `module-core` (firmware/targets/f103/module-core: what every F103 module *image* adds
//! around its application: clocks, the bus executor, the slot timer, flash and LED drivers),
//! nor `hardware/core` (the KiCad sheet every module *board* shares).
#![no_std]
#![warn(missing_docs)]

#[cfg(any(test, feature = "std"))]
extern crate std;

pub mod dfu_sink;
pub mod endpoints;
pub mod filters;
pub mod flash_params;
pub mod float_compare;
pub mod leds;
pub mod long_division;
pub mod mem_clear;
pub mod mem_compare;
pub mod mem_routines;
pub mod param_doc;
pub mod ram_flash;
#[cfg(any(test, feature = "std"))]
pub mod readme;
pub mod soft_float;
#[cfg(test)]
mod test_bits;
pub mod trig;

pub use dfu_sink::DfuSink;
pub use endpoints::{Inbound, InboundCell, Outbound, OutboundCell, TopicNode};
pub use flash_params::{CommitReport, FlashParams, LoadReport, ParamValues};
pub use param_doc::ParamDoc;
pub use ram_flash::RamFlash;
