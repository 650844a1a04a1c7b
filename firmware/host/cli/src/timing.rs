//! `r2p timing`: the RTCAN cycle as a trace's timestamps show it — how regularly the master's
//! syncs start the cycles, and where each HRT stream's frames start in theirs. On a robot this
//! checks on silicon what the emulator and QEMU can only predict: the slot timer's leads
//! (docs/rtcan.md, "The slot lead", "The sync lead") and the HRT streams' jitter.
//!
//! Each frame's start of frame comes from its stamp. A trace stamps a frame at its end (the
//! emulator's traces; a candleLight/gs_usb adapter's hardware timestamps, `candump -H -L`) or,
//! with `--stamped-at start`, at its start of frame. An end-stamped frame started its exact
//! length earlier: header, data and CRC with the stuff bits its content makes
//! (`r2p_vbus::bits`), then the tail to the end of EOF. Software timestamps (`candump` without
//! `-H`) carry the host's latency and say little at this scale.

use std::collections::BTreeMap;
use std::io::Write;

use clap::{Args, ValueEnum};
use r2p_canlink::Stamped;
use r2p_vbus::bits::{stuff_count, unstuffed_bits, TAIL_BITS};
use rtcan::{Frame, Laxity, SyncFrame};
use serde_json::json;

use crate::args::{emit, BusArgs};
use crate::error::CliError;

/// `r2p timing`'s options (the trace comes from `--trace`).
#[derive(Args, Debug)]
pub struct TimingArgs {
    /// The bus's bit rate, bit/s (classic CAN: at most 1 000 000)
    #[arg(long, value_name = "BIT/S", default_value_t = 1_000_000,
          value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub bit_rate: u32,
    /// Where the trace stamps each frame
    #[arg(long, value_enum, default_value = "end")]
    pub stamped_at: StampedAt,
}

/// Where a trace's timestamps lie in each frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum StampedAt {
    /// At the end of the frame (the emulator's traces, gs_usb hardware timestamps)
    End,
    /// At its start of frame
    Start,
}

/// The shortest and longest of some durations (ns), and how many.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Span {
    /// How many.
    pub n: usize,
    /// The shortest, ns.
    pub min: i64,
    /// The longest, ns.
    pub max: i64,
}

impl Span {
    fn one(v: i64) -> Self {
        Self { n: 1, min: v, max: v }
    }

    fn with(self, v: i64) -> Self {
        Self { n: self.n + 1, min: self.min.min(v), max: self.max.max(v) }
    }

    fn of(values: impl IntoIterator<Item = i64>) -> Option<Self> {
        values.into_iter().fold(None, |s, v| Some(s.map_or(Self::one(v), |s| s.with(v))))
    }
}

/// One HRT frame of a stream (a message ID and the fragment the frame carries) across the
/// trace: when it starts in its cycle.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StreamTiming {
    /// The stream's message ID (its publisher's node ID in the high byte).
    pub message: u16,
    /// Which frame of the message.
    pub fragment: u8,
    /// Its start of frame after its cycle's sync's, ns.
    pub offset: Span,
}

/// What a trace shows of the cycle.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Timing {
    /// Syncs in the trace.
    pub syncs: usize,
    /// The median time from one sync's start of frame to the next's, ns.
    pub median_period: Option<i64>,
    /// The times from one sync's start to the next's, ns, those within half a median of it.
    pub period: Option<Span>,
    /// The others: a sync missed, or a new master's first cycle.
    pub gaps: usize,
    /// Every HRT frame after the trace's first sync, per stream and fragment.
    pub streams: Vec<StreamTiming>,
}

/// A frame's length from its start of frame to the end of its EOF, in bit times.
pub fn frame_bits(raw_id: u32, data: &[u8]) -> u32 {
    let bits = unstuffed_bits(raw_id, data);
    bits.len() as u32 + stuff_count(&bits) + TAIL_BITS
}

/// `s`'s start of frame (ns), from its stamp as `args` says.
pub fn start_of_frame(s: &Stamped, args: &TimingArgs) -> i64 {
    let stamp = s.time.as_nanos() as i64;
    match args.stamped_at {
        StampedAt::Start => stamp,
        StampedAt::End => {
            let bits = f64::from(frame_bits(s.frame.id(), s.frame.data()));
            stamp - (bits * 1e9 / f64::from(args.bit_rate.max(1))).round() as i64
        }
    }
}

