//! Parameters set over the bus and kept in flash across reboots.
//!
//! A PARAM_SET is checked and applied in RAM at once (the node answers with the value now
//! held), and marks the parameter dirty; the application calls [`FlashParams::commit`] from
//! thread mode when it suits it, because a flash erase stalls the CPU (on the F103, for ~20 ms,
//! the CAN interrupt included).
//!
//! ## Layout
//! Two erase pages. Each starts with a header (magic `"R2PP"`, sequence number, both
//! little-endian u32); the valid page with the highest sequence is the live one. Records of 8
//! bytes follow: index (u16 LE), type tag, CRC-8 of the other seven bytes, value (u32 LE). A
//! later record for an index replaces an earlier one; an erased record (all `0xFF`) ends the log.
//! When the live page is full, the other page is erased and gets a header with the next
//! sequence and one record per parameter that differs from its default; only then does it
//! become live, so a power cut at any byte loses at most the write in progress.

use core::cell::Cell;

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embedded_storage::nor_flash::{NorFlash, ReadNorFlash};
use r2p_management::message::{ParamFault, Value};
use r2p_node::{Param, ParamStore};

const MAGIC: u32 = u32::from_le_bytes(*b"R2PP");
const HEADER: u32 = 8;
const RECORD: u32 = 8;

/// What [`FlashParams::load`] found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoadReport {
    /// Sequence number of the live page (0: no valid page, defaults kept).
    pub sequence: u32,
    /// Valid records applied.
    pub applied: u16,
    /// Valid records refused by the table (unknown index, wrong type, out of range: the table
    /// changed since they were written).
    pub refused: u16,
    /// Records with a bad CRC (a write torn by a power cut), skipped.
    pub corrupt: u16,
}

/// What [`FlashParams::commit`] wrote.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CommitReport {
    /// Records written.
    pub records: u16,
    /// Whether the log moved to the other page (one page erase).
    pub compacted: bool,
}

#[derive(Clone, Copy)]
struct Log {
    /// Live page (0 or 1), if any.
    page: Option<u8>,
    sequence: u32,
    /// Offset of the next free record in the live page.
    next: u32,
}

/// `N` parameters (N ≤ 32) in RAM, persisted to two flash pages starting at byte `base` of a
/// [`NorFlash`]. See the module documentation.
///
/// The table (names, ranges, defaults) stays where it is, in flash; the values are in a
/// [`ParamValues`] of their own, a `static` of zero bytes (`.bss`) that takes the defaults
/// when first used. A table in this `static` (`.data`) cost each parameter its 36 B twice,
/// in flash for the initial image and in RAM, and its default 8 B more (psu: 684 B of each).
pub struct FlashParams<const N: usize> {
    table: &'static [Param; N],
    values: &'static ParamValues<N>,
    base: u32,
    dirty: Mutex<CriticalSectionRawMutex, Cell<u32>>,
    log: Mutex<CriticalSectionRawMutex, Cell<Log>>,
}

/// The values of a [`FlashParams`]: declare it `static` beside it. Zero bytes until first used,
/// then the table's defaults ([`FlashParams::load`] or any read or write before it).
pub struct ParamValues<const N: usize>(Mutex<CriticalSectionRawMutex, Values<N>>);

struct Values<const N: usize> {
    /// Whether `values` holds the parameters (else the table's defaults are theirs).
    filled: Cell<bool>,
    values: [Cell<Value>; N],
}

impl<const N: usize> ParamValues<N> {
    /// Room for `N` values, not filled yet.
    pub const fn new() -> Self {
        Self(Mutex::new(Values {
            filled: Cell::new(false),
            values: [const { Cell::new(Value::Bool(false)) }; N],
        }))
    }
}

impl<const N: usize> Default for ParamValues<N> {
    fn default() -> Self {
        Self::new()
    }
}

// Out of line: inlined, it was copied into each record's encoding (twice in `commit`) and its
// check in `load`, off the slot path (storing parameters stalls on the flash anyway). One copy:
// motor and proximity -40 B, imu -32 B, template -24 B, psu +8 B (measured; `encode` out of
// line too changed nothing).
#[inline(never)]
fn crc8(bytes: &[u8]) -> u8 {
    // CRC-8/SMBUS (polynomial 0x07): detects any torn or flipped byte of a record.
    bytes.iter().fold(0u8, |mut c, &b| {
        c ^= b;
        for _ in 0..8 {
            c = if c & 0x80 != 0 { (c << 1) ^ 0x07 } else { c << 1 };
        }
        c
    })
}

