//! The socketcand text protocol (<https://github.com/linux-can/socketcand>, `doc/protocol.md`)
//! as far as raw-frame clients use it: python-can's `socketcand` interface, `cangw`-style
//! bridges and `nc`.
//!
//! Messages are `< ... >` with no line separators required (python-can sends none):
//!
//! | direction | message | meaning |
//! |---|---|---|
//! | server → client | `< hi >` | greeting on connect |
//! | client → server | `< open CHANNEL >` | select the bus; answered `< ok >` |
//! | client → server | `< rawmode >` | receive every frame; answered `< ok >` |
//! | client → server | `< send ID DLC B0 B1 … >` | send a frame (hex; 8-digit or > 7FF IDs are extended) |
//! | client → server | `< echo >` | answered `< echo >` |
//! | server → client | `< frame ID SECS.USECS DATA >` | a frame (ID 3 or 8 hex digits, DATA contiguous hex) |
//! | server → client | `< error TEXT >` | a message was not understood |

use std::fmt;

use crate::frame::{format_time, CanFrame, Stamped, MAX_DLC, MAX_EXTENDED_ID, MAX_STANDARD_ID};

/// Longest message accepted (a full `< send >` is under 50 bytes).
pub const MAX_MESSAGE: usize = 256;

/// A message from a client.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Command {
    /// `< open CHANNEL >`.
    Open(String),
    /// `< rawmode >`.
    RawMode,
    /// `< bcmmode >` (the mode after `open`; only `send` is supported in it).
    BcmMode,
    /// `< echo >`.
    Echo,
    /// `< send ID DLC DATA… >`.
    Send(CanFrame),
}

/// Why a client message was not understood; sent back as `< error … >`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ParseError {
    /// Bytes outside `< … >`.
    Garbage,
    /// A message longer than [`MAX_MESSAGE`] without a closing `>`.
    TooLong,
    /// A message that is not ASCII.
    NotAscii,
    /// `< >`.
    Empty,
    /// A command this server does not implement.
    Unknown(String),
    /// A command with the wrong arguments.
    BadArguments(&'static str),
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParseError::Garbage => write!(f, "data outside a message"),
            ParseError::TooLong => write!(f, "message too long"),
            ParseError::NotAscii => write!(f, "message not ASCII"),
            ParseError::Empty => write!(f, "empty message"),
            ParseError::Unknown(c) => write!(f, "unknown command {c}"),
            ParseError::BadArguments(usage) => write!(f, "usage {usage}"),
        }
    }
}

impl std::error::Error for ParseError {}

/// Splits a byte stream into `< … >` messages; whatever is not a message is an error.
#[derive(Debug, Default)]
pub struct Splitter {
    buf: Vec<u8>,
}

impl Splitter {
    /// An empty splitter.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds received bytes and returns every complete message (`< … >` inclusive) or error.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Result<String, ParseError>> {
        self.buf.extend_from_slice(bytes);
        let mut out = Vec::new();
        loop {
            let start = self.buf.iter().position(|b| !b.is_ascii_whitespace());
            let Some(start) = start else {
                self.buf.clear();
                break;
            };
            if self.buf[start] != b'<' {
                // Garbage up to the next message (or all of it).
                let next = self.buf[start..].iter().position(|&b| b == b'<');
                self.buf.drain(..next.map_or(self.buf.len(), |n| start + n));
                out.push(Err(ParseError::Garbage));
                continue;
            }
            let body = &self.buf[start + 1..];
            let close = body.iter().position(|&b| b == b'>');
            let reopen = body.iter().position(|&b| b == b'<');
            match (close, reopen) {
                (Some(c), r) if r.is_none_or(|r| r > c) => {
                    let msg = self.buf[start..start + c + 2].to_vec();
                    self.buf.drain(..start + c + 2);
                    out.push(
                        String::from_utf8(msg)
                            .ok()
                            .filter(|m| m.is_ascii())
                            .ok_or(ParseError::NotAscii),
                    );
                }
                (_, Some(r)) => {
                    // A second `<` before the `>`: drop the broken message, resync there.
                    self.buf.drain(..start + 1 + r);
                    out.push(Err(ParseError::Garbage));
                }
                (None, None) => {
                    if self.buf.len() - start > MAX_MESSAGE {
                        self.buf.clear();
                        out.push(Err(ParseError::TooLong));
                    } else {
                        self.buf.drain(..start);
                    }
                    break;
                }
                (Some(_), None) => unreachable!("covered by the first arm"),
            }
        }
        out
    }
}

