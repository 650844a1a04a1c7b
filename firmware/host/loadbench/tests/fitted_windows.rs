//! `r2p_node::SlotTx::fitted` (feature `fitted-windows`, which this crate turns on): what a
//! merged window takes near its end, on the virtual bus. The frame-sized reservations of
//! `rtcan_framed` rely on it to fill a window up to the next reservation.

use r2p_node::{FreeSlots, SlotTx};
use r2p_vbus::{Bus, Config, EventKind};
use rtcan::cycle::frame_bits_of;
use rtcan::id::MessageId;
use rtcan::{CycleConfig, LaxityEncoding, TxQueue, Urgency};

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
