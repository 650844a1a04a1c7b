//! The gateway's update on an emulated STM32F407VG flash, through the F407 map of
//! firmware/images.toml, as power_cuts.rs does it for the F103: the gateway's receiving side
//! (r2p-module's `DfuSink` over its 128 KiB DFU sectors, embassy-boot's state in its 64 KiB
//! sector, fed by `r2p update`'s sender) and embassy-boot's swap 4 KiB at a time (as the F407
//! bootloader copies), with the power cut at every erase and write of the transfer, the swap and
//! the confirmation: after each cut the board must boot a verified image, the old or the new one.
//!
//! The chip is 1 MiB in units of 16 KiB (its smallest sector); each partition is seen with its
//! own sectors' size, as embassy-stm32's flash regions are, and a sector erase cut by the power
//! is left torn (its first 8 KiB erased, the rest as it was).

use core::cell::RefCell;

use embassy_boot::{BootLoader, BootLoaderConfig, State};
use embassy_sync::blocking_mutex::{raw::CriticalSectionRawMutex, Mutex};
use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
use r2p_boot::layout::{Partition, STM32F407VG as MAP};
use r2p_boot::sender::{Phase, Sender};
use r2p_boot::sign::{public_key, sign, Meta};
use r2p_boot::transfer::Msg;
use r2p_boot::{verify_slot, Expect, Trailer, Version, TRAILER_LEN};
use r2p_module::{DfuSink, RamFlash};
use r2p_node::UpdateSink;

const SEED: [u8; 32] = [0x52; 32];
const MCU: &str = "STM32F407VG";
type Chip = RamFlash<{ 1024 * 1024 }, { 16 * 1024 }>;

/// The chip, recording where each erase and write began (in bytes programmed so far).
struct Recorder {
    chip: Box<Chip>,
    programmed: usize,
    steps: Vec<Step>,
    in_transfer: bool,
}

#[derive(Clone, Copy, Debug)]
enum Step {
    Erase { at: usize },
    Write { at: usize, len: usize, transfer: bool },
}

type Flash = Mutex<CriticalSectionRawMutex, RefCell<Recorder>>;

/// Partition `part` of the chip whose sectors are `SECTOR` bytes.
struct Region<'a, const SECTOR: usize> {
    flash: &'a Flash,
    part: Partition,
}

type Slot<'a> = Region<'a, { 128 * 1024 }>;
type StateSector<'a> = Region<'a, { 64 * 1024 }>;

impl<const SECTOR: usize> ErrorType for Region<'_, SECTOR> {
    type Error = <Chip as ErrorType>::Error;
}

impl<const SECTOR: usize> ReadNorFlash for Region<'_, SECTOR> {
    const READ_SIZE: usize = 1;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.flash.lock(|f| f.borrow_mut().chip.read(self.part.offset + offset, bytes))
    }
    fn capacity(&self) -> usize {
        self.part.size as usize
    }
}

impl<const SECTOR: usize> NorFlash for Region<'_, SECTOR> {
    const WRITE_SIZE: usize = Chip::WRITE_SIZE;
    const ERASE_SIZE: usize = SECTOR;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        self.flash.lock(|f| {
            let mut f = f.borrow_mut();
            // One step per sector, as the F407 erases them.
            for at in (from..to).step_by(SECTOR) {
                let step = Step::Erase { at: f.programmed };
                f.steps.push(step);
                let at = self.part.offset + at;
                f.chip.erase(at, at + SECTOR as u32)?;
            }
            Ok(())
        })
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        self.flash.lock(|f| {
            let mut f = f.borrow_mut();
            let step = Step::Write { at: f.programmed, len: bytes.len(), transfer: f.in_transfer };
            f.steps.push(step);
            f.chip.write(self.part.offset + offset, bytes)?;
            f.programmed += bytes.len();
            Ok(())
        })
    }
}

fn slot(flash: &Flash, part: Partition) -> Slot<'_> {
    Region { flash, part }
}

fn state(flash: &Flash) -> StateSector<'_> {
    Region { flash, part: MAP.state }
}

fn signed(len: usize, patch: u16) -> Vec<u8> {
    let image: Vec<u8> = (0..len)
        .map(|i| (i as u32 ^ patch as u32).wrapping_mul(2_654_435_761).to_le_bytes()[3])
        .collect();
    let meta = Meta { version: Version { major: 1, minor: 0, patch }, kind: "gateway", mcu: MCU };
    sign(&image, &meta, &SEED).unwrap()
}

fn expect(key: &[u8; 32]) -> Expect<'_> {
    Expect { mcu: MCU, kind: None, public_key: key }
}

/// A board as `r2p flash` leaves it: the old image in the active slot, its trailer at the end.
fn factory(old: &[u8]) -> Flash {
    let mut chip = Box::new(Chip::new());
    let (image, trailer) = old.split_at(old.len() - TRAILER_LEN);
    let at = MAP.active.offset as usize;
    chip.bytes_mut()[at..][..image.len()].copy_from_slice(image);
    let t = at + MAP.active.size as usize - TRAILER_LEN;
    chip.bytes_mut()[t..][..TRAILER_LEN].copy_from_slice(trailer);
    Mutex::new(RefCell::new(Recorder {
        chip,
        programmed: 0,
        steps: Vec::new(),
        in_transfer: false,
    }))
}

