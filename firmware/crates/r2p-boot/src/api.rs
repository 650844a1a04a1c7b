//! The bootloader's services to the image it runs, at a fixed address: its public key and its
//! ed25519 check, so the crypto is in flash once (10.8 KiB on the F103), not in every image.
//!
//! The table sits in the last [`API_LEN`] bytes of the bootloader partition
//! ([`crate::layout::FlashMap::api_address`]). An image finds it there, checks [`API_MAGIC`] and
//! [`API_VERSION`], and calls [`BootApi::verify`] on the update it has received before it marks
//! it for the swap. The function uses only its stack (no statics: the RAM is the image's).

/// The table's first word.
pub const API_MAGIC: u32 = u32::from_le_bytes(*b"R2PB");
/// The table's layout version.
pub const API_VERSION: u32 = 1;
/// Bytes reserved for the table at the end of the bootloader partition.
pub const API_LEN: u32 = 64;

/// The check an image calls: the signed image in the slot of `slot_size` bytes at address `slot`
/// (memory-mapped flash), for the MCU and kind named by the ASCII strings given (`kind_len` 0:
/// any kind). Returns 0 when it passes, else the [`crate::Refusal`]'s code.
pub type VerifyFn = unsafe extern "C" fn(
    slot: *const u8,
    slot_size: u32,
    mcu: *const u8,
    mcu_len: u32,
    kind: *const u8,
    kind_len: u32,
) -> u32;

/// The table.
#[repr(C)]
pub struct BootApi {
    /// [`API_MAGIC`].
    pub magic: u32,
    /// [`API_VERSION`].
    pub version: u32,
    /// The public key images must be signed with.
    pub public_key: [u8; 32],
    /// The signature check.
    pub verify: VerifyFn,
}

const _: () = assert!(core::mem::size_of::<BootApi>() as u32 <= API_LEN);

/// The check behind [`BootApi::verify`], over a memory-mapped slot.
///
/// # Safety
/// `slot` must point to `slot_size` readable bytes, `mcu` to `mcu_len` and `kind` to `kind_len`.
pub unsafe fn verify_mapped(
    slot: *const u8,
    slot_size: u32,
    public_key: &[u8; 32],
    mcu: *const u8,
    mcu_len: u32,
    kind: *const u8,
    kind_len: u32,
) -> u32 {
    // SAFETY: the caller's contract.
    let (slot, mcu, kind) = unsafe {
        (
            core::slice::from_raw_parts(slot, slot_size as usize),
            core::slice::from_raw_parts(mcu, mcu_len as usize),
            core::slice::from_raw_parts(kind, kind_len as usize),
        )
    };
    if !mcu.is_ascii() || !kind.is_ascii() {
        return crate::Refusal::UnknownFormat.code() as u32;
    }
    // SAFETY: ASCII is UTF-8 (and core's full UTF-8 check costs the bootloader 368 B).
    let (mcu, kind) =
        unsafe { (core::str::from_utf8_unchecked(mcu), core::str::from_utf8_unchecked(kind)) };
    let expect = crate::Expect { mcu, kind: (!kind.is_empty()).then_some(kind), public_key };
    match crate::verify_slot(&mut MappedSlot(slot), 0, slot_size, &expect) {
        Ok(_) => 0,
        Err(r) => r.code() as u32,
    }
}

/// A slot of memory-mapped flash, read as a NOR flash.
struct MappedSlot<'a>(&'a [u8]);

impl embedded_storage::nor_flash::ErrorType for MappedSlot<'_> {
    type Error = embedded_storage::nor_flash::NorFlashErrorKind;
}

impl embedded_storage::nor_flash::ReadNorFlash for MappedSlot<'_> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        let start = offset as usize;
        let src = self
            .0
            .get(start..start + bytes.len())
            .ok_or(embedded_storage::nor_flash::NorFlashErrorKind::OutOfBounds)?;
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.0.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mapped_check_refuses_by_code() {
        let slot = [0xFFu8; 2048];
        let key = [0u8; 32];
        let mcu = b"STM32F103CB";
        // SAFETY: every pointer covers its length.
        let code =
            unsafe { verify_mapped(slot.as_ptr(), 2048, &key, mcu.as_ptr(), 11, [].as_ptr(), 0) };
        assert_eq!(code, crate::Refusal::NoTrailer.code() as u32);
        let bad_utf8 = [0xFFu8];
        // SAFETY: as above.
        let code = unsafe {
            verify_mapped(slot.as_ptr(), 2048, &key, bad_utf8.as_ptr(), 1, [].as_ptr(), 0)
        };
        assert_eq!(code, crate::Refusal::UnknownFormat.code() as u32);
    }
}
