//! candump log files (`candump -L` / `candump -l`): one frame a line,
//! `(1700000000.000123) vcan0 12345678#DEADBEEF`, standard IDs as 3 hex digits and extended
//! IDs as 8, data as contiguous upper-case hex. can-utils' `canplayer` and `log2asc` and
//! python-can's `can.LogReader` read these files.

use std::fmt;
use std::io::{self, BufRead, Write};
use std::time::Duration;

use crate::frame::{format_time, parse_time, CanFrame, Stamped, MAX_DLC};

/// One line of a log.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Record {
    /// When the frame was on the bus, since the Unix epoch.
    pub time: Duration,
    /// The interface name (`vcan0`, `can0`, …).
    pub channel: String,
    /// The frame.
    pub frame: CanFrame,
}

/// Why a line is not a candump data frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LogError {
    /// Not `(TIME) CHANNEL ID#DATA`.
    Syntax,
    /// The timestamp is not `SECONDS.MICROSECONDS`.
    Time,
    /// The identifier is not 3 or 8 hex digits in range.
    Id,
    /// The data is not an even number of hex digits, at most 8 bytes.
    Data,
    /// Remote, CAN FD or error frames, which this link does not carry.
    Unsupported,
}

impl fmt::Display for LogError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LogError::Syntax => "expected (SECONDS.USECONDS) CHANNEL ID#DATA",
            LogError::Time => "bad timestamp",
            LogError::Id => "bad identifier (3 or 8 hex digits)",
            LogError::Data => "bad data (up to 8 bytes of hex)",
            LogError::Unsupported => "remote, CAN FD and error frames are not supported",
        })
    }
}

impl std::error::Error for LogError {}

/// Formats one log line (without the newline).
pub fn format_line(time: Duration, channel: &str, frame: &CanFrame) -> String {
    let mut line = format!("({}) {} {}#", format_time(time), channel, frame.id_hex());
    for b in frame.data() {
        line.push_str(&format!("{b:02X}"));
    }
    line
}

/// Parses one log line; `Ok(None)` for blank lines and `#` comments.
pub fn parse_line(line: &str) -> Result<Option<Record>, LogError> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') {
        return Ok(None);
    }
    let mut words = line.split_ascii_whitespace();
    let (Some(time), Some(channel), Some(frame)) = (words.next(), words.next(), words.next())
    else {
        return Err(LogError::Syntax);
    };
    // candump -l may append a direction flag (R or T).
    match words.next() {
        None | Some("R" | "T" | "r" | "t") if words.next().is_none() => {}
        _ => return Err(LogError::Syntax),
    }
    let time = time.strip_prefix('(').and_then(|t| t.strip_suffix(')')).ok_or(LogError::Syntax)?;
    let time = parse_time(time).ok_or(LogError::Time)?;
    let (id, data) = frame.split_once('#').ok_or(LogError::Syntax)?;
    if data.starts_with(['#', 'R', 'r']) {
        return Err(LogError::Unsupported);
    }
    let extended = match id.len() {
        3 => false,
        8 => true,
        _ => return Err(LogError::Id),
    };
    if !id.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(LogError::Id);
    }
    let id = u32::from_str_radix(id, 16).map_err(|_| LogError::Id)?;
    if extended && id > crate::frame::MAX_EXTENDED_ID {
        // The error flag (0x20000000) and friends.
        return Err(LogError::Unsupported);
    }
    if data.len() % 2 != 0
        || data.len() > 2 * MAX_DLC
        || !data.bytes().all(|b| b.is_ascii_hexdigit())
    {
        return Err(LogError::Data);
    }
    let bytes: Vec<u8> = (0..data.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&data[i..i + 2], 16))
        .collect::<Result<_, _>>()
        .map_err(|_| LogError::Data)?;
    let frame = CanFrame::new(id, extended, &bytes).map_err(|_| LogError::Id)?;
    Ok(Some(Record { time, channel: channel.to_string(), frame }))
}

/// Reads a whole log; an error names its 1-based line.
pub fn read_log<R: BufRead>(reader: R) -> io::Result<Vec<Record>> {
    let mut out = Vec::new();
    for (n, line) in reader.lines().enumerate() {
        match parse_line(&line?) {
            Ok(Some(r)) => out.push(r),
            Ok(None) => {}
            Err(e) => {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidData,
                    format!("line {}: {e}", n + 1),
                ));
            }
        }
    }
    Ok(out)
}

