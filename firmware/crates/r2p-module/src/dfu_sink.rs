//! A module's side of an update over the bus: r2p-boot's transfer receiver writing the DFU
//! slot, the bootloader's check of what arrived, and embassy-boot's mark so that the next reset
//! swaps it in. The node hands it every UPDATE message for this module ([`UpdateSink`]).
//!
//! The same code on the MCU (over the chip's flash, the check the bootloader lends through its
//! API table) and on an emulated board (over a `RamFlash` with the same map).

use core::cell::RefCell;

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embedded_storage::nor_flash::NorFlash;
use r2p_boot::boot_state::{self, BootState};
use r2p_boot::transfer::{Msg, Receiver, State};
use r2p_boot::{Refusal, Trailer, TRAILER_LEN};
use r2p_node::UpdateSink;

/// The check of a complete DFU slot: the bootloader's (signature, MCU, size). The bootloader
/// does not know which module it serves; the sink checks the kind itself.
pub type VerifySlot<F> = fn(&mut F) -> Result<(), Refusal>;

/// See the module documentation. `F` is the DFU partition, `S` embassy-boot's state partition.
pub struct DfuSink<F, S> {
    inner: Mutex<CriticalSectionRawMutex, RefCell<Inner<F, S>>>,
}

struct Inner<F, S> {
    receiver: Receiver,
    slot_size: u32,
    kind: &'static str,
    dfu: F,
    state: S,
    verify: VerifySlot<F>,
    /// A verified image is marked for the swap at the next reset.
    marked: bool,
    /// Messages that were not transfer messages from a sender: counted and dropped.
    malformed: u32,
}

impl<F: NorFlash, S: NorFlash> DfuSink<F, S> {
    /// A sink writing images for module kind `kind` (modules.toml's name) of up to
    /// `slot_size` bytes (the active slot's size: the trailer goes in its last 128 bytes) into
    /// `dfu`, checked by `verify`, marked in `state`.
    pub const fn new(
        kind: &'static str,
        slot_size: u32,
        dfu: F,
        state: S,
        verify: VerifySlot<F>,
    ) -> Self {
        Self {
            inner: Mutex::new(RefCell::new(Inner {
                receiver: Receiver::new(slot_size),
                slot_size,
                kind,
                dfu,
                state,
                verify,
                marked: false,
                malformed: 0,
            })),
        }
    }

    /// Whether a received, verified image waits for the next reset to be swapped in.
    pub fn is_marked(&self) -> bool {
        self.inner.lock(|i| i.borrow().marked)
    }

    /// Runs `f` on the bootloader's state partition (tools and tests read it).
    pub fn with_state<R>(&self, f: impl FnOnce(&mut S) -> R) -> R {
        self.inner.lock(|i| f(&mut i.borrow_mut().state))
    }

    /// Messages dropped because they were not a sender's transfer message.
    pub fn malformed(&self) -> u32 {
        self.inner.lock(|i| i.borrow().malformed)
    }
}

impl<F: NorFlash, S: NorFlash> Inner<F, S> {
    fn boot_state(&mut self) -> Option<BootState> {
        boot_state::read(&mut self.state, 0).ok()
    }

    /// Writes embassy-boot's magic (r2p-boot's `boot_state`, without embassy-boot's code in
    /// the image): `swap` marks the DFU slot for the next reset, otherwise the mark is taken
    /// back (a new transfer is about to overwrite the slot).
    fn mark(&mut self, swap: bool) -> bool {
        let size = self.state.capacity() as u32;
        let done = if swap {
            boot_state::mark_updated(&mut self.state, 0, size)
        } else {
            boot_state::mark_booted(&mut self.state, 0, size)
        };
        done.is_ok()
    }

    fn handle(&mut self, msg: &Msg<'_>) -> r2p_boot::transfer::Status {
        if let Msg::Begin { id, .. } = *msg {
            if self.marked {
                // The slot is about to change: a reset now must not swap half an image in.
                if !self.mark(false) {
                    return self.receiver.refuse(id, Refusal::FlashWrite);
                }
                self.marked = false;
            } else if self.boot_state() == Some(BootState::Swapped) {
                // Just swapped in and not yet confirmed: embassy-boot would take a new mark
                // for this image's rollback.
                return self.receiver.refuse(id, Refusal::OnTrial);
            }
        }
        let (verify, slot_size, kind) = (self.verify, self.slot_size, self.kind);
        let status = self.receiver.handle(msg, &mut self.dfu, |dfu| {
            verify(dfu)?;
            let mut raw = [0u8; TRAILER_LEN];
            let at = slot_size - TRAILER_LEN as u32;
            dfu.read(at, &mut raw).map_err(|_| Refusal::FlashRead)?;
            match Trailer::parse(&raw)? {
                t if t.kind.as_str() == kind => Ok(()),
                _ => Err(Refusal::WrongKind),
            }
        });
        if status.state == State::Verified && !self.marked {
            if !self.mark(true) {
                return self.receiver.refuse(status.id, Refusal::FlashWrite);
            }
            self.marked = true;
        }
        status
    }
}

impl<F: NorFlash + Send, S: NorFlash + Send> UpdateSink for DfuSink<F, S> {
    fn handle(&self, _from: u8, msg: &[u8], answer: &mut [u8; 64]) -> usize {
        let msg = match Msg::decode(msg) {
            Ok(Msg::Status(_)) | Err(_) => {
                self.inner.lock(|i| i.borrow_mut().malformed += 1);
                return 0;
            }
            Ok(m) => m,
        };
        let status = self.inner.lock(|i| i.borrow_mut().handle(&msg));
        Msg::Status(status).encode(answer)
    }
}
