//! Benewake TFmini-S single-point LiDAR range finder over UART.
//!
//! From the TFmini-S product manual (SJ-PM-TFmini-S, Benewake): UART 115200 baud 8N1 by
//! default; the sensor streams a 9-byte frame at its frame rate (100 Hz by default, 1–1000 Hz):
//!
//! ```text
//! 0x59 0x59 Dist_L Dist_H Strength_L Strength_H Temp_L Temp_H Checksum
//! ```
//!
//! Dist is in cm (0–1200), signed: −1 when the signal strength is 100 or less (unreliable),
//! −2 when the signal saturates (Strength then reads 65535 = −1), −4 when ambient light
//! saturates. Temperature in °C = Temp/8 − 256. Checksum = low byte of the sum of the first
//! eight bytes. Commands to the sensor are `0x5A Len ID Data… Checksum` with the same checksum
//! rule; "set frame rate" is `5A 06 03 rate_L rate_H sum`, answered with the same 6 bytes.
//!
//! [`FrameParser`] takes any byte stream: it hunts for the header, checks the checksum, and
//! on a bad frame resynchronises inside the 9 bytes it already holds (a real frame may start
//! there), counting what it drops. It never panics and holds 9 bytes of state.

use embedded_io::{Read, ReadReady, Write};

/// Frame header byte (sent twice).
pub const HEADER: u8 = 0x59;
/// Frame length, bytes.
pub const FRAME_LEN: usize = 9;
/// Command header byte.
pub const COMMAND_HEADER: u8 = 0x5A;
/// "Set frame rate" command ID.
pub const CMD_FRAME_RATE: u8 = 0x03;

/// Low byte of the sum of `bytes`: the checksum of frames and commands.
pub fn checksum(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0u8, |s, &b| s.wrapping_add(b))
}

/// One data frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Frame {
    /// Dist as sent: cm, or a negative error code.
    pub dist: i16,
    /// Signal strength (65535 when saturated).
    pub strength: u16,
    /// Temp as sent: °C = temp/8 − 256.
    pub temp: u16,
}

/// What a frame says about the range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Range {
    /// A valid distance, m.
    Metres(f32),
    /// Dist −1: signal too weak (strength ≤ 100): nothing in range, or a dark target.
    WeakSignal,
    /// Dist −2: signal saturated (a very near or retro-reflective target).
    SignalSaturated,
    /// Dist −4: ambient light saturated (direct sunlight).
    AmbientSaturated,
    /// Another negative code.
    Other(i16),
}

impl Frame {
    /// The 9 bytes of this frame, checksum included.
    pub fn encode(&self) -> [u8; FRAME_LEN] {
        let [d0, d1] = self.dist.to_le_bytes();
        let [s0, s1] = self.strength.to_le_bytes();
        let [t0, t1] = self.temp.to_le_bytes();
        let mut f = [HEADER, HEADER, d0, d1, s0, s1, t0, t1, 0];
        f[8] = checksum(&f[..8]);
        f
    }

    /// The frame in `b` if its header and checksum are right.
    pub fn decode(b: &[u8; FRAME_LEN]) -> Option<Frame> {
        if b[0] != HEADER || b[1] != HEADER || checksum(&b[..8]) != b[8] {
            return None;
        }
        Some(Frame {
            dist: i16::from_le_bytes([b[2], b[3]]),
            strength: u16::from_le_bytes([b[4], b[5]]),
            temp: u16::from_le_bytes([b[6], b[7]]),
        })
    }

    /// The range it reports.
    pub fn range(&self) -> Range {
        match self.dist {
            d if d >= 0 => Range::Metres(f32::from(d) * 0.01),
            -1 => Range::WeakSignal,
            -2 => Range::SignalSaturated,
            -4 => Range::AmbientSaturated,
            d => Range::Other(d),
        }
    }

    /// Chip temperature, °C.
    pub fn temperature_c(&self) -> f32 {
        f32::from(self.temp) / 8.0 - 256.0
    }
}

/// What the parser has seen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Good frames.
    pub frames: u32,
    /// Frames with a header whose checksum was wrong.
    pub checksum_errors: u32,
    /// Bytes dropped while looking for a header (including those of bad frames).
    pub discarded_bytes: u32,
}

