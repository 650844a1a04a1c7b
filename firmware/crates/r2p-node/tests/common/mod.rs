//! A model of bxCAN's transmit mailboxes for `SlotTx`'s tests: frames start, lose and end when
//! the test says; a frame in an arbitration cannot be withdrawn; one that loses it waits for the
//! next (retransmission mode) and can be withdrawn then.

use std::collections::VecDeque;

use rtcan::controller::{BusState, ErrorCounters, Filter, Received, TxError, TxMode};
use rtcan::{CanController, Frame, TxOutcome, TxResult};

/// Three mailboxes, sent in load order.
#[derive(Default)]
pub struct Mailboxes {
    pub loaded: usize,
    waiting: VecDeque<Frame>,
    on_wire: Option<Frame>,
    results: VecDeque<TxResult>,
}

impl Mailboxes {
    /// The oldest waiting frame starts (arbitration, then transmission).
    pub fn start(&mut self) {
        self.on_wire = self.waiting.pop_front();
    }
    /// The frame on the wire ends: sent, or lost its arbitration and waits again.
    pub fn end(&mut self, outcome: TxOutcome) {
        let f = self.on_wire.take().expect("a frame on the wire");
        match outcome {
            TxOutcome::LostArbitration => self.waiting.push_front(f),
            _ => self.results.push_back(TxResult::new(f.id(), outcome)),
        }
    }
}

impl CanController for Mailboxes {
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        if self.waiting.len() + usize::from(self.on_wire.is_some()) == 3 {
            return Err(TxError::MailboxesFull);
        }
        self.waiting.push_back(*frame);
        self.loaded += 1;
        Ok(())
    }
    fn set_tx_mode(&mut self, _: TxMode) {}
    fn take_tx_result(&mut self) -> Option<TxResult> {
        self.results.pop_front()
    }
    fn try_receive(&mut self) -> Option<Received> {
        None
    }
    fn set_filters(&mut self, _: &[Filter]) {}
    fn abort_pending(&mut self) -> usize {
        let n = self.waiting.len();
        for f in self.waiting.drain(..) {
            self.results.push_back(TxResult::new(f.id(), TxOutcome::Aborted));
        }
        n
    }
    fn bus_state(&self) -> BusState {
        BusState::ErrorActive
    }
    fn error_counters(&self) -> ErrorCounters {
        ErrorCounters { tx: 0, rx: 0 }
    }
}
