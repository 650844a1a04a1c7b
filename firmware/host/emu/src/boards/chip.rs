//! A board's flash as its MCU has it: the STM32F103CB's 128 KiB in 1 KiB pages (the modules) or
//! the STM32F407VG's 1 MiB in sectors of 16, 64 and 128 KiB (the gateway), divided by the
//! bootloader's map of that MCU (firmware/images.toml, r2p-boot's `layout`), with the time each
//! erase and write takes. The parameter store, the update sink and the emulated bootloader all
//! use it, as on the MCU.
//!
//! Both parts have one flash bank: while a page or sector is erased or a unit programmed, any
//! fetch from flash stalls the CPU (RM0008 and RM0090, "Flash memory"), so the firmware does
//! nothing else meanwhile. [`TimedFlash`] counts that time ([`TimedFlash::take_stall_ns`]); the
//! sim holds the board's firmware for it ([`crate::Sim::set_stall`]). Times from the datasheets'
//! flash memory characteristics, each erase drawn from the datasheet's range (from the board's
//! seed): STM32F103xB page erase 20–40 ms, half-word programming 52.5 µs typical; STM32F407xx
//! (DS8626, x32 parallelism, 2.7–3.6 V) sector erase 250–500 ms for 16 KiB, 550–1 100 ms for
//! 64 KiB, 1–2 s for 128 KiB (typical to maximum), word programming 16 µs typical.
//!
//! A [`Region`] is a partition of the chip seen with the erase unit the MCU has there (the F407's
//! sectors differ in size, and `NorFlash` has one erase size), as embassy-stm32's flash regions
//! are on the MCU; [`ChipLayout`] names each MCU's.

use core::cell::RefCell;

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use r2p_boot::layout::{FlashMap, Partition, STM32F103CB, STM32F407VG};
use r2p_node::{
    FramedLeads, SlotPath, CORTEX_M3_FRAMED_PATHS, CORTEX_M3_SLOT_PATH, CORTEX_M3_SYNC_PATH,
    CORTEX_M4_SLOT_PATH, CORTEX_M4_SYNC_PATH,
};
use r2p_world::BoardKind;

/// The MCUs the emulated boards have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mcu {
    /// The modules' STM32F103CB.
    F103,
    /// The gateway's STM32F407VG.
    F407,
}

impl Mcu {
    /// Its core clock as the firmware configures it (Hz): the boards' `sysclk_hz`.
    pub const fn sysclk_hz(self) -> u32 {
        match self {
            Mcu::F103 => 72_000_000,
            Mcu::F407 => 168_000_000,
        }
    }

    /// The slot path built for its core (instructions, measured under QEMU).
    pub const fn slot_path(self) -> SlotPath {
        match self {
            Mcu::F103 => CORTEX_M3_SLOT_PATH,
            Mcu::F407 => CORTEX_M4_SLOT_PATH,
        }
    }

    /// The slot lead its firmware configures (µs): the shortest path at its clock.
    pub const fn slot_lead_us(self) -> u32 {
        self.slot_path().lead_us(self.sysclk_hz())
    }

    /// How long its slot path takes in the emulator (µs): the longest at its clock.
    pub const fn slot_path_us(self) -> u64 {
        self.slot_path().longest_us(self.sysclk_hz()) as u64
    }

    /// A slot-grid master's path to its sync, loaded first in its tick, built for its core
    /// (instructions, measured under QEMU).
    pub const fn sync_path(self) -> SlotPath {
        match self {
            Mcu::F103 => CORTEX_M3_SYNC_PATH,
            Mcu::F407 => CORTEX_M4_SYNC_PATH,
        }
    }

    /// The sync lead its firmware configures (µs): the shortest sync path at its clock.
    pub const fn sync_lead_us(self) -> u32 {
        self.sync_path().lead_us(self.sysclk_hz())
    }

    /// How long its sync path takes in the emulator (µs): the longest at its clock.
    pub const fn sync_path_us(self) -> u64 {
        self.sync_path().longest_us(self.sysclk_hz()) as u64
    }

