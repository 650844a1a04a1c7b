//! What an emulated board's flash holds besides its parameters, and what runs around its
//! application: a signed image in the active slot (as `r2p flash` leaves a board), the
//! bootloader at every reset (embassy-boot's swap or rollback, then the signature check), the
//! update sink that receives a new image over the bus (r2p-module's `DfuSink`, the module
//! image's and the gateway image's code) and the new image's trial (r2p-boot's `trial`). Each
//! over its MCU's map: the modules' F103 or the gateway's F407 ([`super::chip`]).
//!
//! The application the emulator runs is the host build of the module's crate whatever the slot
//! holds: the image bytes here stand for it. What the slot decides is what the board says it
//! runs (FIRMWARE: version, digest, kind), whether it boots, and how long the swap keeps it off
//! the bus.

use std::cell::Cell;
use std::rc::Rc;

use embassy_boot::{BlockingFirmwareState, BootLoader, BootLoaderConfig, State};
use r2p_boot::sign::{parse_key_file, public_key, sign, Meta};
use r2p_boot::trial::{Trial, Verdict};
use r2p_boot::{verify_slot, Expect, Refusal, Version, TRAILER_LEN};
use r2p_module::DfuSink;
use r2p_node::{FirmwareId, UpdateSink};
use rtcan::cycle::ClockState;
use rtcan::failover::Role;
use rtcan::Micros;

use super::chip::{map_of, BoardChip, ChipLayout, Mcu};
use super::BoardNode;
use crate::{on_layout, App};

/// The modules' MCU (the gateway's is [`Mcu::F407`]'s).
pub const MCU: &str = "STM32F103CB";

/// The development key's seed (firmware/keys/development.key: public on purpose). The emulated
/// bootloader trusts its public half, as the committed bootloader images do.
pub fn development_seed() -> [u8; 32] {
    parse_key_file(include_str!("../../../../keys/development.key"))
        .expect("firmware/keys/development.key holds a key")
}

/// The version of the image every emulated board is flashed with.
pub const FACTORY_VERSION: Version = Version { major: 0, minor: 1, patch: 0 };

/// A signed image for module `kind` on `mcu` standing for its firmware: deterministic bytes of
/// about the size of its image (a module's 40 000 B, the gateway's 120 000 B), signed with the
/// development key.
pub fn factory_image(kind: &str, mcu: Mcu) -> Vec<u8> {
    let len = match mcu {
        Mcu::F103 => 40_000u32,
        Mcu::F407 => 120_000,
    };
    let image: Vec<u8> = (0..len)
        .map(|i| (i ^ kind.len() as u32).wrapping_mul(2_654_435_761).to_le_bytes()[3])
        .collect();
    let meta = Meta { version: FACTORY_VERSION, kind, mcu: mcu.spec().name };
    sign(&image, &meta, &development_seed()).expect("a module kind is a valid name")
}

/// Writes `signed` into the active slot as a probe would: the image from the slot's start, its
/// trailer in the slot's last bytes.
pub fn flash_active(chip: &BoardChip, signed: &[u8]) {
    let active = map_of(chip).active;
    let (image, trailer) = signed.split_at(signed.len() - TRAILER_LEN);
    chip.lock(|c| {
        let mut flash = c.borrow_mut();
        let raw = flash.bytes_mut();
        let at = active.offset as usize;
        raw[at..at + image.len()].copy_from_slice(image);
        let t = at + active.size as usize - TRAILER_LEN;
        raw[t..t + TRAILER_LEN].copy_from_slice(trailer);
    });
}

/// What the bootloader left at a reset.
pub struct Booted {
    /// embassy-boot's state as the bootloader found it: `Swap` after a swap (the image is on
    /// trial) and after a rollback, `Revert` on the boot after a rollback.
    pub state: State,
    /// The image in the active slot.
    pub firmware: FirmwareId,
    /// CPU time the bootloader spent in flash operations (the swap): the board is off the bus.
    pub stall_ns: u64,
}

/// The bootloader at a reset: embassy-boot's prepare (swap, rollback or nothing), then the
/// check of the active image. `Err`: no image it can run (the board stays silent).
pub fn bootloader(chip: &'static BoardChip) -> Result<Booted, Refusal> {
    on_layout!(chip, bootloader_on(chip))
}

fn bootloader_on<L: ChipLayout>(chip: &'static BoardChip) -> Result<Booted, Refusal> {
    let m = L::MCU.spec().map;
    let config = BootLoaderConfig {
        active: L::slot(chip, m.active),
        dfu: L::slot(chip, m.dfu),
        state: L::state(chip),
    };
    let mut buf = vec![0u8; L::COPY_BUFFER];
    let state = BootLoader::new(config).prepare_boot(&mut buf).map_err(|_| Refusal::FlashRead)?;
    let stall_ns = chip.lock(|c| c.borrow_mut().take_stall_ns());
    let key = public_key(&development_seed());
    let expect = Expect { mcu: L::MCU.spec().name, kind: None, public_key: &key };
    let t = verify_slot(&mut L::slot(chip, m.active), 0, m.active.size, &expect)?;
    let version = t.version.to_bits();
    let kind = t.kind.as_str().try_into().unwrap_or_default();
    let on_trial = state == State::Swap;
    let firmware = FirmwareId { version, digest: t.digest, kind, on_trial };
    Ok(Booted { state, firmware, stall_ns })
}

