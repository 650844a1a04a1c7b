//! The experiment's mechanics: determinism, the offered-load generator, and what the protocols
//! must do at the extremes of the sweep. Behaviour only: no wall-clock timing is asserted.

use r2p_loadbench::metrics::deliveries;
use r2p_loadbench::traffic::Kind;
use r2p_loadbench::{point, run, Policy, Setup, SetupError, Traffic};
use r2p_node::FreeSlots;
use r2p_vbus::bits::INTERMISSION_BITS;
use r2p_vbus::{EventKind, FrameBits};
use rtcan::cycle::frame_bits as worst_case_frame_bits;
use rtcan::framed_cycle::{FramedCycle, Moment};
use rtcan::{Laxity, SyncFrame};

/// The RTCAN policies (the node runtime's default and both free-slot policies).
const RTCAN: [Policy; 3] = [Policy::Rtcan, Policy::RtcanOneShot, Policy::RtcanMerged];

/// A short load point (debug builds run these tests).
fn short(load: f64, seed: u64, duration_us: u64) -> Setup {
    Setup { duration_us, ..Setup::new(load, seed) }
}

#[test]
fn the_same_seed_gives_the_same_results() {
    let setup = short(0.7, 7, 300_000);
    let a = point(&setup, &Policy::ALL).unwrap();
    let b = point(&setup, &Policy::ALL).unwrap();
    assert_eq!(a, b);
    let traffic = Traffic::generate(&setup).unwrap();
    for policy in Policy::ALL {
        let (x, y) = (run(&setup, &traffic, policy), run(&setup, &traffic, policy));
        assert_eq!(x.trace, y.trace, "{policy:?}: bus logs differ");
    }
}

#[test]
fn another_seed_gives_other_traffic() {
    let a = Traffic::generate(&short(0.5, 1, 200_000)).unwrap();
    let b = Traffic::generate(&short(0.5, 2, 200_000)).unwrap();
    assert_ne!(a.messages, b.messages);
}

#[test]
fn the_generator_reaches_the_requested_load_within_one_percent() {
    for load in [0.1, 0.3, 0.5, 0.7, 0.9, 0.95] {
        let setup = short(load, 3, 1_000_000);
        let t = Traffic::generate(&setup).unwrap();
        let offered = t.offered_load(&setup);
        assert!((offered - load).abs() <= 0.01 * load, "asked {load}, offered {offered}");
        // Every class is present and the shares add up.
        let share = |f: fn(&Kind) -> bool| t.offered_bits_of(f) as f64 / setup.capacity_bits();
        let hrt = share(|k| matches!(k, Kind::Hrt { .. }));
        let srt = share(|k| matches!(k, Kind::Srt { .. }));
        let nrt = share(|k| matches!(k, Kind::Nrt));
        assert!(hrt > 0.0 && srt > 0.0 && nrt > 0.0, "{load}: {hrt} {srt} {nrt}");
        assert!((hrt + srt + nrt - offered).abs() < 1e-9);
    }
}

#[test]
fn offered_bits_are_the_bits_the_bus_carries() {
    // At light load the baseline sends every frame once: the bus's own bit count of them
    // (stuffing, intermission) is exactly what the generator offered.
    let setup = short(0.1, 4, 500_000);
    let traffic = Traffic::generate(&setup).unwrap();
    let r = run(&setup, &traffic, Policy::Fixed);
    let on_wire: u64 = r
        .trace
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Sent { frame, .. } => Some(u64::from(FrameBits::of(&frame).total())),
            _ => None,
        })
        .sum();
    assert_eq!(on_wire, traffic.offered_bits);
}

#[test]
fn hrt_messages_are_released_at_their_reserved_slot() {
    let setup = short(0.6, 5, 200_000);
    let t = Traffic::generate(&setup).unwrap();
    let mut seen = 0;
    for m in &t.messages {
        let Kind::Hrt { period, phase, .. } = t.streams[usize::from(m.stream)].kind else {
            continue;
        };
        let slot_start = u64::from(m.cycle) * u64::from(setup.cycle.cycle_us)
            + u64::from(setup.cycle.slot_offset_us(phase.slot));
        assert_eq!(m.release_us, slot_start);
        assert_eq!(m.cycle % period.cycles(), u32::from(phase.offset));
        seen += 1;
    }
    assert!(seen > 100);
}

