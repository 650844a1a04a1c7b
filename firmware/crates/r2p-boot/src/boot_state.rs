//! The running image's side of embassy-boot's state partition: whether the bootloader has just
//! swapped this image in (it is on trial) or rolled it back, confirming it (`mark_booted`), and
//! asking for the swap of a verified update (`mark_updated`, for the DFU writer of issue 18
//! item 3).
//!
//! embassy-boot's `BlockingFirmwareState` does the same in ~1.2 KiB more of Cortex-M3 code
//! (measured on the F103 module images): it keeps its state word in a slice, which it fills
//! through compiler-builtins' general `memset`, and its flash through a partition behind a
//! mutex; here the word is a small array of the flash's write size, at an offset in the whole
//! flash. The state's layout is embassy-boot's (its magic bytes are crate-private there, so they
//! are repeated below): the tests read what these functions write with embassy-boot's own
//! updater and bootloader, and tests/power_cuts.rs confirms updates with [`mark_booted`] while
//! cutting the power at every step.

use embedded_storage::nor_flash::NorFlash;

/// The bootloader is about to swap, or has just swapped this image in (embassy-boot's
/// `SWAP_MAGIC`).
const SWAP_MAGIC: u8 = 0xF0;
/// The bootloader has just rolled this image back (`REVERT_MAGIC`).
const REVERT_MAGIC: u8 = 0xC0;
/// The image is confirmed (`BOOT_MAGIC`).
const BOOT_MAGIC: u8 = 0xD0;
/// An erased byte (`STATE_ERASE_VALUE`, without embassy-boot's `flash-erase-zero`).
const ERASED: u8 = 0xFF;

/// What the bootloader's state says to the image it runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BootState {
    /// This image was just swapped in: it is on trial until it confirms itself.
    Swapped,
    /// This image was just swapped back after a new one failed its trial.
    Reverted,
    /// Nothing pending (confirmed, or never updated).
    Booted,
}

/// The longest write unit this supports (embassy-boot's aligned buffers go to 32 bytes).
const MAX_WRITE: usize = 32;

/// A state word: one write unit of the flash, aligned as embassy-boot aligns its buffers.
#[repr(align(32))]
struct Word([u8; MAX_WRITE]);

fn all(word: &[u8], value: u8) -> bool {
    word.iter().all(|&b| b == value)
}

/// Reads the state from the partition at `offset` in `flash`.
pub fn read<F: NorFlash>(flash: &mut F, offset: u32) -> Result<BootState, F::Error> {
    let mut w = Word([0; MAX_WRITE]);
    let word = &mut w.0[..F::WRITE_SIZE];
    flash.read(offset, word)?;
    Ok(if all(word, SWAP_MAGIC) {
        BootState::Swapped
    } else if all(word, REVERT_MAGIC) {
        BootState::Reverted
    } else {
        BootState::Booted
    })
}

/// Confirms the running image in the state partition at `offset` (`size` bytes) of `flash`, as
/// embassy-boot's `mark_booted`. The erase stalls an STM32's CPU for a page erase's time.
pub fn mark_booted<F: NorFlash>(flash: &mut F, offset: u32, size: u32) -> Result<(), F::Error> {
    set_magic(flash, offset, size, BOOT_MAGIC)
}

/// Asks the bootloader to swap in the update in the DFU slot at the next reset, as
/// embassy-boot's `mark_updated` (only once the update has been verified: the bootloader
/// swaps without checking).
pub fn mark_updated<F: NorFlash>(flash: &mut F, offset: u32, size: u32) -> Result<(), F::Error> {
    set_magic(flash, offset, size, SWAP_MAGIC)
}

