//! A classic CAN data frame as the link carries it: standard or extended identifier, 0–8 bytes.

use std::time::{Duration, SystemTime, UNIX_EPOCH};

// The frame type is the protocol crate's (no_std), shared with the gateway's server.
pub use r2p_socketcand::frame::{CanFrame, FrameError, MAX_DLC, MAX_EXTENDED_ID, MAX_STANDARD_ID};

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
    let mut s = String::new();
    r2p_socketcand::format::write_time(&mut s, t).expect("a String takes any text");
    s
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
