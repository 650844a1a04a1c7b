//! Where the bootloader, its state, the two image slots and the parameter pages sit in each MCU's
//! flash: generated from firmware/images.toml, checked here against embassy-boot's rules.

/// A partition: a byte offset from the flash base and a size, both whole erase pages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Partition {
    /// Bytes from the start of the flash.
    pub offset: u32,
    /// Bytes.
    pub size: u32,
}

impl Partition {
    /// The first byte after the partition.
    pub const fn end(&self) -> u32 {
        self.offset + self.size
    }
}

/// One MCU's flash map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlashMap {
    /// Bytes of flash on the part.
    pub flash_size: u32,
    /// The bootloader: never written by an update.
    pub bootloader: Partition,
    /// embassy-boot's state: which slot boots, and the swap's progress.
    pub state: Partition,
    /// The running image; its trailer in its last [`crate::TRAILER_LEN`] bytes.
    pub active: Partition,
    /// The update being received, then (after the swap) the previous image, for rollback.
    pub dfu: Partition,
    /// The parameter pages (r2p-module's `FlashParams`): an update leaves them alone.
    pub params: Partition,
}

include!(concat!(env!("OUT_DIR"), "/flash_maps.rs"));

/// Why a flash map is unusable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapError {
    /// Two partitions share bytes.
    Overlap,
    /// A partition ends past the end of the flash.
    PastFlash,
    /// A partition does not start or end on an erase page (of `page` bytes).
    NotPageAligned,
    /// The DFU partition is not at least one page larger than the active one (embassy-boot swaps
    /// through that page).
    DfuTooSmall,
    /// The state partition cannot hold the swap's progress for the active partition's pages.
    StateTooSmall,
}

impl FlashMap {
    /// The partitions in flash order.
    pub fn partitions(&self) -> [Partition; 5] {
        let mut p = [self.bootloader, self.state, self.active, self.dfu, self.params];
        p.sort_unstable_by_key(|p| p.offset);
        p
    }

    /// Checks the map for a flash erased in pages of `page` bytes (the largest erase unit the
    /// slots use) and written in units of `write` bytes: embassy-boot's own conditions
    /// (`assert_partitions` in its boot_loader.rs), refused here instead of panicking at boot.
    pub fn check(&self, page: u32, write: u32) -> Result<(), MapError> {
        let parts = self.partitions();
        for w in parts.windows(2) {
            if w[0].end() > w[1].offset {
                return Err(MapError::Overlap);
            }
        }
        if parts.iter().any(|p| p.end() > self.flash_size) {
            return Err(MapError::PastFlash);
        }
        if [self.active, self.dfu].iter().any(|p| p.offset % page != 0 || p.size % page != 0) {
            return Err(MapError::NotPageAligned);
        }
        if self.dfu.size < self.active.size + page {
            return Err(MapError::DfuTooSmall);
        }
        if 2 + 4 * (self.active.size / page) > self.state.size / write {
            return Err(MapError::StateTooSmall);
        }
        Ok(())
    }

    /// Where the bootloader's [`crate::api::BootApi`] table lies: the last bytes of its partition.
    pub const fn api_offset(&self) -> u32 {
        self.bootloader.end() - crate::api::API_LEN
    }

    /// The largest image (its code and data, without the trailer) the active slot takes.
    pub const fn image_room(&self) -> u32 {
        self.active.size - crate::TRAILER_LEN as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_maps_satisfy_embassy_boot() {
        // The F103's pages are 1 KiB, written by half-words; the F407's slots sit in 128 KiB
        // sectors, written by words.
        assert_eq!(STM32F103CB.check(1024, 2), Ok(()));
        assert_eq!(STM32F407VG.check(128 * 1024, 4), Ok(()));
    }

    #[test]
    fn the_f103_map_uses_the_whole_flash_and_keeps_the_parameter_pages() {
        let used: u32 = STM32F103CB.partitions().iter().map(|p| p.size).sum();
        assert_eq!(used, STM32F103CB.flash_size);
        assert_eq!(STM32F103CB.params, Partition { offset: 0x1F800, size: 0x800 });
    }

    #[test]
    fn broken_maps_are_refused_with_the_rule_they_break() {
        let ok = STM32F103CB;
        let mut m = ok;
        m.dfu.size = m.active.size;
        assert_eq!(m.check(1024, 2), Err(MapError::DfuTooSmall));
        let mut m = ok;
        m.state.size = 256;
        assert_eq!(m.check(1024, 2), Err(MapError::StateTooSmall));
        let mut m = ok;
        m.active.size += 1024;
        assert_eq!(m.check(1024, 2), Err(MapError::Overlap));
        let mut m = ok;
        m.params.offset += 1024;
        assert_eq!(m.check(1024, 2), Err(MapError::PastFlash));
        let mut m = ok;
        m.active.offset += 2;
        m.active.size -= 2;
        assert_eq!(m.check(1024, 2), Err(MapError::NotPageAligned));
    }
}
