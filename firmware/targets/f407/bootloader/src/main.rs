//! The R2P bootloader on the STM32F407VG (docs/flashing.md, "Flash map" and "Updates"): as the
//! F103's (../../f103/bootloader), over the F407's sectors. The two image slots lie in the
//! 128 KiB sectors (embassy-stm32's bank 1 region 3, from 0x0802_0000), embassy-boot's state in
//! the 64 KiB sector 4 (region 2).
#![no_std]
#![no_main]

use core::cell::RefCell;

use embassy_boot_stm32::BootLoaderConfig;
use embassy_embedded_hal::flash::partition::BlockingPartition;
use embassy_stm32::flash::{Flash, BANK1_REGION1, BANK1_REGION2, BANK1_REGION3};
use embassy_sync::blocking_mutex::{raw::NoopRawMutex, Mutex};
use r2p_boot::layout::STM32F407VG as MAP;

include!("../../../shared/bootloader.rs");

#[cortex_m_rt::entry]
fn main() -> ! {
    // SAFETY: nothing else in the bootloader takes the flash peripheral.
    let flash = unsafe { embassy_stm32::peripherals::FLASH::steal() };
    let layout = Flash::new_blocking(flash).into_blocking_regions();
    // Partition offsets count from the flash base; a region's, from the region's start.
    let region2 = BANK1_REGION2.base() - BANK1_REGION1.base();
    let region3 = BANK1_REGION3.base() - BANK1_REGION1.base();
    let slots: Mutex<NoopRawMutex, _> = Mutex::new(RefCell::new(layout.bank1_region3));
    let state: Mutex<NoopRawMutex, _> = Mutex::new(RefCell::new(layout.bank1_region2));
    let config = BootLoaderConfig {
        active: BlockingPartition::new(&slots, MAP.active.offset - region3, MAP.active.size),
        dfu: BlockingPartition::new(&slots, MAP.dfu.offset - region3, MAP.dfu.size),
        state: BlockingPartition::new(&state, MAP.state.offset - region2, MAP.state.size),
    };
    // A 128 KiB sector is copied 4 KiB at a time.
    prepare_and_jump::<_, _, _, 4096>(config, BANK1_REGION1.base() + MAP.active.offset)
}
