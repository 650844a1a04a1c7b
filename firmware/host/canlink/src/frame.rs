//! A classic CAN data frame as the link carries it: standard or extended identifier, 0–8 bytes.

use std::fmt;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// Largest payload of a classic CAN frame.
pub const MAX_DLC: usize = 8;
/// Largest standard (11-bit) identifier.
pub const MAX_STANDARD_ID: u32 = 0x7FF;
/// Largest extended (29-bit) identifier.
pub const MAX_EXTENDED_ID: u32 = 0x1FFF_FFFF;

/// A classic CAN data frame.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct CanFrame {
    id: u32,
    extended: bool,
    len: u8,
    data: [u8; MAX_DLC],
}

/// Why an identifier and payload are not a classic CAN frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// The identifier does not fit 11 (standard) or 29 (extended) bits.
    IdOutOfRange(u32),
    /// More than 8 payload bytes.
    TooLong(usize),
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameError::IdOutOfRange(id) => write!(f, "identifier {id:X} out of range"),
            FrameError::TooLong(n) => write!(f, "{n} data bytes (at most 8)"),
        }
    }
}

impl std::error::Error for FrameError {}

impl CanFrame {
    /// A frame with identifier `id` (extended if `extended`) and `payload`.
    pub fn new(id: u32, extended: bool, payload: &[u8]) -> Result<Self, FrameError> {
        let max = if extended { MAX_EXTENDED_ID } else { MAX_STANDARD_ID };
        if id > max {
            return Err(FrameError::IdOutOfRange(id));
        }
        if payload.len() > MAX_DLC {
            return Err(FrameError::TooLong(payload.len()));
        }
        let mut data = [0; MAX_DLC];
        data[..payload.len()].copy_from_slice(payload);
        Ok(Self { id, extended, len: payload.len() as u8, data })
    }

    /// A standard-identifier (11-bit) frame.
    pub fn standard(id: u32, payload: &[u8]) -> Result<Self, FrameError> {
        Self::new(id, false, payload)
    }

    /// An extended-identifier (29-bit) frame, as RTCAN sends.
    pub fn extended(id: u32, payload: &[u8]) -> Result<Self, FrameError> {
        Self::new(id, true, payload)
    }

    /// The identifier (11 or 29 bits).
    pub const fn id(&self) -> u32 {
        self.id
    }

    /// True for a 29-bit identifier.
    pub const fn is_extended(&self) -> bool {
        self.extended
    }

    /// The payload (0–8 bytes).
    pub fn data(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }

    /// Payload length (the DLC).
    pub const fn len(&self) -> usize {
        self.len as usize
    }

    /// True if the frame carries no payload.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The identifier as CAN tools print it: 3 hex digits (standard) or 8 (extended).
    pub fn id_hex(&self) -> String {
        if self.extended {
            format!("{:08X}", self.id)
        } else {
            format!("{:03X}", self.id)
        }
    }
}

impl fmt::Debug for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}#", self.id_hex())?;
        for b in self.data() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

/// A frame with the time it went on the bus (since the Unix epoch).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stamped {
    /// When the frame was sent, since 1970-01-01 UTC.
    pub time: Duration,
    /// The frame.
    pub frame: CanFrame,
}

/// The current time since the Unix epoch (zero if the clock is before 1970).
pub fn now() -> Duration {
    SystemTime::now().duration_since(UNIX_EPOCH).unwrap_or_default()
}

/// Formats a timestamp as `SECONDS.MICROSECONDS` (6 digits), as candump and socketcand do.
pub fn format_time(t: Duration) -> String {
    format!("{}.{:06}", t.as_secs(), t.subsec_micros())
}

/// Parses `SECONDS.MICROSECONDS` (fraction of 1–9 digits; more than 6 are truncated).
pub fn parse_time(s: &str) -> Option<Duration> {
    let (secs, frac) = s.split_once('.').unwrap_or((s, ""));
    if secs.is_empty() || !secs.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    if frac.len() > 9 || !frac.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let secs: u64 = secs.parse().ok()?;
    let mut nanos: u32 = 0;
    for (i, b) in frac.bytes().enumerate() {
        nanos += u32::from(b - b'0') * 10u32.pow(8 - i as u32);
    }
    // Keep microsecond resolution, as the formats do.
    Some(Duration::new(secs, nanos / 1000 * 1000))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_range_checked() {
        assert!(CanFrame::standard(0x7FF, &[]).is_ok());
        assert_eq!(CanFrame::standard(0x800, &[]), Err(FrameError::IdOutOfRange(0x800)));
        assert!(CanFrame::extended(0x1FFF_FFFF, &[]).is_ok());
        assert_eq!(
            CanFrame::extended(0x2000_0000, &[]),
            Err(FrameError::IdOutOfRange(0x2000_0000))
        );
        assert_eq!(CanFrame::extended(1, &[0; 9]), Err(FrameError::TooLong(9)));
    }

    #[test]
    fn debug_is_candump_like() {
        let f = CanFrame::extended(0x1234_5678, &[0xDE, 0xAD]).unwrap();
        assert_eq!(format!("{f:?}"), "12345678#DEAD");
        assert_eq!(format!("{:?}", CanFrame::standard(0x12, &[]).unwrap()), "012#");
    }

    #[test]
    fn times_roundtrip() {
        let t = Duration::new(1_700_000_000, 123_000);
        assert_eq!(format_time(t), "1700000000.000123");
        assert_eq!(parse_time("1700000000.000123"), Some(t));
        assert_eq!(parse_time("5"), Some(Duration::from_secs(5)));
        assert_eq!(parse_time("5.5"), Some(Duration::from_millis(5500)));
        assert_eq!(parse_time(""), None);
        assert_eq!(parse_time("-1.0"), None);
        assert_eq!(parse_time("1.x"), None);
        assert_eq!(parse_time(".5"), None);
    }
}