#[test]
fn at_light_load_nothing_misses() {
    let p = point(&short(0.1, 6, 1_000_000), &Policy::ALL).unwrap();
    for r in &p.reports {
        assert_eq!(r.hrt_missed, 0, "{}", r.policy);
        assert_eq!((r.srt_missed, r.nrt_delivered), (0, 1.0), "{}", r.policy);
        if r.policy != "fixed" {
            assert_eq!(r.hrt_in_slot, Some(1.0), "{}", r.policy);
            assert_eq!(r.hrt_jitter_max_us, 0.0, "{}", r.policy);
        }
    }
    // The baseline has no slots: an HRT frame waits for the frame on the wire.
    let fixed = p.reports.iter().find(|r| r.policy == "fixed").unwrap();
    assert!(fixed.hrt_jitter_max_us > 0.0);
}

#[test]
fn reserved_slots_stay_isolated_at_95_percent() {
    let p = point(&short(0.95, 8, 500_000), &RTCAN).unwrap();
    for r in &p.reports {
        assert_eq!(r.hrt_in_slot, Some(1.0), "{}", r.policy);
        assert_eq!(r.hrt_jitter_max_us, 0.0, "{}", r.policy);
        assert_eq!(r.counters.resyncs, 0, "{}", r.policy);
    }
}

/// SRT/NRT frame starts per (cycle start, slot), checking on the way that each started in a
/// free slot no later than its window's latest start and left the bus by the window's end
/// (the window: the slot, or the free slots up to the next reserved one or sync).
fn check_windows(setup: &Setup, policy: Policy) -> std::collections::HashMap<(u64, u8), u32> {
    let traffic = Traffic::generate(setup).unwrap();
    let r = run(setup, &traffic, policy);
    let cycle = setup.cycle;
    let merged = policy.free_slots() == Some(FreeSlots::Merged);
    let (mut start_of_cycle, mut mask, mut next_mask) = (None, None, None);
    let mut starts = std::collections::HashMap::new();
    for e in &r.trace {
        let EventKind::Sent { start_ns, frame, .. } = e.kind else { continue };
        let start = start_ns / 1_000;
        if let Ok(sync) = SyncFrame::from_frame(&frame) {
            let continuous = start_of_cycle.is_some_and(|c| start - c == u64::from(cycle.cycle_us));
            start_of_cycle = Some(start);
            mask = next_mask.filter(|_| continuous);
            next_mask = Some(sync.reservations | 1);
            continue;
        }
        if frame.id().laxity == Laxity::HRT {
            continue;
        }
        let (c, mask) = (start_of_cycle.expect("a sync first"), mask.expect("reservations known"));
        let slot = (0..cycle.slots)
            .rev()
            .find(|&j| c + u64::from(cycle.slot_offset_us(j)) <= start)
            .unwrap();
        assert!(mask & 1 << slot == 0, "{policy:?}: {frame:?} in reserved slot {slot}");
        let end_slot = if merged {
            (slot + 1..cycle.slots).find(|&j| mask & 1 << j != 0).unwrap_or(cycle.slots)
        } else {
            slot + 1
        };
        let end = c + u64::from(cycle.slot_offset_us(end_slot));
        let idle = e.time_ns / 1_000 + u64::from(INTERMISSION_BITS);
        assert!(start + u64::from(cycle.frame_us()) <= end, "{policy:?}: {frame:?} starts late");
        assert!(idle <= end, "{policy:?}: {frame:?} ends {} µs into the next window", idle - end);
        *starts.entry((c, slot)).or_insert(0) += 1;
    }
    starts
}

#[test]
fn no_frame_leaves_its_window_and_single_slots_carry_one_frame() {
    // 90 %: the windows are full, frames contend in every one of them.
    let setup = short(0.9, 11, 300_000);
    let single = check_windows(&setup, Policy::RtcanOneShot);
    assert_eq!(single.values().max(), Some(&1), "one frame per free slot");
    let merged = check_windows(&setup, Policy::RtcanMerged);
    assert!(merged.values().filter(|&&n| n >= 2).count() > 100, "frames back to back");
}

