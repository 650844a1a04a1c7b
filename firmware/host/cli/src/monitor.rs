//! `r2p monitor`: every frame, decoded, one line each (or one JSON object each).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use clap::Args;
use r2p_canlink::candump::LogWriter;
use r2p_canlink::pcap::PcapWriter;
use r2p_canlink::replay::Format;
use r2p_canlink::Stamped;
use rtcan::LaxityEncoding;

use crate::args::{emit, parse_laxity, parse_seconds, BusArgs};
use crate::describe::{report_json, report_line};
use crate::error::CliError;
use crate::session::Session;

/// `r2p monitor` options.
#[derive(Args, Debug)]
pub struct MonitorArgs {
    /// Stop after N frames
    #[arg(long, value_name = "N")]
    pub count: Option<u64>,
    /// Stop after SECONDS
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    pub seconds: Option<Duration>,
    /// Join the bus as node r2p-cli first, so that every module advertises its topics again and
    /// topic frames are named (and their values decoded) at once
    #[arg(long)]
    pub announce: bool,
    /// Also record every frame to FILE: pcap if it ends in .pcap, else a candump log
    #[arg(long, value_name = "FILE")]
    pub write: Option<PathBuf>,
    /// How the bus encodes SRT laxity (log:TICK_US or linear:TICK_US), to show the least time
    /// left to an SRT frame's deadline
    #[arg(long, value_name = "ENCODING", default_value = "log:100", value_parser = parse_laxity)]
    pub laxity: LaxityEncoding,
}

/// A trace being recorded in either format.
enum Recorder {
    Pcap(PcapWriter<BufWriter<File>>),
    Candump(LogWriter<BufWriter<File>>),
}

impl Recorder {
    fn create(path: &Path, channel: &str) -> Result<Self, CliError> {
        let err = |e: std::io::Error| CliError::new(format!("--write {}: {e}", path.display()));
        let file = BufWriter::new(File::create(path).map_err(err)?);
        Ok(match Format::for_path(path) {
            Format::Pcap => Recorder::Pcap(PcapWriter::new(file).map_err(err)?),
            Format::Candump => Recorder::Candump(LogWriter::new(file, channel)),
        })
    }

    fn write(&mut self, s: &Stamped) -> std::io::Result<()> {
        match self {
            Recorder::Pcap(w) => w.write(s),
            Recorder::Candump(w) => w.write(s),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Recorder::Pcap(w) => w.flush(),
            Recorder::Candump(w) => w.flush(),
        }
    }
}

/// Runs `r2p monitor`.
pub fn run(
    args: &MonitorArgs,
    bus: &BusArgs,
    mut s: Session,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    if args.announce {
        s.join()?;
    }
    let mut recorder =
        args.write.as_deref().map(|p| Recorder::create(p, &bus.channel)).transpose()?;
    let start = Instant::now();
    let mut shown = 0u64;
    loop {
        if args.seconds.is_some_and(|d| start.elapsed() >= d) || s.ended() {
            break;
        }
        for r in s.step(Duration::from_millis(5))? {
            if let Some(rec) = &mut recorder {
                rec.write(&Stamped { time: r.time, frame: r.frame })
                    .map_err(|e| CliError::new(format!("--write: {e}")))?;
            }
            let line = if bus.json {
                report_json(&r, s.watcher(), args.laxity).to_string()
            } else {
                report_line(&r, s.watcher(), args.laxity)
            };
            emit(out, &line)?;
            shown += 1;
            if args.count.is_some_and(|n| shown >= n) {
                break;
            }
        }
        if let Some(rec) = &mut recorder {
            rec.flush().map_err(|e| CliError::new(format!("--write: {e}")))?;
        }
        if args.count.is_some_and(|n| shown >= n) {
            break;
        }
    }
    Ok(())
}
