//! `r2p replay` (a trace's frames onto a bus) and `r2p convert` (candump log ↔ pcap).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use clap::Args;
use r2p_canlink::replay::{read_trace, replay as replay_frames, write_trace, Format, Pacing};

use crate::args::{open_link, BusArgs};
use crate::error::CliError;

/// `r2p replay` options.
#[derive(Args, Debug)]
pub struct ReplayArgs {
    /// The trace: a candump log or a pcap file (told apart by content)
    pub file: PathBuf,
    /// Send the frames back to back instead of with their recorded spacing
    #[arg(long)]
    pub fast: bool,
}

/// `r2p convert` options.
#[derive(Args, Debug)]
pub struct ConvertArgs {
    /// The trace to read: a candump log or a pcap file (told apart by content)
    pub input: PathBuf,
    /// The file to write: pcap if it ends in .pcap, else a candump log (its lines name the
    /// interface --channel)
    pub output: PathBuf,
}

fn format_name(f: Format) -> &'static str {
    match f {
        Format::Candump => "candump log",
        Format::Pcap => "pcap",
    }
}

/// Runs `r2p convert`.
pub fn convert(args: &ConvertArgs, bus: &BusArgs, _out: &mut dyn Write) -> Result<(), CliError> {
    let (from, frames) = read_trace(&args.input).map_err(|e| CliError::new(e.to_string()))?;
    let to = Format::for_path(&args.output);
    let err = |e: std::io::Error| CliError::new(format!("{}: {e}", args.output.display()));
    let file = File::create(&args.output).map_err(err)?;
    write_trace(BufWriter::new(file), to, &bus.channel, &frames)
        .and_then(|mut w| w.flush())
        .map_err(err)?;
    eprintln!(
        "r2p: converted {} frames: {} ({}) -> {} ({})",
        frames.len(),
        args.input.display(),
        format_name(from),
        args.output.display(),
        format_name(to)
    );
    Ok(())
}

/// Runs `r2p replay`.
pub fn replay(args: &ReplayArgs, bus: &BusArgs, _out: &mut dyn Write) -> Result<(), CliError> {
    if bus.trace.is_some() {
        return Err(CliError::new(
            "replay sends onto a live bus: give --socketcand or --socketcan, not --trace",
        ));
    }
    let (_, frames) = read_trace(&args.file).map_err(|e| CliError::new(e.to_string()))?;
    let mut link = open_link(bus)?;
    let pacing = if args.fast { Pacing::Fast } else { Pacing::Original };
    let start = Instant::now();
    let mut failure = None;
    let sent = replay_frames(&frames, pacing, &AtomicBool::new(false), |f| {
        link.send(f).map_err(|e| {
            failure = Some(e.clone());
            std::io::Error::other(e.to_string())
        })
    })
    .unwrap_or_default();
    if let Some(e) = failure {
        return Err(CliError::new(format!("after {sent} of {} frames: {e}", frames.len())));
    }
    eprintln!(
        "r2p: replayed {sent} frames from {} onto {} in {:.3} s",
        args.file.display(),
        link.describe(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
