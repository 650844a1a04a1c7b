//! A socketcand-protocol TCP server on a [`Hub`]: each client is a participant that sends with
//! `< send >` and, once in raw mode, receives every other participant's frames.
//!
//! Each client has a reader thread and (in raw mode) a writer thread fed by a bounded queue, so
//! a client that reads slowly loses frames (counted) and never holds up the bus.

use std::io::{self, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::RecvTimeoutError;
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::Duration;

use crate::hub::{Hub, DEFAULT_QUEUE};
use crate::socketcand::{format_error, format_frame, Splitter};
use r2p_socketcand::format::{HI, OK};
use r2p_socketcand::{Action, Session};

/// socketcand's usual port.
pub const DEFAULT_PORT: u16 = 29536;
/// Where the server listens unless told otherwise: loopback only.
pub const DEFAULT_ADDR: &str = "127.0.0.1:29536";

const POLL: Duration = Duration::from_millis(100);
/// A client that cannot take a write for this long is disconnected.
const WRITE_TIMEOUT: Duration = Duration::from_secs(5);
/// Pause between `< ok >` for rawmode and the first frame, so that a client reading the `ok`
/// alone (python-can compares the whole `recv`) does not get frames in the same read.
const RAW_SETTLE: Duration = Duration::from_millis(50);

/// What the server is told.
#[derive(Clone, Debug)]
pub struct Config {
    /// Address to listen on (only this one).
    pub addr: SocketAddr,
    /// The bus name clients `open` (`vcan0` unless told otherwise).
    pub channel: String,
    /// Frames queued per client before it loses frames.
    pub queue: usize,
}

impl Config {
    /// Listen on `addr` for channel `vcan0` with the default queue.
    pub fn new(addr: SocketAddr) -> Self {
        Self { addr, channel: "vcan0".to_string(), queue: DEFAULT_QUEUE }
    }
}

/// Counters over the server's life.
#[derive(Debug, Default)]
pub struct Stats {
    /// Connections accepted.
    pub clients: AtomicU64,
    /// Frames clients sent onto the bus.
    pub frames_in: AtomicU64,
    /// Frames written to clients.
    pub frames_out: AtomicU64,
    /// Messages answered with `< error … >`.
    pub errors: AtomicU64,
    /// Frames lost because a client's queue was full (counted when the client leaves).
    pub dropped: AtomicU64,
}

/// A running server; [`Server::shutdown`] (or dropping it) stops it and its clients.
pub struct Server {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    stats: Arc<Stats>,
    thread: Option<JoinHandle<()>>,
}

impl Server {
    /// Binds `config.addr` and serves `hub` until shut down.
    pub fn start(config: Config, hub: Arc<dyn Hub>) -> io::Result<Server> {
        let listener = TcpListener::bind(config.addr)?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let stats = Arc::new(Stats::default());
        let ctx = Ctx { hub, config: Arc::new(config), stop: stop.clone(), stats: stats.clone() };
        let thread = thread::Builder::new()
            .name("socketcand-accept".into())
            .spawn(move || accept_loop(listener, ctx))?;
        Ok(Server { addr, stop, stats, thread: Some(thread) })
    }

    /// The address actually bound (useful with port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// The server's counters.
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Stops accepting, disconnects every client and waits for their threads.
    pub fn shutdown(mut self) {
        self.stop_and_join();
    }

    fn stop_and_join(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop_and_join();
    }
}

#[derive(Clone)]
struct Ctx {
    hub: Arc<dyn Hub>,
    config: Arc<Config>,
    stop: Arc<AtomicBool>,
    stats: Arc<Stats>,
}

fn accept_loop(listener: TcpListener, ctx: Ctx) {
    let mut clients: Vec<JoinHandle<()>> = Vec::new();
    while !ctx.stop.load(Ordering::SeqCst) {
        match listener.accept() {
            Ok((stream, _peer)) => {
                ctx.stats.clients.fetch_add(1, Ordering::Relaxed);
                let c = ctx.clone();
                match thread::Builder::new().name("socketcand-client".into()).spawn(move || {
                    let _ = serve_client(stream, c);
                }) {
                    Ok(h) => clients.push(h),
                    Err(e) => eprintln!("r2p-canlink: cannot start a client thread: {e}"),
                }
                clients.retain(|h| !h.is_finished());
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                thread::sleep(Duration::from_millis(20))
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => {
                eprintln!("r2p-canlink: accept: {e}");
                thread::sleep(POLL);
            }
        }
    }
    for h in clients {
        let _ = h.join();
    }
}

fn write_all(out: &Mutex<TcpStream>, text: &str) -> io::Result<()> {
    out.lock().unwrap_or_else(|e| e.into_inner()).write_all(text.as_bytes())
}

fn serve_client(stream: TcpStream, ctx: Ctx) -> io::Result<()> {
    stream.set_nonblocking(false)?;
    stream.set_nodelay(true)?;
    stream.set_read_timeout(Some(POLL))?;
    stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
    let out = Arc::new(Mutex::new(stream.try_clone()?));
    let closed = Arc::new(AtomicBool::new(false));
    let me = ctx.hub.join();
    let mut writer: Option<JoinHandle<()>> = None;

    let result = (|| {
        write_all(&out, HI)?;
        let mut session = Session::new();
        let mut splitter = Splitter::new();
        let mut buf = [0u8; 1024];
        let mut reader = &stream;
        while !ctx.stop.load(Ordering::SeqCst) && !closed.load(Ordering::SeqCst) {
            let n = match reader.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => n,
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock
                            | io::ErrorKind::TimedOut
                            | io::ErrorKind::Interrupted
                    ) =>
                {
                    continue
                }
                Err(e) => return Err(e),
            };
            for msg in splitter.push(&buf[..n]) {
                match session.on_message(
                    msg.as_deref().map(str::as_bytes).map_err(|e| *e),
                    &ctx.config.channel,
                ) {
                    Action::Reply(text) => write_all(&out, text)?,
                    Action::Refuse(e) => {
                        ctx.stats.errors.fetch_add(1, Ordering::Relaxed);
                        write_all(&out, &format_error(&e))?;
                    }
                    Action::EnterRaw => {
                        // Subscribe before answering so that nothing sent after `ok` is missed.
                        let sub = ctx.hub.subscribe(me, ctx.config.queue);
                        write_all(&out, OK)?;
                        let (out, closed, ctx) = (out.clone(), closed.clone(), ctx.clone());
                        writer =
                            Some(thread::Builder::new().name("socketcand-writer".into()).spawn(
                                move || {
                                    forward(&sub, &out, &closed, &ctx);
                                    ctx.stats.dropped.fetch_add(sub.dropped(), Ordering::Relaxed);
                                },
                            )?);
                    }
                    Action::Send(frame) => {
                        // Count first, so that whoever receives the frame sees it counted.
                        ctx.stats.frames_in.fetch_add(1, Ordering::Relaxed);
                        ctx.hub.send(me, frame);
                    }
                }
            }
        }
        Ok(())
    })();

    closed.store(true, Ordering::SeqCst);
    let _ = stream.shutdown(Shutdown::Both);
    if let Some(w) = writer {
        let _ = w.join();
    }
    result
}

