//! A client of the socketcand protocol (the server side is `r2p_canlink::server`): connects,
//! opens the bus in raw mode, then reads `< frame … >` messages on a thread and sends
//! `< send … >` messages. Every way the connection can fail gets its own message.

use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::thread;
use std::time::{Duration, Instant};

use r2p_canlink::frame::parse_time;
use r2p_canlink::socketcand::Splitter;
use r2p_canlink::{CanFrame, Stamped};

use crate::error::CliError;

/// How long connecting and each handshake step may take.
pub const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(3);

/// What the reader thread hands over.
pub enum Incoming {
    /// A frame.
    Frame(Stamped),
    /// The connection ended (or failed); why.
    Closed(String),
}

/// A connection to a socketcand server in raw mode.
pub struct Client {
    stream: TcpStream,
    addr: String,
    rx: Receiver<Incoming>,
}

/// Parses `< frame ID SECS.USECS DATA >` (DATA contiguous hex, possibly empty). As python-can
/// does, an ID of 3 hex digits is standard and any other length extended.
pub fn parse_frame(msg: &str) -> Option<Stamped> {
    let inner = msg.strip_prefix('<')?.strip_suffix('>')?;
    let mut words = inner.split_ascii_whitespace();
    if words.next()? != "frame" {
        return None;
    }
    let (id, time) = (words.next()?, words.next()?);
    let data = words.next().unwrap_or("");
    if words.next().is_some() || data.len() % 2 != 0 || data.len() > 16 {
        return None;
    }
    if id.is_empty() || id.len() > 8 || !id.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    let raw = u32::from_str_radix(id, 16).ok()?;
    let bytes = (0..data.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(data.get(i..i + 2)?, 16).ok())
        .collect::<Option<Vec<u8>>>()?;
    let frame = CanFrame::new(raw, id.len() != 3, &bytes).ok()?;
    Some(Stamped { time: parse_time(time)?, frame })
}

/// `< send ID DLC B0 … >`, ID as 8 hex digits for an extended frame and 3 for a standard one.
pub fn format_send(f: &CanFrame) -> String {
    let mut s = format!("< send {} {}", f.id_hex(), f.len());
    for b in f.data() {
        s.push_str(&format!(" {b:02X}"));
    }
    s.push_str(" >");
    s
}

fn resolve(addr: &str) -> Result<SocketAddr, CliError> {
    let bad =
        || CliError::new(format!("--socketcand {addr}: expected HOST:PORT, e.g. 127.0.0.1:29536"));
    if !addr.contains(':') {
        return Err(bad());
    }
    let mut addrs = addr
        .to_socket_addrs()
        .map_err(|e| CliError::new(format!("--socketcand {addr}: cannot resolve: {e}")))?;
    addrs.next().ok_or_else(bad)
}

/// Reads messages until one completes; `Err` with the reason on timeout or close.
fn next_message(
    stream: &mut TcpStream,
    splitter: &mut Splitter,
    pending: &mut Vec<String>,
    deadline: Instant,
) -> io::Result<String> {
    loop {
        if !pending.is_empty() {
            return Ok(pending.remove(0));
        }
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(io::Error::new(io::ErrorKind::TimedOut, "no answer"));
        }
        stream.set_read_timeout(Some(left))?;
        let mut buf = [0u8; 1024];
        let n = stream.read(&mut buf)?;
        if n == 0 {
            return Err(io::Error::new(io::ErrorKind::UnexpectedEof, "connection closed"));
        }
        for m in splitter.push(&buf[..n]) {
            pending.push(m.unwrap_or_else(|e| format!("(garbage: {e})")));
        }
    }
}