    /// The slot timer's leads on frame-sized reservations its firmware configures (µs): the
    /// shortest paths to an HRT frame's and to a sync's request at its clock
    /// (`FramedLeads::at`).
    pub const fn framed_leads(self) -> FramedLeads {
        FramedLeads::at(self.sysclk_hz())
    }

    /// How long its paths to a reservation's first frame take in the emulator on frame-sized
    /// reservations (µs): (an HRT frame's, a sync's), the longest at its clock.
    pub const fn framed_paths_us(self) -> (u64, u64) {
        let hz = self.sysclk_hz();
        let hrt = CORTEX_M3_FRAMED_PATHS.slot.longest_us(hz) as u64;
        (hrt, CORTEX_M3_FRAMED_PATHS.sync.longest_us(hz) as u64)
    }

    /// How long its short path on frame-sized reservations takes in the emulator (µs), the
    /// longest at its clock (`r2p_node::CORTEX_M3_FRAMED_PATHS`, `Node::top_up`).
    pub const fn top_up_path_us(self) -> u64 {
        CORTEX_M3_FRAMED_PATHS.top_up.longest_us(self.sysclk_hz()) as u64
    }
}

/// What an MCU's flash is: its erase units, their times, its program unit and time, and the
/// bootloader's map over it.
pub struct Spec {
    /// probe-rs's name of the chip (images are signed for it).
    pub name: &'static str,
    /// Bytes of flash.
    pub size: u32,
    /// Erase units from the flash base, in order: (bytes, how many).
    pub units: &'static [(u32, u32)],
    /// The erase time of a unit of each size: (bytes, shortest ns, longest ns).
    pub erase_ns: &'static [(u32, u64, u64)],
    /// Bytes programmed at once (the F1's half-word, the F4's word at x32) and how long (ns).
    pub program: (u32, u64),
    /// The bootloader's map.
    pub map: FlashMap,
}

/// The STM32F103CB: 128 pages of 1 KiB.
pub const F103_SPEC: Spec = Spec {
    name: "STM32F103CB",
    size: 128 * 1024,
    units: &[(1024, 128)],
    erase_ns: &[(1024, 20_000_000, 40_000_000)],
    program: (2, 52_500),
    map: STM32F103CB,
};

/// The STM32F407VG: sectors 0–3 of 16 KiB, 4 of 64 KiB, 5–11 of 128 KiB.
pub const F407_SPEC: Spec = Spec {
    name: "STM32F407VG",
    size: 1024 * 1024,
    units: &[(16 * 1024, 4), (64 * 1024, 1), (128 * 1024, 7)],
    erase_ns: &[
        (16 * 1024, 250_000_000, 500_000_000),
        (64 * 1024, 550_000_000, 1_100_000_000),
        (128 * 1024, 1_000_000_000, 2_000_000_000),
    ],
    program: (4, 16_000),
    map: STM32F407VG,
};

impl Mcu {
    /// Its flash.
    pub const fn spec(self) -> &'static Spec {
        match self {
            Mcu::F103 => &F103_SPEC,
            Mcu::F407 => &F407_SPEC,
        }
    }

    /// The MCU of a board of model `kind` (modules.toml: the gateway's is the F407).
    pub fn of(kind: BoardKind) -> Self {
        match kind {
            BoardKind::Gateway => Mcu::F407,
            _ => Mcu::F103,
        }
    }
}

impl Spec {
    /// The erase unit holding byte `at`: (its start, its size).
    pub fn unit_at(&self, at: u32) -> Option<(u32, u32)> {
        let mut start = 0;
        for &(size, count) in self.units {
            if at < start + size * count {
                return Some((start + (at - start) / size * size, size));
            }
            start += size * count;
        }
        None
    }
}

/// Why a flash operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlashError {
    /// Not on an erase unit's or a program unit's boundary.
    NotAligned,
    /// Beyond the end of the flash or the region.
    OutOfBounds,
    /// Programming an F1 half-word that is not erased with anything but 0x0000 (PGERR).
    NotErased,
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Self::NotAligned => NorFlashErrorKind::NotAligned,
            Self::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            Self::NotErased => NorFlashErrorKind::Other,
        }
    }
}

