//! What counts as a late withdrawal (`NodeStats::late_withdrawals`, docs/rtcan.md, "Node slot
//! policy"): a queued frame that missed its window because the bus was busy at its latest start
//! — withdrawn at the guard, or, if it was in an arbitration then and lost it, at the window's
//! end. Not a frame sent, and not one a merged window takes back at a slot boundary to load a
//! more urgent frame before it.
//!
//! `SlotTx` against a model of bxCAN's mailboxes (tests/common).

mod common;

use common::Mailboxes;
use r2p_node::slot_tx::{Done, SlotTx};
use r2p_node::FreeSlots;
use rtcan::{CycleConfig, LaxityEncoding, MessageId, Micros, TxOutcome, TxQueue, Urgency};

const CYCLE: CycleConfig = CycleConfig { bit_rate: 1_000_000, cycle_us: 4_000, slots: 16 };

/// A merged window [0, 1000 µs) with `n` NRT frames of stream 0x4301 loaded.
fn loaded(n: u8) -> (SlotTx<usize>, Mailboxes, TxQueue<8>, Micros) {
    let mut tx = TxQueue::new(LaxityEncoding::Linear { tick_us: 100 });
    for k in 0..n {
        tx.push_message(MessageId(0x4301 + u16::from(k)), &[k], Urgency::Nrt).unwrap();
    }
    let mut s = SlotTx::new(&CYCLE, FreeSlots::Merged);
    let mut can = Mailboxes::default();
    assert!(s.load_queued(0, 1_000, &mut can, &tx));
    let guard = 1_000 - Micros::from(CYCLE.frame_us());
    (s, can, tx, guard)
}

/// (outcome, late) of every queued frame `done` reports.
fn fates(done: &[Option<Done<usize>>]) -> Vec<(TxOutcome, bool)> {
    done.iter()
        .flatten()
        .map(|d| match *d {
            Done::Queued { outcome, late, .. } => (outcome, late),
            Done::Slotted { .. } => panic!("no slotted frame was loaded"),
        })
        .collect()
}

#[test]
fn frames_withdrawn_at_the_guard_are_late() {
    let (mut s, mut can, tx, guard) = loaded(2);
    assert!(s.at_guard(guard));
    s.on_guard(&mut can);
    let done = s.settle(1_000, &mut can, &tx);
    assert_eq!(fates(&done), [(TxOutcome::Aborted, true), (TxOutcome::Aborted, true)]);
}

#[test]
fn a_frame_in_an_arbitration_at_the_guard_that_loses_it_is_late_too() {
    let (mut s, mut can, tx, _) = loaded(1);
    can.start(); // arbitrating at the guard: cannot be withdrawn
    s.on_guard(&mut can);
    can.end(TxOutcome::LostArbitration); // waits for the next arbitration
    let done = s.settle(1_000, &mut can, &tx); // the window's end withdraws it
    assert_eq!(fates(&done), [(TxOutcome::Aborted, true)]);
}

#[test]
fn a_frame_on_the_wire_at_the_guard_is_sent_not_late() {
    let (mut s, mut can, tx, _) = loaded(1);
    can.start();
    s.on_guard(&mut can);
    can.end(TxOutcome::Sent);
    let done = s.settle(1_000, &mut can, &tx);
    assert_eq!(fates(&done), [(TxOutcome::Sent, false)]);
}

#[test]
fn frames_taken_back_for_a_more_urgent_one_are_not_late() {
    let (mut s, mut can, mut tx, _) = loaded(2);
    // An SRT message arrives before the window's next slot boundary (250 µs): it goes first,
    // so the loaded NRT frames are withdrawn there, to be loaded again behind it.
    tx.push_message(MessageId(0x4401), &[9], Urgency::Srt { deadline: 2_000 }).unwrap();
    let done = s.settle(250, &mut can, &tx);
    assert_eq!(fates(&done), [(TxOutcome::Aborted, false), (TxOutcome::Aborted, false)]);
}
