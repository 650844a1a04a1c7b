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
use r2p_boot::layout::STM32F407VG as MAP;
use r2p_boot::Refusal;
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

#[path = "../../../shared/boot_api.rs"]
mod boot_api;
use boot_api::FLASH_BASE;

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

/// The bootloader's check of the DFU slot (../../shared/boot_api.rs).
fn check(_dfu: &mut DfuPart) -> Result<(), Refusal> {
    let api = boot_api::api(&MAP).ok_or(Refusal::UnknownFormat)?;
    boot_api::check_dfu(api, &MAP, MCU)
}

/// What the running image is (../../shared/boot_api.rs; an image flashed without a trailer:
/// version 0).
pub fn running_image(on_trial: bool) -> FirmwareId {
    boot_api::running_image(&MAP, KIND, on_trial)
}
