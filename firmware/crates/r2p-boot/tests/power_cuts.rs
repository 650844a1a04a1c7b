//! An update on an emulated STM32F103CB flash, through the F103 map of firmware/images.toml, the
//! module's receiving side (r2p-module's `DfuSink`, fed by `r2p update`'s sender) and
//! embassy-boot's swap, with the power cut at every erase and write of the transfer, the swap and
//! the confirmation: after each cut the board must boot a verified image, the old or the new one.

use core::cell::RefCell;

use embassy_boot::{BootLoader, BootLoaderConfig, State};
use embassy_embedded_hal::flash::partition::BlockingPartition;
use embassy_sync::blocking_mutex::{raw::CriticalSectionRawMutex, Mutex};
use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
use r2p_boot::layout::{Partition, STM32F103CB as MAP};
use r2p_boot::sender::{Phase, Sender};
use r2p_boot::sign::{public_key, sign, Meta};
use r2p_boot::transfer::Msg;
use r2p_boot::{verify_slot, Expect, Trailer, Version, TRAILER_LEN};
use r2p_module::{DfuSink, RamFlash};
use r2p_node::UpdateSink;

const SEED: [u8; 32] = [0x52; 32];
const PAGE: usize = 1024;
type Chip = RamFlash<{ 128 * 1024 }, PAGE>;

/// The chip, recording where each erase and write began (in bytes programmed so far), so the
/// test can cut the power at each of them.
struct Recorder {
    chip: Chip,
    programmed: usize,
    steps: Vec<Step>,
    /// Writes now are the transfer's blocks.
    in_transfer: bool,
}

#[derive(Clone, Copy, Debug)]
enum Step {
    Erase {
        at: usize,
    },
    /// `transfer`: a block of the transfer (as against the swap's and the state's writes).
    Write {
        at: usize,
        len: usize,
        transfer: bool,
    },
}

impl ErrorType for Recorder {
    type Error = <Chip as ErrorType>::Error;
}

impl ReadNorFlash for Recorder {
    const READ_SIZE: usize = 1;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.chip.read(offset, bytes)
    }
    fn capacity(&self) -> usize {
        self.chip.capacity()
    }
}

impl NorFlash for Recorder {
    const WRITE_SIZE: usize = Chip::WRITE_SIZE;
    const ERASE_SIZE: usize = PAGE;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        // One step per page, as the F103 erases them.
        for page in (from..to).step_by(PAGE) {
            self.steps.push(Step::Erase { at: self.programmed });
            self.chip.erase(page, page + PAGE as u32)?;
        }
        Ok(())
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let transfer = self.in_transfer;
        self.steps.push(Step::Write { at: self.programmed, len: bytes.len(), transfer });
        self.chip.write(offset, bytes)?;
        self.programmed += bytes.len();
        Ok(())
    }
}

type Flash = Mutex<CriticalSectionRawMutex, RefCell<Recorder>>;
type Part<'a> = BlockingPartition<'a, CriticalSectionRawMutex, Recorder>;

fn part(flash: &Flash, p: Partition) -> Part<'_> {
    BlockingPartition::new(flash, p.offset, p.size)
}

fn signed(len: usize, patch: u16) -> Vec<u8> {
    let image: Vec<u8> = (0..len)
        .map(|i| (i as u32 ^ patch as u32).wrapping_mul(2_654_435_761).to_le_bytes()[3])
        .collect();
    let meta =
        Meta { version: Version { major: 1, minor: 0, patch }, kind: "motor", mcu: "STM32F103CB" };
    sign(&image, &meta, &SEED).unwrap()
}

/// The signed image's trailer, where it lies in a slot: the last bytes of the active slot's size.
fn trailer_offset() -> usize {
    MAP.active.size as usize - TRAILER_LEN
}

fn expect(key: &[u8; 32]) -> Expect<'_> {
    Expect { mcu: "STM32F103CB", kind: None, public_key: key }
}

/// A board as `r2p flash` leaves it: the old image in the active slot, its trailer at the slot's end.
fn factory(old: &[u8]) -> Recorder {
    let mut chip = Chip::new();
    let (image, trailer) = old.split_at(old.len() - TRAILER_LEN);
    chip.bytes_mut()[MAP.active.offset as usize..][..image.len()].copy_from_slice(image);
    chip.bytes_mut()[(MAP.active.offset as usize + trailer_offset())..][..TRAILER_LEN]
        .copy_from_slice(trailer);
    Recorder { chip, programmed: 0, steps: Vec::new(), in_transfer: false }
}