#[test]
fn merged_windows_carry_more_than_single_slots_at_high_load() {
    let p = point(&short(0.9, 12, 500_000), &[Policy::RtcanOneShot, Policy::RtcanMerged]).unwrap();
    let (single, merged) = (&p.reports[0], &p.reports[1]);
    // One frame of 75-150 bits per 166 µs free slot: at most ~90 % of the free time.
    assert!(single.utilisation < merged.utilisation - 0.05, "{single:?} {merged:?}");
}

/// Frames that started the moment the same node's previous frame left the bus.
fn back_to_back_same_node(setup: &Setup, policy: Policy) -> usize {
    let traffic = Traffic::generate(setup).unwrap();
    let r = run(setup, &traffic, policy);
    let mut last: Option<(usize, u64)> = None;
    let mut n = 0;
    for e in &r.trace {
        let EventKind::Sent { start_ns, .. } = e.kind else { continue };
        let idle = |end_ns: u64| end_ns + u64::from(INTERMISSION_BITS) * 1_000;
        if last.is_some_and(|(port, end)| port == e.port && start_ns == idle(end)) {
            n += 1;
        }
        last = Some((e.port, e.time_ns));
    }
    n
}

#[test]
fn in_merged_windows_a_node_sends_its_next_frames_back_to_back() {
    // Several frames in the mailboxes: a multi-frame message leaves without a gap; one frame
    // per window (single slots) never can.
    let setup = short(0.5, 14, 300_000);
    assert_eq!(back_to_back_same_node(&setup, Policy::RtcanOneShot), 0);
    assert!(back_to_back_same_node(&setup, Policy::RtcanMerged) > 100);
}

#[test]
fn fixed_priority_at_95_percent_misses_low_priority_srt_deadlines() {
    let setup = short(0.95, 10, 1_000_000);
    let traffic = Traffic::generate(&setup).unwrap();
    let r = run(&setup, &traffic, Policy::Fixed);
    let del = deliveries(&traffic, &r);
    let mut misses_by_rank = vec![0u32; 64];
    let mut srt_ranks = Vec::new();
    for (m, d) in traffic.messages.iter().zip(&del) {
        let s = &traffic.streams[usize::from(m.stream)];
        let Kind::Srt { deadline_us, .. } = s.kind else { continue };
        srt_ranks.push(s.rank);
        let deadline_ns = (m.release_us + u64::from(deadline_us)) * 1_000;
        if d.frames < m.frames || d.end_ns > deadline_ns {
            misses_by_rank[usize::from(s.rank)] += 1;
        }
    }
    srt_ranks.sort_unstable();
    srt_ranks.dedup();
    let missed: u32 = misses_by_rank.iter().sum();
    assert!(missed > 0, "fixed priority met every deadline at 95 %");
    // Misses fall on the low priorities: none in the most urgent stream, most of them in the
    // less urgent half of the SRT streams.
    let (high, low) = srt_ranks.split_at(srt_ranks.len() / 2);
    let sum = |ranks: &[u8]| ranks.iter().map(|&k| misses_by_rank[usize::from(k)]).sum::<u32>();
    assert_eq!(misses_by_rank[usize::from(high[0])], 0, "{misses_by_rank:?}");
    assert!(sum(low) > 2 * sum(high), "{misses_by_rank:?}");
}

#[test]
fn reserved_slots_come_in_runs_of_two_with_a_free_slot_after_each() {
    let setup = short(0.9, 13, 200_000);
    let t = Traffic::generate(&setup).unwrap();
    let most = (0..64).map(|c| t.mask(c)).max_by_key(|m| m.count_ones()).unwrap();
    assert!(most.count_ones() > 10, "{most:#b}");
    for c in 0..64 {
        let m = t.mask(c);
        // The sync slot and at most two reserved slots in a row: SRT waits ≤ 3 slots.
        assert_eq!(m & m >> 1 & m >> 2 & !1, 0, "cycle {c}: three reserved slots in a row {m:#b}");
        assert_eq!(m & 0b1000, 0, "cycle {c}: slot 3 follows the first run {m:#b}");
    }
    // Reservations are where the HRT messages go, and nowhere else.
    let p = point(&setup, &[Policy::Rtcan]).unwrap();
    assert_eq!((p.reports[0].hrt_missed, p.reports[0].hrt_in_slot), (0, Some(1.0)));
    let e = Traffic::generate(&Setup { hrt_slots: 30, ..setup }).unwrap_err();
    assert_eq!(e, SetupError::HrtSlots(30));
}

