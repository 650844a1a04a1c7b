//! In a merged window a node keeps its next frames loaded (docs/rtcan.md, "Node slot policy"):
//! at each slot boundary inside the window it tops the mailboxes up behind the frames still
//! loaded, so the bus carries its frames back to back; frames loaded for one window are never
//! mixed with another window's.

mod common;

use common::Mailboxes;
use r2p_node::slot_tx::{Done, SlotTx};
use r2p_node::FreeSlots;
use rtcan::{CycleConfig, LaxityEncoding, MessageId, TxOutcome, TxQueue, Urgency};

const CYCLE: CycleConfig = CycleConfig { bit_rate: 1_000_000, cycle_us: 4_000, slots: 16 };

#[test]
fn a_merged_window_is_topped_up_behind_what_is_still_loaded() {
    let mut tx: TxQueue<8> = TxQueue::new(LaxityEncoding::Linear { tick_us: 100 });
    for k in 0..5u8 {
        tx.push_message(MessageId(0x4301 + u16::from(k)), &[k], Urgency::Nrt).unwrap();
    }
    let mut s: SlotTx<usize> = SlotTx::new(&CYCLE, FreeSlots::Merged);
    let mut can = Mailboxes::default();
    assert!(s.load_queued(0, 1_000, &mut can, &tx));
    assert_eq!(can.loaded, 3, "three mailboxes");
    // Another window's call while these are loaded loads nothing.
    assert!(!s.load_queued(0, 2_000, &mut can, &tx));
    assert_eq!(can.loaded, 3);

    can.start();
    can.end(TxOutcome::Sent);
    for done in s.settle(250, &mut can, &tx).into_iter().flatten() {
        match done {
            Done::Queued { ticket, outcome: TxOutcome::Sent, .. } => assert!(tx.remove(ticket)),
            other => panic!("only the first frame finished: {other:?}"),
        }
    }
    assert_eq!(s.queued().count(), 2, "the other two stay loaded (still the queue's next)");
    assert!(s.load_queued(250, 1_000, &mut can, &tx), "topped up at the boundary");
    assert_eq!((can.loaded, s.queued().count()), (4, 3));
}
