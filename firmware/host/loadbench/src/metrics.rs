//! From a run's bus log to the report: which message each frame carried, when it started and
//! ended on the wire, and the figures per class.

use r2p_vbus::{EventKind, FrameBits};
use serde::Serialize;

use crate::record::{Carried, Counters};
use crate::run::Run;
use crate::setup::Setup;
use crate::traffic::{Kind, Traffic};

/// What became of one message on the wire.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Delivery {
    /// Frames of it that went out.
    pub frames: u8,
    /// Start of its first frame, ns.
    pub first_start_ns: u64,
    /// End of frame (EOF) of its last frame, ns.
    pub end_ns: u64,
}

/// Matches every `Sent` event of the bus log with the frame its node says it sent.
pub fn deliveries(traffic: &Traffic, run: &Run) -> Vec<Delivery> {
    let mut out = vec![Delivery::default(); traffic.messages.len()];
    let mut cursor = vec![0usize; run.sent.len()];
    for e in &run.trace {
        let EventKind::Sent { start_ns, frame, .. } = e.kind else { continue };
        let sent = run.sent[e.port][cursor[e.port]];
        cursor[e.port] += 1;
        assert_eq!(sent.raw_id, frame.id().to_raw(), "node {} and the bus disagree", e.port);
        if let Carried::Message { msg, fragment } = sent.what {
            let d = &mut out[msg as usize];
            if d.frames == 0 {
                d.first_start_ns = start_ns;
            }
            d.frames += 1;
            if rtcan::fragment::is_last_frame(fragment) {
                d.end_ns = e.time_ns;
            }
        }
    }
    out
}

/// The value at quantile `q` (nearest rank) of sorted `v`.
fn quantile(v: &[f64], q: f64) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let rank = (q * v.len() as f64).ceil() as usize;
    Some(v[rank.clamp(1, v.len()) - 1])
}

/// One policy's figures at one load point (times in µs).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Report {
    /// The policy's name.
    pub policy: &'static str,
    /// Bits on the wire of frames that started in the window (syncs included), over its bit
    /// times.
    pub utilisation: f64,
    /// HRT messages released.
    pub hrt_messages: u64,
    /// HRT messages not delivered within their period.
    pub hrt_missed: u64,
    /// Share delivered within their period.
    pub hrt_on_time: f64,
    /// RTCAN: share sent entirely inside their reserved slot (fixed priority: none).
    pub hrt_in_slot: Option<f64>,
    /// RTCAN: share that ended by their reserved slot's end, wherever they started (with
    /// `Setup::hrt_follow` they start early; fixed priority: none).
    pub hrt_ended_in_slot: Option<f64>,
    /// Largest |start of frame − nominal start| (slot start, or the frame-sized reservation's;
    /// release for fixed priority).
    pub hrt_jitter_max_us: f64,
    /// 99th percentile of the same.
    pub hrt_jitter_p99_us: f64,
    /// SRT messages released.
    pub srt_messages: u64,
    /// SRT messages not delivered by their deadline (dropped or late).
    pub srt_missed: u64,
    /// `srt_missed / srt_messages`.
    pub srt_miss_ratio: f64,
    /// Latency release → end of last frame of delivered SRT messages: median.
    pub srt_p50_us: Option<f64>,
    /// 95th percentile.
    pub srt_p95_us: Option<f64>,
    /// 99.9th percentile.
    pub srt_p999_us: Option<f64>,
    /// NRT messages released.
    pub nrt_messages: u64,
    /// Share of them delivered before the run ended.
    pub nrt_delivered: f64,
    /// The nodes' counters.
    pub counters: Counters,
    /// Simulation events.
    pub events: u64,
}

/// The figures of `run`.
pub fn report(setup: &Setup, traffic: &Traffic, run: &Run) -> Report {
    let del = deliveries(traffic, run);
    let (start_ns, end_ns) = (setup.start_us() * 1_000, setup.end_us() * 1_000);
    let bit_ns = setup.bit_ns() as f64;
    let busy_ns: f64 = run
        .trace
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Sent { start_ns: s, frame, .. } if (start_ns..end_ns).contains(&s) => {
                Some(f64::from(FrameBits::of(&frame).total()) * bit_ns)
            }
            _ => None,
        })
        .sum();
    let slotted = run.policy != crate::run::Policy::Fixed;
    let cycle_us = setup.cycle.cycle_us;

    let (mut hrt, mut hrt_missed, mut in_slot, mut ended_in_slot) = (0u64, 0u64, 0u64, 0u64);
    let mut jitter = Vec::new();
    let (mut srt, mut srt_missed) = (0u64, 0u64);
    let mut latency = Vec::new();
    let (mut nrt, mut nrt_done) = (0u64, 0u64);
    for (i, (m, d)) in traffic.messages.iter().zip(&del).enumerate() {
        let stream = &traffic.streams[usize::from(m.stream)];
        let release_ns = m.release_us * 1_000;
        let delivered = d.frames == m.frames;
        let on_time =
            delivered && traffic.deadline_us(m, cycle_us).is_none_or(|dl| d.end_ns <= dl * 1_000);
        match stream.kind {
            Kind::Hrt { phase, .. } => {
                hrt += 1;
                hrt_missed += u64::from(!on_time);
                if delivered {
                    let grid_end = u64::from(setup.cycle.slot_offset_us(phase.slot + 1))
                        + u64::from(m.cycle) * u64::from(cycle_us);
                    let (due_ns, end_us) = match &run.reservations {
                        Some(r) => (r[i].0 * 1_000, r[i].1),
                        None => (release_ns, grid_end),
                    };
                    jitter.push(d.first_start_ns.abs_diff(due_ns) as f64 / 1e3);
                    in_slot += u64::from(d.first_start_ns >= due_ns && d.end_ns <= end_us * 1_000);
                    ended_in_slot += u64::from(d.end_ns <= end_us * 1_000);
                }
            }
            Kind::Srt { .. } => {
                srt += 1;
                srt_missed += u64::from(!on_time);
                if delivered {
                    latency.push((d.end_ns - release_ns) as f64 / 1e3);
                }
            }
            Kind::Nrt => {
                nrt += 1;
                nrt_done += u64::from(delivered);
            }
        }
    }
    jitter.sort_by(f64::total_cmp);
    latency.sort_by(f64::total_cmp);
    let ratio = |a: u64, b: u64| if b == 0 { 0.0 } else { a as f64 / b as f64 };
    Report {
        policy: run.policy.name(),
        utilisation: busy_ns / (setup.duration_us as f64 * 1e3),
        hrt_messages: hrt,
        hrt_missed,
        hrt_on_time: ratio(hrt - hrt_missed, hrt),
        hrt_in_slot: slotted.then(|| ratio(in_slot, hrt)),
        hrt_ended_in_slot: slotted.then(|| ratio(ended_in_slot, hrt)),
        hrt_jitter_max_us: jitter.last().copied().unwrap_or(0.0),
        hrt_jitter_p99_us: quantile(&jitter, 0.99).unwrap_or(0.0),
        srt_messages: srt,
        srt_missed,
        srt_miss_ratio: ratio(srt_missed, srt),
        srt_p50_us: quantile(&latency, 0.50),
        srt_p95_us: quantile(&latency, 0.95),
        srt_p999_us: quantile(&latency, 0.999),
        nrt_messages: nrt,
        nrt_delivered: ratio(nrt_done, nrt),
        counters: run.counters,
        events: run.events,
    }
}
