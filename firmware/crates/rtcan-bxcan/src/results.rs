//! Finished frames' results waiting to be taken ([`rtcan::CanController::take_tx_result`]).

use rtcan::controller::{TxResult, TX_RESULTS};

/// Results not taken yet, oldest first; the oldest is dropped when a new one finds it full
/// (the controller contract keeps the last [`TX_RESULTS`]).
pub struct Results {
    buf: [Option<TxResult>; TX_RESULTS],
    head: usize,
    len: usize,
}

impl Default for Results {
    fn default() -> Self {
        Self::new()
    }
}

impl Results {
    /// No results.
    pub const fn new() -> Self {
        Self { buf: [None; TX_RESULTS], head: 0, len: 0 }
    }

    /// Adds `r`, dropping the oldest result if full.
    pub fn push(&mut self, r: TxResult) {
        if self.len == TX_RESULTS {
            self.head = (self.head + 1) % TX_RESULTS;
            self.len -= 1;
        }
        self.buf[(self.head + self.len) % TX_RESULTS] = Some(r);
        self.len += 1;
    }

    /// The oldest result.
    pub fn pop(&mut self) -> Option<TxResult> {
        if self.len == 0 {
            return None;
        }
        let r = self.buf[self.head].take();
        self.head = (self.head + 1) % TX_RESULTS;
        self.len -= 1;
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rtcan::controller::TxOutcome;
    use rtcan::FrameId;

    fn result(id: u32) -> TxResult {
        TxResult::new(FrameId::from_raw(id).unwrap(), TxOutcome::Sent)
    }

    #[test]
    fn results_come_out_oldest_first_and_a_full_ring_drops_the_oldest() {
        let mut r = Results::new();
        assert_eq!(r.pop(), None);
        for id in 1..=5 {
            r.push(result(id));
        }
        // Five pushed into three places: 1 and 2 dropped.
        assert_eq!(
            [r.pop(), r.pop(), r.pop(), r.pop()],
            [Some(result(3)), Some(result(4)), Some(result(5)), None]
        );
        // Interleaved use wraps around the buffer and keeps the order.
        for id in 10..20 {
            r.push(result(id));
            r.push(result(id + 100));
            assert_eq!(r.pop(), Some(result(id)));
            assert_eq!(r.pop(), Some(result(id + 100)));
        }
        assert_eq!(r.pop(), None);
    }
}
