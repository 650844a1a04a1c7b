//! `r2p_node::SlotTx::fitted` (feature `fitted-windows`, which this crate turns on): what a
//! merged window takes near its end, on the virtual bus. The frame-sized reservations of
//! `rtcan_framed` rely on it to fill a window up to the next reservation.

use r2p_node::slot_tx::Done;
use r2p_node::{FreeSlots, SlotTx};
use r2p_vbus::{Bus, Config, EventKind, Port};
use rtcan::controller::TxOutcome;
use rtcan::cycle::frame_bits_of;
use rtcan::id::MessageId;
use rtcan::{CanController, CycleConfig, LaxityEncoding, TxQueue, Urgency};

const CYCLE: CycleConfig = CycleConfig { bit_rate: 1_000_000, cycle_us: 5_000, slots: 30 };
const URGENT: MessageId = MessageId(0x120);
const LATER: MessageId = MessageId(0x121);

fn queue() -> TxQueue<16> {
    TxQueue::new(LaxityEncoding::Logarithmic { tick_us: 100 })
}

/// The frames that went out by `until_us`: (start µs, end of intermission µs, message).
fn sent(bus: &Bus, until_us: u64) -> Vec<(u64, u64, MessageId)> {
    bus.run_until_idle(until_us * 1_000);
    bus.trace()
        .into_iter()
        .filter_map(|e| match e.kind {
            EventKind::Sent { start_ns, frame, .. } => {
                Some((start_ns / 1_000, e.time_ns / 1_000 + 3, frame.id().message))
            }
            _ => None,
        })
        .collect()
}

#[test]
fn near_its_end_a_fitted_window_sends_the_most_urgent_frame_that_still_fits() {
    // 150 µs left: the urgent 8-byte frame needs up to ~155, a later 1-byte one ~90.
    let (now, end) = (1_000, 1_150);
    let mut q = queue();
    q.push_message(URGENT, &[0x55; 8], Urgency::Srt { deadline: 3_000 }).unwrap();
    q.push_message(LATER, &[1], Urgency::Srt { deadline: 9_000 }).unwrap();
    let bus = Bus::new(2, Config::default());
    bus.advance_to(now * 1_000);
    let mut port = bus.port(0);
    let mut fitted = SlotTx::<()>::new(&CYCLE, FreeSlots::Merged).fitted(&CYCLE);
    assert!(fitted.load_queued(now, end, &mut port, &q));
    assert_eq!(port.pending(), 1);
    // Its latest start is its own: the window's end less its own worst case.
    let own = (end - u64::from(frame_bits_of(q.upcoming(now).nth(1).unwrap().1.id().to_raw(), 1)))
        as rtcan::Micros;
    assert_eq!(fitted.next_wake(now, end), own);
    let s = sent(&bus, end);
    assert_eq!(s.len(), 1);
    assert_eq!(s[0].2, LATER);
    assert!(s[0].1 <= end, "{s:?} ends after the window");

    // A window that is not fitted stops a worst-case frame before its end: nothing goes.
    let bus = Bus::new(2, Config::default());
    let mut port = bus.port(0);
    let mut plain = SlotTx::<()>::new(&CYCLE, FreeSlots::Merged);
    assert!(!plain.load_queued(now, end, &mut port, &q));
}

#[test]
fn a_fragment_that_does_not_fit_holds_back_the_rest_of_its_message() {
    // A 10-byte message: an 8-byte first frame, then a 2-byte last one that alone would fit.
    let (now, end) = (0, 120);
    let mut q = queue();
    q.push_message(URGENT, &[0xaa; 10], Urgency::Srt { deadline: 3_000 }).unwrap();
    let bus = Bus::new(2, Config::default());
    let mut port = bus.port(0);
    let mut fitted = SlotTx::<()>::new(&CYCLE, FreeSlots::Merged).fitted(&CYCLE);
    assert!(!fitted.load_queued(now, end, &mut port, &q), "its last fragment must not go first");
    // With room for both, both go, in order.
    assert!(fitted.load_queued(now, 1_000, &mut port, &q));
    assert_eq!(port.pending(), 2);
}

#[test]
fn a_frame_whose_latest_start_is_now_is_not_loaded() {
    // Its guard could not fire before it starts: if the bus is busy now it would start late.
    let mut q = queue();
    q.push_message(LATER, &[1], Urgency::Srt { deadline: 9_000 }).unwrap();
    let id = q.upcoming(0).next().unwrap().1.id().to_raw();
    let end = u64::from(frame_bits_of(id, 1)); // 1 Mbit/s: one bit a µs
    let bus = Bus::new(2, Config::default());
    let mut port = bus.port(0);
    let mut fitted = SlotTx::<()>::new(&CYCLE, FreeSlots::Merged).fitted(&CYCLE);
    assert!(!fitted.load_queued(0, end as rtcan::Micros, &mut port, &q));
    assert!(fitted.load_queued(0, end as rtcan::Micros + 1, &mut port, &q));
}

