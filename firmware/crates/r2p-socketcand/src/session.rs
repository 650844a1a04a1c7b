//! One client's session: which mode it is in, and what each of its messages asks the server to
//! do. The same rules for every server of the bus on TCP, so a client meets the same answers
//! on the emulated robot and through a gateway.

use core::fmt;

use crate::command::{parse_command, Command, ParseError};
use crate::frame::CanFrame;

/// Where a client is in the protocol.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    /// Connected, no bus open: only `open` (and `echo`) are meaningful.
    #[default]
    Closed,
    /// A bus is open: `send` works, frames are not forwarded to the client.
    Bcm,
    /// Raw mode: every frame of the bus is forwarded to the client.
    Raw,
}

/// Why a message was refused; sent back as `< error … >` and counted by the server.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SessionError {
    /// The message was not understood.
    Parse(ParseError),
    /// `open` named a bus this server does not serve.
    CouldNotOpen,
    /// `open` on a session that has a bus open.
    AlreadyOpen,
    /// A command that needs an open bus, before `open`.
    NoBusOpen,
    /// `bcmmode` after `rawmode` (socketcand does not go back).
    CannotLeaveRaw,
}

impl fmt::Display for SessionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SessionError::Parse(e) => e.fmt(f),
            SessionError::CouldNotOpen => f.write_str("could not open bus"),
            SessionError::AlreadyOpen => f.write_str("bus already open"),
            SessionError::NoBusOpen => f.write_str("no bus open"),
            SessionError::CannotLeaveRaw => f.write_str("cannot leave rawmode"),
        }
    }
}

impl From<ParseError> for SessionError {
    fn from(e: ParseError) -> Self {
        SessionError::Parse(e)
    }
}

/// What the server does for one message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// Write this message back (`< ok >`, `< echo >`).
    Reply(&'static str),
    /// Put this frame on the bus (no answer).
    Send(CanFrame),
    /// Start forwarding the bus's frames to the client, then answer `< ok >` (subscribe
    /// first, so that nothing sent after the `ok` is missed).
    EnterRaw,
    /// Write `< error … >` back and count it.
    Refuse(SessionError),
}

/// One client's session ([`Session::on_message`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Session {
    mode: Mode,
}

impl Session {
    /// A session just connected (after the server's `< hi >`).
    pub const fn new() -> Self {
        Self { mode: Mode::Closed }
    }

    /// The session's mode.
    pub const fn mode(&self) -> Mode {
        self.mode
    }

    /// What to do for a message from [`crate::Splitter`] (or its error), on a server that
    /// serves the bus called `channel`.
    pub fn on_message(&mut self, msg: Result<&[u8], ParseError>, channel: &str) -> Action {
        let command = match msg.and_then(parse_command) {
            Ok(c) => c,
            Err(e) => return Action::Refuse(e.into()),
        };
        match (command, self.mode) {
            (Command::Open(ch), Mode::Closed) if ch == channel => {
                self.mode = Mode::Bcm;
                Action::Reply(crate::format::OK)
            }
            (Command::Open(_), Mode::Closed) => Action::Refuse(SessionError::CouldNotOpen),
            (Command::Open(_), _) => Action::Refuse(SessionError::AlreadyOpen),
            (_, Mode::Closed) => Action::Refuse(SessionError::NoBusOpen),
            (Command::Echo, _) => Action::Reply(crate::format::ECHO),
            (Command::BcmMode, Mode::Bcm) | (Command::RawMode, Mode::Raw) => {
                Action::Reply(crate::format::OK)
            }
            (Command::BcmMode, _) => Action::Refuse(SessionError::CannotLeaveRaw),
            (Command::RawMode, _) => {
                self.mode = Mode::Raw;
                Action::EnterRaw
            }
            (Command::Send(frame), _) => Action::Send(frame),
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::format::{ECHO, OK};

    fn say(s: &mut Session, msg: &str) -> Action {
        s.on_message(Ok(msg.as_bytes()), "vcan0")
    }

    #[test]
    fn a_client_opens_the_bus_then_sends_and_goes_raw() {
        let mut s = Session::new();
        assert_eq!(say(&mut s, "< send 1 0 >"), Action::Refuse(SessionError::NoBusOpen));
        assert_eq!(say(&mut s, "< open can9 >"), Action::Refuse(SessionError::CouldNotOpen));
        assert_eq!(s.mode(), Mode::Closed);
        assert_eq!(say(&mut s, "< open vcan0 >"), Action::Reply(OK));
        assert_eq!(say(&mut s, "< open vcan0 >"), Action::Refuse(SessionError::AlreadyOpen));
        assert_eq!(say(&mut s, "< bcmmode >"), Action::Reply(OK));
        assert_eq!(say(&mut s, "< echo >"), Action::Reply(ECHO));
        let f = CanFrame::extended(0x1234, &[1]).unwrap();
        assert_eq!(say(&mut s, "< send 00001234 1 1 >"), Action::Send(f));
        assert_eq!(say(&mut s, "< rawmode >"), Action::EnterRaw);
        assert_eq!(s.mode(), Mode::Raw);
        assert_eq!(
            say(&mut s, "< rawmode >"),
            Action::Reply(OK),
            "raw again: no second subscription"
        );
        assert_eq!(say(&mut s, "< bcmmode >"), Action::Refuse(SessionError::CannotLeaveRaw));
        assert_eq!(say(&mut s, "< send 00001234 1 1 >"), Action::Send(f));
    }

    #[test]
    fn errors_read_as_socketcand_clients_expect() {
        let mut s = Session::new();
        let e = |a| match a {
            Action::Refuse(e) => std::format!("{e}"),
            other => panic!("{other:?}"),
        };
        assert_eq!(e(s.on_message(Err(ParseError::Garbage), "vcan0")), "data outside a message");
        assert_eq!(e(say(&mut s, "< nope >")), "unknown command nope");
        assert_eq!(e(say(&mut s, "< echo >")), "no bus open");
    }
}
