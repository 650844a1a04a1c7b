//! The gateway's socketcand server: one client's session over any `embedded-io-async` stream
//! — an embassy-net TCP socket on the STM32F407, a host TCP stream in the emulator — on the
//! bus through a [`BusLink`]. The protocol (messages, session rules, errors) is
//! `r2p-socketcand`'s, the same as the emulator's r2p-canlink server, so every tool meets the
//! same answers through either.
//!
//! One task per client: it waits for whichever comes first, the client's bytes or (in raw
//! mode) a bus frame, and writes the replies and frames out in batches. Bad input is answered
//! with `< error … >` and counted; the session goes on. Nothing the client sends can make the
//! server panic or hold the bus up: a client that stops reading loses the oldest frames
//! (counted) and a client whose frames cannot join the queue to the bus is told so.

use core::time::Duration;

use embassy_futures::select::{select, Either};
use embassy_sync::pubsub::WaitResult;
use embedded_hal_async::delay::DelayNs;
use embedded_io_async::{Read, Write};
use r2p_socketcand::format::{self, TextBuf, HI, MAX_ERROR_TEXT, MAX_FRAME_TEXT};
use r2p_socketcand::{Action, Session, SessionError, Splitter};

use crate::link::{BusLink, BusSubscriber, LinkStats, Source};

/// Bytes read from the client at once.
const READ_CHUNK: usize = 128;
/// Bytes gathered before a write: a batch of frames, or the replies to one read.
const OUT_BATCH: usize = 512;

/// Pause between the `< ok >` of `rawmode` and the first frame: python-can reads that `ok`
/// with one `recv` and compares the whole of it, so frames must not arrive in the same read
/// (r2p-canlink's server waits as long).
pub const RAW_SETTLE_MS: u32 = 50;

/// The bus name clients `open`: `vcan0`, as the emulator's r2p-canlink server calls it, so a
/// tool's settings work on both.
pub const CHANNEL: &str = r2p_socketcand::DEFAULT_CHANNEL;

/// How a session ended (errors of the stream end it too: [`serve`]'s `Err`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ended {
    /// The client closed the connection.
    Closed,
    /// [`crate::link::MAX_CLIENTS`] were connected: told so, and closed.
    Full,
}

/// What a session is told.
pub struct Config<'a> {
    /// The bus name clients `open` ([`CHANNEL`]).
    pub channel: &'a str,
}

/// Serves one connected client until it closes the connection or the stream fails; `delay`
/// is the platform's timer (embassy-time's `Delay` on the MCU).
pub async fn serve<S: Read + Write>(
    io: &mut S,
    link: &BusLink,
    config: &Config<'_>,
    delay: &mut impl DelayNs,
) -> Result<Ended, S::Error> {
    let Some(me) = link.join() else {
        let mut out = TextBuf::<MAX_ERROR_TEXT>::new();
        let _ = format::write_error(&mut out, &"too many clients");
        io.write_all(out.as_bytes()).await?;
        io.flush().await?;
        return Ok(Ended::Full);
    };
    let result = session(io, link, config, me, delay).await;
    link.leave(me);
    result
}

async fn session<S: Read + Write>(
    io: &mut S,
    link: &BusLink,
    config: &Config<'_>,
    me: Source,
    delay: &mut impl DelayNs,
) -> Result<Ended, S::Error> {
    io.write_all(HI.as_bytes()).await?;
    io.flush().await?;
    let mut session = Session::new();
    let mut splitter = Splitter::new();
    let mut raw: Option<BusSubscriber<'_>> = None;
    let mut buf = [0u8; READ_CHUNK];
    let mut out = TextBuf::<OUT_BATCH>::new();
    loop {
        let event = match raw.as_mut() {
            None => Either::First(io.read(&mut buf).await),
            Some(sub) => select(io.read(&mut buf), sub.next_message()).await,
        };
        match event {
            Either::First(Ok(0)) => return Ok(Ended::Closed),
            Either::First(Ok(n)) => {
                for &byte in &buf[..n] {
                    let Some(msg) = splitter.push(byte) else { continue };
                    let action = session.on_message(msg, config.channel);
                    if out.room() < MAX_ERROR_TEXT {
                        flush(io, &mut out).await?;
                    }
                    let was_raw = raw.is_some();
                    answer(action, link, me, &mut raw, &mut out);
                    if !was_raw && raw.is_some() {
                        flush(io, &mut out).await?;
                        delay.delay_ms(RAW_SETTLE_MS).await;
                    }
                }
            }
            Either::First(Err(e)) => return Err(e),
            Either::Second(first) => {
                let mut next = Some(first);
                while let Some(m) = next {
                    match m {
                        WaitResult::Lagged(n) => {
                            LinkStats::add(&link.stats.lost, n.min(u64::from(u32::MAX)) as u32)
                        }
                        WaitResult::Message(f) if f.from != me => {
                            let _ = format::write_frame(
                                &mut out,
                                &f.frame,
                                Duration::from_micros(f.at_us),
                            );
                            LinkStats::add(&link.stats.frames_to_clients, 1);
                        }
                        WaitResult::Message(_) => {}
                    }
                    next = match raw.as_mut() {
                        Some(sub) if out.room() >= MAX_FRAME_TEXT => sub.try_next_message(),
                        _ => None,
                    };
                }
            }
        }
        flush(io, &mut out).await?;
    }
}

/// Does what `action` asks: a reply or an error into `out`, a frame to the bus, raw mode.
fn answer<'l, const N: usize>(
    action: Action,
    link: &'l BusLink,
    me: Source,
    raw: &mut Option<BusSubscriber<'l>>,
    out: &mut TextBuf<N>,
) {
    let refuse = |out: &mut TextBuf<N>, why: &dyn core::fmt::Display| {
        LinkStats::add(&link.stats.client_errors, 1);
        let _ = format::write_error(out, &Shown(why));
    };
    match action {
        Action::Reply(text) => {
            let _ = core::fmt::Write::write_str(out, text);
        }
        Action::Refuse(e) => refuse(out, &e),
        Action::Send(frame) => {
            if let Err(why) = link.send(me, frame) {
                LinkStats::add(&link.stats.lost, 1);
                refuse(out, &why);
            }
        }
        Action::EnterRaw => {
            // Subscribe before the `ok`: nothing sent after it is missed.
            *raw = link.subscribe();
            if raw.is_some() {
                let _ = core::fmt::Write::write_str(out, format::OK);
            } else {
                refuse(out, &SessionError::CouldNotOpen);
            }
        }
    }
}

/// A `dyn Display` as `impl Display`.
struct Shown<'a>(&'a dyn core::fmt::Display);

impl core::fmt::Display for Shown<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        self.0.fmt(f)
    }
}

async fn flush<S: Write, const N: usize>(io: &mut S, out: &mut TextBuf<N>) -> Result<(), S::Error> {
    if !out.is_empty() {
        io.write_all(out.as_bytes()).await?;
        io.flush().await?;
        out.clear();
    }
    Ok(())
}