/// The first time after `from` at which the queue's next frame's laxity code is `steps` codes
/// lower (more urgent) than at `from`.
fn code_steps_later(q: &TxQueue<16>, from: rtcan::Micros, steps: u8) -> rtcan::Micros {
    let code = |t| q.upcoming(t).next().unwrap().1.id().laxity.code();
    (from..).find(|&t| code(t) + steps == code(from)).unwrap()
}

#[test]
fn with_a_laxity_drift_a_loaded_frame_that_many_codes_behind_stays_in_its_mailbox() {
    // `SlotTx::laxity_drift` (what-if): one code behind it stays loaded with a drift of 1, two
    // codes behind it is withdrawn; without a drift (the node runtime's), one code is enough.
    let mut q = queue();
    q.push_message(URGENT, &[1], Urgency::Srt { deadline: 3_000 }).unwrap();
    let (one, two) = (code_steps_later(&q, 0, 1), code_steps_later(&q, 0, 2));
    let end = 4_000;
    for (drift, at, stays) in [(1, one, true), (1, two, false), (0, one, false), (0, 0, true)] {
        // The bus stays at 0: the frame is still in its mailbox at `at`.
        let bus = Bus::new(2, Config::default());
        let mut port = bus.port(0);
        let mut tx =
            SlotTx::<()>::new(&CYCLE, FreeSlots::Merged).fitted(&CYCLE).laxity_drift(drift);
        assert!(tx.load_queued(0, end, &mut port, &q));
        let withdrawn = tx.settle(at, &mut port, &q).iter().flatten().count();
        assert_eq!(
            (withdrawn == 0, port.pending()),
            (stays, usize::from(stays)),
            "drift {drift}, {at} µs later"
        );
    }
}

/// What became of the queued frames `settle` reports: their tickets and outcomes.
fn outcomes(done: &[Done<()>]) -> Vec<(rtcan::Ticket, TxOutcome, bool)> {
    done.iter()
        .filter_map(|d| match *d {
            Done::Queued { ticket, outcome, late, .. } => Some((ticket, outcome, late)),
            Done::Slotted { .. } => None,
        })
        .collect()
}

/// A staging node that loaded `URGENT`'s one frame for a window ending at `first_end` and, with
/// the messages `then` (message, payload, deadline) released since, finds it still in the
/// controller when the window ending at `end` opens at 20 µs: it loads nothing (and stages).
/// The bus, the node's port, the node, its queue and the first frame's ticket.
fn staged_behind_one(
    first_end: rtcan::Micros,
    then: &[(MessageId, &[u8], rtcan::Micros)],
    end: rtcan::Micros,
) -> (Bus, Port, SlotTx<()>, TxQueue<16>, rtcan::Ticket) {
    let mut q = queue();
    q.push_message(URGENT, &[1], Urgency::Srt { deadline: 3_000 }).unwrap();
    let bus = Bus::new(2, Config::default());
    let mut port = bus.port(0);
    let mut tx = SlotTx::<()>::new(&CYCLE, FreeSlots::Merged).fitted(&CYCLE).staging(true);
    assert!(tx.load_queued(0, first_end, &mut port, &q));
    let first = q.upcoming(0).next().unwrap().0;
    for &(message, data, deadline) in then {
        q.push_message(message, data, Urgency::Srt { deadline }).unwrap();
    }
    assert!(!tx.load_queued(20, end, &mut port, &q));
    (bus, port, tx, q, first)
}