/// embassy-boot's `set_magic`: nothing if the state already says `magic`; otherwise invalidates
/// the swap's progress (so a torn erase cannot leave progress that looks valid), erases the
/// partition and writes `magic`.
fn set_magic<F: NorFlash>(
    flash: &mut F,
    offset: u32,
    size: u32,
    magic: u8,
) -> Result<(), F::Error> {
    let mut w = Word([0; MAX_WRITE]);
    let word = &mut w.0[..F::WRITE_SIZE];
    flash.read(offset, word)?;
    if all(word, magic) {
        return Ok(());
    }
    let progress = offset + F::WRITE_SIZE as u32;
    flash.read(progress, word)?;
    if all(word, ERASED) {
        word.fill(!ERASED);
        flash.write(progress, word)?;
    }
    flash.erase(offset, offset + size)?;
    word.fill(magic);
    flash.write(offset, word)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use embassy_boot::{AlignedBuffer, BlockingFirmwareState, State};
    use r2p_module::RamFlash;

    type Chip = RamFlash<{ 8 * 1024 }, 1024>;
    /// A state partition of two pages, at 2 KiB in the chip.
    const AT: u32 = 2048;

    /// A state partition as embassy-boot would read it.
    struct Part<'a>(&'a mut Chip);
    impl embedded_storage::nor_flash::ErrorType for Part<'_> {
        type Error = <Chip as embedded_storage::nor_flash::ErrorType>::Error;
    }
    impl embedded_storage::nor_flash::ReadNorFlash for Part<'_> {
        const READ_SIZE: usize = 1;
        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
            self.0.read(AT + offset, bytes)
        }
        fn capacity(&self) -> usize {
            2048
        }
    }
    impl NorFlash for Part<'_> {
        const WRITE_SIZE: usize = Chip::WRITE_SIZE;
        const ERASE_SIZE: usize = 1024;
        fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
            self.0.erase(AT + from, AT + to)
        }
        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
            self.0.write(AT + offset, bytes)
        }
    }

    fn embassy(chip: &mut Chip) -> State {
        let mut aligned = AlignedBuffer([0; Chip::WRITE_SIZE]);
        BlockingFirmwareState::new(Part(chip), &mut aligned.0).get_state().unwrap()
    }

    #[test]
    fn it_reads_what_embassy_boot_writes_and_embassy_boot_reads_its_confirmation() {
        let mut chip = Chip::new();
        assert_eq!(read(&mut chip, AT), Ok(BootState::Booted), "an erased state");
        let mut aligned = AlignedBuffer([0; Chip::WRITE_SIZE]);
        BlockingFirmwareState::new(Part(&mut chip), &mut aligned.0).mark_updated().unwrap();
        assert_eq!(read(&mut chip, AT), Ok(BootState::Swapped));
        // Progress of a swap, as the bootloader records it after the magic word.
        chip.write(AT + 2 * Chip::WRITE_SIZE as u32, &[0; Chip::WRITE_SIZE]).unwrap();
        mark_booted(&mut chip, AT, 2048).unwrap();
        assert_eq!(embassy(&mut chip), State::Boot);
        assert_eq!(read(&mut chip, AT), Ok(BootState::Booted));
        let after_magic = AT as usize + Chip::WRITE_SIZE;
        assert!(
            chip.bytes()[after_magic..AT as usize + 2048].iter().all(|&b| b == ERASED),
            "progress gone"
        );
    }

    /// The chip, logging each erase and write.
    struct Logged<'a>(&'a mut Chip, std::vec::Vec<(char, u32, u8)>);
    impl embedded_storage::nor_flash::ErrorType for Logged<'_> {
        type Error = <Chip as embedded_storage::nor_flash::ErrorType>::Error;
    }
    impl embedded_storage::nor_flash::ReadNorFlash for Logged<'_> {
        const READ_SIZE: usize = 1;
        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
            self.0.read(offset, bytes)
        }
        fn capacity(&self) -> usize {
            self.0.capacity()
        }
    }
    impl NorFlash for Logged<'_> {
        const WRITE_SIZE: usize = Chip::WRITE_SIZE;
        const ERASE_SIZE: usize = 1024;
        fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
            self.1.push(('e', from, 0));
            self.0.erase(from, to)
        }
        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
            self.1.push(('w', offset, bytes[0]));
            self.0.write(offset, bytes)
        }
    }

    #[test]
    fn the_swap_progress_is_invalidated_before_the_erase_as_embassy_boot_does() {
        let mut chip = Chip::new();
        chip.write(AT, &[SWAP_MAGIC; Chip::WRITE_SIZE]).unwrap();
        let mut f = Logged(&mut chip, std::vec::Vec::new());
        mark_booted(&mut f, AT, 2048).unwrap();
        let w = Chip::WRITE_SIZE as u32;
        assert_eq!(f.1, [('w', AT + w, !ERASED), ('e', AT, 0), ('w', AT, BOOT_MAGIC)]);
        // A marker already written is left as it is.
        let mut chip = Chip::new();
        chip.write(AT, &[SWAP_MAGIC; Chip::WRITE_SIZE]).unwrap();
        chip.write(AT + w, &[0; Chip::WRITE_SIZE]).unwrap();
        let mut f = Logged(&mut chip, std::vec::Vec::new());
        mark_updated(&mut f, AT, 2048).unwrap();
        assert_eq!(f.1, [], "already marked for the swap: nothing written");
        mark_booted(&mut f, AT, 2048).unwrap();
        assert_eq!(f.1, [('e', AT, 0), ('w', AT, BOOT_MAGIC)]);
    }

    #[test]
    fn a_confirmed_image_is_not_written_again() {
        let mut chip = Chip::new();
        mark_booted(&mut chip, AT, 2048).unwrap();
        chip.bytes_mut()[AT as usize + 100] = 0x5A; // anything after the magic stays
        mark_booted(&mut chip, AT, 2048).unwrap();
        assert_eq!(chip.bytes_mut()[AT as usize + 100], 0x5A);
    }

    #[test]
    fn an_update_marked_here_is_one_embassy_boot_swaps() {
        let mut chip = Chip::new();
        mark_booted(&mut chip, AT, 2048).unwrap();
        mark_updated(&mut chip, AT, 2048).unwrap();
        assert_eq!(embassy(&mut chip), State::Swap, "what the bootloader's read_state reads too");
        assert_eq!(read(&mut chip, AT), Ok(BootState::Swapped));
    }

    #[test]
    fn a_rolled_back_image_reads_reverted() {
        let mut chip = Chip::new();
        chip.write(AT, &[REVERT_MAGIC; Chip::WRITE_SIZE]).unwrap();
        assert_eq!(embassy(&mut chip), State::Revert, "embassy-boot's own reading");
        assert_eq!(read(&mut chip, AT), Ok(BootState::Reverted));
        mark_booted(&mut chip, AT, 2048).unwrap();
        assert_eq!(embassy(&mut chip), State::Boot);
    }
}
