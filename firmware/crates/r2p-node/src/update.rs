//! Firmware updates over the bus (UPDATE messages): the node only carries them. The module's
//! [`UpdateSink`] (r2p-module's `DfuSink`: r2p-boot's transfer receiver over the DFU slot)
//! writes the image and answers; the node sends the answer back to the sender.

/// Where a module receives a firmware update. The node hands it every UPDATE message addressed
/// to this module and sends back the answer it writes. A tool sending an update registers one
/// too: the module's statuses are UPDATE messages addressed to the tool (it answers nothing).
///
/// `handle` may program flash: on the STM32F1/F4 (one flash bank) the CPU stalls while a page
/// is erased (20–40 ms on the F103), whichever task asks, so the module's own traffic pauses
/// meanwhile; the other modules' slots are untouched. `Sync` and `&self`, as [`crate::ParamStore`]:
/// the node calls it from the bus's executor.
pub trait UpdateSink: Sync {
    /// Handles transfer message `msg` from node `from`; writes the answer into `answer` and
    /// returns its length (0: no answer).
    fn handle(&self, from: u8, msg: &[u8], answer: &mut [u8; 64]) -> usize;
}

/// What the running image is, as its signed trailer says (r2p-boot): sent in FIRMWARE
/// messages. Version 0 and a zero digest: an image flashed without a trailer.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FirmwareId {
    /// major << 24 | minor << 16 | patch.
    pub version: u32,
    /// The first 8 bytes of SHA-512 of the image.
    pub digest: [u8; 8],
    /// The module kind it is for (modules.toml's name).
    pub kind: heapless::String<{ r2p_management::message::NAME_MAX }>,
    /// Just swapped in, not yet confirmed (set it again once confirmed).
    pub on_trial: bool,
}