#[test]
fn a_node_whose_frames_are_still_in_the_controller_stages_what_it_would_load() {
    // `SlotTx::staging` (what-if): a frame loaded for one window is still in the controller
    // when the next window opens; the node cannot load behind it, so it stages the frames it
    // would load, and the transmit interrupt loads them once the controller is empty (into
    // the mailboxes whose results were taken). `settle` takes them as its queued frames.
    // Released since: a two-frame message and a one-frame one. In the next window, while the
    // first frame is in the controller, the next three frames are staged in order, each with
    // its own latest start.
    let end = 4_000;
    let then: [(_, &[u8], _); 2] = [(LATER, &[2; 10], 9_000), (MessageId(0x122), &[3], 9_500)];
    let (bus, mut port, mut tx, q, first) = staged_behind_one(2_000, &then, end);
    let staged: Vec<_> = tx.staged().collect();
    let expected: Vec<_> = q.upcoming(20).skip(1).collect();
    assert_eq!(staged.iter().map(|s| (s.ticket, s.frame)).collect::<Vec<_>>(), expected);
    for s in &staged {
        let own = u64::from(frame_bits_of(s.frame.id().to_raw(), s.frame.payload().len()));
        assert_eq!(s.latest, end - own as rtcan::Micros);
        assert!(s.may_load(s.latest - 1) && !s.may_load(s.latest));
    }
    // The node's timer fires at the loaded frame's latest start, then at the earliest staged
    // frame's.
    let loaded_latest = 2_000 - frame_bits_of(q.upcoming(0).next().unwrap().1.id().to_raw(), 1);
    assert_eq!(tx.next_wake(20, 5_000), rtcan::Micros::from(loaded_latest));
    let staged_latest = staged.iter().map(|s| s.latest).min().unwrap();
    assert_eq!(tx.next_wake(rtcan::Micros::from(loaded_latest), 5_000), staged_latest);
    // At that guard the timer moves on (a timer asked for the µs it fires in fires again).
    assert!(tx.next_wake(staged_latest, 5_000) > staged_latest);
    // Without staging, nothing is staged.
    let mut plain = SlotTx::<()>::new(&CYCLE, FreeSlots::Merged).fitted(&CYCLE);
    let plain_bus = Bus::new(2, Config::default());
    let mut plain_port = plain_bus.port(0);
    assert!(plain.load_queued(0, 2_000, &mut plain_port, &q));
    assert!(!plain.load_queued(20, end, &mut plain_port, &q));
    assert_eq!(plain.staged().count(), 0);

    // The first frame ends, sent; its result waits in its mailbox: two others are free.
    bus.run_until_idle(1_000_000);
    assert_eq!((port.pending(), port.results_waiting()), (0, vec![TxOutcome::Sent]));
    for s in &staged[..2] {
        port.try_transmit(&s.frame).unwrap();
    }
    tx.staged_went_in(2);
    assert_eq!(tx.staged().count(), 0, "nothing staged once the interrupt loaded them");
    bus.run_until_idle(2_000_000);
    let done: Vec<_> = tx.settle(2_000, &mut port, &q).into_iter().flatten().collect();
    let sent = |t| (t, TxOutcome::Sent, false);
    assert_eq!(outcomes(&done), vec![sent(first), sent(staged[0].ticket), sent(staged[1].ticket)]);
}

#[test]
fn a_staged_frame_the_interrupt_loaded_is_withdrawn_at_its_latest_start() {
    // The node's timer fires there (`next_wake`); `at_guard` holds though `settle` has not
    // taken the frame in yet, and the withdrawn frame comes back as late.
    let (bus, mut port, mut tx, q, _) = staged_behind_one(200, &[(LATER, &[2], 9_000)], 1_000);
    let s = tx.staged().next().unwrap();
    bus.run_until_idle(1_000_000);
    // Loaded, and kept waiting (the bus is not run: another node's frames, say).
    port.try_transmit(&s.frame).unwrap();
    tx.staged_went_in(1);
    assert!(!tx.at_guard(s.latest - 1));
    assert!(tx.at_guard(s.latest));
    assert!(!tx.at_guard(1_000), "the window's end is the next reservation's, no guard");
    tx.on_guard(&mut port);
    // That call ends at the guard (`Node::slot_tick` off a boundary); the next one finds no
    // new loads, and its `settle` takes the withdrawn frame's result as the node's.
    tx.staged_went_in(0);
    let done: Vec<_> = tx.settle(s.latest, &mut port, &q).into_iter().flatten().collect();
    assert_eq!(outcomes(&done)[1..], [(s.ticket, TxOutcome::Aborted, true)]);
}

#[test]
fn a_staged_frame_still_in_its_mailbox_at_the_next_settle_is_the_windows_queued_frame() {
    // `settle` takes it in: a queued frame of the window it was staged for, withdrawn at its
    // own latest start, its result the node's.
    let (bus, mut port, mut tx, q, first) = staged_behind_one(200, &[(LATER, &[2], 9_000)], 1_000);
    let s = tx.staged().next().unwrap();
    bus.run_until_idle(1_000_000);
    port.try_transmit(&s.frame).unwrap();
    tx.staged_went_in(1);
    let now = 300;
    let done: Vec<_> = tx.settle(now, &mut port, &q).into_iter().flatten().collect();
    assert_eq!(outcomes(&done), [(first, TxOutcome::Sent, false)]);
    assert_eq!(tx.queued().collect::<Vec<_>>(), [(s.ticket, s.frame.id())]);
    assert_eq!(tx.next_wake(now, 5_000), s.latest);
    assert!(!tx.at_guard(s.latest - 1) && tx.at_guard(s.latest));
    bus.run_until_idle(2_000_000);
    let done: Vec<_> = tx.settle(now + 200, &mut port, &q).into_iter().flatten().collect();
    assert_eq!(outcomes(&done), [(s.ticket, TxOutcome::Sent, false)]);
}

