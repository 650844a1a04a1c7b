//! What an emulated board's flash holds besides its parameters, and what runs around its
//! application: a signed image in the active slot (as `r2p flash` leaves a board), the
//! bootloader at every reset (embassy-boot's swap or rollback, then the signature check), the
//! update sink that receives a new image over the bus (r2p-module's `DfuSink`, the module
//! image's code) and the new image's trial (r2p-boot's `trial`).
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
use r2p_node::FirmwareId;
use rtcan::cycle::ClockState;
use rtcan::failover::Role;
use rtcan::Micros;

use super::chip::{map, part, BoardChip, Part, PAGE};
use super::BoardNode;
use crate::App;

/// The MCU every emulated board's flash follows.
pub const MCU: &str = "STM32F103CB";

/// The development key's seed (firmware/keys/development.key: public on purpose). The emulated
/// bootloader trusts its public half, as the committed bootloader images do.
pub fn development_seed() -> [u8; 32] {
    parse_key_file(include_str!("../../../../keys/development.key"))
        .expect("firmware/keys/development.key holds a key")
}

/// The version of the image every emulated board is flashed with.
pub const FACTORY_VERSION: Version = Version { major: 0, minor: 1, patch: 0 };

/// A signed image for module `kind` standing for its firmware: deterministic bytes of the size of
/// a module image, signed with the development key.
pub fn factory_image(kind: &str) -> Vec<u8> {
    let image: Vec<u8> = (0..40_000u32)
        .map(|i| (i ^ kind.len() as u32).wrapping_mul(2_654_435_761).to_le_bytes()[3])
        .collect();
    let meta = Meta { version: FACTORY_VERSION, kind, mcu: MCU };
    sign(&image, &meta, &development_seed()).expect("a module kind is a valid name")
}

/// Writes `signed` into the active slot as a probe would: the image from the slot's start, its
/// trailer in the slot's last bytes.
pub fn flash_active(chip: &BoardChip, signed: &[u8]) {
    let active = map().active;
    let (image, trailer) = signed.split_at(signed.len() - TRAILER_LEN);
    chip.lock(|c| {
        let bytes = c.borrow_mut();
        let mut bytes = bytes;
        let raw = bytes.chip.bytes_mut();
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
    let m = map();
    let config = BootLoaderConfig {
        active: part(chip, m.active),
        dfu: part(chip, m.dfu),
        state: part(chip, m.state),
    };
    let mut buf = [0u8; PAGE];
    let state = BootLoader::new(config).prepare_boot(&mut buf).map_err(|_| Refusal::FlashRead)?;
    let stall_ns = chip.lock(|c| c.borrow_mut().take_stall_ns());
    let key = public_key(&development_seed());
    let expect = Expect { mcu: MCU, kind: None, public_key: &key };
    let t = verify_slot(&mut part(chip, m.active), 0, m.active.size, &expect)?;
    let version = u32::from(t.version.major) << 24
        | u32::from(t.version.minor) << 16
        | u32::from(t.version.patch);
    let kind = t.kind.as_str().try_into().unwrap_or_default();
    let on_trial = state == State::Swap;
    let firmware = FirmwareId { version, digest: t.digest, kind, on_trial };
    Ok(Booted { state, firmware, stall_ns })
}

/// The bootloader's check a module asks for through its API table, here over the DFU slot.
fn check_dfu(dfu: &mut Part) -> Result<(), Refusal> {
    let key = public_key(&development_seed());
    let expect = Expect { mcu: MCU, kind: None, public_key: &key };
    verify_slot(dfu, 0, map().active.size, &expect).map(|_| ())
}

/// The update sink of one boot (its receiver's RAM state goes with the boot).
pub fn update_sink(chip: &'static BoardChip, kind: &'static str) -> &'static DfuSink<Part, Part> {
    let m = map();
    Box::leak(Box::new(DfuSink::new(
        kind,
        m.active.size,
        part(chip, m.dfu),
        part(chip, m.state),
        check_dfu,
    )))
}

/// Wraps a board's application step with what the module core does around it on the MCU: a
/// REBOOT request resets the board, and an image on trial confirms itself once its node runs
/// and hears the master's sync (or it is the master), or resets unconfirmed when its time is up
/// (the bootloader then rolls it back).
pub fn around_app(
    mut app: App<'static, BoardNode>,
    chip: &'static BoardChip,
    booted: &Booted,
    boot_us: Micros,
    heartbeat_us: Micros,
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
                || matches!(node.clock().state(now), ClockState::Running(_)));
        match trial.poll(now / 1_000, healthy) {
            Verdict::Confirm => {
                let mut aligned = [0u8; 4];
                let state = part(chip, map().state);
                if BlockingFirmwareState::new(state, &mut aligned).mark_booted().is_ok() {
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
    let active = map().active;
    chip.lock(|c| {
        let at = (active.offset + active.size) as usize - TRAILER_LEN;
        let flash = c.borrow();
        let raw: &[u8; TRAILER_LEN] = flash.chip.bytes()[at..at + TRAILER_LEN].try_into().ok()?;
        r2p_boot::Trailer::parse(raw).ok()
    })
}

/// embassy-boot's state as the flash holds it now (`Swap`: an update is marked, or the running
/// image is on trial; `Boot`: confirmed, nothing pending).
pub fn boot_state(chip: &'static BoardChip) -> Option<State> {
    let mut aligned = [0u8; 4];
    BlockingFirmwareState::new(part(chip, map().state), &mut aligned).get_state().ok()
}
