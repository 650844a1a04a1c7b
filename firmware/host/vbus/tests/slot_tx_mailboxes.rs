//! `r2p_node::SlotTx` keeping several queued frames in the controller's mailboxes (merged
//! windows), on this bus: what goes out back to back, and what must never overtake what.

use r2p_node::slot_tx::{Done, Settled};
use r2p_node::{FreeSlots, SlotTx};
use r2p_vbus::{Bus, Config, EventKind, Port};
use rtcan::controller::TxOutcome;
use rtcan::id::MessageId;
use rtcan::{CanController, CycleConfig, Frame, FrameId, Laxity, LaxityEncoding, TxQueue, Urgency};

const CYCLE: CycleConfig = CycleConfig { bit_rate: 1_000_000, cycle_us: 10_000, slots: 60 };
/// One window for everything below: 2 ms of free slots.
const END_US: u64 = 2_000;
const M: MessageId = MessageId(0x120);
const X: MessageId = MessageId(0x121);

fn queue() -> TxQueue<16> {
    TxQueue::new(LaxityEncoding::Logarithmic { tick_us: 100 })
}

fn srt(deadline: u64) -> Urgency {
    Urgency::Srt { deadline }
}

/// Frames on the wire: (start ns, port, frame).
fn sent(bus: &Bus) -> Vec<(u64, usize, Frame)> {
    bus.trace()
        .into_iter()
        .filter_map(|e| match e.kind {
            EventKind::Sent { start_ns, frame, .. } => Some((start_ns, e.port, frame)),
            _ => None,
        })
        .collect()
}

/// Settles at `now` µs and takes what went out out of the queue; returns the outcomes.
fn settle(
    tx_state: &mut SlotTx<()>,
    now: u64,
    port: &mut Port,
    q: &mut TxQueue<16>,
) -> Vec<TxOutcome> {
    let done: Settled<()> = tx_state.settle(now, port, q);
    let mut outcomes = Vec::new();
    for d in done.into_iter().flatten() {
        if let Done::Queued { ticket, outcome, .. } = d {
            if outcome == TxOutcome::Sent {
                assert!(q.remove(ticket));
            }
            outcomes.push(outcome);
        }
    }
    outcomes
}

#[test]
fn a_merged_window_sends_a_three_frame_message_back_to_back() {
    let bus = Bus::new(2, Config::default());
    let mut a = bus.port(0);
    let mut q = queue();
    q.push_message(M, &[7; 20], srt(8_000)).unwrap();
    let mut slot_tx = SlotTx::<()>::new(&CYCLE, FreeSlots::Merged);
    assert!(slot_tx.load_queued(0, END_US, &mut a, &q));
    assert_eq!(a.pending(), 3, "the message's three frames, at once");
    bus.run_until_idle(END_US * 1_000);
    let s = sent(&bus);
    assert_eq!(s.iter().map(|f| f.2.id().fragment).collect::<Vec<_>>(), [3, 2, 1]);
    for w in s.windows(2) {
        assert_eq!(w[1].0, w[0].0 + bus.frame_ns(&w[0].2), "no idle bus between fragments");
    }
    assert_eq!(settle(&mut slot_tx, 500, &mut a, &mut q), [TxOutcome::Sent; 3]);
    assert!(q.is_empty());

    // One frame per window, one-shot: the single-slot policy.
    let mut q = queue();
    q.push_message(M, &[7; 20], srt(8_000)).unwrap();
    let mut single = SlotTx::<()>::new(&CYCLE, FreeSlots::Single);
    let mut b = Bus::new(2, Config::default()).port(0);
    assert!(single.load_queued(0, 166, &mut b, &q));
    assert_eq!(b.pending(), 1);
}

#[test]
fn frames_with_one_identifier_are_not_loaded_together() {
    // Two one-frame messages of one stream, same deadline: same identifier, and the
    // controller's results name frames by identifier.
    let bus = Bus::new(2, Config::default());
    let mut a = bus.port(0);
    let mut q = queue();
    q.push_message(M, &[1], srt(8_000)).unwrap();
    q.push_message(M, &[2], srt(8_000)).unwrap();
    let ids: Vec<FrameId> = q.upcoming(0).map(|(_, f)| f.id()).collect();
    assert_eq!(ids[0], ids[1]);
    let mut slot_tx = SlotTx::<()>::new(&CYCLE, FreeSlots::Merged);
    assert!(slot_tx.load_queued(0, END_US, &mut a, &q));
    assert_eq!(a.pending(), 1);
    bus.run_until_idle(END_US * 1_000);
    assert_eq!(settle(&mut slot_tx, 200, &mut a, &mut q), [TxOutcome::Sent]);
    assert!(slot_tx.load_queued(200, END_US, &mut a, &q));
    bus.run_until_idle(END_US * 1_000);
    let payloads: Vec<u8> = sent(&bus).iter().map(|f| f.2.payload()[0]).collect();
    assert_eq!(payloads, [1, 2]);
}

