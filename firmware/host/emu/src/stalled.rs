//! A board's controller as its firmware drives it while its CPU stalls.
//!
//! On an F103 the CPU stops while its flash erases a page (20–40 ms) or programs a half-word
//! (52.5 µs): the firmware's work after the flash operation happens that much later, and so do
//! the frames it loads then. An update sink answers a block *after* writing it: the answer must
//! leave after the stall, not at the instant the node's step began, or a sender would send
//! its next block into a receiver that cannot take it — and the emulator would hide that the
//! sender must wait for the answer.

use rtcan::controller::{
    BusState, CanController, ErrorCounters, Filter, Received, StagedFrame, TxError, TxMode,
    TxResult,
};
use rtcan::Frame;

use crate::{SimPort, StallSource};

/// The port for one step of a board: frames loaded after a stall reach the mailbox after it.
pub(crate) struct StalledPort<'p, 'a> {
    port: &'p mut SimPort,
    stall: Option<&'p mut StallSource<'a>>,
    stalled_ns: u64,
}

impl<'p, 'a> StalledPort<'p, 'a> {
    pub(crate) fn new(port: &'p mut SimPort, stall: Option<&'p mut StallSource<'a>>) -> Self {
        Self { port, stall, stalled_ns: 0 }
    }

    fn drain(&mut self) {
        if let Some(stall) = &mut self.stall {
            self.stalled_ns += stall();
        }
    }

    /// The CPU time the step lost to stalls in all.
    pub(crate) fn stalled_ns(mut self) -> u64 {
        self.drain();
        self.stalled_ns
    }
}

impl CanController for StalledPort<'_, '_> {
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        self.drain();
        self.port.transmit_after_stall(frame, self.stalled_ns)
    }
    fn set_tx_mode(&mut self, mode: TxMode) {
        self.port.set_tx_mode(mode);
    }
    fn take_tx_result(&mut self) -> Option<TxResult> {
        self.port.take_tx_result()
    }
    fn try_receive(&mut self) -> Option<Received> {
        self.port.try_receive()
    }
    fn set_filters(&mut self, filters: &[Filter]) {
        self.port.set_filters(filters);
    }
    fn abort_pending(&mut self) -> usize {
        self.port.abort_pending()
    }
    fn bus_state(&self) -> BusState {
        self.port.bus_state()
    }
    fn error_counters(&self) -> ErrorCounters {
        self.port.error_counters()
    }
    fn stage(&mut self, frames: &[StagedFrame]) {
        self.port.stage(frames);
    }
    fn staged_loaded(&mut self) -> usize {
        self.port.staged_loaded()
    }
}

#[cfg(test)]
mod tests {
    use r2p_vbus::{Bus, Config};

    use super::*;

    #[test]
    fn a_frame_loaded_after_a_stall_leaves_after_it() {
        let bus = Bus::new(2, Config::default());
        let mut port = SimPort::new(bus.port(0), Config::default().bit_rate);
        let mut stalls = [30_000_000u64, 0].into_iter();
        let mut stall: StallSource<'_> = Box::new(move || stalls.next().unwrap_or(0));
        let mut stalled = StalledPort::new(&mut port, Some(&mut stall));
        let frame = Frame::from_raw(0x1F00_0001, &[1]).unwrap();
        stalled.try_transmit(&frame).unwrap();
        assert_eq!(stalled.stalled_ns(), 30_000_000, "the step's stall, for the board's hold");
        bus.run_until_idle(100_000_000);
        let (start, _, _) = bus.frames().next().expect("the frame went out");
        assert!(start >= 30_000_000, "left at {start} ns, inside the 30 ms stall");
    }

    #[test]
    fn without_a_stall_a_frame_leaves_at_once() {
        let bus = Bus::new(2, Config::default());
        let mut port = SimPort::new(bus.port(0), Config::default().bit_rate);
        let mut stalled = StalledPort::new(&mut port, None);
        stalled.try_transmit(&Frame::from_raw(0x1F00_0001, &[1]).unwrap()).unwrap();
        assert_eq!(stalled.stalled_ns(), 0);
        bus.run_until_idle(100_000_000);
        assert!(bus.frames().next().expect("the frame went out").0 < 1_000_000);
    }
}
