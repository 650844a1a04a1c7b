//! Traces back onto a bus: read a candump log or a pcap file (told apart by their first
//! bytes) and send its frames again, with their original spacing or as fast as possible.
//!
//! The schedule is computed from the frames' own times ([`schedule`]), so what a replay does
//! depends only on the trace; [`replay`] then sends each frame when its offset from the start
//! has passed on the wall clock. Times that go backwards in a trace (two merged logs, a clock
//! step) do not make the replay wait or go back: such a frame goes out right after the
//! previous one.

use std::fs::File;
use std::io::{self, BufReader, Read, Write};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use crate::candump::{read_log, LogWriter};
use crate::frame::{CanFrame, Stamped};
use crate::hub::Hub;
use crate::pcap::{looks_like_pcap, parse_pcap, write_pcap};

/// The two trace formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// candump log (`(SECS.USECS) CHANNEL ID#DATA` lines).
    Candump,
    /// pcap with link type `LINKTYPE_CAN_SOCKETCAN`.
    Pcap,
}

impl Format {
    /// The format a file is written in, from its name: `.pcap` (or `.cap`) is pcap, anything
    /// else a candump log.
    pub fn for_path(path: &Path) -> Format {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("pcap" | "cap") => Format::Pcap,
            _ => Format::Candump,
        }
    }
}

/// Reads a trace in either format, whatever its name: pcap files are recognised by their magic
/// number. Errors name the file and the line or record.
pub fn read_trace(path: &Path) -> io::Result<(Format, Vec<Stamped>)> {
    let named = |e: io::Error| io::Error::new(e.kind(), format!("{}: {e}", path.display()));
    let mut bytes = Vec::new();
    File::open(path).and_then(|f| BufReader::new(f).read_to_end(&mut bytes)).map_err(named)?;
    parse_trace(&bytes).map_err(named)
}

/// Parses a trace held in memory (see [`read_trace`]).
pub fn parse_trace(bytes: &[u8]) -> io::Result<(Format, Vec<Stamped>)> {
    if looks_like_pcap(bytes) {
        return Ok((Format::Pcap, parse_pcap(bytes)?));
    }
    let records = read_log(bytes)?;
    let frames = records.into_iter().map(|r| Stamped { time: r.time, frame: r.frame }).collect();
    Ok((Format::Candump, frames))
}

/// Writes `frames` in `format` (candump lines name the interface `channel`).
pub fn write_trace<W: Write>(
    out: W,
    format: Format,
    channel: &str,
    frames: &[Stamped],
) -> io::Result<W> {
    match format {
        Format::Pcap => write_pcap(out, frames),
        Format::Candump => {
            let mut w = LogWriter::new(out, channel);
            for s in frames {
                w.write(s)?;
            }
            w.flush()?;
            Ok(w.into_inner())
        }
    }
}

/// How fast a trace is replayed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pacing {
    /// Each frame at its original offset from the first one.
    Original,
    /// Back to back, as fast as the receiver takes them.
    Fast,
}

/// When each frame goes out, as an offset from the start of the replay: its time minus the
/// first frame's, never less than the previous frame's offset (zero for every frame with
/// [`Pacing::Fast`]).
pub fn schedule(frames: &[Stamped], pacing: Pacing) -> Vec<Duration> {
    let Some(first) = frames.first() else { return Vec::new() };
    let mut last = Duration::ZERO;
    frames
        .iter()
        .map(|s| {
            if pacing == Pacing::Original {
                last = last.max(s.time.saturating_sub(first.time));
            }
            last
        })
        .collect()
}

/// Longest sleep between checks of the stop flag.
const STOP_POLL: Duration = Duration::from_millis(50);

/// Sends `frames` through `send` on `pacing`'s schedule, until done or `stop` is set. Returns
/// how many frames were sent; stops at the first error of `send`.
pub fn replay(
    frames: &[Stamped],
    pacing: Pacing,
    stop: &AtomicBool,
    mut send: impl FnMut(&CanFrame) -> io::Result<()>,
) -> io::Result<usize> {
    let start = Instant::now();
    for (n, (s, at)) in frames.iter().zip(schedule(frames, pacing)).enumerate() {
        loop {
            if stop.load(Ordering::SeqCst) {
                return Ok(n);
            }
            let now = start.elapsed();
            if now >= at {
                break;
            }
            thread::sleep((at - now).min(STOP_POLL));
        }
        send(&s.frame)?;
    }
    Ok(frames.len())
}