/// An update as it arrives over the bus: r2p-update's sender and the module's `DfuSink` (the
/// code a module runs) exchanging transfer messages, each block written into the DFU slot as it
/// comes, the image checked where it landed and marked for the swap. A power cut fails every write
/// after it: the module refuses (flash write) and the transfer ends there.
fn receive(flash: &Flash, new: &[u8]) -> Result<(), String> {
    let sink =
        DfuSink::new("motor", MAP.active.size, part(flash, MAP.dfu), part(flash, MAP.state), check);
    let mut sender = Sender::new(new, 1, 8, 1_000);
    flash.lock(|f| f.borrow_mut().in_transfer = true);
    let (mut now, mut answer) = (0u64, [0u8; 64]);
    while !matches!(sender.phase(), Phase::Done | Phase::Refused(_)) {
        let mut buf = [0u8; 64];
        match sender.poll(now) {
            Some(msg) => {
                let n = msg.encode(&mut buf);
                let a = sink.handle(0x7F, &buf[..n], &mut answer);
                if let Ok(Msg::Status(s)) = Msg::decode(&answer[..a]) {
                    sender.on_status(&s, now);
                }
            }
            None => now += 1,
        }
    }
    flash.lock(|f| f.borrow_mut().in_transfer = false);
    match sender.phase() {
        Phase::Refused(r) => Err(r.message().to_string()),
        _ if sink.is_marked() => Ok(()),
        _ => Err("verified but not marked".into()),
    }
}

/// The bootloader's check of a complete DFU slot, as a module calls it.
fn check(dfu: &mut Part<'_>) -> Result<(), r2p_boot::Refusal> {
    let key = public_key(&SEED);
    verify_slot(dfu, 0, MAP.active.size, &expect(&key)).map(|_| ())
}

/// The bootloader: embassy-boot's prepare (swap, revert or nothing), then the image it would run.
fn boot(flash: &Flash) -> Result<(State, Trailer), String> {
    let config = BootLoaderConfig {
        active: part(flash, MAP.active),
        dfu: part(flash, MAP.dfu),
        state: part(flash, MAP.state),
    };
    let mut bl = BootLoader::new(config);
    let mut buf = [0u8; PAGE];
    let state = bl.prepare_boot(&mut buf).map_err(|e| format!("prepare: {e:?}"))?;
    let key = public_key(&SEED);
    let mut active = part(flash, MAP.active);
    let t = verify_slot(&mut active, 0, MAP.active.size, &expect(&key))
        .map_err(|r| r.message().to_string())?;
    Ok((state, t))
}

/// The new image, once it has joined the bus and passed its self-checks: as the images do it
/// (r2p-boot's `boot_state`, not embassy-boot's updater).
fn confirm(flash: &Flash) -> Result<(), String> {
    flash
        .lock(|f| {
            r2p_boot::boot_state::mark_booted(
                &mut *f.borrow_mut(),
                MAP.state.offset,
                MAP.state.size,
            )
        })
        .map_err(|e| format!("confirm: {e:?}"))
}

/// Receive, reboot into the swap, confirm, reboot.
fn update(flash: &Flash, new: &[u8]) -> Result<(), String> {
    receive(flash, new)?;
    let (state, t) = boot(flash)?;
    assert_eq!(
        (state, t.version.patch),
        (State::Swap, 2),
        "the swap ran and the new image is active"
    );
    confirm(flash)?;
    let (state, t) = boot(flash)?;
    assert_eq!((state, t.version.patch), (State::Boot, 2));
    Ok(())
}

fn version_in_active(flash: &Flash) -> u16 {
    boot(flash).expect("a verified image boots").1.version.patch
}

#[test]
fn an_update_swaps_in_the_new_image_and_keeps_it_once_confirmed() {
    let flash = Mutex::new(RefCell::new(factory(&signed(40_000, 1))));
    assert_eq!(version_in_active(&flash), 1);
    update(&flash, &signed(52_000, 2)).unwrap();
    assert_eq!(version_in_active(&flash), 2);
    let r = flash.lock(|f| f.borrow().steps.len());
    println!("an update of a 52 000 B image: {r} erase and write steps");
}

