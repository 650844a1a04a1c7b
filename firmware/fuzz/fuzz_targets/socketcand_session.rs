//! Any bytes from a client of the bus on TCP (the gateway's and the emulator's socketcand
//! servers): splitting, parsing and the session never panic, every answer fits the server's
//! error buffer, and whatever it would send on the bus is a valid frame of what the client wrote.
#![no_main]

use libfuzzer_sys::fuzz_target;
use r2p_socketcand::format::{write_error, TextBuf, MAX_ERROR_TEXT};
use r2p_socketcand::{Action, Session, Splitter, MAX_MESSAGE};

fuzz_target!(|data: &[u8]| {
    let mut splitter = Splitter::new();
    let mut session = Session::new();
    for &b in data {
        let Some(msg) = splitter.push(b) else { continue };
        if let Ok(m) = msg {
            assert!(m.len() <= MAX_MESSAGE && m.starts_with(b"<") && m.ends_with(b">"));
            assert!(m.is_ascii());
        }
        match session.on_message(msg, "vcan0") {
            Action::Refuse(e) => {
                write_error(&mut TextBuf::<MAX_ERROR_TEXT>::new(), &e).expect("fits the buffer")
            }
            Action::Send(f) => assert!(f.len() <= 8),
            Action::Reply(_) | Action::EnterRaw => {}
        }
    }
});