/// Writes frames as a candump log on one channel.
pub struct LogWriter<W: Write> {
    out: W,
    channel: String,
}

impl<W: Write> LogWriter<W> {
    /// A writer naming every frame's interface `channel`.
    pub fn new(out: W, channel: &str) -> Self {
        Self { out, channel: channel.to_string() }
    }

    /// Writes one frame.
    pub fn write(&mut self, s: &Stamped) -> io::Result<()> {
        writeln!(self.out, "{}", format_line(s.time, &self.channel, &s.frame))
    }

    /// Flushes the underlying writer.
    pub fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(secs: u64, us: u32, frame: CanFrame) -> Record {
        Record { time: Duration::new(secs, us * 1000), channel: "vcan0".into(), frame }
    }

    #[test]
    fn formats_like_candump() {
        let f = CanFrame::extended(0x1234_5678, &[0xDE, 0xAD, 0xBE, 0xEF]).unwrap();
        let t = Duration::new(1_700_000_000, 123_000);
        assert_eq!(format_line(t, "vcan0", &f), "(1700000000.000123) vcan0 12345678#DEADBEEF");
        let f = CanFrame::standard(0x7, &[]).unwrap();
        assert_eq!(format_line(t, "can1", &f), "(1700000000.000123) can1 007#");
    }

    #[test]
    fn roundtrips_through_a_file() {
        let frames = [
            rec(
                1_700_000_000,
                123,
                CanFrame::extended(0x1234_5678, &[0xDE, 0xAD, 0xBE, 0xEF]).unwrap(),
            ),
            rec(1_700_000_000, 999_999, CanFrame::standard(0x123, &[]).unwrap()),
            rec(1_700_000_001, 0, CanFrame::extended(0x1, &[0, 1, 2, 3, 4, 5, 6, 0xFF]).unwrap()),
            rec(0, 1, CanFrame::standard(0x7FF, &[0x80]).unwrap()),
        ];
        let mut w = LogWriter::new(Vec::new(), "vcan0");
        for r in &frames {
            w.write(&Stamped { time: r.time, frame: r.frame }).unwrap();
        }
        let bytes = w.into_inner();
        assert_eq!(read_log(&bytes[..]).unwrap(), frames);
    }

    #[test]
    fn reads_other_tools_variants() {
        let r = parse_line("  (1.5) can0 0000007F#0102 R\n").unwrap().unwrap();
        assert_eq!(r.frame, CanFrame::extended(0x7F, &[1, 2]).unwrap());
        assert_eq!(r.time, Duration::from_millis(1500));
        assert_eq!(parse_line("# comment"), Ok(None));
        assert_eq!(parse_line(""), Ok(None));
        assert_eq!(parse_line("(1.0) can0 123#abcd").unwrap().unwrap().frame.data(), &[0xAB, 0xCD]);
    }

    #[test]
    fn rejects_malformed_lines() {
        for (line, err) in [
            ("1.0 can0 123#00", LogError::Syntax),
            ("(1.0) can0", LogError::Syntax),
            ("(1.0) can0 12300", LogError::Syntax),
            ("(1.0) can0 123#00 X", LogError::Syntax),
            ("(x) can0 123#00", LogError::Time),
            ("(1.0) can0 12#00", LogError::Id),
            ("(1.0) can0 1234#00", LogError::Id),
            ("(1.0) can0 12G#00", LogError::Id),
            ("(1.0) can0 800#00", LogError::Id),
            ("(1.0) can0 123#0", LogError::Data),
            ("(1.0) can0 123#zz", LogError::Data),
            ("(1.0) can0 123#000000000000000000", LogError::Data),
            ("(1.0) can0 123#R", LogError::Unsupported),
            ("(1.0) can0 123##1AB", LogError::Unsupported),
            ("(1.0) can0 20000080#0000000000000000", LogError::Unsupported),
        ] {
            assert_eq!(parse_line(line), Err(err), "{line}");
        }
        let e = read_log(&b"(1.0) can0 123#00\nbad\n"[..]).unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
    }
}
