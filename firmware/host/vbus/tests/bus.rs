//! Behaviour of the virtual bus through its public API.

use proptest::prelude::*;
use r2p_vbus::{Bus, Config, ErrorCause, EventKind, FaultAction, FaultRule, FrameBits, TxOrder};
use rtcan::controller::{BusState, ErrorCounters, Filter, TxError, TxMode, TxOutcome, TxResult};
use rtcan::{CanController, Frame, FrameId};

const MS: u64 = 1_000_000;

fn frame(raw: u32, data: &[u8]) -> Frame {
    Frame::new(FrameId::from_raw(raw).unwrap(), data).unwrap()
}

fn bus(ports: usize) -> Bus {
    Bus::new(ports, Config::default())
}

fn drain(port: &mut r2p_vbus::Port) -> Vec<Frame> {
    std::iter::from_fn(|| port.try_receive()).map(|r| r.frame).collect()
}

#[test]
fn arbitration_lowest_id_first_losers_retry_at_next_idle() {
    let bus = bus(4);
    let frames = [frame(0x300, &[3]), frame(0x100, &[1]), frame(0x200, &[2])];
    for (p, f) in frames.iter().enumerate() {
        bus.port(p).try_transmit(f).unwrap();
    }
    bus.run_until_idle(MS);
    let sent: Vec<_> = bus
        .trace()
        .into_iter()
        .filter_map(|e| match e.kind {
            EventKind::Sent { start_ns, frame, .. } => Some((start_ns, e.port, frame)),
            _ => None,
        })
        .collect();
    let ids: Vec<u32> = sent.iter().map(|s| s.2.id().to_raw()).collect();
    assert_eq!(ids, [0x100, 0x200, 0x300]);
    assert_eq!(sent.iter().map(|s| s.1).collect::<Vec<_>>(), [1, 2, 0]);
    // Each loser starts exactly when the bus goes idle after the previous frame.
    assert_eq!(sent[0].0, 0);
    assert_eq!(sent[1].0, bus.frame_ns(&frames[1]));
    assert_eq!(sent[2].0, sent[1].0 + bus.frame_ns(&frames[2]));
    assert_eq!(drain(&mut bus.port(3)).len(), 3);
}

#[test]
fn a_port_sends_its_mailboxes_in_load_order_or_lowest_id_first() {
    // Transmit FIFO priority (bxCAN TXFP = 1, the default here): load order.
    let bus = bus(2);
    let mut a = bus.port(0);
    for raw in [0x30, 0x10, 0x20] {
        a.try_transmit(&frame(raw, &[])).unwrap();
    }
    assert_eq!(a.try_transmit(&frame(0x5, &[])), Err(TxError::MailboxesFull));
    bus.run_until_idle(MS);
    let ids: Vec<u32> = bus.frames().map(|f| f.2.id().to_raw()).collect();
    assert_eq!(ids, [0x30, 0x10, 0x20]);
    assert_eq!(a.pending(), 0);
    // Identifier priority (TXFP = 0): lowest identifier first.
    let bus = self::bus(2);
    let mut a = bus.port(0);
    a.set_tx_order(TxOrder::Identifier);
    for raw in [0x30, 0x10, 0x20] {
        a.try_transmit(&frame(raw, &[])).unwrap();
    }
    bus.run_until_idle(MS);
    let ids: Vec<u32> = bus.frames().map(|f| f.2.id().to_raw()).collect();
    assert_eq!(ids, [0x10, 0x20, 0x30]);
}

#[test]
fn exact_duration_and_timestamps() {
    let bus = bus(2);
    let f = frame(0x1234_5678 & 0x1fff_ffff, &[0xde, 0xad, 0xbe, 0xef, 0, 1, 2, 3]);
    let bits = FrameBits::of(&f);
    bus.advance_to(5 * MS);
    bus.port(0).try_transmit(&f).unwrap();
    assert_eq!(bus.step(), Some(5 * MS)); // start of frame
    let end = bus.step().unwrap();
    assert_eq!(end, 5 * MS + u64::from(bits.to_eof_end()) * 1000);
    let rx = bus.port(1).try_receive().unwrap();
    assert_eq!((rx.frame, rx.at), (f, end / 1000));
    assert_eq!(bus.frame_ns(&f), u64::from(bits.total()) * 1000);
    assert!(bits.total() <= rtcan::cycle::WORST_CASE_FRAME_BITS);
}

