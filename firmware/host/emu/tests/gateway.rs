//! The emulated Triskar2's gateway serving the bus on TCP through its own application's
//! socketcand server (r2p-app-gateway, over host TCP), as its STM32F407 image does over
//! embassy-net: a client in raw mode sees every frame of the bus, byte for byte, stamped with
//! the gateway's clock; its frames reach the bus and the gateway's own node.

use std::collections::HashMap;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::thread;
use std::time::{Duration, Instant};

use r2p_emu::robot::EmuRobot;

fn robot() -> EmuRobot {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../robots/triskar2.toml");
    EmuRobot::load(path).unwrap_or_else(|e| panic!("{e}"))
}

/// A socketcand client over TCP.
struct Client {
    stream: TcpStream,
    pending: Vec<u8>,
}

impl Client {
    fn connect(addr: std::net::SocketAddr) -> Client {
        let stream = TcpStream::connect(addr).unwrap();
        stream.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        Client { stream, pending: Vec::new() }
    }

    fn say(&mut self, text: &str) {
        self.stream.write_all(text.as_bytes()).unwrap();
    }

    fn next(&mut self) -> Option<String> {
        loop {
            if let Some(end) = self.pending.iter().position(|&b| b == b'>') {
                let msg: Vec<u8> = self.pending.drain(..=end).collect();
                return Some(String::from_utf8(msg).unwrap().trim().to_string());
            }
            let mut buf = [0; 4096];
            match self.stream.read(&mut buf) {
                Ok(0) | Err(_) => return None,
                Ok(n) => self.pending.extend_from_slice(&buf[..n]),
            }
        }
    }

    fn raw(addr: std::net::SocketAddr) -> Client {
        let mut c = Client::connect(addr);
        assert_eq!(c.next().as_deref(), Some("< hi >"));
        c.say("< open vcan0 >");
        assert_eq!(c.next().as_deref(), Some("< ok >"));
        c.say("< rawmode >");
        assert_eq!(c.next().as_deref(), Some("< ok >"));
        c
    }
}

/// A frame as the client received it: (time µs, identifier, data).
fn parse_frame(msg: &str) -> (u64, u32, Vec<u8>) {
    let words: Vec<&str> = msg.trim_start_matches('<').trim_end_matches('>').split(' ').collect();
    // "", "frame", ID, TIME, DATA, ""
    assert_eq!(words[1], "frame", "{msg}");
    let id = u32::from_str_radix(words[2], 16).unwrap();
    let (s, us) = words[3].split_once('.').unwrap();
    let t = s.parse::<u64>().unwrap() * 1_000_000 + us.parse::<u64>().unwrap();
    let data = (0..words[4].len() / 2)
        .map(|i| u8::from_str_radix(&words[4][2 * i..2 * i + 2], 16).unwrap())
        .collect();
    (t, id, data)
}

/// Runs `r` against the wall clock until `done` (at most `limit`).
fn run_realtime(r: &mut EmuRobot, limit: Duration, done: impl Fn() -> bool) {
    let start = Instant::now();
    let base = r.sim.now_ns();
    while start.elapsed() < limit && !done() {
        r.sim.run_until(base + start.elapsed().as_nanos() as u64);
        thread::sleep(Duration::from_millis(1));
    }
}