impl Client {
    /// Connects to `addr` (`HOST:PORT`), opens bus `channel` and switches to raw mode.
    pub fn connect(addr: &str, channel: &str) -> Result<Client, CliError> {
        let sa = resolve(addr)?;
        let mut stream = TcpStream::connect_timeout(&sa, HANDSHAKE_TIMEOUT).map_err(|e| {
            CliError::new(match e.kind() {
                io::ErrorKind::ConnectionRefused => format!(
                    "cannot reach socketcand at {addr}: connection refused (nothing listens there). \
                     Start an emulated robot (`r2p-emu demo --realtime --socketcand {addr}`) or a \
                     bus (`r2p-canlink serve --socketcand {addr}`), or give --socketcand HOST:PORT \
                     of a running socketcand"
                ),
                io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock => format!(
                    "cannot reach socketcand at {addr}: no answer within {} s",
                    HANDSHAKE_TIMEOUT.as_secs()
                ),
                _ => format!("cannot reach socketcand at {addr}: {e}"),
            })
        })?;
        stream.set_nodelay(true).map_err(|e| CliError::new(format!("{addr}: {e}")))?;
        let deadline = Instant::now() + HANDSHAKE_TIMEOUT;
        let mut splitter = Splitter::new();
        let mut pending = Vec::new();
        let not_socketcand = |what: &str| {
            CliError::new(format!(
                "{addr} does not speak the socketcand protocol ({what}); is --socketcand the \
                 address of a socketcand server?"
            ))
        };
        let mut expect = |stream: &mut TcpStream, want: &str, step: &str| -> Result<(), CliError> {
            match next_message(stream, &mut splitter, &mut pending, deadline) {
                Ok(m) if m == want => Ok(()),
                Ok(m) if m.starts_with("< error") && step == "open" => Err(CliError::new(format!(
                    "socketcand at {addr} has no bus named {channel:?} (it said {m}); give the \
                     bus name it serves with --channel"
                ))),
                Ok(m) => Err(not_socketcand(&format!("answered {m:?} to {step}"))),
                Err(e) if e.kind() == io::ErrorKind::TimedOut => Err(not_socketcand(&format!(
                    "no {want} within {} s",
                    HANDSHAKE_TIMEOUT.as_secs()
                ))),
                Err(e) => Err(CliError::new(format!(
                    "socketcand at {addr} closed the connection before answering {step} ({e}); \
                     is it shutting down?"
                ))),
            }
        };
        expect(&mut stream, "< hi >", "connecting")?;
        let say = |stream: &mut TcpStream, text: &str| {
            stream.write_all(text.as_bytes()).map_err(|e| CliError::new(format!("{addr}: {e}")))
        };
        say(&mut stream, &format!("< open {channel} >"))?;
        expect(&mut stream, "< ok >", "open")?;
        say(&mut stream, "< rawmode >")?;
        expect(&mut stream, "< ok >", "rawmode")?;

        let (tx, rx) = mpsc::channel();
        let mut reader = stream.try_clone().map_err(|e| CliError::new(format!("{addr}: {e}")))?;
        reader.set_read_timeout(None).map_err(|e| CliError::new(format!("{addr}: {e}")))?;
        let who = addr.to_string();
        thread::Builder::new()
            .name("socketcand-reader".into())
            .spawn(move || {
                for m in pending {
                    if let Some(s) = parse_frame(&m) {
                        let _ = tx.send(Incoming::Frame(s));
                    }
                }
                let mut buf = [0u8; 4096];
                let why = loop {
                    match reader.read(&mut buf) {
                        Ok(0) => break format!("socketcand at {who} closed the connection"),
                        Ok(n) => {
                            for m in splitter.push(&buf[..n]).into_iter().flatten() {
                                if let Some(s) = parse_frame(&m) {
                                    if tx.send(Incoming::Frame(s)).is_err() {
                                        return;
                                    }
                                }
                            }
                        }
                        Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                        Err(e) => break format!("socketcand at {who}: {e}"),
                    }
                };
                let _ = tx.send(Incoming::Closed(why));
            })
            .map_err(|e| CliError::new(format!("cannot start a thread: {e}")))?;
        Ok(Client { stream, addr: addr.to_string(), rx })
    }

    /// The server's address as given.
    pub fn addr(&self) -> &str {
        &self.addr
    }