/// Replays `frames` onto `hub` as a new participant (every other participant receives them).
pub fn replay_into_hub(
    hub: &dyn Hub,
    frames: &[Stamped],
    pacing: Pacing,
    stop: &AtomicBool,
) -> usize {
    let me = hub.join();
    replay(frames, pacing, stop, |f| {
        hub.send(me, *f);
        Ok(())
    })
    .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hub::BroadcastHub;

    fn at(ms: u64, n: u8) -> Stamped {
        Stamped {
            time: Duration::from_millis(1_700_000_000_000 + ms),
            frame: CanFrame::extended(0x100 + u32::from(n), &[n]).unwrap(),
        }
    }

    #[test]
    fn the_schedule_keeps_spacing_and_never_goes_back() {
        let frames = [at(0, 0), at(5, 1), at(5, 2), at(3, 3), at(30, 4)];
        let ms = |v: Vec<Duration>| v.iter().map(|d| d.as_millis()).collect::<Vec<_>>();
        assert_eq!(ms(schedule(&frames, Pacing::Original)), [0, 5, 5, 5, 30]);
        assert_eq!(ms(schedule(&frames, Pacing::Fast)), [0, 0, 0, 0, 0]);
        assert!(schedule(&[], Pacing::Original).is_empty());
    }

    #[test]
    fn replay_sends_everything_in_order_at_the_original_pace() {
        let frames: Vec<_> = (0..5).map(|i| at(u64::from(i) * 20, i)).collect();
        let hub = BroadcastHub::new();
        let rx = hub.subscribe(hub.join(), 64);
        let t0 = Instant::now();
        assert_eq!(replay_into_hub(&hub, &frames, Pacing::Original, &AtomicBool::new(false)), 5);
        assert!(t0.elapsed() >= Duration::from_millis(80), "{:?}", t0.elapsed());
        let got: Vec<_> = std::iter::from_fn(|| rx.try_recv().ok()).map(|s| s.frame).collect();
        assert_eq!(got, frames.iter().map(|s| s.frame).collect::<Vec<_>>());
    }

    #[test]
    fn a_stop_flag_ends_the_replay_and_errors_stop_it() {
        let frames = [at(0, 0), at(60_000, 1)];
        let stop = AtomicBool::new(true);
        assert_eq!(replay(&frames, Pacing::Original, &stop, |_| Ok(())).unwrap(), 0);
        let mut sent = 0;
        let e = replay(&frames, Pacing::Fast, &AtomicBool::new(false), |_| {
            sent += 1;
            Err(io::Error::other("link down"))
        });
        assert_eq!((e.unwrap_err().to_string(), sent), ("link down".to_string(), 1));
    }

    #[test]
    fn traces_convert_both_ways_and_are_recognised_by_content() {
        let frames = [at(0, 0), at(1, 1), at(2, 2)];
        let log = write_trace(Vec::new(), Format::Candump, "vcan0", &frames).unwrap();
        let pcap = write_trace(Vec::new(), Format::Pcap, "vcan0", &frames).unwrap();
        assert_eq!(parse_trace(&log).unwrap(), (Format::Candump, frames.to_vec()));
        assert_eq!(parse_trace(&pcap).unwrap(), (Format::Pcap, frames.to_vec()));
        // candump → pcap → candump gives the same bytes back.
        let (_, back) = parse_trace(&pcap).unwrap();
        assert_eq!(write_trace(Vec::new(), Format::Candump, "vcan0", &back).unwrap(), log);
        assert_eq!(Format::for_path(Path::new("x/bus.PCAP")), Format::Pcap);
        assert_eq!(Format::for_path(Path::new("bus.log")), Format::Candump);
        let e = parse_trace(b"(1.0) vcan0 123#00\nnonsense\n").unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
    }
}