#[test]
fn a_raw_client_sees_every_frame_of_the_bus_byte_for_byte() {
    let mut r = robot();
    // Let the bus settle in virtual time (node IDs, subscriptions, HRT grants).
    r.sim.run_until(1_500_000_000);
    let server = r.serve_gateway("127.0.0.1:0".parse().unwrap()).unwrap();
    let addr = server.local_addr();
    let client = thread::spawn(move || {
        let mut c = Client::raw(addr);
        let mut got = Vec::new();
        let start = Instant::now();
        while start.elapsed() < Duration::from_millis(700) {
            match c.next() {
                Some(m) => got.push(m),
                None => break,
            }
        }
        got
    });
    run_realtime(&mut r, Duration::from_secs(10), || client.is_finished());
    let got: Vec<_> = client.join().unwrap().iter().map(|m| parse_frame(m)).collect();
    server.shutdown();

    assert!(got.len() > 150, "a loaded bus for 0.7 s: {} frames", got.len());
    // Every frame the client got went on the bus, identical, within 300 µs after its stamp
    // (its start of frame on the gateway's clock, which is the sim's).
    let bus: Vec<(u64, u32, Vec<u8>)> = r
        .sim
        .bus()
        .frames()
        .map(|(t_ns, _, f)| (t_ns / 1000, f.id().to_raw(), f.payload().to_vec()))
        .collect();
    let mut on_bus: HashMap<(u32, Vec<u8>), Vec<u64>> = HashMap::new();
    for (t, id, data) in &bus {
        on_bus.entry((*id, data.clone())).or_default().push(*t);
    }
    for (t, id, data) in &got {
        let ends = on_bus
            .get(&(*id, data.clone()))
            .unwrap_or_else(|| panic!("{id:08X} {data:02X?} at {t} µs never went on the bus"));
        assert!(
            ends.iter().any(|end| *end >= *t && *end - *t <= 300),
            "{id:08X} {data:02X?} stamped {t} µs: ends on the bus at {ends:?}"
        );
    }
    // And the client missed none of the bus's frames between its first and last.
    let (first, last) = (got.first().unwrap().0, got.last().unwrap().0);
    let mut seen: HashMap<(u32, Vec<u8>), usize> = HashMap::new();
    for (_, id, data) in &got {
        *seen.entry((*id, data.clone())).or_default() += 1;
    }
    for (t, id, data) in bus.iter().filter(|(t, ..)| *t > first + 1000 && *t + 1000 < last) {
        let n = seen.get_mut(&(*id, data.clone())).unwrap_or_else(|| {
            panic!("{id:08X} {data:02X?} went on the bus at {t} µs, the client never saw it")
        });
        assert!(*n > 0, "{id:08X} {data:02X?} at {t} µs: seen fewer times than sent");
        *n -= 1;
    }
}

#[test]
fn a_clients_frames_reach_the_bus_and_bad_input_is_answered() {
    let mut r = robot();
    r.sim.run_until(1_000_000_000);
    let server = r.serve_gateway("127.0.0.1:0".parse().unwrap()).unwrap();
    let addr = server.local_addr();
    let client = thread::spawn(move || {
        let mut c = Client::connect(addr);
        assert_eq!(c.next().as_deref(), Some("< hi >"));
        c.say("< open vcan0 >");
        assert_eq!(c.next().as_deref(), Some("< ok >"));
        c.say("< send 1ABCDE00 3 de ad 1 >< send 123 1 0 >< frobnicate >");
        let errors = [c.next(), c.next()];
        c.say("< echo >");
        assert_eq!(c.next().as_deref(), Some("< echo >"));
        errors
    });
    run_realtime(&mut r, Duration::from_secs(10), || client.is_finished());
    let errors = client.join().unwrap();
    run_realtime(&mut r, Duration::from_millis(50), || false);
    server.shutdown();
    assert_eq!(
        errors,
        [
            Some("< error the R2P bus carries 29-bit identifiers only, frame dropped >".into()),
            Some("< error unknown command frobnicate >".into())
        ]
    );
    let sent: Vec<_> = r
        .sim
        .bus()
        .frames()
        .filter(|(_, _, f)| f.id().to_raw() == 0x1ABC_DE00)
        .map(|(_, port, f)| (port, f.payload().to_vec()))
        .collect();
    let gateway = r.board("gateway").unwrap();
    assert_eq!(
        sent,
        [(r.sim.port_of(gateway), vec![0xDE, 0xAD, 0x01])],
        "sent once, by the gateway"
    );
}

#[test]
fn a_gateway_reboot_closes_its_connections_and_it_serves_again() {
    let mut r = robot();
    r.sim.run_until(500_000_000);
    let server = r.serve_gateway("127.0.0.1:0".parse().unwrap()).unwrap();
    let addr = server.local_addr();
    let client = thread::spawn(move || {
        let mut c = Client::raw(addr);
        // Frames until the reboot, then the end of the connection (not a read timeout: 5 s).
        while c.next().is_some() {}
        let ended = Instant::now();
        let mut again = Client::raw(addr);
        (ended, again.next().expect("frames from the rebooted gateway"))
    });
    run_realtime(&mut r, Duration::from_millis(300), || false);
    r.reboot("gateway").unwrap();
    let rebooted = Instant::now();
    run_realtime(&mut r, Duration::from_secs(10), || client.is_finished());
    let (ended, frame) = client.join().unwrap();
    assert!(ended.duration_since(rebooted) < Duration::from_secs(1), "closed by the reboot");
    assert!(frame.starts_with("< frame "), "{frame}");
    server.shutdown();
}