fn hex_u32(s: &str) -> Option<u32> {
    if s.is_empty() || s.len() > 8 || !s.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    u32::from_str_radix(s, 16).ok()
}

const SEND_USAGE: &str = "send ID DLC DATA";

/// Parses one message (`< … >` inclusive, as [`Splitter`] returns it).
pub fn parse_command(msg: &str) -> Result<Command, ParseError> {
    let inner =
        msg.strip_prefix('<').and_then(|m| m.strip_suffix('>')).ok_or(ParseError::Garbage)?;
    let mut words = inner.split_ascii_whitespace();
    let cmd = words.next().ok_or(ParseError::Empty)?;
    let args: Vec<&str> = words.collect();
    match (cmd, args.as_slice()) {
        ("open", [channel]) => Ok(Command::Open((*channel).to_string())),
        ("open", _) => Err(ParseError::BadArguments("open CHANNEL")),
        ("rawmode", []) => Ok(Command::RawMode),
        ("bcmmode", []) => Ok(Command::BcmMode),
        ("echo", []) => Ok(Command::Echo),
        ("rawmode" | "bcmmode" | "echo", _) => Err(ParseError::BadArguments("without arguments")),
        ("send", [id, dlc, data @ ..]) => {
            let raw = hex_u32(id).ok_or(ParseError::BadArguments(SEND_USAGE))?;
            let extended = id.len() == 8 || raw > MAX_STANDARD_ID;
            if raw > MAX_EXTENDED_ID {
                return Err(ParseError::BadArguments("send ID below 20000000"));
            }
            let dlc = hex_u32(dlc).filter(|&d| d as usize <= MAX_DLC);
            let dlc = dlc.ok_or(ParseError::BadArguments("send DLC of 0 to 8"))? as usize;
            if data.len() != dlc {
                return Err(ParseError::BadArguments("send with DLC data bytes"));
            }
            let mut bytes = [0u8; MAX_DLC];
            for (b, s) in bytes.iter_mut().zip(data) {
                *b = hex_u32(s)
                    .filter(|&v| s.len() <= 2 && v <= 0xFF)
                    .ok_or(ParseError::BadArguments("send data bytes in hex"))?
                    as u8;
            }
            CanFrame::new(raw, extended, &bytes[..dlc])
                .map(Command::Send)
                .map_err(|_| ParseError::BadArguments(SEND_USAGE))
        }
        ("send", _) => Err(ParseError::BadArguments(SEND_USAGE)),
        (other, _) => Err(ParseError::Unknown(other.chars().take(32).collect())),
    }
}

/// `< frame ID SECS.USECS DATA >` as socketcand sends it (empty data leaves two spaces).
pub fn format_frame(s: &Stamped) -> String {
    let mut out = format!("< frame {} {} ", s.frame.id_hex(), format_time(s.time));
    for b in s.frame.data() {
        out.push_str(&format!("{b:02X}"));
    }
    out.push_str(" >");
    out
}

