//! The server's messages, written into any `core::fmt::Write`: a `String` on the host, a
//! [`TextBuf`] on the MCU.

use core::fmt::{self, Write};
use core::time::Duration;

use crate::frame::CanFrame;

/// The greeting a server sends on connect.
pub const HI: &str = "< hi >";
/// The answer to `open`, `rawmode` and `bcmmode`.
pub const OK: &str = "< ok >";
/// The answer to `echo`.
pub const ECHO: &str = "< echo >";

/// Longest `< frame … >` message: 8-digit ID, 20-digit seconds, 8 data bytes.
pub const MAX_FRAME_TEXT: usize = "< frame ".len() + 8 + 1 + 20 + 1 + 6 + 1 + 2 * 8 + " >".len();

/// Room any `< error … >` of a session takes (the longest: an unknown command's 32-byte word,
/// 58 bytes); a server's own refusals must fit it too. The fuzz target `socketcand_session`
/// checks it for arbitrary input.
pub const MAX_ERROR_TEXT: usize = 96;

/// `SECONDS.MICROSECONDS` (6 digits), as candump and socketcand write a time.
pub fn write_time(out: &mut impl Write, t: Duration) -> fmt::Result {
    write!(out, "{}.{:06}", t.as_secs(), t.subsec_micros())
}

/// `< frame ID SECS.USECS DATA >` as socketcand sends it (empty data leaves two spaces).
pub fn write_frame(out: &mut impl Write, frame: &CanFrame, time: Duration) -> fmt::Result {
    write!(out, "< frame {} ", frame.id_hex())?;
    write_time(out, time)?;
    out.write_char(' ')?;
    for b in frame.data() {
        write!(out, "{b:02X}")?;
    }
    out.write_str(" >")
}

/// `< error TEXT >`.
pub fn write_error(out: &mut impl Write, why: &impl fmt::Display) -> fmt::Result {
    write!(out, "< error {why} >")
}

/// Text in a fixed buffer: `fmt::Write` that fails, keeping what it had, when full.
#[derive(Clone, Debug)]
pub struct TextBuf<const N: usize> {
    buf: [u8; N],
    len: usize,
}

impl<const N: usize> Default for TextBuf<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> TextBuf<N> {
    /// An empty buffer.
    pub const fn new() -> Self {
        Self { buf: [0; N], len: 0 }
    }

    /// The text written so far.
    pub fn as_bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// Bytes written so far.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// True if nothing was written.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Room left.
    pub const fn room(&self) -> usize {
        N - self.len
    }

    /// Empties the buffer.
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

impl<const N: usize> Write for TextBuf<N> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let end = self.len + s.len();
        if end > N {
            return Err(fmt::Error);
        }
        self.buf[self.len..end].copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text<const N: usize>(b: &TextBuf<N>) -> &str {
        core::str::from_utf8(b.as_bytes()).unwrap()
    }

    #[test]
    fn frames_as_python_can_parses_them() {
        let t = Duration::new(1_700_000_000, 123_000);
        let mut b = TextBuf::<64>::new();
        let f = CanFrame::extended(0x1234_5678, &[0xDE, 0xAD, 0xBE, 0xEF]).unwrap();
        write_frame(&mut b, &f, t).unwrap();
        assert_eq!(text(&b), "< frame 12345678 1700000000.000123 DEADBEEF >");
        b.clear();
        write_frame(&mut b, &CanFrame::standard(0x12, &[]).unwrap(), t).unwrap();
        assert_eq!(text(&b), "< frame 012 1700000000.000123  >");
    }

    #[test]
    fn the_longest_frame_fits_its_bound() {
        let mut b = TextBuf::<MAX_FRAME_TEXT>::new();
        let f = CanFrame::extended(0x1FFF_FFFF, &[0xFF; 8]).unwrap();
        write_frame(&mut b, &f, Duration::new(u64::MAX, 999_999_999)).unwrap();
        assert_eq!(b.room(), 0);
    }

    #[test]
    fn a_full_buffer_refuses_and_keeps_what_it_had() {
        let mut b = TextBuf::<8>::new();
        b.write_str(OK).unwrap();
        assert!(b.write_str(OK).is_err());
        assert_eq!(text(&b), OK);
        assert!(write_error(&mut b, &"x").is_err());
    }
}