fn encode(index: u16, value: Value) -> [u8; 8] {
    let (tag, bits) = match value {
        Value::Bool(b) => (0u8, u32::from(b)),
        Value::U32(v) => (1, v),
        Value::I32(v) => (2, v as u32),
        Value::F32(v) => (3, v.to_bits()),
    };
    let mut r = [0u8; 8];
    r[0..2].copy_from_slice(&index.to_le_bytes());
    r[2] = tag;
    r[4..8].copy_from_slice(&bits.to_le_bytes());
    r[3] = crc8(&[r[0], r[1], r[2], r[4], r[5], r[6], r[7]]);
    r
}

fn decode(r: &[u8; 8]) -> Option<(u16, Value)> {
    if r[3] != crc8(&[r[0], r[1], r[2], r[4], r[5], r[6], r[7]]) {
        return None;
    }
    let bits = u32::from_le_bytes([r[4], r[5], r[6], r[7]]);
    let value = match r[2] {
        0 => Value::Bool(bits != 0),
        1 => Value::U32(bits),
        2 => Value::I32(bits as i32),
        3 => Value::F32(f32::from_bits(bits)),
        _ => return None,
    };
    Some((u16::from_le_bytes([r[0], r[1]]), value))
}

fn same(a: Value, b: Value) -> bool {
    match (a, b) {
        (Value::F32(x), Value::F32(y)) => x.to_bits() == y.to_bits(),
        _ => a == b,
    }
}

impl<const N: usize> FlashParams<N> {
    /// A store of the parameters `table` describes (index = position), their values in
    /// `values`, persisted at byte `base` of the flash given to [`Self::load`] and
    /// [`Self::commit`] (two erase pages from there).
    pub const fn new(
        table: &'static [Param; N],
        values: &'static ParamValues<N>,
        base: u32,
    ) -> Self {
        assert!(N <= 32, "FlashParams tracks dirty parameters in a u32");
        Self {
            table,
            values,
            base,
            dirty: Mutex::new(Cell::new(0)),
            log: Mutex::new(Cell::new(Log { page: None, sequence: 0, next: 0 })),
        }
    }

    /// Runs `f` on the values, filled with the table's defaults if they were not yet.
    fn with_values<R>(&self, f: impl FnOnce(&[Cell<Value>; N]) -> R) -> R {
        self.values.0.lock(|v| {
            if !v.filled.get() {
                for (cell, p) in v.values.iter().zip(self.table) {
                    cell.set(p.value);
                }
                v.filled.set(true);
            }
            f(&v.values)
        })
    }

    /// Parameter `index` as the application reads it.
    pub fn param(&self, index: u16) -> Option<Param> {
        let p = self.table.get(usize::from(index))?;
        Some(Param { value: self.with_values(|v| v[usize::from(index)].get()), ..*p })
    }

    /// Sets parameter `index` to `value` if the table allows it (type, range, writable): what
    /// [`ParamStore::set`] does, without marking it dirty (what `load` reads is in flash).
    fn set_value(&self, index: u16, value: Value) -> Result<Value, ParamFault> {
        let p = self.table.get(usize::from(index)).ok_or(ParamFault::UnknownIndex)?;
        p.check(value)?;
        self.with_values(|v| v[usize::from(index)].set(value));
        Ok(value)
    }

    /// The value of parameter `index` (which the caller knows is in the table).
    fn value(&self, index: u16) -> Value {
        self.with_values(|v| v.get(usize::from(index)).map_or(Value::U32(0), Cell::get))
    }

    /// Whether some value set over the bus is not in flash yet.
    pub fn is_dirty(&self) -> bool {
        self.dirty.lock(Cell::get) != 0
    }

    fn page_at(&self, page: u8, page_size: u32) -> u32 {
        self.base + u32::from(page) * page_size
    }

    /// Reads the live page and applies its records (call once at boot, before the node
    /// starts). Unreadable data never panics: it is counted in the report and defaults stay.
    pub fn load<F: ReadNorFlash + NorFlash>(&self, flash: &mut F) -> Result<LoadReport, F::Error> {
        let size = F::ERASE_SIZE as u32;
        let mut best: Option<(u8, u32)> = None;
        for page in 0..2u8 {
            let mut h = [0u8; 8];
            flash.read(self.page_at(page, size), &mut h)?;
            let magic = u32::from_le_bytes([h[0], h[1], h[2], h[3]]);
            let seq = u32::from_le_bytes([h[4], h[5], h[6], h[7]]);
            if magic == MAGIC && seq != u32::MAX && best.is_none_or(|(_, s)| seq > s) {
                best = Some((page, seq));
            }
        }
        let mut report = LoadReport::default();
        let Some((page, sequence)) = best else {
            return Ok(report);
        };
        report.sequence = sequence;
        let start = self.page_at(page, size);
        let mut off = HEADER;
        while off + RECORD <= size {
            let mut r = [0u8; 8];
            flash.read(start + off, &mut r)?;
            if r == [0xFF; 8] {
                break;
            }
            off += RECORD;
            match decode(&r) {
                None => report.corrupt += 1,
                Some((index, value)) => match self.set_value(index, value) {
                    Ok(_) => report.applied += 1,
                    Err(_) => report.refused += 1,
                },
            }
        }
        self.log.lock(|l| l.set(Log { page: Some(page), sequence, next: off }));
        Ok(report)
    }