fn forward(sub: &crate::hub::Subscription, out: &Mutex<TcpStream>, closed: &AtomicBool, ctx: &Ctx) {
    thread::sleep(RAW_SETTLE);
    let mut batch = String::new();
    while !closed.load(Ordering::SeqCst) && !ctx.stop.load(Ordering::SeqCst) {
        match sub.recv_timeout(POLL) {
            Ok(first) => {
                batch.clear();
                batch.push_str(&format_frame(&first));
                let mut n = 1;
                while n < 64 {
                    let Ok(next) = sub.try_recv() else { break };
                    batch.push_str(&format_frame(&next));
                    n += 1;
                }
                if write_all(out, &batch).is_err() {
                    closed.store(true, Ordering::SeqCst);
                    break;
                }
                ctx.stats.frames_out.fetch_add(n, Ordering::Relaxed);
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BroadcastHub, CanFrame};

    fn start() -> (Arc<BroadcastHub>, Server) {
        let hub = Arc::new(BroadcastHub::new());
        let server =
            Server::start(Config::new("127.0.0.1:0".parse().unwrap()), hub.clone()).unwrap();
        (hub, server)
    }

    struct Client(TcpStream, Vec<u8>);

    impl Client {
        fn connect(server: &Server) -> Client {
            let s = TcpStream::connect(server.local_addr()).unwrap();
            s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
            let mut c = Client(s, Vec::new());
            assert_eq!(c.next(), "< hi >");
            c
        }

        fn say(&mut self, text: &str) {
            self.0.write_all(text.as_bytes()).unwrap();
        }

        fn next(&mut self) -> String {
            loop {
                if let Some(end) = self.1.iter().position(|&b| b == b'>') {
                    let msg: Vec<u8> = self.1.drain(..=end).collect();
                    return String::from_utf8(msg).unwrap().trim().to_string();
                }
                let mut buf = [0; 256];
                let n = self.0.read(&mut buf).expect("a reply within 5 s");
                assert!(n > 0, "server closed the connection");
                self.1.extend_from_slice(&buf[..n]);
            }
        }

        fn raw(server: &Server) -> Client {
            let mut c = Client::connect(server);
            c.say("< open vcan0 >");
            assert_eq!(c.next(), "< ok >");
            c.say("< rawmode >");
            assert_eq!(c.next(), "< ok >");
            c
        }
    }

    #[test]
    fn clients_and_in_process_participants_see_each_other() {
        let (hub, server) = start();
        let mut a = Client::raw(&server);
        let mut b = Client::raw(&server);
        let me = hub.join();
        let sub = hub.subscribe(me, 16);
        a.say("< send 12345678 2 de ad >");
        let got = sub.recv_timeout(Duration::from_secs(5)).unwrap();
        assert_eq!(got.frame, CanFrame::extended(0x1234_5678, &[0xDE, 0xAD]).unwrap());
        let line = b.next();
        assert!(line.starts_with("< frame 12345678 ") && line.ends_with(" DEAD >"), "{line}");
        hub.send(me, CanFrame::standard(0x12, &[]).unwrap());
        for c in [&mut a, &mut b] {
            let line = c.next();
            assert!(line.starts_with("< frame 012 ") && line.ends_with("  >"), "{line}");
        }
        // The sender does not get its own frame back: a's next frame is b's.
        b.say("< send 1 1 7 >");
        assert!(a.next().ends_with(" 07 >"));
        assert_eq!(server.stats().frames_in.load(Ordering::Relaxed), 2);
        server.shutdown();
    }

    #[test]
    fn malformed_messages_get_errors_and_the_session_goes_on() {
        let (_hub, server) = start();
        let mut c = Client::connect(&server);
        c.say("< send 1 0 >");
        assert_eq!(c.next(), "< error no bus open >");
        c.say("< open can9 >");
        assert_eq!(c.next(), "< error could not open bus >");
        c.say("< open vcan0 >");
        assert_eq!(c.next(), "< ok >");
        c.say("garbage< echo >< send 1 2 3 >< nope >");
        assert_eq!(c.next(), "< error data outside a message >");
        assert_eq!(c.next(), "< echo >");
        assert!(c.next().starts_with("< error usage send"));
        assert_eq!(c.next(), "< error unknown command nope >");
        assert_eq!(server.stats().errors.load(Ordering::Relaxed), 5);
        server.shutdown();
    }

    #[test]
    fn a_client_that_never_reads_does_not_block_the_bus() {
        let hub = Arc::new(BroadcastHub::new());
        let mut config = Config::new("127.0.0.1:0".parse().unwrap());
        config.queue = 4;
        let server = Server::start(config, hub.clone()).unwrap();
        let _stuck = Client::raw(&server); // never reads again
        let me = hub.join();
        let start = std::time::Instant::now();
        for _ in 0..200_000 {
            hub.send(me, CanFrame::extended(0x1000, &[0; 8]).unwrap());
        }
        assert!(start.elapsed() < Duration::from_secs(10));
        assert!(hub.dropped() > 0);
        server.shutdown();
    }

    #[test]
    fn binding_an_address_in_use_fails() {
        let (hub, server) = start();
        let e = Server::start(Config::new(server.local_addr()), hub).err().unwrap();
        assert_eq!(e.kind(), io::ErrorKind::AddrInUse);
    }
}
