//! A board's transmit-mailbox-empty interrupt as its firmware arms it (rtcan-bxcan's
//! `TransmitWake`, on frame-sized reservations): it masks itself (`TMEIE`) when it fires, and
//! the bus task unmasks it after the call it woke ends (`BxCan::arm_transmit_wake`). A mailbox
//! that empties in between leaves its `RQCP` set unless that call took its result: the
//! interrupt, level-triggered, fires again at the unmasking. So a frame of the node's that ends
//! while the bus task is still in its call is neither reacted to nor followed by the staged
//! frames until the call is over.

/// The interrupt's mask and its pending request.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct TransmitIrq {
    /// `TMEIE` cleared by the interrupt: `Some(None)` until the call it woke runs, then the
    /// end of that call (ns).
    masked: Option<Option<u64>>,
    /// A mailbox emptied while masked and no call took its result since (`RQCP` set).
    requested: bool,
    /// Interrupts that waited for the unmasking.
    pub(crate) deferred: u64,
}

impl TransmitIrq {
    /// At `t_ns`, with `emptied` if one of the node's frames left a mailbox since the last
    /// look: whether the interrupt runs now (and masks itself).
    pub(crate) fn fires(&mut self, t_ns: u64, emptied: bool) -> bool {
        if let Some(until) = self.masked {
            if until.is_none_or(|u| t_ns < u) {
                self.requested |= emptied;
                return false;
            }
            self.masked = None;
            if std::mem::take(&mut self.requested) {
                self.deferred += 1;
                self.masked = Some(None);
                return true;
            }
        }
        if emptied {
            self.masked = Some(None);
        }
        emptied
    }

    /// The bus task ran a call at `t_ns` taking `call_ns`: it took the controller's results
    /// (clearing `RQCP`), and unmasks the interrupt when it ends.
    pub(crate) fn on_call(&mut self, t_ns: u64, call_ns: u64) {
        self.requested = false;
        if let Some(until) = &mut self.masked {
            *until = Some(until.map_or(t_ns + call_ns, |u| u.max(t_ns + call_ns)));
        }
    }

    /// When the interrupt waits to fire at its unmasking.
    pub(crate) fn due_ns(&self) -> Option<u64> {
        self.masked.flatten().filter(|_| self.requested)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn it_fires_at_once_when_armed_and_then_waits_for_the_call_it_woke() {
        let mut irq = TransmitIrq::default();
        assert!(!irq.fires(0, false));
        assert!(irq.fires(100_000, true));
        // Its call runs at 100 µs for 58 µs: a frame of the node's ending at 150 µs waits.
        irq.on_call(100_000, 58_000);
        assert!(!irq.fires(150_000, true));
        assert_eq!(irq.due_ns(), Some(158_000));
        assert!(!irq.fires(157_999, false));
        assert!(irq.fires(158_000, false), "RQCP still set at the unmasking");
        assert_eq!(irq.deferred, 1);
        assert_eq!(irq.due_ns(), None);
        // Masked again until its next call.
        assert!(!irq.fires(300_000, true));
        assert_eq!(irq.due_ns(), None, "no call ran yet: it stays masked");
        irq.on_call(400_000, 20_000);
        assert_eq!(irq.due_ns(), None, "that call took the result");
        assert!(!irq.fires(420_000, false));
        assert!(irq.fires(430_000, true), "armed again");
    }

    #[test]
    fn a_call_that_takes_the_result_cancels_the_request() {
        let mut irq = TransmitIrq::default();
        assert!(irq.fires(0, true));
        irq.on_call(0, 58_000);
        assert!(!irq.fires(30_000, true));
        // The slot timer's call at 40 µs takes the result; the mask lasts until its end.
        irq.on_call(40_000, 25_000);
        assert_eq!(irq.due_ns(), None);
        assert!(!irq.fires(60_000, false));
        assert!(!irq.fires(65_000, false));
        assert!(irq.fires(70_000, true));
        assert_eq!(irq.deferred, 0);
    }
}
