//! The socketcand text protocol (<https://github.com/linux-can/socketcand>, `doc/protocol.md`)
//! for this crate's server and the `r2p` tools: the protocol crate's (`r2p-socketcand`, no_std,
//! shared with the gateway module's server) with `String`s and `Vec`s, as host code wants them.
//! The messages are listed there.

pub use r2p_socketcand::command::Word;
pub use r2p_socketcand::{Command, ParseError, MAX_MESSAGE};

use crate::frame::Stamped;

/// Splits a byte stream into `< … >` messages; whatever is not a message is an error.
#[derive(Debug, Default)]
pub struct Splitter {
    inner: r2p_socketcand::Splitter,
}

impl Splitter {
    /// An empty splitter.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds received bytes and returns every complete message (`< … >` inclusive) or error.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Result<String, ParseError>> {
        let mut out = Vec::new();
        self.inner.feed(bytes, |m| {
            // The splitter returns ASCII messages only.
            out.push(m.map(|m| String::from_utf8_lossy(m).into_owned()));
        });
        out
    }
}

/// Parses one message (`< … >` inclusive, as [`Splitter`] returns it).
pub fn parse_command(msg: &str) -> Result<Command<'_>, ParseError> {
    r2p_socketcand::parse_command(msg.as_bytes())
}

/// `< frame ID SECS.USECS DATA >` as socketcand sends it (empty data leaves two spaces).
pub fn format_frame(s: &Stamped) -> String {
    let mut out = String::new();
    r2p_socketcand::format::write_frame(&mut out, &s.frame, s.time)
        .expect("a String takes any text");
    out
}

/// `< error TEXT >`.
pub fn format_error(e: &impl std::fmt::Display) -> String {
    let mut out = String::new();
    r2p_socketcand::format::write_error(&mut out, e).expect("a String takes any text");
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::CanFrame;
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
        assert_eq!(parse_command("< open vcan0 >"), Ok(Command::Open("vcan0")));
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
