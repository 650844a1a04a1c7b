// What every R2P bootloader shares (included by targets/<mcu>/bootloader/src/main.rs): the API
// table it lends the image it runs (r2p-boot's api: magic, version, public key, the ed25519
// check), embassy-boot's prepare-and-jump, and resets on any fault (a swap resumes from its
// progress).

use r2p_boot::api::{BootApi, API_MAGIC, API_VERSION};

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

/// Swaps or reverts as embassy-boot's state says, then jumps to the image at `active_start`.
fn prepare_and_jump<A, D, S, const PAGE_BUFFER: usize>(
    config: embassy_boot_stm32::BootLoaderConfig<A, D, S>,
    active_start: u32,
) -> !
where
    A: embedded_storage::nor_flash::NorFlash,
    D: embedded_storage::nor_flash::NorFlash,
    S: embedded_storage::nor_flash::NorFlash,
{
    let bl = embassy_boot_stm32::BootLoader::prepare::<_, _, _, PAGE_BUFFER>(config);
    // SAFETY: the active slot holds an image linked there (its vector table first).
    unsafe { bl.load(active_start) }
}

/// A fault in the bootloader resets the chip: the swap resumes where its progress says.
#[unsafe(no_mangle)]
#[cfg_attr(target_os = "none", unsafe(link_section = ".HardFault.user"))]
unsafe extern "C" fn HardFault() {
    cortex_m::peripheral::SCB::sys_reset();
}

#[cortex_m_rt::exception]
unsafe fn DefaultHandler(_: i16) -> ! {
    cortex_m::peripheral::SCB::sys_reset();
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    cortex_m::peripheral::SCB::sys_reset();
}