/// Byte-stream to frame parser; see the module documentation.
#[derive(Clone, Debug, Default)]
pub struct FrameParser {
    buf: [u8; FRAME_LEN],
    len: usize,
    stats: Stats,
}

impl FrameParser {
    /// An empty parser.
    pub fn new() -> Self {
        Self::default()
    }

    /// Counters so far.
    pub fn stats(&self) -> Stats {
        self.stats
    }

    /// Takes one byte; returns a frame when this byte completes a good one.
    pub fn push(&mut self, byte: u8) -> Option<Frame> {
        // Header hunt: byte 0 and 1 must be 0x59.
        if self.len < 2 && byte != HEADER {
            self.stats.discarded_bytes += self.len as u32 + 1;
            self.len = 0;
            return None;
        }
        self.buf[self.len] = byte;
        self.len += 1;
        if self.len < FRAME_LEN {
            return None;
        }
        self.len = 0;
        if let Some(f) = Frame::decode(&self.buf) {
            self.stats.frames += 1;
            return Some(f);
        }
        // Bad checksum: drop the first byte and rescan the other eight, where the next real
        // frame may already have started (8 bytes cannot complete a frame, so no recursion).
        self.stats.checksum_errors += 1;
        self.stats.discarded_bytes += 1;
        let rest = self.buf;
        for &b in &rest[1..] {
            self.push(b);
        }
        None
    }
}

/// A TFmini-S on a UART.
#[derive(Debug)]
pub struct Tfmini<U> {
    uart: U,
    parser: FrameParser,
    latest: Option<Frame>,
}

impl<U: Read + ReadReady> Tfmini<U> {
    /// The sensor on `uart` (115200 8N1 unless reconfigured).
    pub fn new(uart: U) -> Self {
        Self { uart, parser: FrameParser::new(), latest: None }
    }

    /// Reads every byte the UART has ready (never blocking) and returns the newest frame
    /// completed by them, if any.
    pub fn poll(&mut self) -> Result<Option<Frame>, U::Error> {
        let mut newest = None;
        let mut buf = [0u8; 32];
        while self.uart.read_ready()? {
            let n = self.uart.read(&mut buf)?;
            if n == 0 {
                break;
            }
            for &b in &buf[..n] {
                if let Some(f) = self.parser.push(b) {
                    newest = Some(f);
                    // Kept at once: an error later in this poll loses no frame.
                    self.latest = newest;
                }
            }
        }
        Ok(newest)
    }

    /// The last good frame received.
    pub fn latest(&self) -> Option<Frame> {
        self.latest
    }

    /// Parser counters.
    pub fn stats(&self) -> Stats {
        self.parser.stats()
    }

    /// The UART, e.g. to read its error counters.
    pub fn uart(&self) -> &U {
        &self.uart
    }

    /// The UART, mutably (the emulator advances its virtual time through this).
    pub fn uart_mut(&mut self) -> &mut U {
        &mut self.uart
    }

    /// Gives the UART back.
    pub fn release(self) -> U {
        self.uart
    }
}

/// The "set frame rate" command for `hz` (0 = output only on trigger).
pub fn frame_rate_command(hz: u16) -> [u8; 6] {
    let [lo, hi] = hz.to_le_bytes();
    let mut c = [COMMAND_HEADER, 6, CMD_FRAME_RATE, lo, hi, 0];
    c[5] = checksum(&c[..5]);
    c
}