/// `< error TEXT >`.
pub fn format_error(e: &ParseError) -> String {
    format!("< error {e} >")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn send(msg: &str) -> CanFrame {
        match parse_command(msg) {
            Ok(Command::Send(f)) => f,
            other => panic!("{msg}: {other:?}"),
        }
    }

    #[test]
    fn parses_what_python_can_sends() {
        // python-can: f"< send {id:03X|08X} {dlc:X} {' '.join(f'{x:x}')} >"
        assert_eq!(
            send("< send 123 3 1 a ff >"),
            CanFrame::standard(0x123, &[1, 0xA, 0xFF]).unwrap()
        );
        assert_eq!(send("< send 0000001F 0  >"), CanFrame::extended(0x1F, &[]).unwrap());
        assert_eq!(send("< send 12345678 8 0 1 2 3 4 5 6 7 >").len(), 8);
        assert!(send("< send 800 0 >").is_extended(), "above 7FF is extended");
        assert!(!send("< send 7FF 0 >").is_extended());
        assert_eq!(parse_command("< open vcan0 >"), Ok(Command::Open("vcan0".into())));
        assert_eq!(parse_command("< rawmode >"), Ok(Command::RawMode));
        assert_eq!(parse_command("<echo>"), Ok(Command::Echo));
        assert_eq!(parse_command("< bcmmode >"), Ok(Command::BcmMode));
    }

    #[test]
    fn malformed_commands_are_errors() {
        for bad in [
            "< >",
            "< send >",
            "< send 123 >",
            "< send 123 2 1 >",
            "< send 123 1 1 2 >",
            "< send 123 9 0 0 0 0 0 0 0 0 0 >",
            "< send xyz 0 >",
            "< send 20000000 0 >",
            "< send 123456789 0 >",
            "< send 123 1 100 >",
            "< send 123 1 -1 >",
            "< send 123 1 0x1 >",
            "< open >",
            "< open a b >",
            "< rawmode now >",
            "< frobnicate >",
            "send 1 0",
        ] {
            let e = parse_command(bad).expect_err(bad);
            let text = format_error(&e);
            assert!(text.starts_with("< error ") && text.ends_with(" >"), "{text}");
            assert_eq!(text.matches('<').count() + text.matches('>').count(), 2, "{text}");
        }
        let long = format!("< {} >", "x".repeat(100));
        assert_eq!(format_error(&parse_command(&long).unwrap_err()).len(), 8 + 16 + 32 + 2);
    }

    #[test]
    fn formats_frames_as_python_can_parses_them() {
        let t = Duration::new(1_700_000_000, 123_000);
        let f = Stamped {
            time: t,
            frame: CanFrame::extended(0x1234_5678, &[0xDE, 0xAD, 0xBE, 0xEF]).unwrap(),
        };
        assert_eq!(format_frame(&f), "< frame 12345678 1700000000.000123 DEADBEEF >");
        let f = Stamped { time: t, frame: CanFrame::standard(0x12, &[]).unwrap() };
        assert_eq!(format_frame(&f), "< frame 012 1700000000.000123  >");
    }

    #[test]
    fn splits_a_stream_without_separators() {
        let mut s = Splitter::new();
        assert_eq!(s.push(b"< open vcan0 >< raw"), vec![Ok("< open vcan0 >".to_string())]);
        assert_eq!(
            s.push(b"mode >\n  < echo >"),
            vec![Ok("< rawmode >".into()), Ok("< echo >".into())]
        );
        assert!(s.push(b"").is_empty());
    }

    #[test]
    fn splitter_recovers_from_garbage() {
        let mut s = Splitter::new();
        assert_eq!(
            s.push(b"hello < echo >"),
            vec![Err(ParseError::Garbage), Ok("< echo >".into())]
        );
        assert_eq!(
            s.push(b"< send 1 < echo >"),
            vec![Err(ParseError::Garbage), Ok("< echo >".into())]
        );
        assert_eq!(s.push(b"junk"), vec![Err(ParseError::Garbage)]);
        assert_eq!(s.push(&[b'<'; 1]), vec![]);
        assert_eq!(s.push(&[b'x'; MAX_MESSAGE + 1]), vec![Err(ParseError::TooLong)]);
        assert_eq!(s.push(b"< echo >"), vec![Ok("< echo >".into())]);
        assert_eq!(s.push(b"< \xff >"), vec![Err(ParseError::NotAscii)]);
        assert_eq!(s.push(b"> < echo >"), vec![Err(ParseError::Garbage), Ok("< echo >".into())]);
    }

    #[test]
    fn never_panics_on_arbitrary_bytes() {
        // A cheap deterministic fuzz: every byte pattern from a small alphabet, split anywhere.
        let alphabet = b"< >sendopx0F9\xff";
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        for _ in 0..20_000 {
            let mut s = Splitter::new();
            let mut input = Vec::new();
            for _ in 0..(seed % 40) {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                input.push(alphabet[(seed % alphabet.len() as u64) as usize]);
            }
            let cut = (seed as usize) % (input.len() + 1);
            for chunk in [&input[..cut], &input[cut..]] {
                for msg in s.push(chunk).into_iter().flatten() {
                    let _ = parse_command(&msg);
                }
            }
        }
    }
}