/// The bootloader's check a module asks for through its API table, here over the DFU slot.
fn check_dfu<L: ChipLayout>(dfu: &mut L::Slot) -> Result<(), Refusal> {
    let key = public_key(&development_seed());
    let spec = L::MCU.spec();
    let expect = Expect { mcu: spec.name, kind: None, public_key: &key };
    verify_slot(dfu, 0, spec.map.active.size, &expect).map(|_| ())
}

/// The update sink of one boot (its receiver's RAM state goes with the boot).
pub fn update_sink(chip: &'static BoardChip, kind: &'static str) -> &'static dyn UpdateSink {
    on_layout!(chip, update_sink_on(chip, kind))
}

fn update_sink_on<L: ChipLayout>(
    chip: &'static BoardChip,
    kind: &'static str,
) -> &'static dyn UpdateSink {
    let m = L::MCU.spec().map;
    let sink: DfuSink<L::Slot, L::State> =
        DfuSink::new(kind, m.active.size, L::slot(chip, m.dfu), L::state(chip), check_dfu::<L>);
    Box::leak(Box::new(sink))
}

/// embassy-boot's `mark_booted` in the board's state partition (a confirmation; after a
/// rollback, the old image saying it knows).
pub fn mark_booted(chip: &'static BoardChip) -> bool {
    on_layout!(chip, mark_booted_on(chip))
}

fn mark_booted_on<L: ChipLayout>(chip: &'static BoardChip) -> bool {
    let mut aligned = [0u8; 4];
    BlockingFirmwareState::new(L::state(chip), &mut aligned).mark_booted().is_ok()
}

/// Wraps a board's application step with what the module core does around it on the MCU: a
/// REBOOT request resets the board, and an image on trial confirms itself once its node runs
/// and hears the master's sync (or it is the master; with `master_needs_peer`, as the gateway's
/// image, and it has heard another node: a standby master alone on its side of the bus keeps
/// its own syncs), or resets unconfirmed when its time is up (the bootloader then rolls it back).
pub fn around_app(
    mut app: App<'static, BoardNode>,
    chip: &'static BoardChip,
    booted: &Booted,
    boot_us: Micros,
    heartbeat_us: Micros,
    master_needs_peer: bool,
    reset: Rc<Cell<bool>>,
) -> App<'static, BoardNode> {
    let mut trial = Trial::new(boot_us / 1_000, booted.firmware.on_trial);
    let confirmed = FirmwareId { on_trial: false, ..booted.firmware.clone() };
    let running_after = boot_us + 2 * heartbeat_us;
    Box::new(move |now, node: &mut BoardNode| {
        app(now, node);
        if node.take_reboot_request() {
            reset.set(true);
        }
        let healthy = now >= running_after
            && (node.role() == Role::Master
                || matches!(node.clock().state(now), ClockState::Running(_)))
            && (!master_needs_peer || node.peer_count() > 0);
        match trial.poll(now / 1_000, healthy) {
            Verdict::Confirm => {
                if mark_booted(chip) {
                    node.set_firmware(confirmed.clone());
                }
            }
            Verdict::GiveUp => reset.set(true),
            Verdict::Wait | Verdict::Kept => {}
        }
    })
}

/// The trailer of the image in the active slot (what the board runs), read without side
/// effects; `None` if there is no valid one.
pub fn active_trailer(chip: &BoardChip) -> Option<r2p_boot::Trailer> {
    let active = map_of(chip).active;
    chip.lock(|c| {
        let at = (active.offset + active.size) as usize - TRAILER_LEN;
        let flash = c.borrow();
        let raw: &[u8; TRAILER_LEN] = flash.bytes()[at..at + TRAILER_LEN].try_into().ok()?;
        r2p_boot::Trailer::parse(raw).ok()
    })
}

/// embassy-boot's state as the flash holds it now (`Swap`: an update is marked, or the running
/// image is on trial; `Boot`: confirmed, nothing pending).
pub fn boot_state(chip: &'static BoardChip) -> Option<State> {
    on_layout!(chip, boot_state_on(chip))
}

fn boot_state_on<L: ChipLayout>(chip: &'static BoardChip) -> Option<State> {
    let mut aligned = [0u8; 4];
    BlockingFirmwareState::new(L::state(chip), &mut aligned).get_state().ok()
}