#[test]
fn slower_bit_rate_scales_durations() {
    let bus = Bus::new(2, Config { bit_rate: 125_000, ..Config::default() });
    let f = frame(7, &[1, 2, 3]);
    assert_eq!(bus.frame_ns(&f), u64::from(FrameBits::of(&f).total()) * 8000);
}

#[test]
fn delivered_to_every_other_port_not_the_sender() {
    let bus = bus(4);
    let f = frame(0x42, &[9]);
    bus.port(2).try_transmit(&f).unwrap();
    bus.run_until_idle(MS);
    for p in [0, 1, 3] {
        assert_eq!(drain(&mut bus.port(p)), [f], "port {p}");
    }
    assert!(drain(&mut bus.port(2)).is_empty());
    assert_eq!(bus.port(2).pending(), 0, "mailbox freed on confirmation");
}

#[test]
fn filters_and_fifo_overflow() {
    let bus = Bus::new(3, Config { rx_depth: 2, ..Config::default() });
    bus.port(1).set_filters(&[Filter { value: 0x10, mask: 0xff }]);
    bus.port(2).set_filters(&[]);
    for raw in [0x10, 0x11, 0x110, 0x210] {
        bus.port(0).try_transmit(&frame(raw, &[])).unwrap();
        bus.run_until_idle(10 * MS);
    }
    let got: Vec<u32> = drain(&mut bus.port(1)).iter().map(|f| f.id().to_raw()).collect();
    assert_eq!(got, [0x10, 0x110]);
    assert_eq!(bus.overflows(1), 1);
    assert!(drain(&mut bus.port(2)).is_empty());
    // Receiving needs no filter match to count as a successful reception.
    assert_eq!(bus.port(2).error_counters(), ErrorCounters::default());
}

#[test]
fn dropped_frame_is_missed_but_confirmed() {
    let bus = bus(3);
    bus.inject(FaultRule::drop_frames().id(0x50).times(1));
    bus.port(0).try_transmit(&frame(0x50, &[1])).unwrap();
    bus.run_until_idle(MS);
    assert!(drain(&mut bus.port(1)).is_empty());
    assert!(drain(&mut bus.port(2)).is_empty());
    assert_eq!(bus.port(0).pending(), 0);
    assert!(bus.faults().is_empty(), "rule retired");
    // One receiver only.
    bus.inject(FaultRule::new(FaultAction::Drop(Some(1))).times(1));
    bus.port(0).try_transmit(&frame(0x50, &[2])).unwrap();
    bus.run_until_idle(2 * MS);
    assert!(drain(&mut bus.port(1)).is_empty());
    assert_eq!(drain(&mut bus.port(2)), [frame(0x50, &[2])]);
    let sent: Vec<_> =
        bus.trace().into_iter().filter(|e| matches!(e.kind, EventKind::Sent { .. })).collect();
    assert!(matches!(sent[0].kind, EventKind::Sent { missed_by: Some(None), .. }));
}

#[test]
fn corrupted_frame_moves_counters_and_is_retransmitted() {
    let bus = bus(3);
    let f = frame(0x60, &[1, 2, 3, 4]);
    bus.inject(FaultRule::corrupt().times(1));
    bus.port(0).try_transmit(&f).unwrap();
    bus.step(); // SOF
    let err_end = bus.step().unwrap();
    assert_eq!(err_end, u64::from(FrameBits::of(&f).to_error_end()) * 1000);
    assert_eq!(bus.port(0).error_counters(), ErrorCounters { tx: 8, rx: 0 });
    assert_eq!(bus.port(1).error_counters(), ErrorCounters { tx: 0, rx: 1 });
    assert!(drain(&mut bus.port(1)).is_empty());
    bus.run_until_idle(MS);
    assert_eq!(drain(&mut bus.port(1)), [f]);
    assert_eq!(bus.port(0).error_counters(), ErrorCounters { tx: 7, rx: 0 });
    assert_eq!(bus.port(1).error_counters(), ErrorCounters { tx: 0, rx: 0 });
    let kinds: Vec<_> = bus.trace().into_iter().map(|e| e.kind).collect();
    assert!(matches!(kinds[0], EventKind::Error { cause: ErrorCause::Corrupted, .. }));
    // The retransmission starts after the error frame and intermission.
    let EventKind::Sent { start_ns, .. } = kinds[1] else { panic!() };
    assert_eq!(start_ns, u64::from(FrameBits::of(&f).error_total()) * 1000);
}