/// One erase: where, how large, how long the CPU stalled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Erase {
    /// Offset from the flash base.
    pub at: u32,
    /// Bytes.
    pub size: u32,
    /// CPU stall, ns.
    pub ns: u64,
}

/// The chip and the CPU time its operations took.
pub struct TimedFlash {
    /// Which MCU's flash.
    pub mcu: Mcu,
    bytes: Vec<u8>,
    stall_ns: u64,
    rng: u64,
    /// Every erase so far, in order.
    pub erases: Vec<Erase>,
    /// Program units (half-words or words) written so far.
    pub units_programmed: u64,
}

impl TimedFlash {
    /// An erased chip of `mcu`; `seed` draws its erase times.
    pub fn new(mcu: Mcu, seed: u64) -> Self {
        let bytes = vec![0xFF; mcu.spec().size as usize];
        Self { mcu, bytes, stall_ns: 0, rng: seed | 1, erases: Vec::new(), units_programmed: 0 }
    }

    /// CPU time spent in flash operations since the last call.
    pub fn take_stall_ns(&mut self) -> u64 {
        core::mem::take(&mut self.stall_ns)
    }

    /// The raw contents.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The raw contents, mutably (a probe's write; a flipped bit in a test).
    pub fn bytes_mut(&mut self) -> &mut [u8] {
        &mut self.bytes
    }

    fn erase_ns(&mut self, size: u32) -> u64 {
        // xorshift64: deterministic per board, no dependency.
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        let spec = self.mcu.spec();
        let &(_, lo, hi) =
            spec.erase_ns.iter().find(|e| e.0 == size).expect("a time for every unit size");
        lo + self.rng % (hi - lo + 1)
    }

    fn range(&self, at: u32, len: usize) -> Result<core::ops::Range<usize>, FlashError> {
        let end = (at as usize).checked_add(len).ok_or(FlashError::OutOfBounds)?;
        if end > self.bytes.len() {
            return Err(FlashError::OutOfBounds);
        }
        Ok(at as usize..end)
    }

    /// Erases the whole units from `from` to `to` (both on unit boundaries), each stalling the
    /// CPU for its time.
    pub fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        let spec = self.mcu.spec();
        let on_boundary = |at: u32| at == spec.size || spec.unit_at(at).is_some_and(|u| u.0 == at);
        if to < from || !on_boundary(from) || !on_boundary(to) {
            return Err(FlashError::NotAligned);
        }
        self.range(from, (to - from) as usize)?;
        let mut at = from;
        while at < to {
            let (_, size) = spec.unit_at(at).ok_or(FlashError::OutOfBounds)?;
            let ns = self.erase_ns(size);
            self.stall_ns += ns;
            self.erases.push(Erase { at, size, ns });
            self.bytes[at as usize..(at + size) as usize].fill(0xFF);
            at += size;
        }
        Ok(())
    }

    /// Programs `data` at `at` (whole write units), each program unit stalling the CPU for its
    /// time. The F1 programs a half-word only where erased (or to 0x0000: PGERR otherwise, and
    /// nothing written); the F4 clears bits, never sets them.
    pub fn write(&mut self, at: u32, data: &[u8]) -> Result<(), FlashError> {
        let (unit, ns) = self.mcu.spec().program;
        if !at.is_multiple_of(unit) || !(data.len() as u32).is_multiple_of(unit) {
            return Err(FlashError::NotAligned);
        }
        let r = self.range(at, data.len())?;
        let units = (data.len() / unit as usize) as u64;
        self.units_programmed += units;
        self.stall_ns += units * ns;
        let old = &mut self.bytes[r];
        match self.mcu {
            Mcu::F103 => {
                for (o, d) in old.chunks_exact_mut(2).zip(data.chunks_exact(2)) {
                    if o != [0xFF, 0xFF] && d != [0, 0] {
                        return Err(FlashError::NotErased);
                    }
                    o.copy_from_slice(d);
                }
            }
            Mcu::F407 => old.iter_mut().zip(data).for_each(|(o, d)| *o &= d),
        }
        Ok(())
    }
}