    /// Writes every dirty parameter to flash (nothing if none is dirty). On error the values
    /// stay dirty, to be written by a later call.
    pub fn commit<F: NorFlash>(&self, flash: &mut F) -> Result<CommitReport, F::Error> {
        let size = F::ERASE_SIZE as u32;
        let mut report = CommitReport::default();
        let dirty = self.dirty.lock(Cell::get);
        if dirty == 0 {
            return Ok(report);
        }
        let mut log = self.log.lock(Cell::get);
        let pending = dirty.count_ones();
        let fits = log.page.is_some() && log.next + pending * RECORD <= size;
        if fits {
            let start = self.page_at(log.page.unwrap_or(0), size);
            for index in (0..N as u16).filter(|i| dirty & (1 << i) != 0) {
                let value = self.value(index);
                flash.write(start + log.next, &encode(index, value))?;
                log.next += RECORD;
                self.log.lock(|l| l.set(log));
                self.dirty.lock(|d| d.set(d.get() & !(1 << index)));
                report.records += 1;
            }
            return Ok(report);
        }
        // Compact into the other page: everything that differs from its default.
        let page = log.page.map_or(0, |p| 1 - p);
        let start = self.page_at(page, size);
        flash.erase(start, start + size)?;
        let mut next = HEADER;
        for index in 0..N as u16 {
            let value = self.value(index);
            if !same(value, self.table[usize::from(index)].value) {
                flash.write(start + next, &encode(index, value))?;
                next += RECORD;
                report.records += 1;
            }
        }
        let sequence = log.sequence.wrapping_add(1) % u32::MAX;
        let mut header = [0u8; 8];
        header[0..4].copy_from_slice(&MAGIC.to_le_bytes());
        header[4..8].copy_from_slice(&sequence.to_le_bytes());
        // The header goes last: until it is written, the old page stays live.
        flash.write(start, &header)?;
        self.log.lock(|l| l.set(Log { page: Some(page), sequence, next }));
        self.dirty.lock(|d| d.set(0));
        report.compacted = true;
        Ok(report)
    }
}

impl<const N: usize> ParamStore for FlashParams<N> {
    fn get(&self, index: u16) -> Result<Value, ParamFault> {
        if usize::from(index) < N {
            Ok(self.value(index))
        } else {
            Err(ParamFault::UnknownIndex)
        }
    }

    fn set(&self, index: u16, value: Value) -> Result<Value, ParamFault> {
        let v = self.set_value(index, value)?;
        self.dirty.lock(|d| d.set(d.get() | (1 << index)));
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RamFlash;

    const PAGE: usize = 1024;
    type Flash = RamFlash<{ 4 * PAGE }, PAGE>;
    const TABLE: [Param; 3] = [
        Param::u32("rate_hz", 100, 1, 1000),
        Param::f32("gain", 1.5, 0.0, 10.0),
        Param::bool("enabled", true),
    ];

    fn values<const N: usize>() -> &'static ParamValues<N> {
        std::boxed::Box::leak(std::boxed::Box::new(ParamValues::new()))
    }

    fn store() -> FlashParams<3> {
        FlashParams::new(&TABLE, values(), PAGE as u32) // pages 1 and 2 of the flash
    }

    #[test]
    fn values_survive_a_reboot() {
        let mut flash = Flash::new();
        let a = store();
        assert_eq!(a.load(&mut flash).unwrap(), LoadReport::default());
        a.set(0, Value::U32(250)).unwrap();
        a.set(1, Value::F32(2.25)).unwrap();
        assert!(a.is_dirty());
        a.commit(&mut flash).unwrap();
        assert!(!a.is_dirty());
        let b = store(); // reboot
        let r = b.load(&mut flash).unwrap();
        assert_eq!((r.applied, r.corrupt, r.refused), (2, 0, 0));
        assert_eq!(b.get(0), Ok(Value::U32(250)));
        assert_eq!(b.get(1), Ok(Value::F32(2.25)));
        assert_eq!(b.get(2), Ok(Value::Bool(true)));
        assert!(flash.bytes()[..PAGE].iter().all(|&x| x == 0xFF), "page 0 is not ours");
    }