#[test]
fn repeated_errors_go_passive_then_bus_off_then_recover() {
    let bus = bus(2);
    let f = frame(0x70, &[]);
    bus.inject(FaultRule::corrupt().from(0).times(32));
    let mut p0 = bus.port(0);
    p0.try_transmit(&f).unwrap();
    for _ in 0..16 {
        bus.step();
        bus.step();
    }
    assert_eq!(p0.error_counters().tx, 128);
    assert_eq!(p0.bus_state(), BusState::ErrorPassive);
    for _ in 0..16 {
        bus.step();
        bus.step();
    }
    assert_eq!(p0.bus_state(), BusState::BusOff);
    assert_eq!(p0.try_transmit(&f), Err(TxError::BusOff));
    let off_at = bus.now();
    // Idle bus: 128 runs of 11 recessive bits from the error delimiter on.
    let recovered = bus.step().unwrap();
    assert_eq!(recovered, off_at + 3 * 1000 - 11 * 1000 + 128 * 11 * 1000);
    assert_eq!(p0.bus_state(), BusState::ErrorActive);
    assert_eq!(p0.error_counters(), ErrorCounters::default());
    // The frame still in its mailbox goes out now.
    bus.run_until_idle(10 * MS);
    assert_eq!(drain(&mut bus.port(1)), [f]);
    assert!(bus.trace().iter().any(|e| e.kind == EventKind::BusOff));
}

#[test]
fn lone_sender_gets_no_ack_and_stops_at_error_passive() {
    let bus = bus(2);
    bus.power(1, false);
    let mut p0 = bus.port(0);
    p0.try_transmit(&frame(0x1, &[])).unwrap();
    bus.advance_to(10 * MS);
    assert_eq!(p0.error_counters().tx, 128);
    assert_eq!(p0.bus_state(), BusState::ErrorPassive);
    assert_eq!(p0.pending(), 1);
    bus.power(1, true);
    bus.advance_to(11 * MS);
    assert_eq!(p0.pending(), 0);
    assert_eq!(drain(&mut bus.port(1)).len(), 1);
}

#[test]
fn abort_pending_counts_frames_not_on_the_wire() {
    let bus = bus(3);
    bus.port(0).try_transmit(&frame(0x1, &[])).unwrap();
    let mut p1 = bus.port(1);
    p1.try_transmit(&frame(0x2, &[])).unwrap();
    p1.try_transmit(&frame(0x3, &[])).unwrap();
    bus.step(); // start of frame: port 0 will win
                // 0x3 waits in a mailbox; 0x2 is sending its identifier until the bit where it loses.
    assert_eq!(p1.abort_pending(), 1);
    let result = |id, outcome| TxResult::new(FrameId::from_raw(id).unwrap(), outcome);
    assert_eq!(results(&mut p1), [result(0x3, TxOutcome::Aborted)]);
    let loses = u64::from(r2p_vbus::bits::arbitration_loss_bits(0x1, 0x2)) * 1_000;
    assert_eq!(bus.step(), Some(loses));
    assert_eq!(results(&mut p1), [result(0x2, TxOutcome::LostArbitration)], "not retried");
    let mut p0 = bus.port(0);
    assert_eq!(p0.abort_pending(), 0, "on the wire");
    assert_eq!(p0.take_tx_result(), None, "no result before its end");
    bus.run_until_idle(MS);
    assert_eq!(bus.frames().count(), 1);
    assert!(results(&mut p0)[0].sent());
    // A frame on the wire that fails is not counted, not retried, and reported as an error.
    bus.inject(FaultRule::corrupt().times(1));
    p0.try_transmit(&frame(0x4, &[])).unwrap();
    bus.step();
    assert_eq!(p0.abort_pending(), 0);
    bus.run_until_idle(2 * MS);
    assert_eq!(bus.frames().count(), 1);
    assert_eq!(p0.pending(), 0);
    assert_eq!(results(&mut p0)[0].outcome, TxOutcome::Error);
}