#[test]
fn a_bad_setup_is_refused_with_the_reason() {
    let e = Traffic::generate(&Setup::new(1.5, 0)).unwrap_err();
    assert_eq!(e, SetupError::Load(1.5));
    assert!(e.to_string().contains("outside (0, 1]"));
    let e = Traffic::generate(&Setup { nodes: 1, ..Setup::new(0.5, 0) }).unwrap_err();
    assert_eq!(e, SetupError::Nodes(1));
    let e = Traffic::generate(&Setup { srt_deadline_us: (5_000, 1_000), ..Setup::new(0.5, 0) });
    assert_eq!(e.unwrap_err(), SetupError::Deadlines((5_000, 1_000)));
    for blocks in [0, rtcan::layout::MAX_BLOCKS + 1] {
        let e = Traffic::generate(&Setup { hrt_blocks: blocks, ..Setup::new(0.5, 0) });
        assert_eq!(e.unwrap_err(), SetupError::HrtBlocks(blocks));
    }
}

#[test]
fn rtcan_never_carries_more_than_its_slot_grid_leaves() {
    // The grid's ceiling (docs/rtcan.md, "Capacity"): every bit time but the idle remainder of
    // the reserved slots. What RTCAN carries stays under it, and it is the reserved time's
    // complement plus the sync and HRT frames' own bits (a sync is at most 160 bits, 200 a
    // second: 3.2 % of the bus).
    let p = point(&short(0.95, 6, 500_000), &RTCAN).unwrap();
    assert!(p.grid_ceiling < 1.0, "{}", p.grid_ceiling);
    let frames = p.grid_ceiling - (1.0 - p.reserved_share);
    assert!(frames > p.offered_hrt && frames < p.offered_hrt + 0.032, "{frames} {}", p.offered_hrt);
    for r in &p.reports {
        assert!(
            r.utilisation <= p.grid_ceiling,
            "{:?}: {} > {}",
            r.policy,
            r.utilisation,
            p.grid_ceiling
        );
    }
}

#[test]
fn frame_sized_reservations_would_leave_only_their_frames_worst_case_idle() {
    // Worst-case lengths (docs/rtcan.md, "Slot length"): 8 bytes is the slot's 160 bits, an
    // empty frame 80, a 4-byte HRT frame 120.
    assert_eq!(worst_case_frame_bits(8), rtcan::cycle::WORST_CASE_FRAME_BITS);
    assert_eq!(worst_case_frame_bits(0), 80);
    assert_eq!(worst_case_frame_bits(4), 120);
    // Sized to their frames, the reservations leave more of the bus than the grid, never all of
    // it (each still idles its frame's stuffing slack and the guard).
    let p = point(&short(0.95, 6, 500_000), &RTCAN).unwrap();
    assert!(
        p.frame_sized_ceiling > p.grid_ceiling + 0.03,
        "{} {}",
        p.frame_sized_ceiling,
        p.grid_ceiling
    );
    assert!(p.frame_sized_ceiling < 1.0, "{}", p.frame_sized_ceiling);
}