impl<U: Read + ReadReady + Write> Tfmini<U> {
    /// Sends "set frame rate" (the sensor echoes it; data frames keep coming meanwhile and
    /// the parser skips the echo as garbage).
    pub fn set_frame_rate(&mut self, hz: u16) -> Result<(), U::Error> {
        self.uart.write_all(&frame_rate_command(hz))?;
        self.uart.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    fn frame(dist: i16) -> Frame {
        Frame { dist, strength: 1234, temp: (40 + 256) * 8 }
    }

    fn parse(bytes: &[u8]) -> (Vec<Frame>, Stats) {
        let mut p = FrameParser::new();
        let frames = bytes.iter().filter_map(|&b| p.push(b)).collect();
        (frames, p.stats())
    }

    #[test]
    fn encodes_the_manuals_example() {
        // 0x59 0x59, Dist 0x0032 = 50 cm, Strength 0x03E8 = 1000, Temp 0x0900 = 32 °C.
        let f = Frame { dist: 50, strength: 1000, temp: 0x0900 };
        let b = f.encode();
        assert_eq!(b[..8], [0x59, 0x59, 0x32, 0x00, 0xE8, 0x03, 0x00, 0x09]);
        assert_eq!(b[8], (0x59 + 0x59 + 0x32 + 0xE8 + 0x03 + 0x09) as u8);
        assert_eq!(Frame::decode(&b), Some(f));
        assert_eq!(f.range(), Range::Metres(0.5));
        assert_eq!(f.temperature_c(), 32.0);
    }

    #[test]
    fn error_codes() {
        assert_eq!(frame(-1).range(), Range::WeakSignal);
        assert_eq!(frame(-2).range(), Range::SignalSaturated);
        assert_eq!(frame(-4).range(), Range::AmbientSaturated);
        assert_eq!(frame(-3).range(), Range::Other(-3));
    }

    #[test]
    fn resynchronises_after_garbage_and_counts_it() {
        let mut s = std::vec![0x00, 0x59, 0x12, 0xFF];
        s.extend(frame(100).encode());
        s.extend(frame(101).encode());
        let (frames, st) = parse(&s);
        assert_eq!(frames, [frame(100), frame(101)]);
        assert_eq!(st, Stats { frames: 2, checksum_errors: 0, discarded_bytes: 4 });
    }

    #[test]
    fn bad_checksum_is_counted_and_the_next_frame_inside_it_is_found() {
        let mut bad = frame(100).encode();
        bad[8] ^= 1;
        // A frame cut short after 4 bytes, the next one starting right there: the parser
        // reads 9 bytes across both, fails the checksum, and must find the second frame.
        let mut s = frame(7).encode()[..4].to_vec();
        s.extend(frame(200).encode());
        s.extend(bad);
        s.extend(frame(300).encode());
        let (frames, st) = parse(&s);
        assert_eq!(frames, [frame(200), frame(300)]);
        assert_eq!(st.checksum_errors, 2);
        assert_eq!(st.frames, 2);
        // 4 bytes of the cut frame and the 9 of the bad one.
        assert_eq!(st.discarded_bytes, 13);
    }

    #[test]
    fn frame_rate_command_bytes() {
        // 100 Hz: 5A 06 03 64 00 C7 (manual's example).
        assert_eq!(frame_rate_command(100), [0x5A, 0x06, 0x03, 0x64, 0x00, 0xC7]);
    }

    proptest! {
        /// Any byte stream: no panic, every byte accounted for (in a frame, dropped, or
        /// still buffered), and every frame returned has a valid encoding.
        #[test]
        fn any_bytes_never_panic_and_balance(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
            let mut p = FrameParser::new();
            let mut n = 0u32;
            for &b in &bytes {
                if let Some(f) = p.push(b) {
                    prop_assert_eq!(Frame::decode(&f.encode()), Some(f));
                    n += 1;
                }
            }
            let st = p.stats();
            prop_assert_eq!(st.frames, n);
            prop_assert!(p.len < FRAME_LEN);
            prop_assert_eq!(st.frames as usize * FRAME_LEN + st.discarded_bytes as usize + p.len, bytes.len());
        }

        /// Good frames with garbage between them (garbage free of 0x59) all come through.
        #[test]
        fn frames_between_garbage_all_parse(
            parts in proptest::collection::vec((any::<i16>(), any::<u16>(), proptest::collection::vec(0u8..0x59, 0..20)), 1..20)
        ) {
            let mut s = Vec::new();
            let mut want = Vec::new();
            for (d, st, junk) in &parts {
                s.extend(junk);
                let f = Frame { dist: *d, strength: *st, temp: 2400 };
                s.extend(f.encode());
                want.push(f);
            }
            let (frames, _) = parse(&s);
            prop_assert_eq!(frames, want);
        }
    }
}