#[test]
fn a_frame_whose_identifier_a_loaded_frame_has_is_not_staged() {
    // Results name a frame by its identifier: two messages of one stream with the same
    // deadline have the same one while the first is loaded.
    let (_bus, _port, tx, q, _) = staged_behind_one(200, &[(URGENT, &[2], 3_000)], 1_000);
    assert_eq!(q.upcoming(20).nth(1).unwrap().1.id(), tx.queued().next().unwrap().1);
    assert_eq!(tx.staged().count(), 0);
}

#[test]
fn after_a_staged_frames_guard_nothing_loads_behind_it_while_it_is_on_the_wire() {
    // The guard ran for the staged frame the interrupt loaded before `settle` took it in; the
    // frame was on the wire, so it stays, and its guard, past, lets nothing load behind it.
    let end = 1_000;
    let then: [(_, &[u8], _); 2] = [(LATER, &[2; 8], 9_000), (MessageId(0x122), &[3], 9_500)];
    let (bus, mut port, mut tx, q, _) = staged_behind_one(200, &then, end);
    let s = tx.staged().next().unwrap();
    let t = bus.run_until_idle(1_000_000);
    port.try_transmit(&s.frame).unwrap();
    tx.staged_went_in(1);
    // On the wire at its latest start (it started just before).
    bus.advance_to(t + 20_000);
    assert_eq!(port.pending(), 1);
    tx.on_guard(&mut port);
    let now = s.latest.max((t + 20_000) / 1_000);
    let done: Vec<_> = tx.settle(now, &mut port, &q).into_iter().flatten().collect();
    assert_eq!(outcomes(&done).len(), 1, "the first frame's result only: {done:?}");
    assert_eq!(tx.queued().count(), 1, "the staged frame, still on the wire");
    assert!(!tx.load_queued(now, end, &mut port, &q), "nothing behind a frame past its guard");
}

#[test]
fn the_controller_holds_what_the_node_staged_and_nothing_once_the_node_drops_it() {
    // `SlotTx` hands each staging to the controller's transmit interrupt
    // (`CanController::stage`) and takes it back when the next call drops it: else the
    // interrupt would load frames the node no longer counts as staged (they would go out twice).
    let mut q = queue();
    q.push_message(URGENT, &[1], Urgency::Srt { deadline: 3_000 }).unwrap();
    let bus = Bus::new(2, Config::default());
    let mut port = r2p_vbus::BxCanPort::new(bus.port(0), CYCLE.bit_rate);
    let mut tx = SlotTx::<()>::new(&CYCLE, FreeSlots::Merged).fitted(&CYCLE).staging(true);
    assert!(tx.load_queued(0, 2_000, &mut port, &q));
    q.push_message(LATER, &[2], Urgency::Srt { deadline: 9_000 }).unwrap();
    assert!(!tx.load_queued(20, 4_000, &mut port, &q));
    assert_eq!(tx.staged().count(), 1);
    assert!(port.has_staged(), "handed to the interrupt");
    // The next call, its frame still waiting for the bus: it drops the staging, and so does
    // the controller; the interrupt then loads nothing.
    tx.settle(40, &mut port, &q);
    assert_eq!(tx.staged().count(), 0);
    assert!(!port.has_staged(), "taken back from the interrupt");
    bus.run_until_idle(1_000_000);
    assert_eq!(port.load_staged(100), 0);
    // Not dropped, the interrupt loads it once the frame before has gone.
    let mut q = queue();
    q.push_message(URGENT, &[1], Urgency::Srt { deadline: 3_000 }).unwrap();
    let mut tx = SlotTx::<()>::new(&CYCLE, FreeSlots::Merged).fitted(&CYCLE).staging(true);
    let bus = Bus::new(2, Config::default());
    let mut port = r2p_vbus::BxCanPort::new(bus.port(0), CYCLE.bit_rate);
    assert!(tx.load_queued(0, 2_000, &mut port, &q));
    q.push_message(LATER, &[2], Urgency::Srt { deadline: 9_000 }).unwrap();
    assert!(!tx.load_queued(20, 4_000, &mut port, &q));
    bus.run_until_idle(1_000_000);
    assert_eq!(port.load_staged(100), 1);
    assert_eq!(port.staged_loaded(), 1);
}