#[test]
fn frame_sized_reservations_keep_hrt_frames_on_time_and_strictly_periodic() {
    // Issue 22's capacity what-if (`rtcan_framed`): at 95 % the free window is full up to each
    // reservation, and every HRT frame still starts at its reservation's start and ends inside
    // it; each stream's frames start at one offset in the cycle, every cycle.
    let setup = short(0.95, 8, 500_000);
    let traffic = Traffic::generate(&setup).unwrap();
    let r = run(&setup, &traffic, Policy::RtcanFramed);
    let report = r2p_loadbench::metrics::report(&setup, &traffic, &r);
    assert_eq!(report.hrt_missed, 0);
    assert_eq!(report.hrt_in_slot, Some(1.0));
    assert_eq!(report.hrt_jitter_max_us, 0.0);
    let due = r.reservations.as_ref().expect("framed runs report their reservations");
    let cycle_us = u64::from(setup.cycle.cycle_us);
    let mut offset = std::collections::HashMap::new();
    for (m, d) in traffic.messages.iter().zip(deliveries(&traffic, &r)) {
        if let Kind::Hrt { .. } = traffic.streams[usize::from(m.stream)].kind {
            let at = d.first_start_ns / 1_000 % cycle_us;
            assert_eq!(*offset.entry(m.stream).or_insert(at), at, "stream {} moved", m.stream);
            let i = traffic.messages.iter().position(|x| std::ptr::eq(x, m)).unwrap();
            assert!(due[i].0 % cycle_us == at && due[i].1 > due[i].0);
        }
    }
    assert!(offset.len() > 10, "{} HRT streams", offset.len());
}

#[test]
fn hrt_frames_that_follow_go_early_inside_their_run_and_end_inside_their_reservation() {
    // `Setup::hrt_follow` (what-if): an HRT frame whose reservation starts where another ends
    // is loaded while that one is on the wire and goes at its actual end. It starts early (by
    // the stuff bits the frames before it in the run did not need), never before its run's
    // first reservation, and still ends by its own reservation's end: 0 misses.
    let setup = Setup { hrt_follow: true, ..short(0.95, 8, 500_000) };
    let traffic = Traffic::generate(&setup).unwrap();
    let r = run(&setup, &traffic, Policy::RtcanFramed);
    let report = r2p_loadbench::metrics::report(&setup, &traffic, &r);
    assert_eq!((report.hrt_missed, report.hrt_ended_in_slot), (0, Some(1.0)));
    let due = r.reservations.as_ref().expect("framed runs report their reservations");
    let cycle_us = u64::from(setup.cycle.cycle_us);
    let (mut early, mut hrt) = (0, 0);
    for (i, (m, d)) in traffic.messages.iter().zip(deliveries(&traffic, &r)).enumerate() {
        let Kind::Hrt { .. } = traffic.streams[usize::from(m.stream)].kind else { continue };
        let (start, end) = (d.first_start_ns / 1_000, d.end_ns / 1_000);
        // The run of reservations back to back that ends with this one, this cycle.
        let (c, mut run_start) = (due[i].0 / cycle_us, due[i].0 % cycle_us);
        let mask = traffic.framed_mask(c as u32) | 1;
        let announced = traffic.layout.iter().filter(|&(slot, _)| mask & 1 << slot != 0);
        let spans: Vec<(u64, u64)> =
            announced.map(|(_, s)| (u64::from(s.start_us), u64::from(s.end_us()))).collect();
        while let Some(&(before, _)) = spans.iter().find(|&&(_, e)| e == run_start) {
            run_start = before;
        }
        assert!(start <= due[i].0 && end <= due[i].1, "message {i}: {start}–{end} in {:?}", due[i]);
        assert!(start >= c * cycle_us + run_start, "message {i} at {start}, before its run");
        early += u64::from(start < due[i].0);
        hrt += 1;
    }
    assert!(early * 2 > hrt, "{early} of {hrt} HRT frames went early");
    assert!(report.hrt_jitter_max_us > 20.0, "{report:?}");
}