fn results(port: &mut r2p_vbus::Port) -> Vec<TxResult> {
    std::iter::from_fn(|| port.take_tx_result()).collect()
}

#[test]
fn one_shot_losers_are_withdrawn_at_the_bit_where_they_lose() {
    // Against identifier 0 (all dominant), hand-counted from SOF, stuff bits included:
    // 0x1000_0000 is recessive at base-ID bit 10, the 2nd bit; 0x0040_0000 at base-ID bit 4,
    // the 8th unstuffed bit, after 7 zeros and so one stuff bit: 9 bits; 0x1 at the last
    // extended-ID bit, the 32nd unstuffed bit, after 12 zeros, SRR and IDE, 17 zeros: 5 stuff
    // bits, 37 bits.
    let bus = bus(4);
    let win = frame(0x0, &[1]);
    let losers =
        [(frame(0x1000_0000, &[2]), 2), (frame(0x0040_0000, &[3]), 9), (frame(0x1, &[]), 37)];
    bus.port(0).try_transmit(&win).unwrap();
    for (p, (f, _)) in losers.iter().enumerate() {
        let mut port = bus.port(p + 1);
        port.set_tx_mode(TxMode::OneShot);
        port.try_transmit(f).unwrap();
    }
    assert_eq!(bus.step(), Some(0)); // start of frame: all four arbitrate
    for (p, &(f, bits)) in losers.iter().enumerate() {
        assert_eq!(r2p_vbus::bits::arbitration_loss_bits(0, f.id().to_raw()), bits);
        let mut port = bus.port(p + 1);
        assert_eq!(port.pending(), 1, "still loaded before the bit where it loses");
        assert_eq!(bus.step(), Some(u64::from(bits) * 1_000));
        assert_eq!(results(&mut port), [TxResult::new(f.id(), TxOutcome::LostArbitration)]);
        assert_eq!(port.pending(), 0);
    }
    bus.run_until_idle(MS);
    // Only the winner went out; nobody retried.
    assert_eq!(bus.frames().map(|f| f.2).collect::<Vec<_>>(), [win]);
    assert!(results(&mut bus.port(0))[0].sent());
    let lost: Vec<_> = bus
        .trace()
        .into_iter()
        .filter_map(|e| match e.kind {
            EventKind::LostArbitration { start_ns: 0, frame } => Some((e.time_ns, e.port, frame)),
            _ => None,
        })
        .collect();
    let expected: Vec<_> =
        losers.iter().enumerate().map(|(p, &(f, b))| (u64::from(b) * 1_000, p + 1, f)).collect();
    assert_eq!(lost, expected);
}

#[test]
fn a_one_shot_frame_that_fails_is_withdrawn_and_reported() {
    let bus = bus(2);
    let mut a = bus.port(0);
    a.set_tx_mode(TxMode::OneShot);
    bus.inject(FaultRule::corrupt().times(1));
    let f = frame(0x60, &[1, 2, 3, 4]);
    a.try_transmit(&f).unwrap();
    bus.run_until_idle(MS);
    assert_eq!(bus.frames().count(), 0, "not retransmitted");
    assert_eq!(a.pending(), 0);
    assert_eq!(results(&mut a), [TxResult::new(f.id(), TxOutcome::Error)]);
    assert_eq!(a.error_counters().tx, 8);
    // Back to retransmission: the same fault is retried until it goes out.
    a.set_tx_mode(TxMode::Retransmit);
    bus.inject(FaultRule::corrupt().times(1));
    a.try_transmit(&f).unwrap();
    bus.run_until_idle(2 * MS);
    assert_eq!(bus.frames().count(), 1);
    assert_eq!(results(&mut a), [TxResult::new(f.id(), TxOutcome::Sent)]);
}

