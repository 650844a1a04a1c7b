//! The module's side of an update over the bus on the F103 (docs/flashing.md, "Updates over the
//! bus"): r2p-module's `DfuSink` over the DFU slot and the bootloader's state in this chip's
//! flash, checked by the bootloader's own code through its API table, and what the running image
//! says of itself in FIRMWARE (its trailer, in the active slot's last bytes).
//!
//! The flash is shared: the application's task stores parameters and confirms a trial in it, the
//! bus task writes updates into it. Each use holds a critical section; a page erase stalls the
//! single-bank F103's CPU for its 20–40 ms whoever asks, so nothing else would run meanwhile
//! anyway.

use core::cell::RefCell;

use embassy_embedded_hal::flash::partition::BlockingPartition;
use embassy_stm32::flash::{Blocking, Flash};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use r2p_boot::layout::STM32F103CB as MAP;
use r2p_boot::Refusal;
use r2p_module::DfuSink;
use r2p_node::FirmwareId;
use static_cell::StaticCell;

/// The chip's flash, shared by the application's task and the bus task.
pub type SharedFlash = Mutex<CriticalSectionRawMutex, RefCell<Flash<'static, Blocking>>>;
/// A partition of the shared flash.
pub type Part = BlockingPartition<'static, CriticalSectionRawMutex, Flash<'static, Blocking>>;
/// The update sink of this image.
pub type ModuleSink = DfuSink<Part, Part>;

#[path = "../../../shared/boot_api.rs"]
mod boot_api;

/// The MCU the bootloader checks images for (probe-rs's name, as in images.toml).
const MCU: &str = "STM32F103CB";

static SINK: StaticCell<ModuleSink> = StaticCell::new();

/// The bootloader's state partition of `flash`.
pub fn state_partition(flash: &'static SharedFlash) -> Part {
    BlockingPartition::new(flash, MAP.state.offset, MAP.state.size)
}

/// The image's update sink for module kind `kind`, over `flash` (made once, at boot).
pub fn sink(flash: &'static SharedFlash, kind: &'static str) -> &'static ModuleSink {
    let dfu = BlockingPartition::new(flash, MAP.dfu.offset, MAP.dfu.size);
    SINK.init(DfuSink::new(kind, MAP.active.size, dfu, state_partition(flash), check))
}

/// The bootloader's check of the DFU slot (../../shared/boot_api.rs).
fn check(_dfu: &mut Part) -> Result<(), Refusal> {
    let Some(api) = boot_api::api(&MAP) else {
        defmt::warn!("update: no R2P bootloader API table to check the image with");
        return Err(Refusal::UnknownFormat);
    };
    boot_api::check_dfu(api, &MAP, MCU)
}

/// What the running image is (../../shared/boot_api.rs; an image flashed without a trailer:
/// version 0, kind `fallback_kind`). Out of line: called at boot and once after a trial.
#[inline(never)]
pub fn running_image(fallback_kind: &str, on_trial: bool) -> FirmwareId {
    boot_api::running_image(&MAP, fallback_kind, on_trial)
}