/// The cycle's timing in `frames` (in time order), stamped as `args` says.
pub fn analyse(frames: &[Stamped], args: &TimingArgs) -> Timing {
    let mut syncs: Vec<i64> = Vec::new();
    let mut streams: BTreeMap<(u16, u8), Span> = BTreeMap::new();
    for s in frames {
        let Ok(frame) = Frame::from_raw(s.frame.id(), s.frame.data()) else { continue };
        let start = start_of_frame(s, args);
        if SyncFrame::from_frame(&frame).is_ok() {
            syncs.push(start);
        } else if frame.id().laxity == Laxity::HRT {
            // Frames do not overlap on the bus: the last sync before it is its cycle's.
            let Some(&sync) = syncs.last().filter(|&&t| t <= start) else { continue };
            let key = (frame.id().message.0, frame.id().fragment);
            let offset = start - sync;
            streams.entry(key).and_modify(|o| *o = o.with(offset)).or_insert(Span::one(offset));
        }
    }
    let periods: Vec<i64> = syncs.windows(2).map(|w| w[1] - w[0]).collect();
    let median_period = {
        let mut sorted = periods.clone();
        sorted.sort_unstable();
        sorted.get(sorted.len() / 2).copied()
    };
    let regular = |p: &&i64| median_period.is_some_and(|m| (**p - m).abs() <= m / 2);
    Timing {
        syncs: syncs.len(),
        median_period,
        period: Span::of(periods.iter().filter(regular).copied()),
        gaps: periods.iter().filter(|p| !regular(p)).count(),
        streams: streams
            .into_iter()
            .map(|((message, fragment), offset)| StreamTiming { message, fragment, offset })
            .collect(),
    }
}

