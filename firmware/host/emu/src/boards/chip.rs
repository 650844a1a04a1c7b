//! A board's flash as the STM32F103CB has it: 128 KiB in 1 KiB pages, divided by the bootloader's
//! map (firmware/images.toml, r2p-boot's `layout`), with the time each erase and write takes.
//! The parameter store, the update sink and the emulated bootloader all use it, as on the MCU.
//!
//! The F103 has one flash bank: while a page is erased or a half-word programmed, any fetch from
//! flash stalls the CPU (RM0008, "Flash memory"), so the firmware does nothing else meanwhile.
//! [`TimedFlash`] counts that time ([`TimedFlash::take_stall_ns`]); the sim holds the board's
//! firmware for it ([`crate::Sim::set_stall`]). Times from the STM32F103xB datasheet (flash
//! memory characteristics): page erase 20–40 ms (drawn per erase, from the board's seed),
//! half-word programming 52.5 µs typical.

use core::cell::RefCell;

use embassy_embedded_hal::flash::partition::BlockingPartition;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
use r2p_boot::layout::{Partition, STM32F103CB as MAP};
use r2p_module::RamFlash;

/// Bytes of an erase page.
pub const PAGE: usize = 1024;
/// The chip's flash.
pub type Chip = RamFlash<{ 128 * 1024 }, PAGE>;

/// Page erase, shortest and longest (ns).
const ERASE_NS: (u64, u64) = (20_000_000, 40_000_000);
/// Half-word programming, typical (ns).
const PROGRAM_NS: u64 = 52_500;

/// The chip and the CPU time its operations took.
pub struct TimedFlash {
    /// The flash's contents and rules.
    pub chip: Chip,
    stall_ns: u64,
    rng: u64,
    /// Erases and half-word writes so far.
    pub erases: u64,
    /// Half-words programmed so far.
    pub half_words: u64,
}

impl TimedFlash {
    /// An erased chip; `seed` draws its erase times.
    pub fn new(seed: u64) -> Self {
        Self { chip: Chip::new(), stall_ns: 0, rng: seed | 1, erases: 0, half_words: 0 }
    }

    /// CPU time spent in flash operations since the last call.
    pub fn take_stall_ns(&mut self) -> u64 {
        core::mem::take(&mut self.stall_ns)
    }

    fn erase_ns(&mut self) -> u64 {
        // xorshift64: deterministic per board, no dependency.
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        ERASE_NS.0 + self.rng % (ERASE_NS.1 - ERASE_NS.0 + 1)
    }
}

impl ErrorType for TimedFlash {
    type Error = <Chip as ErrorType>::Error;
}

impl ReadNorFlash for TimedFlash {
    const READ_SIZE: usize = 1;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.chip.read(offset, bytes)
    }
    fn capacity(&self) -> usize {
        self.chip.capacity()
    }
}

impl NorFlash for TimedFlash {
    const WRITE_SIZE: usize = Chip::WRITE_SIZE;
    const ERASE_SIZE: usize = PAGE;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        for _ in (from..to).step_by(PAGE) {
            self.erases += 1;
            self.stall_ns += self.erase_ns();
        }
        self.chip.erase(from, to)
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let half_words = bytes.len().div_ceil(2) as u64;
        self.half_words += half_words;
        self.stall_ns += half_words * PROGRAM_NS;
        self.chip.write(offset, bytes)
    }
}

/// A board's flash, shared by what uses it (leaked once per board: it outlives its boots).
pub type BoardChip = Mutex<CriticalSectionRawMutex, RefCell<TimedFlash>>;

/// A partition of a board's flash.
pub type Part = BlockingPartition<'static, CriticalSectionRawMutex, TimedFlash>;

/// A board's flash, erased; `seed` draws its erase times.
pub fn new_chip(seed: u64) -> &'static BoardChip {
    Box::leak(Box::new(Mutex::new(RefCell::new(TimedFlash::new(seed)))))
}

/// Partition `p` of `chip`.
pub fn part(chip: &'static BoardChip, p: Partition) -> Part {
    BlockingPartition::new(chip, p.offset, p.size)
}

/// The map every emulated board's flash follows.
pub const fn map() -> r2p_boot::layout::FlashMap {
    MAP
}
