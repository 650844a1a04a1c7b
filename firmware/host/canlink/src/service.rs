//! What a program serving the hub needs around the server, shared by `r2p-canlink` and
//! `r2p-emu`: knowing when to stop (SIGINT/SIGTERM or standard input closing), a candump
//! logger on the hub, a clear message when the listening address cannot be used, and
//! [`HubService`], which starts and stops the three in the one right order.

use std::fs::File;
use std::io::{self, BufWriter, Read};
use std::net::SocketAddr;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::Duration;

use crate::candump::LogWriter;
use crate::hub::{BroadcastHub, Hub};
use crate::server::{Config, Server, DEFAULT_ADDR};

#[cfg(unix)]
mod signals {
    use std::sync::atomic::{AtomicBool, Ordering};

    static STOP: AtomicBool = AtomicBool::new(false);

    extern "C" fn on_signal(_: i32) {
        STOP.store(true, Ordering::SeqCst);
    }

    extern "C" {
        fn signal(signum: i32, handler: extern "C" fn(i32)) -> usize;
    }

    const SIGINT: i32 = 2;
    const SIGTERM: i32 = 15;

    pub fn install() {
        // SAFETY: the handler only stores to an atomic, which is async-signal-safe.
        unsafe {
            signal(SIGINT, on_signal);
            signal(SIGTERM, on_signal);
        }
    }

    pub fn received() -> bool {
        STOP.load(Ordering::SeqCst)
    }
}

#[cfg(not(unix))]
mod signals {
    pub fn install() {}
    pub fn received() -> bool {
        false
    }
}

/// Why a serving program stops: a signal, or its standard input closing (so a parent process
/// that dies takes it down). Standard input is not watched when it is `/dev/null` or when the
/// caller does not ask for it (`--no-stdin`).
pub struct StopConditions {
    stdin_closed: Arc<AtomicBool>,
}

impl StopConditions {
    /// Installs the SIGINT/SIGTERM handler and, if `watch_stdin`, a thread that reads standard
    /// input to its end.
    pub fn install(watch_stdin: bool) -> Self {
        signals::install();
        let stdin_closed = Arc::new(AtomicBool::new(false));
        if watch_stdin && !stdin_is_null() {
            let closed = stdin_closed.clone();
            thread::spawn(move || {
                let mut buf = [0u8; 256];
                let mut stdin = io::stdin();
                loop {
                    match stdin.read(&mut buf) {
                        Ok(0) => break,
                        Ok(_) => {}
                        Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                        Err(_) => break,
                    }
                }
                closed.store(true, Ordering::SeqCst);
            });
        }
        Self { stdin_closed }
    }

    /// Why to stop now, if so: `"signal"` or `"standard input closed"`.
    pub fn reason(&self) -> Option<&'static str> {
        if signals::received() {
            Some("signal")
        } else if self.stdin_closed.load(Ordering::SeqCst) {
            Some("standard input closed")
        } else {
            None
        }
    }
}

fn stdin_is_null() -> bool {
    std::fs::read_link("/proc/self/fd/0").is_ok_and(|p| p == std::path::Path::new("/dev/null"))
}

/// Writes every frame on `hub` to `file` as a candump log until `stop` is set, then drains;
/// joins as a participant with a queue of `queue` frames. Returns the frames it had to drop.
pub fn spawn_logger(
    hub: Arc<BroadcastHub>,
    file: File,
    channel: String,
    stop: Arc<AtomicBool>,
    queue: usize,
) -> JoinHandle<io::Result<u64>> {
    let sub = hub.subscribe(hub.join(), queue);
    thread::spawn(move || {
        let mut log = LogWriter::new(BufWriter::new(file), &channel);
        loop {
            match sub.recv_timeout(Duration::from_millis(100)) {
                Ok(s) => {
                    log.write(&s)?;
                    while let Ok(s) = sub.try_recv() {
                        log.write(&s)?;
                    }
                    log.flush()?;
                }
                Err(_) if stop.load(Ordering::SeqCst) => break,
                Err(_) => {}
            }
        }
        while let Ok(s) = sub.try_recv() {
            log.write(&s)?;
        }
        log.flush()?;
        Ok(sub.dropped())
    })
}

