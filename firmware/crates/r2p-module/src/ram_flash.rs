//! A NOR flash in RAM that enforces what the STM32's flash enforces, so parameter storage is
//! tested against the rules it must live with.

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// `SIZE` bytes of NOR flash in pages of `PAGE` bytes, written in units of 4 bytes (the
/// STM32F1 programs half-words; 4 covers it and the F4's words).
pub struct RamFlash<const SIZE: usize, const PAGE: usize> {
    bytes: [u8; SIZE],
    /// Bytes that may still be programmed before the simulated power cut (`None`: no cut).
    budget: Option<usize>,
    erases: u32,
}

/// Why a [`RamFlash`] operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RamFlashError {
    /// Offset or length not a multiple of the write or erase unit.
    NotAligned,
    /// Beyond the end.
    OutOfBounds,
    /// Programming a half-word that is not erased with anything but 0x0000 (the F1 reports PGERR
    /// and writes nothing).
    NotErased,
    /// The simulated power cut happened during this operation.
    PowerCut,
}

impl NorFlashError for RamFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Self::NotAligned => NorFlashErrorKind::NotAligned,
            Self::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            Self::NotErased | Self::PowerCut => NorFlashErrorKind::Other,
        }
    }
}

impl<const SIZE: usize, const PAGE: usize> RamFlash<SIZE, PAGE> {
    /// An erased flash.
    pub const fn new() -> Self {
        Self { bytes: [0xFF; SIZE], budget: None, erases: 0 }
    }

    /// Cuts the power after `bytes` more bytes have been programmed: the write in progress is
    /// torn there and fails, and so does every later write until [`Self::power_on`]; an erase
    /// started with no bytes left is torn (half its first page erased) and fails.
    pub fn cut_power_after(&mut self, bytes: usize) {
        self.budget = Some(bytes);
    }

    /// Power back: writes work again; the flash keeps what it held.
    pub fn power_on(&mut self) {
        self.budget = None;
    }

    /// Erase cycles so far (flash wears out after ~10 000 per page on the F103).
    pub fn erases(&self) -> u32 {
        self.erases
    }

    /// The raw contents.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The raw contents, mutably (to flip a bit in a test).
    pub fn bytes_mut(&mut self) -> &mut [u8] {
        &mut self.bytes
    }

    fn range(&self, offset: u32, len: usize) -> Result<core::ops::Range<usize>, RamFlashError> {
        let start = offset as usize;
        let end = start.checked_add(len).ok_or(RamFlashError::OutOfBounds)?;
        if end > SIZE {
            return Err(RamFlashError::OutOfBounds);
        }
        Ok(start..end)
    }
}

impl<const SIZE: usize, const PAGE: usize> Default for RamFlash<SIZE, PAGE> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const SIZE: usize, const PAGE: usize> ErrorType for RamFlash<SIZE, PAGE> {
    type Error = RamFlashError;
}

impl<const SIZE: usize, const PAGE: usize> ReadNorFlash for RamFlash<SIZE, PAGE> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        let r = self.range(offset, bytes.len())?;
        bytes.copy_from_slice(&self.bytes[r]);
        Ok(())
    }

    fn capacity(&self) -> usize {
        SIZE
    }
}

impl<const SIZE: usize, const PAGE: usize> NorFlash for RamFlash<SIZE, PAGE> {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = PAGE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        if !(from as usize).is_multiple_of(PAGE) || !(to as usize).is_multiple_of(PAGE) || to < from
        {
            return Err(RamFlashError::NotAligned);
        }
        let r = self.range(from, (to - from) as usize)?;
        if self.budget == Some(0) {
            // Power lost during the erase: the page is left neither old nor erased (modelled as
            // its first half erased, the rest as it was).
            if !r.is_empty() {
                self.bytes[r.start..r.start + PAGE / 2].fill(0xFF);
            }
            return Err(RamFlashError::PowerCut);
        }
        self.bytes[r].fill(0xFF);
        self.erases += (to - from) / PAGE as u32;
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        if !(offset as usize).is_multiple_of(Self::WRITE_SIZE)
            || !bytes.len().is_multiple_of(Self::WRITE_SIZE)
        {
            return Err(RamFlashError::NotAligned);
        }
        let r = self.range(offset, bytes.len())?;
        // The F1 programs a half-word only where it reads 0xFFFF, except 0x0000, which it
        // programs over anything (PM0075 §2.3.3): how a flag is cleared without an erase.
        let refused = self.bytes[r.clone()]
            .chunks(2)
            .zip(bytes.chunks(2))
            .any(|(old, new)| old != [0xFF, 0xFF] && new != [0, 0]);
        if refused {
            return Err(RamFlashError::NotErased);
        }
        // A cut tears the write between half-words: each is programmed whole or not at all.
        let n = match self.budget {
            Some(b) => b.min(bytes.len()) & !1,
            None => bytes.len(),
        };
        self.bytes[r.start..r.start + n].copy_from_slice(&bytes[..n]);
        if let Some(b) = &mut self.budget {
            if n < bytes.len() {
                *b = 0; // the power is off now, whatever was left of a half-word
                return Err(RamFlashError::PowerCut);
            }
            *b -= n;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn programming_needs_erased_bytes_and_alignment() {
        let mut f: RamFlash<2048, 1024> = RamFlash::new();
        f.write(0, &[1, 2, 3, 4]).unwrap();
        assert_eq!(f.write(0, &[1, 2, 3, 4]), Err(RamFlashError::NotErased));
        assert_eq!(f.write(0, &[0, 0, 3, 4]), Err(RamFlashError::NotErased));
        f.write(0, &[0; 4]).unwrap(); // zeros go over anything
        assert_eq!(&f.bytes()[..4], &[0; 4]);
        assert_eq!(f.write(2, &[1, 2, 3, 4]), Err(RamFlashError::NotAligned));
        assert_eq!(f.write(2048, &[1, 2, 3, 4]), Err(RamFlashError::OutOfBounds));
        assert_eq!(f.erase(0, 512), Err(RamFlashError::NotAligned));
        f.erase(0, 1024).unwrap();
        assert_eq!(&f.bytes()[..4], &[0xFF; 4]);
        assert_eq!(f.erases(), 1);
    }

    #[test]
    fn erases_work_until_the_power_is_cut() {
        let mut f: RamFlash<2048, 1024> = RamFlash::new();
        f.write(0, &[0; 4]).unwrap();
        f.cut_power_after(4);
        f.erase(0, 1024).unwrap();
        assert_eq!(&f.bytes()[..4], &[0xFF; 4]);
    }

    #[test]
    fn a_power_cut_tears_the_write_in_progress() {
        let mut f: RamFlash<1024, 1024> = RamFlash::new();
        f.cut_power_after(7);
        f.write(0, &[0; 4]).unwrap();
        assert_eq!(f.write(4, &[0; 4]), Err(RamFlashError::PowerCut));
        assert_eq!(
            &f.bytes()[..8],
            &[0, 0, 0, 0, 0, 0, 0xFF, 0xFF],
            "torn after a whole half-word"
        );
        f.bytes_mut()[512..516].copy_from_slice(&[1, 2, 3, 4]);
        assert_eq!(f.erase(0, 1024), Err(RamFlashError::PowerCut));
        assert_eq!(&f.bytes()[..8], &[0xFF; 8], "the torn erase cleared the page's start");
        assert_eq!(&f.bytes()[512..516], &[1, 2, 3, 4], "and left its end as it was");
        f.power_on();
        f.erase(0, 1024).unwrap();
    }
}
