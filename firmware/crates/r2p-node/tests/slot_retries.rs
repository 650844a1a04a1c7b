//! Which transmit outcomes count as a retry (`NodeStats::slot_retries`, docs/rtcan.md, "Node
//! slot policy"): a queued frame that did not go out in its window and had to wait for another
//! one — lost a one-shot arbitration, ended in an error, was withdrawn at its latest start, or,
//! with one-slot windows, withdrawn at its slot's end. Not a sent frame, not a sync or HRT frame
//! (those are counted as sent or missed), and not a frame a merged window takes back at a slot
//! boundary only to load it again at once.

use r2p_node::slot_tx::{Done, Slotted};
use r2p_node::FreeSlots;
use rtcan::{FrameId, Laxity, LaxityEncoding, MessageId, TxOutcome, TxQueue, Urgency};

#[test]
fn a_retry_is_a_queued_frame_that_had_to_wait_for_another_window() {
    let mut tx: TxQueue<4> = TxQueue::new(LaxityEncoding::Linear { tick_us: 100 });
    tx.push_message(MessageId(0x4301), &[1, 2, 3], Urgency::Nrt).unwrap();
    let (ticket, frame) = tx.upcoming(0).next().unwrap();
    let id = frame.id();
    let queued = |outcome, late| Done::<usize>::Queued { ticket, id, outcome, late };
    use FreeSlots::{Merged, Single};
    use TxOutcome::{Aborted, Error, LostArbitration, Sent};
    let cases = [
        (queued(Sent, false), [false, false]),
        (queued(LostArbitration, false), [true, true]),
        (queued(Error, false), [true, true]),
        (queued(Aborted, true), [true, true]),
        (queued(Aborted, false), [true, false]),
    ];
    for (done, [single, merged]) in cases {
        assert_eq!((done.is_retry(Single), done.is_retry(Merged)), (single, merged), "{done:?}");
    }
    let hrt = FrameId { laxity: Laxity::HRT, message: MessageId(0x4302), fragment: 0 };
    for outcome in [Sent, LostArbitration, Error, Aborted] {
        let done =
            Done::Slotted { what: Slotted::Hrt(0usize), id: hrt, outcome, start_of_frame: None };
        assert!(!done.is_retry(Single) && !done.is_retry(Merged), "{done:?}");
    }
}