#[test]
fn framed_windows_end_before_every_reservation_and_carry_past_the_grids_ceiling() {
    let setup = short(0.95, 6, 500_000);
    let traffic = Traffic::generate(&setup).unwrap();
    let r = run(&setup, &traffic, Policy::RtcanFramed);
    let cycle_us = u64::from(setup.cycle.cycle_us);
    // No SRT/NRT frame, intermission included, runs into a reservation's start, or starts in
    // a reservation before its owner's frame has (`FOLLOW_US` after its start: only the last
    // of a block lets free frames follow its frame).
    // Per cycle: each announced reservation, from its start until free frames may follow it.
    let held_in = |c: u64| -> Vec<(u64, u64)> {
        let cycle = FramedCycle::new(&traffic.layout, traffic.framed_mask(c as u32));
        let reserved =
            |slot, t| matches!(cycle.at(t), Moment::Reserved { slot: Some(s), .. } if s == slot);
        traffic
            .layout
            .iter()
            .filter(|&(slot, res)| reserved(slot, u32::from(res.start_us)))
            .map(|(slot, res)| {
                let start = u32::from(res.start_us);
                let free_at = (start..res.end_us()).find(|&t| !reserved(slot, t));
                let at = |us: u32| c * cycle_us + u64::from(us);
                (at(start), at(free_at.unwrap_or(res.end_us())))
            })
            .collect()
    };
    let mut held = std::collections::HashMap::new();
    let mut free_frames = 0;
    for e in &r.trace {
        let EventKind::Sent { start_ns, frame, .. } = e.kind else { continue };
        if SyncFrame::from_frame(&frame).is_ok() || frame.id().laxity == Laxity::HRT {
            continue;
        }
        let (start, idle) = (start_ns / 1_000, e.time_ns / 1_000 + u64::from(INTERMISSION_BITS));
        let cycle = start / cycle_us;
        for c in [cycle, cycle + 1] {
            for &(a, b) in held.entry(c).or_insert_with(|| held_in(c)) as &Vec<(u64, u64)> {
                assert!(idle <= a || start >= b, "{frame:?} at {start}–{idle} µs overlaps {a}–{b}");
            }
        }
        free_frames += 1;
    }
    assert!(free_frames > 1_000, "{free_frames}");
    // What no layout of whole slots can carry (docs/rtcan.md, "Capacity").
    let p = point(&setup, &[Policy::RtcanFramed]).unwrap();
    assert!(
        p.reports[0].utilisation > p.grid_ceiling + 0.01,
        "{:?} {}",
        p.reports[0],
        p.grid_ceiling
    );
    assert!(p.reports[0].utilisation <= p.frame_sized_ceiling);
}

#[test]
fn a_reservation_sized_by_its_identifier_holds_every_frame_of_that_identifier() {
    // `rtcan::cycle::frame_bits_of`: the header's stuffing exactly, the worst case after it.
    // Every frame the bus carries fits it, and it is never longer than the identifier-blind
    // worst case (the slot's 160 bits for 8 bytes).
    use rand::{RngExt, SeedableRng};
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(22);
    let mut saved = 0u32;
    for _ in 0..20_000 {
        let raw_id = rng.random::<u32>() & 0x1fff_ffff;
        let len = rng.random_range(0..=8usize);
        let data: Vec<u8> = (0..len)
            .map(|_| {
                if rng.random_bool(0.5) {
                    rng.random()
                } else {
                    [0, 0xff][rng.random_range(0..2)]
                }
            })
            .collect();
        let bound = rtcan::cycle::frame_bits_of(raw_id, len);
        let actual = FrameBits::of_raw(raw_id, &data).total();
        // The header's part, from the bus's own encoder: its stuff bits and last run exactly.
        let bits = r2p_vbus::bits::unstuffed_bits(raw_id, &data);
        let header = rtcan::cycle::HEADER_BITS as usize;
        let (mut level, mut run, mut stuff) = (None, 0, 0);
        for &bit in &bits[..header] {
            run = if level == Some(bit) { run + 1 } else { 1 };
            level = Some(bit);
            if run == 5 {
                (stuff, level, run) = (stuff + 1, Some(!bit), 1);
            }
        }
        let rest = (bits.len() - header) as u32;
        let exact_header = header as u32 + stuff + rest + (rest + run - 1) / 4 + 10 + 3;
        assert_eq!(bound, exact_header, "id {raw_id:#x} len {len}");
        assert!(actual <= bound, "id {raw_id:#x} {data:02x?}: {actual} > {bound}");
        assert!(bound <= worst_case_frame_bits(len), "id {raw_id:#x} len {len}");
        saved += worst_case_frame_bits(len) - bound;
    }
    assert!(saved > 20_000 * 3, "{saved}"); // a few bits a frame: what the reservation gains
}