#[test]
fn a_one_shot_frame_loaded_while_the_bus_is_busy_waits_then_tries_once() {
    let bus = bus(3);
    let (mut a, mut b, mut c) = (bus.port(0), bus.port(1), bus.port(2));
    b.set_tx_mode(TxMode::OneShot);
    a.try_transmit(&frame(0x300, &[0; 8])).unwrap();
    bus.step(); // A alone on the wire
    b.try_transmit(&frame(0x200, &[])).unwrap();
    c.try_transmit(&frame(0x100, &[])).unwrap();
    bus.run_until_idle(MS);
    // At the next idle B and C arbitrate: C wins, B is withdrawn, never sent.
    let ids: Vec<u32> = bus.frames().map(|f| f.2.id().to_raw()).collect();
    assert_eq!(ids, [0x300, 0x100]);
    assert_eq!(results(&mut b)[0].outcome, TxOutcome::LostArbitration);
}

#[test]
fn results_are_kept_for_the_last_three_frames_and_cleared_at_power_on() {
    let bus = bus(2);
    let mut a = bus.port(0);
    for k in 0..5u32 {
        a.try_transmit(&frame(0x10 + k, &[])).unwrap();
        bus.run_until_idle(u64::from(k + 1) * MS);
    }
    let ids: Vec<u32> = results(&mut a).iter().map(|r| r.id.to_raw()).collect();
    assert_eq!(ids, [0x12, 0x13, 0x14]);
    a.set_tx_mode(TxMode::OneShot);
    a.try_transmit(&frame(0x20, &[])).unwrap();
    bus.run_until_idle(6 * MS);
    bus.power(0, false);
    bus.power(0, true);
    assert_eq!(a.take_tx_result(), None);
    // Power-on is back to retransmission.
    bus.inject(FaultRule::corrupt().times(1));
    a.try_transmit(&frame(0x21, &[])).unwrap();
    bus.run_until_idle(8 * MS);
    assert!(results(&mut a)[0].sent());
}

#[test]
fn babbler_starves_lower_priority_until_it_pauses() {
    let bus = bus(3);
    bus.babble(0, Some(frame(0x0, &[0xff; 8])));
    let mut p1 = bus.port(1);
    p1.try_transmit(&frame(0x100, &[1])).unwrap();
    bus.advance_to(20 * MS);
    assert_eq!(p1.pending(), 1);
    assert!(bus.frames().all(|(_, p, _)| p == 0));
    let n = bus.frames().count() as u64;
    // Back to back: 20 ms of frames of ≤ 160 bits.
    assert!(n >= 20 * MS / 160_000, "{n}");
    drain(&mut bus.port(2));
    bus.babble(0, None);
    bus.advance_to(21 * MS);
    assert_eq!(p1.pending(), 0);
    assert!(drain(&mut bus.port(2)).contains(&frame(0x100, &[1])));
}

#[test]
fn powered_off_port_neither_sends_nor_receives() {
    let bus = bus(3);
    let mut p2 = bus.port(2);
    p2.try_transmit(&frame(0x9, &[])).unwrap();
    bus.power(2, false);
    assert_eq!(p2.pending(), 0, "mailboxes cleared");
    assert_eq!(p2.try_transmit(&frame(0x9, &[])), Err(TxError::BusOff));
    assert_eq!(p2.bus_state(), BusState::BusOff);
    bus.port(0).try_transmit(&frame(0x10, &[])).unwrap();
    bus.run_until_idle(MS);
    assert!(p2.try_receive().is_none());
    assert_eq!(bus.frames().count(), 1);
    bus.power(2, true);
    assert_eq!(p2.bus_state(), BusState::ErrorActive);
    bus.port(0).try_transmit(&frame(0x11, &[])).unwrap();
    bus.run_until_idle(2 * MS);
    assert_eq!(drain(&mut p2), [frame(0x11, &[])]);
}

#[test]
fn power_off_mid_frame_truncates_it() {
    let bus = bus(3);
    bus.port(0).try_transmit(&frame(0x10, &[1; 8])).unwrap();
    bus.step();
    bus.power(0, false);
    bus.run_until_idle(MS);
    assert!(bus.port(1).try_receive().is_none());
    assert_eq!(bus.port(1).error_counters().rx, 1);
    assert!(bus
        .trace()
        .iter()
        .any(|e| matches!(e.kind, EventKind::Error { cause: ErrorCause::SenderLost, .. })));
}