    #[test]
    fn before_load_the_values_are_the_tables_defaults() {
        // The values start as zero bytes (`ParamValues` is `.bss`): the first use fills them.
        let a = store();
        assert_eq!(a.get(1), Ok(Value::F32(1.5)));
        assert_eq!(a.param(2).map(|p| (p.name, p.value)), Some(("enabled", Value::Bool(true))));
        a.set(0, Value::U32(7)).unwrap();
        assert_eq!(
            (a.get(0), a.get(1), a.get(2)),
            (Ok(Value::U32(7)), Ok(Value::F32(1.5)), Ok(Value::Bool(true)))
        );
        assert_eq!(a.get(3), Err(ParamFault::UnknownIndex));
        assert_eq!(a.set(3, Value::U32(1)), Err(ParamFault::UnknownIndex));
        assert!(a.param(3).is_none());
    }

    #[test]
    fn out_of_range_is_refused_and_not_stored() {
        let mut flash = Flash::new();
        let a = store();
        a.load(&mut flash).unwrap();
        assert_eq!(a.set(0, Value::U32(5000)), Err(ParamFault::OutOfRange));
        assert_eq!(a.set(1, Value::U32(1)), Err(ParamFault::WrongType));
        assert!(!a.is_dirty());
        assert_eq!(a.get(0), Ok(Value::U32(100)));
    }

    #[test]
    fn a_full_page_compacts_into_the_other_and_keeps_the_latest_values() {
        let mut flash = Flash::new();
        let a = store();
        a.load(&mut flash).unwrap();
        let per_page = (PAGE as u32 - HEADER) / RECORD;
        for v in 0..(3 * per_page) {
            a.set(0, Value::U32(1 + v % 999)).unwrap();
            a.commit(&mut flash).unwrap();
        }
        a.set(2, Value::Bool(false)).unwrap();
        a.commit(&mut flash).unwrap();
        assert!(flash.erases() >= 3, "the log moved between pages");
        let b = store();
        let r = b.load(&mut flash).unwrap();
        assert_eq!(b.get(0), Ok(Value::U32(1 + (3 * per_page - 1) % 999)));
        assert_eq!(b.get(2), Ok(Value::Bool(false)));
        assert!(r.sequence >= 3, "{r:?}");
    }

    #[test]
    fn a_power_cut_at_any_byte_loses_at_most_the_write_in_progress() {
        // Fill the first page to one record short of full, then cut the power at every byte
        // of the compaction that follows: after reboot every value is the old or the new one.
        let per_page = (PAGE as u32 - HEADER) / RECORD;
        for cut in 0..40usize {
            let mut flash = Flash::new();
            let a = store();
            a.load(&mut flash).unwrap();
            a.set(1, Value::F32(3.0)).unwrap();
            a.commit(&mut flash).unwrap();
            for _ in 1..per_page {
                a.set(0, Value::U32(7)).unwrap();
                a.commit(&mut flash).unwrap();
            }
            a.set(0, Value::U32(9)).unwrap();
            a.set(2, Value::Bool(false)).unwrap();
            flash.cut_power_after(cut);
            let _ = a.commit(&mut flash);
            flash.power_on();
            let b = store();
            let r = b.load(&mut flash).unwrap();
            let v0 = b.get(0).unwrap();
            assert!(v0 == Value::U32(7) || v0 == Value::U32(9), "cut at {cut}: {v0:?} {r:?}");
            assert_eq!(b.get(1), Ok(Value::F32(3.0)), "cut at {cut}: an older value was lost");
        }
    }

    #[test]
    fn corrupt_records_are_counted_and_skipped() {
        let mut flash = Flash::new();
        let a = store();
        a.load(&mut flash).unwrap();
        a.set(0, Value::U32(300)).unwrap();
        a.commit(&mut flash).unwrap();
        a.set(1, Value::F32(4.0)).unwrap();
        a.commit(&mut flash).unwrap();
        flash.bytes_mut()[PAGE + HEADER as usize + 4] ^= 0x01; // flip a bit of record 0
        let b = store();
        let r = b.load(&mut flash).unwrap();
        assert_eq!((r.applied, r.corrupt), (1, 1));
        assert_eq!(b.get(0), Ok(Value::U32(100)), "the corrupt record is not applied");
        assert_eq!(b.get(1), Ok(Value::F32(4.0)));
    }

    #[test]
    fn records_from_an_older_table_are_refused() {
        let mut flash = Flash::new();
        let a = store();
        a.load(&mut flash).unwrap();
        a.set(0, Value::U32(900)).unwrap();
        a.commit(&mut flash).unwrap();
        const NARROWER: [Param; 3] = [Param::u32("rate_hz", 100, 1, 500), TABLE[1], TABLE[2]];
        let narrower = FlashParams::new(&NARROWER, values(), PAGE as u32);
        let r = narrower.load(&mut flash).unwrap();
        assert_eq!((r.applied, r.refused), (0, 1));
        assert_eq!(narrower.get(0), Ok(Value::U32(100)));
    }
}
