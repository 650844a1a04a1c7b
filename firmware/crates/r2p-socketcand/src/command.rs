//! A client's message into a [`Command`], or why it is not one.

use core::fmt;

use crate::frame::{CanFrame, MAX_DLC, MAX_EXTENDED_ID, MAX_STANDARD_ID};

/// A message from a client.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command<'a> {
    /// `< open CHANNEL >`.
    Open(&'a str),
    /// `< rawmode >`.
    RawMode,
    /// `< bcmmode >` (the mode after `open`; only `send` is supported in it).
    BcmMode,
    /// `< echo >`.
    Echo,
    /// `< send ID DLC DATA… >`.
    Send(CanFrame),
}

/// Longest unknown command word repeated back in an error.
pub const WORD_MAX: usize = 32;

/// An unknown command's word, as much of it as [`WORD_MAX`] allows (shown in the error).
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Word {
    bytes: [u8; WORD_MAX],
    len: u8,
}

impl Word {
    fn new(s: &str) -> Self {
        let mut bytes = [0; WORD_MAX];
        let mut len = 0;
        // Whole characters only, so that the word stays valid UTF-8.
        for (i, c) in s.char_indices() {
            let end = i + c.len_utf8();
            if end > WORD_MAX {
                break;
            }
            len = end;
        }
        bytes[..len].copy_from_slice(&s.as_bytes()[..len]);
        Self { bytes, len: len as u8 }
    }

    /// The word.
    pub fn as_str(&self) -> &str {
        core::str::from_utf8(&self.bytes[..usize::from(self.len)]).unwrap_or("")
    }
}

impl fmt::Debug for Word {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self.as_str(), f)
    }
}

/// Why a client message was not understood; sent back as `< error … >`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParseError {
    /// Bytes outside `< … >`.
    Garbage,
    /// A message longer than [`crate::MAX_MESSAGE`] without a closing `>`.
    TooLong,
    /// A message that is not ASCII.
    NotAscii,
    /// `< >`.
    Empty,
    /// A command this server does not implement.
    Unknown(Word),
    /// A command with the wrong arguments; the text says what it takes.
    BadArguments(&'static str),
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParseError::Garbage => write!(f, "data outside a message"),
            ParseError::TooLong => write!(f, "message too long"),
            ParseError::NotAscii => write!(f, "message not ASCII"),
            ParseError::Empty => write!(f, "empty message"),
            ParseError::Unknown(c) => write!(f, "unknown command {}", c.as_str()),
            ParseError::BadArguments(usage) => write!(f, "usage {usage}"),
        }
    }
}

impl core::error::Error for ParseError {}

fn hex_u32(s: &str) -> Option<u32> {
    if s.is_empty() || s.len() > 8 || !s.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    u32::from_str_radix(s, 16).ok()
}

const SEND_USAGE: &str = "send ID DLC DATA";

/// Most arguments a command takes (`send`: ID, DLC and 8 bytes), plus one to tell "too many".
const MAX_ARGS: usize = 2 + MAX_DLC + 1;

/// Parses one message (`< … >` inclusive, as [`crate::Splitter`] returns it).
pub fn parse_command(msg: &[u8]) -> Result<Command<'_>, ParseError> {
    let msg =
        core::str::from_utf8(msg).ok().filter(|m| m.is_ascii()).ok_or(ParseError::NotAscii)?;
    let inner =
        msg.strip_prefix('<').and_then(|m| m.strip_suffix('>')).ok_or(ParseError::Garbage)?;
    let mut words = inner.split_ascii_whitespace();
    let cmd = words.next().ok_or(ParseError::Empty)?;
    let mut argv = [""; MAX_ARGS];
    let mut argc = 0;
    for w in words {
        if argc == MAX_ARGS {
            break;
        }
        argv[argc] = w;
        argc += 1;
    }
    match (cmd, &argv[..argc]) {
        ("open", [channel]) => Ok(Command::Open(channel)),
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
        (other, _) => Err(ParseError::Unknown(Word::new(other))),
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use super::*;

    fn send(msg: &str) -> CanFrame {
        match parse_command(msg.as_bytes()) {
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
        assert_eq!(parse_command(b"< open vcan0 >"), Ok(Command::Open("vcan0")));
        assert_eq!(parse_command(b"< rawmode >"), Ok(Command::RawMode));
        assert_eq!(parse_command(b"<echo>"), Ok(Command::Echo));
        assert_eq!(parse_command(b"< bcmmode >"), Ok(Command::BcmMode));
    }

    #[test]
    fn malformed_commands_are_errors_that_say_what_is_wrong() {
        for (bad, why) in [
            ("< >", "empty message"),
            ("< send >", "usage send ID DLC DATA"),
            ("< send 123 >", "usage send ID DLC DATA"),
            ("< send 123 2 1 >", "usage send with DLC data bytes"),
            ("< send 123 1 1 2 >", "usage send with DLC data bytes"),
            ("< send 123 9 0 0 0 0 0 0 0 0 0 >", "usage send DLC of 0 to 8"),
            ("< send 123 8 0 0 0 0 0 0 0 0 0 0 0 0 >", "usage send with DLC data bytes"),
            ("< send xyz 0 >", "usage send ID DLC DATA"),
            ("< send 20000000 0 >", "usage send ID below 20000000"),
            ("< send 123456789 0 >", "usage send ID DLC DATA"),
            ("< send 123 1 100 >", "usage send data bytes in hex"),
            ("< send 123 1 -1 >", "usage send data bytes in hex"),
            ("< send 123 1 0x1 >", "usage send data bytes in hex"),
            ("< open >", "usage open CHANNEL"),
            ("< open a b >", "usage open CHANNEL"),
            ("< rawmode now >", "usage without arguments"),
            ("< frobnicate >", "unknown command frobnicate"),
            ("send 1 0", "data outside a message"),
            ("< \u{e9}cho >", "message not ASCII"),
        ] {
            let e = parse_command(bad.as_bytes()).expect_err(bad);
            assert_eq!(e.to_string(), why, "{bad}");
        }
        let long = std::format!("< {} >", "x".repeat(100));
        assert_eq!(parse_command(long.as_bytes()).unwrap_err().to_string().len(), 16 + WORD_MAX);
    }
}
