//! A controller's report on a finished frame: only `Sent` means the frame went out (a master
//! counts its syncs and decides to step down on this; lost arbitration, errors and aborts are
//! all "not sent").

use rtcan::controller::{TxOutcome, TxResult};
use rtcan::{FrameId, Laxity, MessageId};

#[test]
fn only_a_sent_outcome_counts_as_sent() {
    let id = FrameId { laxity: Laxity::NRT, message: MessageId(0x0101), fragment: 0 };
    let sent = |outcome| TxResult::new(id, outcome).sent();
    assert!(sent(TxOutcome::Sent));
    for outcome in [TxOutcome::LostArbitration, TxOutcome::Error, TxOutcome::Aborted] {
        assert!(!sent(outcome), "{outcome:?}");
    }
}
