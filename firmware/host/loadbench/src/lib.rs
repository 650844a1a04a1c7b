//! RTCAN under load (the paper's Fig. 8, extended): the same seeded traffic — periodic HRT
//! control streams, SRT messages with random deadlines, NRT filler — offered at a chosen share
//! of the bus to RTCAN nodes and to plain fixed-priority CAN nodes on the virtual CAN bus
//! ([`r2p_vbus`]: exact frame lengths with stuffing, bitwise arbitration), in virtual time.
//!
//! The RTCAN nodes use the protocol crate itself — [`rtcan::TxQueue`] (EDF order, laxity
//! codes in identifiers), [`rtcan::SlotClock`] on the master's [`rtcan::SyncFrame`] frames,
//! [`rtcan::Scheduler`] phases — and the node runtime's slot transmit path
//! ([`r2p_node::SlotTx`]: windows, one-shot or merged, latest-start guard, results), driven slot
//! by slot as the node runtime drives them ([`rtcan_node`]). The baseline ([`fixed_node`]) gives every stream a static rate-monotonic
//! identifier. [`point`] runs one offered load and reports, per protocol, HRT on-time ratio and
//! start jitter, SRT deadline misses and latency percentiles, and the bus utilisation reached
//! ([`metrics::Report`]). Same setup and seed, same report: nothing reads a clock.
#![warn(missing_docs)]

pub mod fixed_node;
pub mod metrics;
pub mod publish;
pub mod record;
pub mod rtcan_node;
pub mod run;
pub mod setup;
pub mod traffic;

use serde::Serialize;

pub use metrics::Report;
pub use run::{run, Policy};
pub use setup::{Setup, SetupError};
pub use traffic::Traffic;

/// The outcome of one load point.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Point {
    /// Requested offered load.
    pub load: f64,
    /// Offered load the traffic reached (bits on the wire over bit times).
    pub offered: f64,
    /// Its HRT, SRT and NRT parts.
    pub offered_hrt: f64,
    /// SRT part.
    pub offered_srt: f64,
    /// NRT part.
    pub offered_nrt: f64,
    /// Share of the bus time RTCAN reserves: the sync slot of every cycle and the slot of every
    /// HRT occurrence, whatever the frames in them occupy.
    pub reserved_share: f64,
    /// The most RTCAN can carry with this calendar on its fixed slot grid: every bit time but
    /// the reserved slots' idle remainder (a slot of 166 µs holds one sync or HRT frame of
    /// 100–160 bits, and nothing else may start in it without delaying the next slot's owner).
    /// At 95 % offered load this ceiling is below issue 22's 92 % (docs/rtcan.md, "Capacity").
    pub grid_ceiling: f64,
    /// The ceiling if every reservation lasted its own frame's worst case (its data length,
    /// worst-case stuffing, intermission) plus [`RESERVATION_GUARD_BITS`] instead of a whole
    /// slot: what the frame-sized reservations of docs/rtcan.md "Capacity" could reach with this
    /// calendar — a bound computed from the run's frames, not a run of that protocol.
    pub frame_sized_ceiling: f64,
    /// The cycle's length, µs.
    pub cycle_us: u32,
    /// Where the grid calendar's slots lie: (slot, start µs, length µs, 256ths of the cycles it
    /// is reserved in), the sync's first; for the layout picture of docs/rtcan.md.
    pub grid_slots: Vec<[u32; 4]>,
    /// The same for the frame-sized calendar (`rtcan::layout`, [`Traffic::framed`]).
    pub framed_slots: Vec<[u32; 4]>,
    /// Streams per class: HRT, SRT, NRT.
    pub streams: [usize; 3],
    /// Messages released.
    pub messages: usize,
    /// One report per policy, in the order asked.
    pub reports: Vec<Report>,
}

pub use rtcan::layout::RESERVATION_GUARD_BITS;

