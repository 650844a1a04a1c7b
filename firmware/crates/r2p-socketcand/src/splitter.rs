//! A byte stream into `< … >` messages, one byte at a time, in a fixed buffer: TCP delivers a
//! message in any number of pieces, or several in one, with no separators (python-can sends
//! none). Whatever is not a message is reported once per run, and the splitter resynchronises
//! at the next `<`: one broken message never costs the ones after it.

use crate::command::ParseError;
use crate::MAX_MESSAGE;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    /// Between messages: whitespace is skipped.
    Between,
    /// In bytes that are not a message (reported once), until the next `<`.
    Garbage,
    /// In a message; `ascii` is false once a byte above 0x7F was seen.
    Message { ascii: bool },
}

/// Splits a byte stream into `< … >` messages ([`Splitter::push`]).
#[derive(Clone, Debug)]
pub struct Splitter {
    buf: [u8; MAX_MESSAGE],
    len: usize,
    state: State,
}

impl Default for Splitter {
    fn default() -> Self {
        Self::new()
    }
}

impl Splitter {
    /// An empty splitter.
    pub const fn new() -> Self {
        Self { buf: [0; MAX_MESSAGE], len: 0, state: State::Between }
    }

    /// Takes one received byte; returns a complete message (`< … >` inclusive, ASCII) or why
    /// the bytes before it were not one:
    /// [`ParseError::Garbage`] (bytes outside `< … >`, or a `<` inside a message: the broken
    /// message is dropped and the new `<` starts the next), [`ParseError::TooLong`] (more than
    /// [`MAX_MESSAGE`] bytes without `>`: dropped up to the next `<`),
    /// [`ParseError::NotAscii`].
    pub fn push(&mut self, byte: u8) -> Option<Result<&[u8], ParseError>> {
        match (self.state, byte) {
            (State::Between, b) if b.is_ascii_whitespace() => None,
            (State::Between | State::Garbage, b'<') => {
                self.start();
                None
            }
            (State::Between, _) => {
                self.state = State::Garbage;
                Some(Err(ParseError::Garbage))
            }
            (State::Garbage, _) => None,
            (State::Message { .. }, b'<') => {
                self.start();
                Some(Err(ParseError::Garbage))
            }
            (State::Message { ascii }, b) => {
                if self.len == MAX_MESSAGE {
                    self.state = State::Garbage;
                    return Some(Err(ParseError::TooLong));
                }
                self.buf[self.len] = b;
                self.len += 1;
                let ascii = ascii && b.is_ascii();
                if b != b'>' {
                    self.state = State::Message { ascii };
                    return None;
                }
                self.state = State::Between;
                Some(if ascii { Ok(&self.buf[..self.len]) } else { Err(ParseError::NotAscii) })
            }
        }
    }

    /// [`Splitter::push`]es every byte of `bytes`, handing each message or error to `each`.
    pub fn feed(&mut self, bytes: &[u8], mut each: impl FnMut(Result<&[u8], ParseError>)) {
        for &b in bytes {
            if let Some(piece) = self.push(b) {
                each(piece);
            }
        }
    }

    fn start(&mut self) {
        self.buf[0] = b'<';
        self.len = 1;
        self.state = State::Message { ascii: true };
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::String;
    use std::vec::Vec;

    use super::*;

    fn split(s: &mut Splitter, bytes: &[u8]) -> Vec<Result<String, ParseError>> {
        let mut out = Vec::new();
        s.feed(bytes, |m| out.push(m.map(|m| String::from_utf8(m.to_vec()).unwrap())));
        out
    }

    #[test]
    fn splits_a_stream_without_separators() {
        let mut s = Splitter::new();
        assert_eq!(split(&mut s, b"< open vcan0 >< raw"), [Ok("< open vcan0 >".into())]);
        assert_eq!(
            split(&mut s, b"mode >\n  < echo >"),
            [Ok("< rawmode >".into()), Ok("< echo >".into())]
        );
        assert!(split(&mut s, b"").is_empty());
    }

    #[test]
    fn recovers_from_garbage_at_the_next_message() {
        let mut s = Splitter::new();
        assert_eq!(
            split(&mut s, b"hello < echo >"),
            [Err(ParseError::Garbage), Ok("< echo >".into())]
        );
        assert_eq!(
            split(&mut s, b"< send 1 < echo >"),
            [Err(ParseError::Garbage), Ok("< echo >".into())]
        );
        assert_eq!(split(&mut s, b"junk"), [Err(ParseError::Garbage)]);
        assert_eq!(split(&mut s, b"<"), []);
        assert_eq!(split(&mut s, &[b'x'; MAX_MESSAGE + 1]), [Err(ParseError::TooLong)]);
        assert_eq!(split(&mut s, b"< echo >"), [Ok("< echo >".into())]);
        assert_eq!(split(&mut s, b"< \xff >"), [Err(ParseError::NotAscii)]);
        assert_eq!(split(&mut s, b"> < echo >"), [Err(ParseError::Garbage), Ok("< echo >".into())]);
    }

    #[test]
    fn the_longest_message_fits_and_one_byte_more_does_not() {
        let mut s = Splitter::new();
        let mut longest = [b'x'; MAX_MESSAGE];
        (longest[0], longest[MAX_MESSAGE - 1]) = (b'<', b'>');
        assert_eq!(split(&mut s, &longest).len(), 1);
        assert!(split(&mut s, &longest)[0].is_ok());
        let mut over = [b'x'; MAX_MESSAGE + 1];
        (over[0], over[MAX_MESSAGE]) = (b'<', b'>');
        assert_eq!(split(&mut s, &over), [Err(ParseError::TooLong)]);
        assert_eq!(split(&mut s, b"<echo>"), [Ok("<echo>".into())]);
    }
}