#[test]
fn a_new_image_that_never_confirms_is_rolled_back() {
    let flash = Mutex::new(RefCell::new(factory(&signed(40_000, 1))));
    receive(&flash, &signed(52_000, 2)).unwrap();
    let (state, t) = boot(&flash).unwrap();
    assert_eq!((state, t.version.patch), (State::Swap, 2), "on trial");
    // It resets (its watchdog) before confirming: the bootloader swaps the old image back
    // (prepare_boot reports the state it found: still Swap), and says so on the next boot.
    let (state, t) = boot(&flash).unwrap();
    assert_eq!((state, t.version.patch), (State::Swap, 1), "rolled back");
    assert_eq!(boot(&flash).unwrap(), (State::Revert, t), "the old image learns of the rollback");
    confirm(&flash).unwrap();
    assert_eq!(boot(&flash).unwrap(), (State::Boot, t), "and stays");
}

#[test]
fn an_image_that_fails_its_check_is_never_marked() {
    let flash = Mutex::new(RefCell::new(factory(&signed(40_000, 1))));
    let mut bad = signed(30_000, 2);
    bad[12_345] ^= 0x04;
    assert_eq!(receive(&flash, &bad).unwrap_err(), r2p_boot::Refusal::BadSignature.message());
    assert_eq!(boot(&flash).unwrap().0, State::Boot, "no swap requested");
    assert_eq!(version_in_active(&flash), 1);
}

#[test]
fn a_power_cut_at_any_step_leaves_a_verified_image_that_boots() {
    let old = signed(40_000, 1);
    let new = signed(52_000, 2);
    // The steps of an uninterrupted update, to cut at each.
    let flash = Mutex::new(RefCell::new(factory(&old)));
    update(&flash, &new).unwrap();
    let steps = flash.lock(|f| f.borrow().steps.clone());
    let mut cuts: Vec<usize> = Vec::new();
    let mut blocks = 0;
    for s in &steps {
        match *s {
            // Budget `at`: the erase begins with nothing left, and is torn.
            Step::Erase { at } => cuts.push(at),
            // Before the first byte, and in the middle: every write of the swap and the state,
            // every 8th of the transfer's (its 1 100 blocks tear alike; each is cut before it).
            Step::Write { at, len, transfer } => {
                cuts.push(at);
                blocks += usize::from(transfer);
                if !transfer || blocks % 8 == 1 {
                    cuts.push(at + len / 2);
                }
            }
        }
    }
    cuts.dedup();
    let (mut old_boots, mut new_boots) = (0, 0);
    for (i, &cut) in cuts.iter().enumerate() {
        let flash = Mutex::new(RefCell::new(factory(&old)));
        flash.lock(|f| f.borrow_mut().chip.cut_power_after(cut));
        assert!(update(&flash, &new).is_err(), "cut at {cut} bytes: the update ran to its end");
        flash.lock(|f| f.borrow_mut().chip.power_on());
        // Power back: the bootloader finishes or undoes what was cut, and a verified image boots.
        let (_, t) = boot(&flash).unwrap_or_else(|e| panic!("cut at {cut} bytes: {e}"));
        match t.version.patch {
            1 => old_boots += 1,
            2 => new_boots += 1,
            v => panic!("cut at {cut} bytes: version {v} booted"),
        }
        // Whatever booted, an update from there completes (a transfer cut short starts again):
        // checked after every 4th cut (the transfer begins again the same way every time).
        if i % 4 != 0 {
            continue;
        }
        if t.version.patch == 2 {
            let _ = confirm(&flash);
            let _ = boot(&flash);
        }
        if version_in_active(&flash) == 1 {
            update(&flash, &new)
                .unwrap_or_else(|e| panic!("cut at {cut} bytes, the update again: {e}"));
        }
        assert_eq!(version_in_active(&flash), 2, "cut at {cut} bytes");
    }
    println!(
        "{} steps, {} cut points: the old image booted after {old_boots}, the new one after {new_boots}, neither after 0",
        steps.len(),
        cuts.len()
    );
}