/// The sync's slot and every slot `calendar` reserves, in slot order: (slot, start, length,
/// 256ths of the cycles it is reserved in), `at` giving start and length.
fn slots_of<const N: usize>(
    calendar: &rtcan::Scheduler<N>,
    at: impl Fn(u8) -> (u32, u32),
) -> Vec<[u32; 4]> {
    let mut used = [0u32; 64];
    used[usize::from(rtcan::cycle::SYNC_SLOT)] = 256;
    for r in calendar.iter() {
        used[usize::from(r.phase.slot)] += 256 / r.period.cycles();
    }
    (0..64u8)
        .filter(|&s| used[usize::from(s)] > 0)
        .map(|s| {
            let (start, len) = at(s);
            [u32::from(s), start, len, used[usize::from(s)]]
        })
        .collect()
}

/// Generates the traffic of `setup` and runs it under each of `policies`.
pub fn point(setup: &Setup, policies: &[Policy]) -> Result<Point, SetupError> {
    let traffic = Traffic::generate(setup)?;
    let cap = setup.capacity_bits();
    let share = |f: fn(&traffic::Kind) -> bool| traffic.offered_bits_of(f) as f64 / cap;
    let count =
        |f: fn(&traffic::Kind) -> bool| traffic.streams.iter().filter(|s| f(&s.kind)).count();
    let is_hrt: fn(&traffic::Kind) -> bool = |k| matches!(k, traffic::Kind::Hrt { .. });
    let is_srt: fn(&traffic::Kind) -> bool = |k| matches!(k, traffic::Kind::Srt { .. });
    let is_nrt: fn(&traffic::Kind) -> bool = |k| matches!(k, traffic::Kind::Nrt);
    let reports = policies
        .iter()
        .map(|&p| metrics::report(setup, &traffic, &run(setup, &traffic, p)))
        .collect();
    let hrt_messages: Vec<_> = traffic
        .messages
        .iter()
        .filter(|m| is_hrt(&traffic.streams[usize::from(m.stream)].kind))
        .collect();
    let cycles = setup.duration_us as f64 / f64::from(setup.cycle.cycle_us);
    // What the reserved slots carry, with RTCAN's own identifiers: one sync per cycle (its
    // length varies a little with the cycle counter: the first one stands for all) and each
    // HRT message in its slot.
    let sync = rtcan::SyncFrame::new(0, 0, false).to_frame();
    let reserved_worst_bits = cycles
        * f64::from(rtcan::cycle::frame_bits(sync.payload().len()) + RESERVATION_GUARD_BITS)
        + hrt_messages
            .iter()
            .map(|m| f64::from(rtcan::cycle::frame_bits(m.payload.len()) + RESERVATION_GUARD_BITS))
            .sum::<f64>();
    let slotted_bits = cycles * f64::from(r2p_vbus::FrameBits::of(&sync).total())
        + hrt_messages
            .iter()
            .map(|m| {
                let id = rtcan::FrameId {
                    laxity: rtcan::Laxity::HRT,
                    message: traffic.streams[usize::from(m.stream)].message,
                    fragment: 0,
                };
                let frame = rtcan::Frame::new(id, &m.payload).expect("HRT payloads fit one frame");
                f64::from(r2p_vbus::FrameBits::of(&frame).total())
            })
            .sum::<f64>();
    let slot_us = f64::from(setup.cycle.cycle_us) / f64::from(setup.cycle.slots);
    let reserved_us = (hrt_messages.len() as f64 + cycles) * slot_us;
    Ok(Point {
        load: setup.load,
        offered: traffic.offered_load(setup),
        offered_hrt: share(is_hrt),
        offered_srt: share(is_srt),
        offered_nrt: share(is_nrt),
        reserved_share: reserved_us / setup.duration_us as f64,
        grid_ceiling: 1.0
            - (reserved_us * f64::from(setup.cycle.bit_rate) / 1e6 - slotted_bits) / cap,
        frame_sized_ceiling: 1.0 - (reserved_worst_bits - slotted_bits) / cap,
        cycle_us: setup.cycle.cycle_us,
        grid_slots: slots_of(&traffic.scheduler, |slot| {
            let start = setup.cycle.slot_offset_us(slot);
            (start, setup.cycle.slot_offset_us(slot + 1) - start)
        }),
        framed_slots: slots_of(&traffic.framed, |slot| {
            let span = traffic.layout.span(slot).expect("a slot of the calendar is placed");
            (u32::from(span.start_us), u32::from(span.len_us))
        }),
        streams: [count(is_hrt), count(is_srt), count(is_nrt)],
        messages: traffic.messages.len(),
        reports,
    })
}
