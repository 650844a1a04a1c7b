//! MCAP recordings of an R2P bus (issue 23): `r2p sim ROBOT --seconds N --log x.mcap` and
//! `r2p record x.mcap`. MCAP (mcap.dev, the `mcap` crate of the format's authors) is what
//! Foxglove, `ros2 bag` (rosbag2's MCAP storage) and the `mcap` Python library read.
//!
//! The bus is decoded passively, as `r2p monitor` does ([`Watcher`]): advertisements name each
//! stream's topic and type; every message of an advertised topic whose type the CLI knows is
//! written on that topic's channel as JSON (`message_encoding` "json") with a JSON Schema of
//! its type (`schema encoding` "jsonschema"): one channel per topic and type, one schema per
//! type, the log time the frame's time on the bus. JSON rather than CDR because R2P types have
//! no ROS 2 package a reader would need installed; Foxglove plots JSON fields directly. A
//! message of a topic the recording has not seen advertised yet (it started mid-run) or of an
//! unknown type is counted, not written; so are messages that do not decode.
//!
//! Only what is on the bus is recorded: a topic nobody subscribed to over the bus stays on its
//! module. Recordings of the emulated robot are reproducible byte for byte (no wall-clock time
//! in the file; chunks uncompressed).

use std::collections::BTreeMap;
use std::io::{Seek, Write};

use crate::describe::class_text;
use crate::error::CliError;
use crate::types::MsgType;
use crate::watch::{TopicInfo, Watcher, What};
use r2p_canlink::Stamped;

/// What a recording wrote and skipped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct McapStats {
    /// Messages written.
    pub messages: u64,
    /// Channels (topic and type pairs).
    pub channels: usize,
    /// Messages of streams not (yet) advertised, or of types the CLI does not know.
    pub unknown: u64,
    /// Messages whose bytes their type refused.
    pub undecodable: u64,
    /// Frames seen.
    pub frames: u64,
}

/// A recording being written to `W`.
pub struct McapLog<W: Write + Seek> {
    writer: mcap::Writer<W>,
    watcher: Watcher,
    /// Channel IDs by (topic, type name).
    channels: BTreeMap<(String, String), u16>,
    /// Sequence number of each channel's next message.
    sequence: BTreeMap<u16, u32>,
    stats: McapStats,
}

fn mcap_error(e: mcap::McapError) -> CliError {
    CliError::new(format!("writing the MCAP file: {e}"))
}

impl<W: Write + Seek> McapLog<W> {
    /// A recording on `out` (a file: MCAP's summary is written at the end, seeking back).
    pub fn new(out: W) -> Result<Self, CliError> {
        let options = mcap::WriteOptions::new().compression(None).profile("").library("r2p");
        Ok(Self {
            writer: options.create(out).map_err(mcap_error)?,
            watcher: Watcher::new(),
            channels: BTreeMap::new(),
            sequence: BTreeMap::new(),
            stats: McapStats::default(),
        })
    }

    /// The channel of `info`'s topic with type `t`, made at its first message.
    fn channel(&mut self, info: &TopicInfo, t: &MsgType) -> Result<u16, CliError> {
        let key = (info.topic.clone(), t.name.clone());
        if let Some(&id) = self.channels.get(&key) {
            return Ok(id);
        }
        let schema = serde_json::to_vec(&t.json_schema()).expect("a JSON value serialises");
        let schema_id =
            self.writer.add_schema(&t.name, "jsonschema", &schema).map_err(mcap_error)?;
        let metadata = BTreeMap::from([
            ("r2p_type_hash".to_string(), format!("0x{:08X}", t.hash)),
            ("r2p_class".to_string(), class_text(info.class)),
        ]);
        let id = self
            .writer
            .add_channel(schema_id, &info.topic, "json", &metadata)
            .map_err(mcap_error)?;
        self.channels.insert(key, id);
        self.stats.channels = self.channels.len();
        Ok(id)
    }

    /// Takes one frame off the bus; writes the message it completes, if any.
    pub fn feed(&mut self, s: &Stamped) -> Result<(), CliError> {
        self.stats.frames += 1;
        let report = self.watcher.feed(s);
        let What::Topic { topic, done: Some(bytes), .. } = report.what else { return Ok(()) };
        let Some((info, t)) = topic.and_then(|i| i.msg_type().map(|t| (i, t))) else {
            self.stats.unknown += 1;
            return Ok(());
        };
        let Ok(decoded) = t.decode(&bytes) else {
            self.stats.undecodable += 1;
            return Ok(());
        };
        let channel_id = self.channel(&info, &t)?;
        let seq = self.sequence.entry(channel_id).or_insert(0);
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: *seq,
            log_time: s.time.as_nanos() as u64,
            publish_time: s.time.as_nanos() as u64,
        };
        *seq += 1;
        let json = serde_json::to_vec(&t.record_json(&decoded)).expect("a JSON value serialises");
        self.writer.write_to_known_channel(&header, &json).map_err(mcap_error)?;
        self.stats.messages += 1;
        Ok(())
    }

    /// Writes the summary and the footer.
    pub fn finish(mut self) -> Result<McapStats, CliError> {
        self.writer.finish().map_err(mcap_error)?;
        Ok(self.stats)
    }
}

/// Writes `frames` as an MCAP recording to `path`.
pub fn write_file(path: &str, frames: &[Stamped]) -> Result<McapStats, CliError> {
    let file = std::fs::File::create(path)
        .map_err(|e| CliError::new(format!("cannot create {path}: {e}")))?;
    let mut log = McapLog::new(std::io::BufWriter::new(file))?;
    for f in frames {
        log.feed(f)?;
    }
    log.finish()
}