/// A board's flash, shared by what uses it (leaked once per board: it outlives its boots).
pub type BoardChip = Mutex<CriticalSectionRawMutex, RefCell<TimedFlash>>;

/// A board's flash of `mcu`, erased; `seed` draws its erase times.
pub fn new_chip(mcu: Mcu, seed: u64) -> &'static BoardChip {
    Box::leak(Box::new(Mutex::new(RefCell::new(TimedFlash::new(mcu, seed)))))
}

/// The MCU of a board's flash.
pub fn mcu_of(chip: &BoardChip) -> Mcu {
    chip.lock(|c| c.borrow().mcu)
}

/// Partition `part` of a chip, whose erase unit there is `ERASE` bytes (checked at each erase
/// against the chip's own units, as the MCU's flash controller erases only whole ones).
pub struct Region<const ERASE: usize> {
    chip: &'static BoardChip,
    part: Partition,
}

impl<const ERASE: usize> Region<ERASE> {
    /// Partition `part` of `chip`.
    pub fn new(chip: &'static BoardChip, part: Partition) -> Self {
        Self { chip, part }
    }

    fn at(&self, offset: u32, len: usize) -> Result<u32, FlashError> {
        match offset.checked_add(len as u32) {
            Some(end) if end <= self.part.size => Ok(self.part.offset + offset),
            _ => Err(FlashError::OutOfBounds),
        }
    }
}

impl<const ERASE: usize> ErrorType for Region<ERASE> {
    type Error = FlashError;
}

impl<const ERASE: usize> ReadNorFlash for Region<ERASE> {
    const READ_SIZE: usize = 1;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        let at = self.at(offset, bytes.len())? as usize;
        self.chip.lock(|c| bytes.copy_from_slice(&c.borrow().bytes[at..at + bytes.len()]));
        Ok(())
    }
    fn capacity(&self) -> usize {
        self.part.size as usize
    }
}

impl<const ERASE: usize> NorFlash for Region<ERASE> {
    /// Both MCUs' images program words at most (the F1 a half-word at a time).
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = ERASE;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        let aligned = |x: u32| (x as usize).is_multiple_of(ERASE);
        if to < from || !aligned(from) || !aligned(to) {
            return Err(FlashError::NotAligned);
        }
        let at = self.at(from, (to - from) as usize)?;
        self.chip.lock(|c| c.borrow_mut().erase(at, at + (to - from)))
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let at = self.at(offset, bytes.len())?;
        self.chip.lock(|c| c.borrow_mut().write(at, bytes))
    }
}