/// Sends three frames on a partitioned bus of `ports` ports: (start, port, id) of each.
fn partitioned_run(ports: usize) -> Vec<(u64, usize, u32)> {
    let bus = bus(ports);
    let last = ports - 1;
    bus.partition(&[last - 1, last]);
    bus.port(0).try_transmit(&frame(0x30, &[3])).unwrap();
    bus.port(1).try_transmit(&frame(0x20, &[2, 2])).unwrap();
    bus.port(last).try_transmit(&frame(0x10, &[])).unwrap();
    bus.run_until_idle(MS);
    assert_eq!(drain(&mut bus.port(last - 1)), [frame(0x10, &[])]);
    bus.trace()
        .into_iter()
        .filter_map(|e| match e.kind {
            EventKind::Sent { start_ns, frame, .. } => {
                Some((start_ns, e.port, frame.id().to_raw()))
            }
            _ => None,
        })
        .collect()
}

#[test]
fn a_bus_of_many_ports_schedules_as_a_small_one() {
    // Up to 16 segments the next start comes from one pass over the ports; beyond, per segment.
    let small = partitioned_run(4);
    let many = partitioned_run(20);
    let renumber = |v: &[(u64, usize, u32)], last: usize| -> Vec<(u64, usize, u32)> {
        v.iter().map(|&(t, p, id)| (t, if p == last { 99 } else { p }, id)).collect()
    };
    assert_eq!(renumber(&small, 3), renumber(&many, 19));
    let b = bus(4);
    // Both segments start at once; on the big one the loser follows the winner.
    let mut sorted = small.clone();
    sorted.sort();
    assert_eq!(sorted, [(0, 1, 0x20), (0, 3, 0x10), (b.frame_ns(&frame(0x20, &[2, 2])), 0, 0x30)]);
}

#[test]
fn partitioned_segments_do_not_hear_each_other() {
    let bus = bus(4);
    bus.partition(&[2, 3]);
    bus.port(0).try_transmit(&frame(0x20, &[])).unwrap();
    bus.port(2).try_transmit(&frame(0x10, &[])).unwrap();
    bus.run_until_idle(MS);
    // Both went out at once: no arbitration across segments.
    let starts: Vec<u64> = bus
        .trace()
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Sent { start_ns, .. } => Some(start_ns),
            _ => None,
        })
        .collect();
    assert_eq!(starts, [0, 0]);
    assert_eq!(drain(&mut bus.port(1)), [frame(0x20, &[])]);
    assert_eq!(drain(&mut bus.port(3)), [frame(0x10, &[])]);
    assert!(drain(&mut bus.port(0)).is_empty() && drain(&mut bus.port(2)).is_empty());
    bus.heal();
    bus.port(0).try_transmit(&frame(0x21, &[])).unwrap();
    bus.run_until_idle(2 * MS);
    for p in 1..4 {
        assert_eq!(drain(&mut bus.port(p)), [frame(0x21, &[])]);
    }
}

/// Random traffic with probabilistic faults; returns the bus for inspection.
fn scripted(seed: u64) -> Bus {
    let bus = Bus::new(5, Config { seed, ..Config::default() });
    bus.inject(FaultRule::corrupt().probability_ppm(100_000));
    bus.inject(FaultRule::drop_frames().probability_ppm(50_000));
    let mut x = 12345u64;
    for step in 0..2000u64 {
        x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let p = (x >> 33) as usize % 5;
        let raw = (x >> 40) as u32 & 0x1fff_ffff;
        let _ = bus.port(p).try_transmit(&frame(raw, &[(x >> 8) as u8; 3]));
        if step % 7 == 0 {
            bus.port(p).abort_pending();
        }
        for q in 0..5 {
            drain(&mut bus.port(q));
        }
        bus.advance_by(50_000);
    }
    bus
}

#[test]
fn same_seed_same_trace() {
    let (a, b) = (scripted(7), scripted(7));
    assert_eq!(a.trace_hash(), b.trace_hash());
    assert_eq!(a.trace(), b.trace());
    assert!(a.trace().iter().any(|e| matches!(e.kind, EventKind::Error { .. })));
    assert_ne!(a.trace_hash(), scripted(8).trace_hash());
}

