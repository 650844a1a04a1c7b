//! The R2P bootloader on the STM32F103CB (docs/flashing.md, "Flash map" and "Updates").
//!
//! At reset it runs embassy-boot: when the image has marked an update, the update and the image
//! swap places page by page (a power cut resumes it); when an image on trial resets without
//! confirming itself, the swap is undone (rollback). Then it jumps to the active slot. It checks
//! no signature at boot: the running image checks an update before it marks it, with the check
//! this bootloader lends it (the [`BOOT_API`] table), so only signed images are ever swapped in;
//! a probe writes whatever it is given.
#![no_std]
#![no_main]

use core::cell::RefCell;

use cortex_m_rt::{entry, exception};
use embassy_boot_stm32::{BootLoader, BootLoaderConfig};
use embassy_embedded_hal::flash::partition::BlockingPartition;
use embassy_stm32::flash::{Flash, BANK1_REGION};
use embassy_sync::blocking_mutex::{raw::NoopRawMutex, Mutex};
use r2p_boot::api::{BootApi, API_MAGIC, API_VERSION};
use r2p_boot::layout::STM32F103CB as MAP;

/// The public key images must be signed with (build.rs: the development key unless told).
const PUBLIC_KEY: [u8; 32] = include!(concat!(env!("OUT_DIR"), "/public_key.rs"));

/// The table the image finds at the end of the bootloader partition.
#[used]
#[unsafe(link_section = ".boot_api")]
static BOOT_API: BootApi =
    BootApi { magic: API_MAGIC, version: API_VERSION, public_key: PUBLIC_KEY, verify };

/// [`r2p_boot::api::VerifyFn`] with this bootloader's key.
unsafe extern "C" fn verify(
    slot: *const u8,
    slot_size: u32,
    mcu: *const u8,
    mcu_len: u32,
    kind: *const u8,
    kind_len: u32,
) -> u32 {
    // SAFETY: the caller's contract (VerifyFn).
    unsafe {
        r2p_boot::api::verify_mapped(slot, slot_size, &PUBLIC_KEY, mcu, mcu_len, kind, kind_len)
    }
}

#[entry]
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
    let bl = BootLoader::prepare::<_, _, _, 1024>(config);
    // SAFETY: the active slot holds an image linked there (its vector table first).
    unsafe { bl.load(BANK1_REGION.base() + MAP.active.offset) }
}

/// A fault in the bootloader resets the chip: the swap resumes where its progress says.
#[unsafe(no_mangle)]
#[cfg_attr(target_os = "none", unsafe(link_section = ".HardFault.user"))]
unsafe extern "C" fn HardFault() {
    cortex_m::peripheral::SCB::sys_reset();
}

#[exception]
unsafe fn DefaultHandler(_: i16) -> ! {
    cortex_m::peripheral::SCB::sys_reset();
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    cortex_m::peripheral::SCB::sys_reset();
}