/// Which erase unit each partition of an MCU's map has: the types the parameter store, the
/// update sink and the bootloader use on it.
pub trait ChipLayout: 'static {
    /// The MCU.
    const MCU: Mcu;
    /// The parameter pages (two erase units).
    type Params: NorFlash<Error = FlashError> + Send + 'static;
    /// embassy-boot's state.
    type State: NorFlash<Error = FlashError> + Send + 'static;
    /// The image slots, active and DFU.
    type Slot: NorFlash<Error = FlashError> + Send + 'static;
    /// The bootloader's copy buffer (a divisor of the slots' erase unit, as the MCU's
    /// bootloader uses).
    const COPY_BUFFER: usize;
    /// The parameter pages of `chip`.
    fn params(chip: &'static BoardChip) -> Self::Params;
    /// The state partition of `chip`.
    fn state(chip: &'static BoardChip) -> Self::State;
    /// Slot `part` (active or DFU) of `chip`.
    fn slot(chip: &'static BoardChip, part: Partition) -> Self::Slot;
}

/// The F103's map: 1 KiB pages everywhere.
pub struct F103;
/// The F407's map: parameters in 16 KiB sectors, the state in the 64 KiB one, the slots in
/// 128 KiB ones.
pub struct F407;

impl ChipLayout for F103 {
    const MCU: Mcu = Mcu::F103;
    type Params = Region<1024>;
    type State = Region<1024>;
    type Slot = Region<1024>;
    const COPY_BUFFER: usize = 1024;
    fn params(chip: &'static BoardChip) -> Self::Params {
        Region::new(chip, STM32F103CB.params)
    }
    fn state(chip: &'static BoardChip) -> Self::State {
        Region::new(chip, STM32F103CB.state)
    }
    fn slot(chip: &'static BoardChip, part: Partition) -> Self::Slot {
        Region::new(chip, part)
    }
}

impl ChipLayout for F407 {
    const MCU: Mcu = Mcu::F407;
    type Params = Region<{ 16 * 1024 }>;
    type State = Region<{ 64 * 1024 }>;
    type Slot = Region<{ 128 * 1024 }>;
    /// The F407 bootloader's (firmware/targets/f407/bootloader): 4 KiB at a time.
    const COPY_BUFFER: usize = 4096;
    fn params(chip: &'static BoardChip) -> Self::Params {
        Region::new(chip, STM32F407VG.params)
    }
    fn state(chip: &'static BoardChip) -> Self::State {
        Region::new(chip, STM32F407VG.state)
    }
    fn slot(chip: &'static BoardChip, part: Partition) -> Self::Slot {
        Region::new(chip, part)
    }
}

/// Calls generic function `$f::<L, ...>($args)` with the [`ChipLayout`] of `$chip`'s MCU first
/// (further generic arguments after it, as `f::<N>(...)`).
#[macro_export]
#[doc(hidden)]
macro_rules! on_layout {
    ($chip:expr, $f:ident $(::<$($g:tt),*>)? ( $($args:expr),* $(,)? )) => {
        match $crate::boards::chip::mcu_of($chip) {
            $crate::boards::chip::Mcu::F103 => {
                $f::<$crate::boards::chip::F103 $(, $($g),*)?>($($args),*)
            }
            $crate::boards::chip::Mcu::F407 => {
                $f::<$crate::boards::chip::F407 $(, $($g),*)?>($($args),*)
            }
        }
    };
}

/// The map of a board's flash.
pub fn map_of(chip: &BoardChip) -> FlashMap {
    mcu_of(chip).spec().map
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_f407_erases_whole_sectors_of_their_own_size_and_time() {
        let chip = new_chip(Mcu::F407, 7);
        assert_eq!(chip.lock(|c| c.borrow().bytes.len()), 1 << 20);
        let mut slot = <F407 as ChipLayout>::slot(chip, STM32F407VG.dfu);
        slot.write(0, &[0x12, 0x34, 0x56, 0x78]).unwrap();
        assert_eq!(slot.erase(0, 64 * 1024), Err(FlashError::NotAligned), "half a sector");
        slot.erase(0, 128 * 1024).unwrap();
        let e = chip.lock(|c| c.borrow().erases.clone());
        assert_eq!((e[0].at, e[0].size), (STM32F407VG.dfu.offset, 128 * 1024));
        assert!((1_000_000_000..=2_000_000_000).contains(&e[0].ns), "{} ns", e[0].ns);
        // A region whose erase unit is not the chip's there is refused by the chip.
        let mut wrong = Region::<{ 16 * 1024 }>::new(chip, STM32F407VG.dfu);
        assert_eq!(wrong.erase(0, 16 * 1024), Err(FlashError::NotAligned));
        let stall = chip.lock(|c| c.borrow_mut().take_stall_ns());
        assert_eq!(stall, e[0].ns + 16_000, "the erase and one word");
        let mut state = <F407 as ChipLayout>::state(chip);
        state.erase(0, 64 * 1024).unwrap();
        let ns = chip.lock(|c| c.borrow().erases[1].ns);
        assert!((550_000_000..=1_100_000_000).contains(&ns), "{ns} ns");
    }

    #[test]
    fn the_f103_programs_a_half_word_only_where_erased() {
        let chip = new_chip(Mcu::F103, 7);
        let mut params = <F103 as ChipLayout>::params(chip);
        params.write(0, &[1, 2, 3, 4]).unwrap();
        assert_eq!(params.write(0, &[1, 2, 3, 4]), Err(FlashError::NotErased));
        params.write(0, &[0, 0, 0, 0]).unwrap();
    }
}
