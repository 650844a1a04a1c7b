// What a running image asks of its R2P bootloader, on any STM32 behind one (included by the F103
// module images' module-core and by the gateway, so both keep one copy): the bootloader's check
// of the DFU slot through the API table at the end of its partition (the ed25519 code is in
// flash once, in the bootloader), and what the running image is, from its trailer in the active
// slot's last bytes.

use r2p_boot::api::{BootApi, API_MAGIC, API_VERSION};
use r2p_boot::layout::FlashMap;
use r2p_boot::{Refusal, Trailer, TRAILER_LEN};
use r2p_node::FirmwareId;

/// Where the flash maps start.
pub const FLASH_BASE: u32 = 0x0800_0000;

/// The API table of the bootloader in `map`'s partition, if it has one this image knows.
#[inline(always)]
pub fn api(map: &FlashMap) -> Option<&'static BootApi> {
    // SAFETY: the bootloader partition is mapped flash, never written by the image; its last
    // bytes hold the table, taken only with its magic and version.
    let api = unsafe { &*((FLASH_BASE + map.api_offset()) as *const BootApi) };
    (api.magic == API_MAGIC && api.version == API_VERSION).then_some(api)
}

/// The bootloader's check of `map`'s DFU slot (signature, `mcu`, size); the module kind is the
/// update sink's to check.
#[inline(always)]
pub fn check_dfu(api: &BootApi, map: &FlashMap, mcu: &str) -> Result<(), Refusal> {
    let slot = (FLASH_BASE + map.dfu.offset) as *const u8;
    // SAFETY: the DFU slot is at least `map.active.size` bytes of mapped flash (the DFU
    // partition is one page or sector larger); the strings are the lengths given; no kind.
    let code = unsafe {
        (api.verify)(slot, map.active.size, mcu.as_ptr(), mcu.len() as u32, mcu.as_ptr(), 0)
    };
    match code {
        0 => Ok(()),
        c => Err(Refusal::from_code(c as u8).unwrap_or(Refusal::BadSignature)),
    }
}

/// What the running image is, from its trailer in `map`'s active slot (an image flashed without
/// one: version 0, kind `fallback_kind`).
#[inline(always)]
pub fn running_image(map: &FlashMap, fallback_kind: &str, on_trial: bool) -> FirmwareId {
    let at = FLASH_BASE + map.active.end() - TRAILER_LEN as u32;
    // SAFETY: the active slot is mapped flash; the image is running from it.
    let raw = unsafe { &*(at as *const [u8; TRAILER_LEN]) };
    match Trailer::parse(raw) {
        Ok(t) => FirmwareId {
            version: t.version.to_bits(),
            digest: t.digest,
            kind: t.kind.as_str().try_into().unwrap_or_default(),
            on_trial,
        },
        Err(_) => FirmwareId {
            kind: fallback_kind.try_into().unwrap_or_default(),
            ..FirmwareId::default()
        },
    }
}