/// An update as it arrives over the bus: the sender and the gateway's `DfuSink` exchanging
/// transfer messages; a power cut fails every write after it and the transfer ends there.
fn receive(flash: &Flash, new: &[u8]) -> Result<(), String> {
    let sink = DfuSink::new("gateway", MAP.active.size, slot(flash, MAP.dfu), state(flash), check);
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

/// The bootloader's check of a complete DFU slot, as the gateway calls it.
fn check(dfu: &mut Slot<'_>) -> Result<(), r2p_boot::Refusal> {
    let key = public_key(&SEED);
    verify_slot(dfu, 0, MAP.active.size, &expect(&key)).map(|_| ())
}

/// The bootloader: embassy-boot's prepare (a 4 KiB copy buffer, as the F407's), then the image
/// it would run.
fn boot(flash: &Flash) -> Result<(State, Trailer), String> {
    let config = BootLoaderConfig {
        active: slot(flash, MAP.active),
        dfu: slot(flash, MAP.dfu),
        state: state(flash),
    };
    let mut buf = [0u8; 4096];
    let s =
        BootLoader::new(config).prepare_boot(&mut buf).map_err(|e| format!("prepare: {e:?}"))?;
    let key = public_key(&SEED);
    let t = verify_slot(&mut slot(flash, MAP.active), 0, MAP.active.size, &expect(&key))
        .map_err(|r| r.message().to_string())?;
    Ok((s, t))
}

/// The new image's confirmation, as the gateway's trial does it.
fn confirm(flash: &Flash) -> Result<(), String> {
    r2p_boot::boot_state::mark_booted(&mut state(flash), 0, MAP.state.size)
        .map_err(|e| format!("confirm: {e:?}"))
}

/// Receive, reboot into the swap, confirm, reboot.
fn update(flash: &Flash, new: &[u8]) -> Result<(), String> {
    receive(flash, new)?;
    let (s, t) = boot(flash)?;
    assert_eq!((s, t.version.patch), (State::Swap, 2), "the swap ran, the new image is active");
    confirm(flash)?;
    let (s, t) = boot(flash)?;
    assert_eq!((s, t.version.patch), (State::Boot, 2));
    Ok(())
}

fn version_in_active(flash: &Flash) -> u16 {
    boot(flash).expect("a verified image boots").1.version.patch
}

/// Runs `f` on a thread with room for the 1 MiB chip on its stack while it is made.
fn with_room(f: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new().stack_size(64 << 20).spawn(f).unwrap().join().unwrap();
}

#[test]
fn a_gateway_update_swaps_in_and_a_new_image_that_never_confirms_is_rolled_back() {
    with_room(|| {
        let flash = factory(&signed(16_000, 1));
        update(&flash, &signed(20_000, 2)).unwrap();
        let steps = flash.lock(|f| f.borrow().steps.len());
        println!("an update of a 20 000 B image on the F407 map: {steps} erase and write steps");
        let flash = factory(&signed(16_000, 1));
        receive(&flash, &signed(20_000, 2)).unwrap();
        assert_eq!(boot(&flash).unwrap().0, State::Swap, "on trial");
        let (s, t) = boot(&flash).unwrap();
        assert_eq!((s, t.version.patch), (State::Swap, 1), "rolled back");
        assert_eq!(boot(&flash).unwrap().0, State::Revert, "the old image learns of it");
    });
}

#[test]
fn a_power_cut_at_any_step_of_a_gateway_update_leaves_a_verified_image_that_boots() {
    with_room(|| {
        let (old, new) = (signed(16_000, 1), signed(20_000, 2));
        let flash = factory(&old);
        update(&flash, &new).unwrap();
        let steps = flash.lock(|f| f.borrow().steps.clone());
        let mut cuts: Vec<usize> = Vec::new();
        let mut blocks = 0;
        for s in &steps {
            match *s {
                Step::Erase { at } => cuts.push(at),
                // Before the first byte and in the middle: every write of the swap and the
                // state, every 8th of the transfer's blocks (each is cut before it).
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
            let flash = factory(&old);
            flash.lock(|f| f.borrow_mut().chip.cut_power_after(cut));
            assert!(update(&flash, &new).is_err(), "cut at {cut} bytes: the update ran to its end");
            flash.lock(|f| f.borrow_mut().chip.power_on());
            let (_, t) = boot(&flash).unwrap_or_else(|e| panic!("cut at {cut} bytes: {e}"));
            match t.version.patch {
                1 => old_boots += 1,
                2 => new_boots += 1,
                v => panic!("cut at {cut} bytes: version {v} booted"),
            }
            // Whatever booted, an update from there completes: after every 4th cut.
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
            "F407 map: {} steps, {} cut points: the old image booted after {old_boots}, the new \
             one after {new_boots}, neither after 0",
            steps.len(),
            cuts.len()
        );
    });
}