#[test]
fn a_frame_withdrawn_in_its_arbitration_is_not_overtaken() {
    // A loads M's three frames; B's more urgent frame wins the first arbitration. While A's
    // first frame is still in that arbitration, a more urgent message X makes A withdraw: its
    // first frame cannot be taken back until the bit where it loses, the two behind it are
    // aborted at once. Loading X and M's next frames behind a frame whose fate is open would
    // let them overtake it when it is withdrawn.
    let bus = Bus::new(3, Config::default());
    let (mut a, mut b) = (bus.port(0), bus.port(1));
    let mut q = queue();
    q.push_message(M, &[7; 20], srt(9_000)).unwrap();
    let mut slot_tx = SlotTx::<()>::new(&CYCLE, FreeSlots::Merged);
    assert!(slot_tx.load_queued(0, END_US, &mut a, &q));
    let urgent = FrameId { laxity: Laxity::from_code(0), message: MessageId(0x130), fragment: 0 };
    b.try_transmit(&Frame::new(urgent, &[0]).unwrap()).unwrap();

    bus.advance_to(1_000); // 1 µs: A's first frame is in the arbitration it will lose
    q.push_message(X, &[9], srt(3_000)).unwrap();
    let outcomes = settle(&mut slot_tx, 1, &mut a, &mut q);
    assert_eq!(outcomes, [TxOutcome::Aborted; 2]);
    assert!(!slot_tx.load_queued(1, END_US, &mut a, &q), "nothing behind an open fate");
    assert_eq!(a.pending(), 1);

    bus.run_until_idle(END_US * 1_000);
    assert_eq!(settle(&mut slot_tx, 200, &mut a, &mut q), [TxOutcome::LostArbitration]);
    let mut now = 200;
    while !q.is_empty() {
        assert!(slot_tx.load_queued(now, END_US, &mut a, &q));
        bus.run_until_idle(END_US * 1_000);
        now += 300;
        settle(&mut slot_tx, now, &mut a, &mut q);
    }
    let from_a: Vec<(MessageId, u8)> = sent(&bus)
        .iter()
        .filter(|f| f.1 == 0)
        .map(|f| (f.2.id().message, f.2.id().fragment))
        .collect();
    assert_eq!(from_a, [(X, 0), (M, 3), (M, 2), (M, 1)]);
}

#[test]
fn after_a_withdrawal_nothing_is_loaded_until_every_fate_is_known() {
    // As above, but what makes A withdraw is its first frame's laxity code changing between
    // two slot boundaries (a deadline where the code steps at 1 µs), so that frame is still the
    // queue's head: only waiting for its fate keeps M's later frames from overtaking it.
    let enc = LaxityEncoding::Logarithmic { tick_us: 100 };
    let deadline = (1_000..9_000u64)
        .find(|&d| enc.encode(d as u32) != enc.encode(d as u32 - 1))
        .expect("the code steps somewhere");
    let bus = Bus::new(3, Config::default());
    let (mut a, mut b) = (bus.port(0), bus.port(1));
    let mut q = queue();
    q.push_message(M, &[7; 20], srt(deadline)).unwrap();
    let mut slot_tx = SlotTx::<()>::new(&CYCLE, FreeSlots::Merged);
    assert!(slot_tx.load_queued(0, END_US, &mut a, &q));
    let urgent = FrameId { laxity: Laxity::from_code(0), message: MessageId(0x130), fragment: 0 };
    b.try_transmit(&Frame::new(urgent, &[0]).unwrap()).unwrap();

    bus.advance_to(1_000);
    assert_eq!(settle(&mut slot_tx, 1, &mut a, &mut q), [TxOutcome::Aborted; 2]);
    assert!(!slot_tx.load_queued(1, END_US, &mut a, &q), "nothing behind an open fate");

    bus.run_until_idle(END_US * 1_000);
    let mut now = 200;
    settle(&mut slot_tx, now, &mut a, &mut q);
    while !q.is_empty() {
        assert!(slot_tx.load_queued(now, END_US, &mut a, &q));
        bus.run_until_idle(END_US * 1_000);
        now += 300;
        settle(&mut slot_tx, now, &mut a, &mut q);
    }
    let fragments: Vec<u8> =
        sent(&bus).iter().filter(|f| f.1 == 0).map(|f| f.2.id().fragment).collect();
    assert_eq!(fragments, [3, 2, 1]);
}