/// The options `r2p-canlink serve` and `r2p-emu demo --realtime` share: where the socketcand
/// server listens, the bus name, the candump log and whether standard input closing stops it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ServiceOptions {
    /// `--socketcand ADDR` ([`DEFAULT_ADDR`] by default).
    pub addr: SocketAddr,
    /// `--channel NAME` (`vcan0` by default).
    pub channel: String,
    /// `--log FILE`.
    pub log: Option<String>,
    /// Cleared by `--no-stdin`.
    pub watch_stdin: bool,
}

impl Default for ServiceOptions {
    fn default() -> Self {
        Self {
            addr: DEFAULT_ADDR.parse().expect("default address"),
            channel: "vcan0".into(),
            log: None,
            watch_stdin: true,
        }
    }
}

impl ServiceOptions {
    /// Takes `arg` if it is one of these options, asking `value` for its value: `Ok(false)` if
    /// it is not one of them (the program's own, or unknown), an error if its value is bad.
    pub fn take(
        &mut self,
        arg: &str,
        value: impl FnOnce() -> Result<String, String>,
    ) -> Result<bool, String> {
        match arg {
            "--socketcand" => self.addr = parse_listen_addr(&value()?)?,
            "--channel" => self.channel = parse_channel(&value()?)?,
            "--log" => self.log = Some(value()?),
            "--no-stdin" => self.watch_stdin = false,
            _ => return Ok(false),
        }
        Ok(true)
    }
}

/// Reads a program's command line: its one `command`, then options, the shared ones into
/// `service` and every other through `own(option, value)`, where `value()` takes the option's
/// value (or fails naming the option). `own` returns [`unknown_option`] for one it does not
/// know.
pub fn parse_command_line(
    args: &[String],
    command: &str,
    service: &mut ServiceOptions,
    mut own: impl FnMut(&str, &mut dyn FnMut() -> Result<String, String>) -> Result<(), String>,
) -> Result<(), String> {
    let mut it = args.iter();
    match it.next().map(String::as_str) {
        Some(c) if c == command => {}
        Some(other) => return Err(format!("unknown command {other} (try --help)")),
        None => return Err("missing command (try --help)".into()),
    }
    while let Some(arg) = it.next() {
        let mut value = || it.next().cloned().ok_or_else(|| format!("{arg} needs a value"));
        if !service.take(arg, &mut value)? {
            own(arg, &mut value)?;
        }
    }
    Ok(())
}

/// A serving program's `main` around `run`, which gets the arguments: no argument prints
/// `help` (exit status 2), `--help` or `-h` prints it (0); an error is printed as
/// "`name`: error: …" (2).
pub fn run_main(
    name: &str,
    help: &str,
    run: impl FnOnce(&[String]) -> Result<(), String>,
) -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() || args.iter().any(|a| a == "--help" || a == "-h") {
        print!("{help}");
        return if args.is_empty() { ExitCode::from(2) } else { ExitCode::SUCCESS };
    }
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{name}: error: {e}");
            ExitCode::from(2)
        }
    }
}

/// The error for an option a program does not know.
pub fn unknown_option(option: &str) -> String {
    format!("unknown option {option} (try --help)")
}

/// The value of `--socketcand`: the address to listen on.
pub fn parse_listen_addr(v: &str) -> Result<SocketAddr, String> {
    v.parse().map_err(|_| format!("--socketcand {v}: expected IP:PORT, e.g. 127.0.0.1:29536"))
}

/// The value of `--channel`: a bus name as socketcand's `< open NAME >` carries it (no blanks,
/// no angle brackets).
pub fn parse_channel(v: &str) -> Result<String, String> {
    if v.is_empty() || v.contains(|c: char| c.is_whitespace() || c == '<' || c == '>') {
        return Err(format!("--channel {v:?}: not a bus name"));
    }
    Ok(v.into())
}

/// The message for a server that cannot listen on `addr`; `others` names what else might hold
/// the port (e.g. "another r2p-canlink or socketcand").
pub fn listen_error(addr: SocketAddr, e: &io::Error, others: &str) -> String {
    match e.kind() {
        io::ErrorKind::AddrInUse => {
            format!("{addr} is already in use ({others}?); pick another port with --socketcand")
        }
        io::ErrorKind::AddrNotAvailable => format!("{addr} is not an address of this machine"),
        _ => format!("cannot listen on {addr}: {e}"),
    }
}

