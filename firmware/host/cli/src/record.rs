//! `r2p record FILE.mcap`: the topics on a live bus (or a trace), decoded, into an MCAP
//! recording for Foxglove and the mcap libraries (`crate::mcap_log`).

use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use clap::Args;
use r2p_canlink::Stamped;

use crate::args::{emit, parse_seconds, BusArgs};
use crate::error::CliError;
use crate::mcap_log::McapLog;
use crate::session::Session;

/// `r2p record` options.
#[derive(Args, Debug)]
pub struct RecordArgs {
    /// The recording to write (MCAP: its name should end in .mcap)
    pub file: PathBuf,
    /// Stop after SECONDS; without it, record until Enter is pressed (or standard input
    /// closes) or the bus ends (a --trace: its end)
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    pub seconds: Option<Duration>,
    /// Do not join the bus: only listen. By default the CLI's node joins first, so that every
    /// module advertises its topics again and they are named from the start
    #[arg(long)]
    pub passive: bool,
}

/// Set when a line or the end arrives on standard input.
fn stdin_stop() -> Arc<AtomicBool> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    std::thread::spawn(move || {
        let _ = std::io::stdin().lock().read_line(&mut String::new());
        flag.store(true, Ordering::SeqCst);
    });
    stop
}

/// Runs `r2p record`.
pub fn run(
    args: &RecordArgs,
    bus: &BusArgs,
    mut s: Session,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let path = args.file.display().to_string();
    if args.file.extension().and_then(|e| e.to_str()) != Some("mcap") {
        return Err(CliError::new(format!(
            "{path}: `r2p record` writes MCAP; name the file FILE.mcap (for pcap or candump \
             traces: `r2p monitor --write FILE`)"
        )));
    }
    let file = std::fs::File::create(&args.file)
        .map_err(|e| CliError::new(format!("cannot create {path}: {e}")))?;
    let mut log = McapLog::new(std::io::BufWriter::new(file))?;
    if !args.passive {
        s.join()?;
    }
    let stop = if args.seconds.is_none() && bus.trace.is_none() {
        if !bus.json {
            emit(out, &format!("r2p record: recording to {path}; press Enter to stop"))?;
        }
        Some(stdin_stop())
    } else {
        None
    };
    let start = Instant::now();
    loop {
        let stopped = stop.as_ref().is_some_and(|f| f.load(Ordering::SeqCst));
        if stopped || args.seconds.is_some_and(|d| start.elapsed() >= d) || s.ended() {
            break;
        }
        for r in s.step(Duration::from_millis(5))? {
            log.feed(&Stamped { time: r.time, frame: r.frame })?;
        }
    }
    let st = log.finish()?;
    let line = if bus.json {
        serde_json::json!({
            "file": path, "messages": st.messages, "channels": st.channels,
            "unknown": st.unknown, "undecodable": st.undecodable, "frames": st.frames,
        })
        .to_string()
    } else {
        format!(
            "r2p record: {path}: {} messages on {} channels from {} frames ({} of streams not \
             advertised while recording or of unknown types, {} that did not decode)",
            st.messages, st.channels, st.frames, st.unknown, st.undecodable
        )
    };
    emit(out, &line)
}
