//! The gateway's side of an update over the bus (docs/flashing.md, "Updates over the bus"), as a
//! module's (../../f103/module-core/src/update.rs) over the F407's sectors: r2p-module's
//! `DfuSink` writing the DFU slot (sectors 8–11, 128 KiB each: embassy-stm32's bank 1 region 3),
//! the bootloader's state in sector 4 (region 2), the image checked by the bootloader's own code
//! through its API table, and what the running image says of itself in FIRMWARE.
//!
//! The state sector is shared: the application's task confirms a trial in it, the bus task marks
//! an update in it; each use holds a critical section. The sink erases each 128 KiB sector as
//! the transfer first reaches it (RM0090: the F407's one bank stalls every fetch from flash
//! meanwhile, 1–2 s at x32): the whole gateway, bus and network, stops that long, twice for an
//! image under 128 KiB (its first sector and the trailer's), and the sender resends what was
//! lost meanwhile.

use core::cell::RefCell;

use embassy_embedded_hal::flash::partition::BlockingPartition;
use embassy_stm32::flash::{Bank1Region2, Bank1Region3, Blocking, BANK1_REGION2, BANK1_REGION3};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use r2p_boot::api::{BootApi, API_MAGIC, API_VERSION};
use r2p_boot::layout::STM32F407VG as MAP;
use r2p_boot::{Refusal, Trailer, TRAILER_LEN};
use r2p_module::DfuSink;
use r2p_node::FirmwareId;
use static_cell::StaticCell;

/// The 64 KiB sector of embassy-boot's state, shared by the trial and the update sink.
pub type SharedState = Mutex<CriticalSectionRawMutex, RefCell<Bank1Region2<'static, Blocking>>>;
/// The state partition (the whole sector).
pub type StatePart =
    BlockingPartition<'static, CriticalSectionRawMutex, Bank1Region2<'static, Blocking>>;
/// The 128 KiB sectors of the image slots.
pub type SharedSlots = Mutex<CriticalSectionRawMutex, RefCell<Bank1Region3<'static, Blocking>>>;
/// The DFU slot.
pub type DfuPart =
    BlockingPartition<'static, CriticalSectionRawMutex, Bank1Region3<'static, Blocking>>;
/// The gateway's update sink.
pub type GatewaySink = DfuSink<DfuPart, StatePart>;

const FLASH_BASE: u32 = 0x0800_0000;
/// The MCU the bootloader checks images for (probe-rs's name, as in images.toml).
const MCU: &str = "STM32F407VG";
/// The module kind the gateway's images are signed for (modules.toml).
pub const KIND: &str = r2p_app_gateway::NAME;

static STATE: StaticCell<SharedState> = StaticCell::new();
static SLOTS: StaticCell<SharedSlots> = StaticCell::new();
static SINK: StaticCell<GatewaySink> = StaticCell::new();

/// The state sector, shared from now on.
pub fn share_state(region: Bank1Region2<'static, Blocking>) -> &'static SharedState {
    STATE.init(Mutex::new(RefCell::new(region)))
}

/// The state partition of the shared sector (partition offsets count from the region's start).
pub fn state_partition(state: &'static SharedState) -> StatePart {
    let at = MAP.state.offset - (BANK1_REGION2.base() - FLASH_BASE);
    BlockingPartition::new(state, at, MAP.state.size)
}

/// The gateway's update sink over the slot sectors and the shared state (made once, at boot).
pub fn sink(
    slots: Bank1Region3<'static, Blocking>,
    state: &'static SharedState,
) -> &'static GatewaySink {
    let slots: &'static SharedSlots = SLOTS.init(Mutex::new(RefCell::new(slots)));
    let at = MAP.dfu.offset - (BANK1_REGION3.base() - FLASH_BASE);
    let dfu = BlockingPartition::new(slots, at, MAP.dfu.size);
    SINK.init(DfuSink::new(KIND, MAP.active.size, dfu, state_partition(state), check))
}

/// The bootloader's check of the DFU slot (signature, MCU, size), through the API table at the
/// end of its partition: the ed25519 code is in flash once, in the bootloader.
fn check(_dfu: &mut DfuPart) -> Result<(), Refusal> {
    // SAFETY: the bootloader partition is mapped flash, never written by the image; its last
    // bytes hold the table (checked by its magic and version before its function is called).
    let api = unsafe { &*((FLASH_BASE + MAP.api_offset()) as *const BootApi) };
    if api.magic != API_MAGIC || api.version != API_VERSION {
        return Err(Refusal::UnknownFormat);
    }
    let slot = (FLASH_BASE + MAP.dfu.offset) as *const u8;
    // SAFETY: the DFU slot is `MAP.active.size` bytes of mapped flash (the DFU partition is one
    // sector larger); the strings are the lengths given; no kind (the sink checks it).
    let code = unsafe {
        (api.verify)(slot, MAP.active.size, MCU.as_ptr(), MCU.len() as u32, MCU.as_ptr(), 0)
    };
    match code {
        0 => Ok(()),
        c => Err(Refusal::from_code(c as u8).unwrap_or(Refusal::BadSignature)),
    }
}

/// What the running image is, from its trailer in the active slot (an image flashed without
/// one: version 0).
pub fn running_image(on_trial: bool) -> FirmwareId {
    let at = FLASH_BASE + MAP.active.end() - TRAILER_LEN as u32;
    // SAFETY: the active slot is mapped flash; the image is running from it.
    let raw = unsafe { &*(at as *const [u8; TRAILER_LEN]) };
    match Trailer::parse(raw) {
        Ok(t) => FirmwareId {
            version: t.version.to_bits(),
            digest: t.digest,
            kind: t.kind.as_str().try_into().unwrap_or_default(),
            on_trial,
        },
        Err(_) => FirmwareId { kind: KIND.try_into().unwrap_or_default(), ..FirmwareId::default() },
    }
}