#[derive(Clone, Debug)]
enum Op {
    Send(usize, u32, Vec<u8>),
    Advance(u64),
    Step,
    Abort(usize),
    Power(usize, bool),
    Partition(Vec<usize>),
    Babble(usize, Option<u32>),
    Fault(u8, u32),
    Mode(usize, bool),
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        4 => (0..4usize, 0..0x2000_0000u32, prop::collection::vec(any::<u8>(), 0..=8))
            .prop_map(|(p, id, d)| Op::Send(p, id, d)),
        3 => (0..400_000u64).prop_map(Op::Advance),
        2 => Just(Op::Step),
        1 => (0..4usize).prop_map(Op::Abort),
        1 => (0..4usize, any::<bool>()).prop_map(|(p, on)| Op::Power(p, on)),
        1 => prop::collection::vec(0..4usize, 0..3).prop_map(Op::Partition),
        1 => (0..4usize, prop::option::of(0..0x2000_0000u32)).prop_map(|(p, id)| Op::Babble(p, id)),
        1 => (0..3u8, 0..1_000_000u32).prop_map(|(k, ppm)| Op::Fault(k, ppm)),
        1 => (0..4usize, any::<bool>()).prop_map(|(p, one)| Op::Mode(p, one)),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn random_traffic_never_panics_and_delivers_only_sent_frames(
        seed in any::<u64>(),
        ops in prop::collection::vec(op(), 1..120),
    ) {
        let bus = Bus::new(4, Config { seed, rx_depth: 4, ..Config::default() });
        let mut offered: Vec<(usize, Frame)> = Vec::new();
        let mut received: Vec<(usize, Frame, u64)> = Vec::new();
        let mut reported: Vec<(usize, TxResult)> = Vec::new();
        for op in ops {
            match op {
                Op::Send(p, id, d) => {
                    let f = frame(id, &d);
                    if bus.port(p).try_transmit(&f).is_ok() {
                        offered.push((p, f));
                    }
                }
                Op::Advance(dt) => bus.advance_by(dt),
                Op::Step => { bus.step(); }
                Op::Abort(p) => { bus.port(p).abort_pending(); }
                Op::Power(p, on) => bus.power(p, on),
                Op::Partition(ps) => bus.partition(&ps),
                Op::Babble(p, id) => {
                    let f = id.map(|id| frame(id, &[0xaa]));
                    if let Some(f) = f { offered.push((p, f)); }
                    bus.babble(p, f);
                }
                Op::Fault(k, ppm) => bus.inject(match k {
                    0 => FaultRule::corrupt(),
                    1 => FaultRule::drop_frames(),
                    _ => FaultRule::new(FaultAction::Drop(Some(ppm as usize % 4))),
                }.probability_ppm(ppm).times(3)),
                Op::Mode(p, one) => bus.port(p).set_tx_mode(if one { TxMode::OneShot } else { TxMode::Retransmit }),
            }
            for q in 0..4 {
                while let Some(rx) = bus.port(q).try_receive() {
                    received.push((q, rx.frame, rx.at));
                }
                reported.extend(results(&mut bus.port(q)).into_iter().map(|r| (q, r)));
            }
        }
        bus.run_until_idle(bus.now() + 5 * MS);
        let sent: Vec<(u64, usize, Frame)> = bus.frames().collect();
        for (_, p, f) in &sent {
            prop_assert!(offered.contains(&(*p, *f)), "sent but never offered: {f:?}");
        }
        for (q, f, at) in &received {
            prop_assert!(
                sent.iter().any(|(t, p, g)| g == f && p != q && t / 1000 == *at),
                "port {q} received {f:?} at {at} that nobody else sent then"
            );
        }
        let times: Vec<u64> = bus.trace().iter().map(|e| e.time_ns).collect();
        prop_assert!(times.windows(2).all(|w| w[0] <= w[1]), "trace out of order");
        // Results name frames the port loaded; a frame reported sent went out.
        for (q, r) in &reported {
            prop_assert!(offered.iter().any(|(p, f)| p == q && f.id() == r.id), "{r:?} never loaded");
            if r.sent() {
                prop_assert!(sent.iter().any(|(_, p, f)| p == q && f.id() == r.id), "{r:?} not sent");
            }
        }
    }
}