/// A hub, its optional candump log and its socketcand server: how `r2p-canlink serve` and
/// `r2p-emu`'s real-time run (`r2p sim --realtime`) start and stop their service.
pub struct HubService {
    /// The bus every participant joins.
    pub hub: Arc<BroadcastHub>,
    /// Set when the service stops; threads serving the hub (the logger, heartbeats) watch it.
    pub stop: Arc<AtomicBool>,
    logger: Option<JoinHandle<io::Result<u64>>>,
}

impl HubService {
    /// A hub and, with `log`, a logger appending every frame it carries to that candump log
    /// (bus name `channel`, a queue of `queue` frames).
    pub fn new(log: Option<&str>, channel: &str, queue: usize) -> Result<Self, String> {
        let hub = Arc::new(BroadcastHub::new());
        let stop = Arc::new(AtomicBool::new(false));
        let logger = match log {
            Some(path) => {
                let file = File::options()
                    .create(true)
                    .append(true)
                    .open(path)
                    .map_err(|e| format!("cannot open log {path}: {e}"))?;
                Some(spawn_logger(hub.clone(), file, channel.into(), stop.clone(), queue))
            }
            None => None,
        };
        Ok(Self { hub, stop, logger })
    }

    /// Starts the socketcand server on the hub. If it cannot listen, stops the logger and says
    /// why, naming `others` as what may hold the address.
    pub fn listen(&mut self, config: Config, others: &str) -> Result<Server, String> {
        let addr = config.addr;
        Server::start(config, self.hub.clone()).map_err(|e| {
            self.stop.store(true, Ordering::SeqCst);
            if let Some(l) = self.logger.take() {
                let _ = l.join();
            }
            listen_error(addr, &e, others)
        })
    }

    /// Sets [`stop`](Self::stop) (call before shutting the server down, as the threads
    /// serving the hub end with it).
    pub fn stopping(&self) {
        self.stop.store(true, Ordering::SeqCst);
    }

    /// Waits for the log to be written; true if there is one.
    pub fn finish(mut self) -> Result<bool, String> {
        self.stopping();
        match self.logger.take().map(JoinHandle::join) {
            None => Ok(false),
            Some(Ok(Ok(_))) => Ok(true),
            Some(Ok(Err(e))) => Err(format!("writing the log: {e}")),
            Some(Err(_)) => Err("the log writer panicked".into()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str]) -> Result<(ServiceOptions, Vec<String>), String> {
        let args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
        let (mut opts, mut rest) = (ServiceOptions::default(), Vec::new());
        parse_command_line(&args, "serve", &mut opts, |arg, value| {
            match arg {
                "--own" => rest.push(value()?),
                "--flag" => rest.push(arg.into()),
                other => return Err(unknown_option(other)),
            }
            Ok(())
        })?;
        Ok((opts, rest))
    }

    #[test]
    fn the_shared_options_are_taken_and_the_others_left() {
        let (o, rest) = parse(&[
            "serve",
            "--socketcand",
            "0.0.0.0:1234",
            "--flag",
            "--channel",
            "can1",
            "--log",
            "x.log",
            "--no-stdin",
            "--own",
            "--log",
        ])
        .unwrap();
        assert_eq!(o.addr, "0.0.0.0:1234".parse().unwrap());
        assert_eq!(
            (o.channel.as_str(), o.log.as_deref(), o.watch_stdin),
            ("can1", Some("x.log"), false)
        );
        assert_eq!(rest, ["--flag", "--log"], "the program's own options, their values included");
        let d = parse(&["serve"]).unwrap().0;
        assert_eq!(d, ServiceOptions::default());
        assert_eq!(
            (d.addr.to_string().as_str(), d.channel.as_str(), d.watch_stdin),
            (DEFAULT_ADDR, "vcan0", true)
        );
    }

    #[test]
    fn bad_values_and_commands_are_clear_errors() {
        assert_eq!(parse(&["serve", "--log"]).unwrap_err(), "--log needs a value");
        assert!(parse(&["serve", "--socketcand", "here"])
            .unwrap_err()
            .contains("expected IP:PORT"));
        assert!(parse(&["serve", "--channel", "a b"]).unwrap_err().contains("not a bus name"));
        assert_eq!(parse(&["serve", "--own"]).unwrap_err(), "--own needs a value");
        assert_eq!(parse(&["serve", "--x"]).unwrap_err(), "unknown option --x (try --help)");
        assert_eq!(parse(&["demo"]).unwrap_err(), "unknown command demo (try --help)");
        assert_eq!(parse(&[]).unwrap_err(), "missing command (try --help)");
    }
}