    /// The next frame, waiting at most `timeout`.
    pub fn recv(&self, timeout: Duration) -> Result<Option<Stamped>, CliError> {
        match self.rx.recv_timeout(timeout) {
            Ok(Incoming::Frame(s)) => Ok(Some(s)),
            Ok(Incoming::Closed(why)) => Err(CliError::new(why)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => {
                Err(CliError::new(format!("socketcand at {}: connection lost", self.addr)))
            }
        }
    }

    /// Sends a frame.
    pub fn send(&mut self, f: &CanFrame) -> Result<(), CliError> {
        self.stream
            .write_all(format_send(f).as_bytes())
            .map_err(|e| CliError::new(format!("sending to socketcand at {}: {e}", self.addr)))
    }
}

impl Drop for Client {
    fn drop(&mut self) {
        let _ = self.stream.shutdown(std::net::Shutdown::Both);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use r2p_canlink::{BroadcastHub, Config, Hub, Server};
    use std::net::TcpListener;
    use std::sync::Arc;

    #[test]
    fn frames_parse_as_python_can_reads_them() {
        let s = parse_frame("< frame 1F808003 1700000000.000123 1100 >").unwrap();
        assert_eq!(s.frame, CanFrame::extended(0x1F80_8003, &[0x11, 0]).unwrap());
        assert_eq!(s.time, Duration::new(1_700_000_000, 123_000));
        let s = parse_frame("< frame 012 1.5  >").unwrap();
        assert_eq!(s.frame, CanFrame::standard(0x12, &[]).unwrap());
        assert!(parse_frame("< frame 0000007 1.0 00 >").unwrap().frame.is_extended());
        for bad in
            ["< frame 1 >", "< frame XYZ 1.0 >", "< frame 123 1.0 0 >", "< ok >", "< frame 123 x >"]
        {
            assert!(parse_frame(bad).is_none(), "{bad}");
        }
        assert_eq!(
            format_send(&CanFrame::extended(0x1F, &[1, 0xAB]).unwrap()),
            "< send 0000001F 2 01 AB >"
        );
        assert_eq!(format_send(&CanFrame::standard(0x7FF, &[]).unwrap()), "< send 7FF 0 >");
    }

    #[test]
    fn talks_to_the_canlink_server_both_ways() {
        let hub = Arc::new(BroadcastHub::new());
        let server =
            Server::start(Config::new("127.0.0.1:0".parse().unwrap()), hub.clone()).unwrap();
        let addr = server.local_addr().to_string();
        let mut c = Client::connect(&addr, "vcan0").unwrap();
        let me = hub.join();
        let sub = hub.subscribe(me, 16);
        let f = CanFrame::extended(0x1F80_8003, &[1, 2, 3]).unwrap();
        c.send(&f).unwrap();
        assert_eq!(sub.recv_timeout(Duration::from_secs(5)).unwrap().frame, f);
        let g = CanFrame::standard(0x42, &[9]).unwrap();
        hub.send(me, g);
        let got = (0..50).find_map(|_| c.recv(Duration::from_millis(100)).unwrap());
        assert_eq!(got.unwrap().frame, g);
        drop(c);
        server.shutdown();
    }

    #[test]
    fn each_connection_failure_has_its_own_message() {
        // Nothing listening: a port that was just free.
        let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let e = Client::connect(&format!("127.0.0.1:{port}"), "vcan0").err().unwrap();
        assert!(e.to_string().contains("connection refused (nothing listens there)"), "{e}");
        let e = Client::connect("nowhere", "vcan0").err().unwrap();
        assert!(e.to_string().contains("expected HOST:PORT"), "{e}");

        // A server with another bus name.
        let hub = Arc::new(BroadcastHub::new());
        let server = Server::start(Config::new("127.0.0.1:0".parse().unwrap()), hub).unwrap();
        let e = Client::connect(&server.local_addr().to_string(), "can9").err().unwrap();
        assert!(e.to_string().contains("has no bus named \"can9\""), "{e}");
        server.shutdown();

        // Something that is not socketcand.
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = l.local_addr().unwrap().to_string();
        let t = thread::spawn(move || {
            let (mut s, _) = l.accept().unwrap();
            s.write_all(b"SSH-2.0-OpenSSH\r\n").unwrap();
            thread::sleep(Duration::from_millis(200));
        });
        let e = Client::connect(&addr, "vcan0").err().unwrap();
        assert!(e.to_string().contains("does not speak the socketcand protocol"), "{e}");
        t.join().unwrap();
    }
}
