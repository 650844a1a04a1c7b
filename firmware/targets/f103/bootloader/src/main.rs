//! The R2P bootloader on the STM32F103CB (docs/flashing.md, "Flash map" and "Updates").
//!
//! At reset it runs embassy-boot: when the image has marked an update, the update and the image
//! swap places page by page (a power cut resumes it); when an image on trial resets without
//! confirming itself, the swap is undone (rollback). Then it jumps to the active slot. It checks
//! no signature at boot: the running image checks an update before it marks it, with the check
//! this bootloader lends it (`BOOT_API`, ../../shared/bootloader.rs), so only signed images are
//! ever swapped in; a probe writes whatever it is given.
#![no_std]
#![no_main]

use core::cell::RefCell;

use embassy_boot_stm32::BootLoaderConfig;
use embassy_embedded_hal::flash::partition::BlockingPartition;
use embassy_stm32::flash::{Flash, BANK1_REGION};
use embassy_sync::blocking_mutex::{raw::NoopRawMutex, Mutex};
use r2p_boot::layout::STM32F103CB as MAP;

include!("../../../shared/bootloader.rs");

// The module images' 8-byte aligned copy and clear as a branch to the 4-byte aligned ones
// (compiler-builtins has a copy of each: 330 B), so the bootloader fits its 14 KiB partition.
#[path = "../../../../crates/r2p-module/src/mem_routines.rs"]
mod mem_routines;

#[cortex_m_rt::entry]
fn main() -> ! {
    // Only the flash controller, on the reset clock (HSI, 8 MHz: enough to copy pages; the image
    // sets its own): no `embassy_stm32::init`, whose clock and GPIO set-up cost 1.3 KiB here.
    // SAFETY: nothing else in the bootloader takes the flash peripheral.
    let flash = unsafe { embassy_stm32::peripherals::FLASH::steal() };
    let layout = Flash::new_blocking(flash).into_blocking_regions();
    let flash: Mutex<NoopRawMutex, _> = Mutex::new(RefCell::new(layout.bank1_region));
    let config = BootLoaderConfig {
        active: BlockingPartition::new(&flash, MAP.active.offset, MAP.active.size),
        dfu: BlockingPartition::new(&flash, MAP.dfu.offset, MAP.dfu.size),
        state: BlockingPartition::new(&flash, MAP.state.offset, MAP.state.size),
    };
    // One 1 KiB page at a time.
    prepare_and_jump::<_, _, _, 1024>(config, BANK1_REGION.base() + MAP.active.offset)
}