/// Runs `r2p --trace FILE timing`.
pub fn run(args: &TimingArgs, bus: &BusArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let Some(path) = &bus.trace else {
        return Err(CliError::new(
            "r2p timing reads a trace: give one with --trace FILE (a candump log with hardware \
             timestamps, `candump -H -L can0 > bus.log`, or pcap; or `r2p sim … --log FILE`)",
        ));
    };
    let (_, frames) = r2p_canlink::replay::read_trace(path)
        .map_err(|e| CliError::new(format!("reading the trace: {e}")))?;
    let t = analyse(&frames, args);
    if t.syncs < 2 {
        return Err(CliError::new(format!(
            "{}: {} sync(s) in {} frames: no cycle to measure (is it an RTCAN bus in TDMA mode?)",
            path.display(),
            t.syncs,
            frames.len()
        )));
    }
    let us = |ns: i64| ns as f64 / 1e3;
    if bus.json {
        let span = |s: &Span| json!({"n": s.n, "min_us": us(s.min), "max_us": us(s.max)});
        let streams: Vec<_> = t
            .streams
            .iter()
            .map(|s| {
                json!({"message": s.message, "fragment": s.fragment, "offset": span(&s.offset)})
            })
            .collect();
        let line = json!({
            "syncs": t.syncs,
            "median_period_us": t.median_period.map(us),
            "period": t.period.as_ref().map(span),
            "gaps": t.gaps,
            "hrt": streams,
        });
        return emit(out, &line.to_string());
    }
    let median = t.median_period.map_or(0.0, us);
    let p = t.period.expect("two syncs make a period");
    emit(
        out,
        &format!(
            "syncs: {}, one every {median:.1} µs (median); from one start of frame to the next \
             {:.1}–{:.1} µs (spread {:.1} µs); {} gap(s) (a sync missed, a new master)",
            t.syncs,
            us(p.min),
            us(p.max),
            us(p.max - p.min),
            t.gaps
        ),
    )?;
    for s in &t.streams {
        emit(
            out,
            &format!(
                "HRT 0x{:04X} frame {}: {} frames, {:.1}–{:.1} µs after their cycle's sync \
                 (spread {:.1} µs)",
                s.message,
                s.fragment,
                s.offset.n,
                us(s.offset.min),
                us(s.offset.max),
                us(s.offset.max - s.offset.min)
            ),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    fn is_sync(s: &Stamped) -> bool {
        Frame::from_raw(s.frame.id(), s.frame.data())
            .is_ok_and(|f| SyncFrame::from_frame(&f).is_ok())
    }

    fn args() -> TimingArgs {
        TimingArgs { bit_rate: 1_000_000, stamped_at: StampedAt::End }
    }

    /// The emulated demo robot for 1 s, its bus's frames stamped as its traces are.
    fn demo() -> (Vec<Stamped>, Vec<u64>) {
        let (mut sim, _) = r2p_emu::demo::build(1).expect("the demo, once in this process");
        sim.run_until(1_000_000_000);
        let starts = r2p_emu::sync_starts(sim.bus()).into_iter().map(|s| s.0).collect();
        (r2p_emu::serve::stamped_frames(sim.bus()), starts)
    }

    #[test]
    fn an_emulated_robots_trace_gives_its_syncs_starts_and_a_steady_cycle() {
        let (frames, starts) = demo();
        let t = analyse(&frames, &args());
        // The syncs' starts of frame, from their end stamps (µs in the trace) and their bits:
        // the bus's own, to the µs.
        let epoch = Duration::from_secs(r2p_emu::serve::EPOCH_S).as_nanos() as i64;
        assert_eq!(t.syncs, starts.len());
        let ours: Vec<i64> = frames
            .iter()
            .filter(|s| is_sync(s))
            .map(|s| start_of_frame(s, &args()) - epoch)
            .collect();
        for (&o, &s) in ours.iter().zip(&starts) {
            assert!((o - s as i64).abs() < 1_000, "start of frame {o} ns, the bus's {s} ns");
        }
        // The demo's 10 ms cycle, every sync a cycle after the last (to the stamps' µs), the
        // master's first too (loaded at the end of the tick in which it took over, which the
        // emulator times on the slot path, as the firmware's path then is).
        assert_eq!(t.median_period, Some(10_000_000));
        let p = t.period.unwrap();
        assert!(p.max - p.min <= 1_000, "{p:?}");
        assert_eq!(t.gaps, 0);
        // Its HRT stream (the motor's setpoint, slot 1 every 2 cycles): every frame within
        // the emulated path's 2 µs of its slot's start and the stamps' µs.
        assert!(!t.streams.is_empty());
        for s in &t.streams {
            assert!(s.offset.n >= 30, "{s:?}");
            assert!(s.offset.max - s.offset.min <= 3_000, "{s:?}");
            // A slot's start (the demo's 250 µs slots) and the 2 µs, to the stamps' µs.
            assert!(s.offset.min >= 250_000, "{s:?}");
            assert!((s.offset.min % 250_000).abs_diff(2_000) <= 1_000, "{s:?}");
        }
        // A sync stamped 5 µs late shows as a period 5 µs long and the next 5 µs short.
        let mut late = frames.clone();
        let i = late.iter().enumerate().filter(|(_, s)| is_sync(s)).nth(50).unwrap().0;
        late[i].time += Duration::from_micros(5);
        let p2 = analyse(&late, &args()).period.unwrap();
        assert_eq!((p2.min, p2.max), (9_995_000, 10_005_000), "{p:?} → {p2:?}");
    }

    #[test]
    fn a_start_stamped_trace_is_taken_as_it_is() {
        let sync = |cycle: u32, at_us: u64| {
            let f = SyncFrame::new(cycle, 0b10, false).to_frame();
            Stamped {
                time: Duration::from_micros(at_us),
                frame: r2p_canlink::CanFrame::extended(f.id().to_raw(), f.payload()).unwrap(),
            }
        };
        let frames = [sync(0, 1_000), sync(1, 11_000), sync(2, 21_003), sync(4, 41_003)];
        let t = analyse(&frames, &TimingArgs { stamped_at: StampedAt::Start, ..args() });
        assert_eq!(t.syncs, 4);
        assert_eq!(t.median_period, Some(10_003_000));
        assert_eq!(t.period, Some(Span { n: 2, min: 10_000_000, max: 10_003_000 }));
        assert_eq!(t.gaps, 1, "a missing sync: 20 ms between two");
        // Stamped at their ends, the same syncs started their own lengths earlier: the periods
        // move by the few stuff bits their cycle counters make them differ by.
        let ends = analyse(&frames, &args()).period.unwrap();
        let p = t.period.unwrap();
        assert!((ends.min - p.min).abs() <= 3_000 && (ends.max - p.max).abs() <= 3_000, "{ends:?}");
    }

    /// A start-stamped frame at `at_us`: a sync of `cycle`, or else an HRT frame of `message`.
    fn stamped(at_us: u64, cycle: u32, message: Option<u16>) -> Stamped {
        let f = match message {
            None => SyncFrame::new(cycle, 0b10, false).to_frame(),
            Some(m) => {
                let id = rtcan::FrameId {
                    laxity: Laxity::HRT,
                    message: rtcan::MessageId(m),
                    fragment: 0,
                };
                Frame::new(id, &[1, 2, 3, 4]).unwrap()
            }
        };
        Stamped {
            time: Duration::from_micros(at_us),
            frame: r2p_canlink::CanFrame::extended(f.id().to_raw(), f.payload()).unwrap(),
        }
    }

    #[test]
    fn the_median_period_is_the_middle_one() {
        let at = [1_000, 11_000, 21_003, 41_003, 51_004];
        let frames: Vec<_> = at.iter().zip(0..).map(|(&t, c)| stamped(t, c, None)).collect();
        let t = analyse(&frames, &TimingArgs { stamped_at: StampedAt::Start, ..args() });
        // Periods 10 000, 10 003, 20 000 and 10 001 µs: the median of four, the upper middle.
        assert_eq!(t.median_period, Some(10_003_000));
    }

    /// `r2p --trace FILE timing …` on `frames` written as a candump log: its exit and output.
    fn run_on(frames: &[Stamped], extra: &[&str]) -> (Result<(), CliError>, String) {
        use clap::Parser;
        let path = std::env::temp_dir().join(format!(
            "r2p-timing-{}-{}.log",
            std::process::id(),
            frames.len()
        ));
        let mut w =
            r2p_canlink::candump::LogWriter::new(std::fs::File::create(&path).unwrap(), "can0");
        frames.iter().for_each(|s| w.write(s).unwrap());
        w.flush().unwrap();
        let mut argv = std::vec!["r2p", "--trace", path.to_str().unwrap()];
        argv.extend(extra);
        let mut out = Vec::new();
        let r = crate::cli::run(crate::cli::Cli::try_parse_from(argv).unwrap(), &mut out);
        std::fs::remove_file(&path).unwrap();
        (r, String::from_utf8(out).unwrap())
    }

    #[test]
    fn run_prints_the_cycle_in_microseconds_and_needs_two_syncs() {
        let frames =
            [stamped(1_000, 0, None), stamped(11_000, 1, None), stamped(11_169, 0, Some(0x7F02))];
        let (r, out) = run_on(&frames, &["timing", "--stamped-at", "start"]);
        r.unwrap();
        assert!(out.starts_with("syncs: 2, one every 10000.0 µs (median)"), "{out}");
        assert!(out.contains("10000.0–10000.0 µs (spread 0.0 µs); 0 gap(s)"), "{out}");
        assert!(out.contains("HRT 0x7F02 frame 0: 1 frames, 169.0–169.0 µs"), "{out}");
        let (r, out) = run_on(&frames, &["--json", "timing", "--stamped-at", "start"]);
        r.unwrap();
        let j: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
        assert_eq!(j["median_period_us"], 10_000.0);
        assert_eq!(j["hrt"][0]["offset"]["min_us"], 169.0);
        // One sync is no cycle: said, not a panic.
        let (r, _) = run_on(&frames[..1], &["timing", "--stamped-at", "start"]);
        let err = r.expect_err("one sync").to_string();
        assert!(err.contains("1 sync(s) in 1 frames: no cycle to measure"), "{err}");
    }

    #[test]
    fn a_bit_rate_classic_can_cannot_have_is_refused_by_name() {
        use clap::Parser;
        let parse = |rate: &str| {
            crate::cli::Cli::try_parse_from([
                "r2p",
                "--trace",
                "t.log",
                "timing",
                "--bit-rate",
                rate,
            ])
        };
        assert!(parse("500000").is_ok());
        for rate in ["0", "2000000"] {
            let err = parse(rate).expect_err(rate).to_string();
            assert!(err.contains("--bit-rate") && err.contains("1..=1000000"), "{err}");
        }
    }

    #[test]
    fn frame_bits_count_the_stuff_bits_of_the_content() {
        // An 8-byte frame of zeros stuffs more than one of alternating bits.
        let zeros = frame_bits(0x0100_0000, &[0; 8]);
        let alternating = frame_bits(0x0100_0000, &[0x55; 8]);
        assert!(zeros > alternating, "{zeros} vs {alternating}");
        // Never beyond the worst case rtcan reserves for (intermission included there).
        assert!(zeros + 3 <= rtcan::cycle::frame_bits_of(0x0100_0000, 8), "{zeros}");
    }
}
