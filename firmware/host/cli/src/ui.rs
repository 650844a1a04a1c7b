//! `r2p ui`: a web page for the live bus, served by `r2p` itself on loopback (nothing is fetched
//! from the internet: the page, its script and the vendored charting library, uPlot, are built
//! into the binary). The page gets the bus as a stream of snapshots (server-sent events, which
//! the browser reconnects by itself) and asks for parameters and publications with small JSON
//! requests, which run the CLI's own commands ([`crate::ui_actions`]).
//!
//! The server is tiny_http (synchronous, one thread per request): the bus loop
//! ([`crate::ui_bus`]) is a plain thread, as in every other command.

use std::io::Write;
use std::net::{IpAddr, SocketAddr};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use clap::Args;
use rtcan::LaxityEncoding;
use serde_json::{json, Value as Json};
use tiny_http::{Header, Method, Request, Response, Server};

use crate::args::{open_link, parse_laxity, parse_seconds, BusArgs};
use crate::error::CliError;
use crate::link::TraceLink;
use crate::session::Session;
use crate::ui_actions::{self, body, text_field, Open};
use crate::ui_bus::{self, Snapshots};
use crate::ui_view::BusView;

/// `r2p ui` options.
#[derive(Args, Debug)]
pub struct UiArgs {
    /// The TCP port to serve the page on
    #[arg(long, value_name = "N", default_value_t = 8023)]
    pub port: u16,
    /// The address to serve on; loopback by default (the page can set parameters and publish:
    /// serve another address only on a network you trust)
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1")]
    pub bind: IpAddr,
    /// Show a module as lost after this long without a heartbeat (10 of its default 100 ms
    /// periods, as the bus master drops its reservations)
    #[arg(long, value_name = "SECONDS", default_value = "1", value_parser = parse_seconds)]
    pub lost_after: Duration,
    /// How the bus encodes SRT laxity (log:TICK_US or linear:TICK_US), for the SRT latency
    /// histogram (as `r2p monitor --laxity`)
    #[arg(long, value_name = "ENCODING", default_value = "log:100", value_parser = parse_laxity)]
    pub laxity: LaxityEncoding,
}

/// The page's files, built in: (path, content type, bytes).
const ASSETS: &[(&str, &str, &[u8])] = &[
    ("/", "text/html; charset=utf-8", include_bytes!("../ui/index.html")),
    ("/app.js", "text/javascript; charset=utf-8", include_bytes!("../ui/app.js")),
    ("/style.css", "text/css; charset=utf-8", include_bytes!("../ui/style.css")),
    (
        "/vendor/uPlot.iife.min.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../ui/vendor/uPlot.iife.min.js"),
    ),
    (
        "/vendor/uPlot.min.css",
        "text/css; charset=utf-8",
        include_bytes!("../ui/vendor/uPlot.min.css"),
    ),
];

/// The built-in file at `path` (a query string ignored): its content type and bytes.
pub fn asset(path: &str) -> Option<(&'static str, &'static [u8])> {
    let path = path.split('?').next().unwrap_or(path);
    ASSETS.iter().find(|(p, _, _)| *p == path).map(|(_, t, b)| (*t, *b))
}

fn header(name: &str, value: &str) -> Header {
    Header::from_bytes(name.as_bytes(), value.as_bytes()).expect("a valid header")
}

/// A JSON answer: 200 with `Ok`, 400 with `{"error": …}` (the page shows the text).
fn answer(r: Result<Json, CliError>) -> Response<std::io::Cursor<Vec<u8>>> {
    let (code, j) = match r {
        Ok(j) => (200, j),
        Err(e) => (400, json!({"error": e.to_string()})),
    };
    Response::from_string(j.to_string())
        .with_status_code(code)
        .with_header(header("Content-Type", "application/json"))
}

/// Query parameter `key` of `url`, percent-decoded.
pub fn query(url: &str, key: &str) -> Option<String> {
    let q = url.split_once('?')?.1;
    q.split('&').filter_map(|kv| kv.split_once('=')).find(|(k, _)| *k == key).map(|(_, v)| {
        let mut out = Vec::new();
        let b = v.as_bytes();
        let mut i = 0;
        while i < b.len() {
            match b[i] {
                b'%' if i + 2 < b.len() => {
                    let hex = std::str::from_utf8(&b[i + 1..i + 3]).ok();
                    match hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                        Some(x) => {
                            out.push(x);
                            i += 3;
                            continue;
                        }
                        None => out.push(b'%'),
                    }
                }
                b'+' => out.push(b' '),
                c => out.push(c),
            }
            i += 1;
        }
        String::from_utf8_lossy(&out).into_owned()
    })
}

/// True if a request's `Host` header names the server by address or as `localhost`. A page of
/// another site that makes its name resolve to 127.0.0.1 (DNS rebinding) sends its own name,
/// and is refused: it could otherwise read the bus and set parameters.
pub fn host_ok(host: Option<&str>) -> bool {
    let Some(host) = host else { return false };
    let name = match host.rsplit_once(':') {
        Some((n, port)) if !port.contains(']') => n,
        _ => host,
    };
    let name = name.trim_start_matches('[').trim_end_matches(']');
    name.eq_ignore_ascii_case("localhost") || name.parse::<IpAddr>().is_ok()
}

/// True if a POST comes from the page itself: JSON (a form of another site cannot send that
/// without the browser asking first, and r2p ui never allows it), and no `Origin` but the
/// page's own.
pub fn post_ok(content_type: Option<&str>, origin: Option<&str>, host: Option<&str>) -> bool {
    let json = content_type.is_some_and(|t| t.starts_with("application/json"));
    let same = match (origin, host) {
        (None, _) => true,
        (Some(o), Some(h)) => o == format!("http://{h}"),
        (Some(_), None) => false,
    };
    json && same
}

fn header_value<'a>(req: &'a Request, name: &'static str) -> Option<&'a str> {
    req.headers().iter().find(|h| h.field.equiv(name)).map(|h| h.value.as_str())
}

/// Streams snapshots to the page as server-sent events until it goes away.
fn events(req: Request, snaps: &Snapshots) {
    let mut w = req.into_writer();
    let head = "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-cache\r\n\
                Connection: close\r\n\r\nretry: 1000\n\n";
    if w.write_all(head.as_bytes()).and_then(|()| w.flush()).is_err() {
        return;
    }
    let mut seen = 0;
    loop {
        // A comment every few seconds when nothing changes notices a page that left.
        let msg = match snaps.next_after(seen, Duration::from_secs(5)) {
            Some((n, text)) => {
                seen = n;
                format!("data: {text}\n\n")
            }
            None => ": idle\n\n".to_string(),
        };
        if w.write_all(msg.as_bytes()).and_then(|()| w.flush()).is_err() {
            return;
        }
    }
}

/// Answers one request; `open` opens a session for an action.
fn handle(mut req: Request, bus: &BusArgs, open: &Open, snaps: &Snapshots) {
    let url = req.url().to_string();
    let path = url.split('?').next().unwrap_or("").to_string();
    let host = header_value(&req, "Host");
    if !host_ok(host) {
        let r = Response::from_string("r2p ui answers only to its address or localhost")
            .with_status_code(403);
        let _ = req.respond(r);
        return;
    }
    if *req.method() == Method::Post
        && !post_ok(header_value(&req, "Content-Type"), header_value(&req, "Origin"), host)
    {
        let e = CliError::new("a POST must be JSON from r2p ui's own page");
        let _ = req.respond(answer(Err(e)).with_status_code(403));
        return;
    }
    let mut text = String::new();
    if *req.method() == Method::Post && req.as_reader().read_to_string(&mut text).is_err() {
        let _ = req.respond(answer(Err(CliError::new("the request body is not UTF-8"))));
        return;
    }
    let r = match (req.method(), path.as_str()) {
        (Method::Get, "/events") => return events(req, snaps),
        (Method::Get, "/api/params") => match query(&url, "node") {
            Some(node) => ui_actions::read_params(bus, open, &node),
            None => Err(CliError::new("/api/params?node=NODE: which module?")),
        },
        (Method::Post, "/api/param") => body(&text).and_then(|j| {
            let index = j["index"]
                .as_u64()
                .and_then(|i| u16::try_from(i).ok())
                .ok_or_else(|| CliError::new("the request has no parameter \"index\""))?;
            ui_actions::set_param(
                bus,
                open,
                text_field(&j, "node")?,
                index,
                j["type"].as_str(),
                text_field(&j, "value")?,
            )
        }),
        (Method::Post, "/api/publish") => body(&text).and_then(|j| {
            let values: Vec<String> =
                text_field(&j, "values")?.split_whitespace().map(String::from).collect();
            let deadline = match j["deadline_us"].as_u64() {
                None => None,
                Some(d) => Some(u32::try_from(d).map_err(|_| CliError::new("deadline too long"))?),
            };
            ui_actions::publish(
                bus,
                open,
                text_field(&j, "topic")?,
                values,
                j["type"].as_str().map(String::from),
                deadline,
            )
        }),
        (Method::Get, p) => match asset(p) {
            Some((ty, bytes)) => {
                let r = Response::from_data(bytes).with_header(header("Content-Type", ty));
                let _ = req.respond(r);
                return;
            }
            None => {
                let r = Response::from_string("not found").with_status_code(404);
                let _ = req.respond(r);
                return;
            }
        },
        _ => Err(CliError::new(format!("{} {path}: not something r2p ui answers", req.method()))),
    };
    let _ = req.respond(answer(r));
}

/// How the page's sessions open the bus. A trace is read once, here, before anything is
/// served: a file that is missing or not a trace is refused at once (it will not appear later,
/// as a robot that is not up yet will), and every session reads the same frames. A live bus is
/// opened for each session, and opened again while it is away (the robot or socketcand may
/// start after `r2p ui`).
pub fn opener(bus: &BusArgs) -> Result<Arc<Open>, CliError> {
    if let Some(path) = &bus.trace {
        let frames = TraceLink::read(path)?;
        let name = path.display().to_string();
        return Ok(Arc::new(move || {
            Ok(Session::new(Box::new(TraceLink::new(name.clone(), frames.clone()))))
        }));
    }
    let b = bus.clone();
    Ok(Arc::new(move || Ok(Session::new(open_link(&b)?))))
}

/// Runs `r2p ui`: serves the page until interrupted.
pub fn run(args: &UiArgs, bus: &BusArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let open = opener(bus)?;
    let addr = SocketAddr::new(args.bind, args.port);
    let server = Server::http(addr).map_err(|e| {
        CliError::new(format!("--bind {} --port {}: cannot serve there: {e}", args.bind, args.port))
    })?;
    let (lost, laxity) = (args.lost_after, args.laxity);
    crate::args::emit(out, &format!("r2p ui: open http://{addr}/"))?;
    out.flush().map_err(|e| CliError::new(format!("writing the output: {e}")))?;
    serve(&server, bus, open, move || BusView::new(lost, laxity));
    Ok(())
}

/// Serves the page on `server` until it stops: the bus loop on its own thread (sessions opened
/// by `open`, each watched into a fresh `view()`), and a thread per request.
pub fn serve(
    server: &Server,
    bus: &BusArgs,
    open: Arc<Open>,
    view: impl Fn() -> BusView + Send + 'static,
) {
    let snaps = Arc::new(Snapshots::default());
    let stop = Arc::new(AtomicBool::new(false));
    {
        let (open, snaps, stop) = (open.clone(), snaps.clone(), stop.clone());
        std::thread::spawn(move || ui_bus::run(&*open, view, &snaps, &stop));
    }
    for req in server.incoming_requests() {
        let (bus, snaps, open) = (bus.clone(), snaps.clone(), open.clone());
        std::thread::spawn(move || handle(req, &bus, &*open, &snaps));
    }
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_page_file_is_built_in_and_nothing_else_is_served() {
        let (ty, html) = asset("/").unwrap();
        assert!(ty.starts_with("text/html"));
        let html = std::str::from_utf8(html).unwrap();
        for (p, _, _) in &ASSETS[1..] {
            assert!(html.contains(&format!("\"{}\"", &p[1..])), "index.html loads {p}");
        }
        assert!(asset("/app.js?v=1").is_some());
        assert!(asset("/../Cargo.toml").is_none() && asset("/vendor/").is_none());
        assert!(
            !html.contains("http://") && !html.contains("https://"),
            "nothing from the internet"
        );
    }

    #[test]
    fn only_the_page_itself_is_answered() {
        for ok in
            ["127.0.0.1:8023", "localhost:8023", "LOCALHOST", "[::1]:8023", "10.0.0.2:80", "[::1]"]
        {
            assert!(host_ok(Some(ok)), "{ok}");
        }
        for bad in ["evil.example:8023", "evil.example", "127.0.0.1.evil.example:8023", ""] {
            assert!(!host_ok(Some(bad)), "{bad}");
        }
        assert!(!host_ok(None));
        let h = Some("127.0.0.1:8023");
        assert!(post_ok(Some("application/json"), None, h));
        assert!(post_ok(Some("application/json"), Some("http://127.0.0.1:8023"), h));
        assert!(!post_ok(Some("text/plain"), None, h), "a cross-site form's type");
        assert!(!post_ok(None, None, h));
        assert!(!post_ok(Some("application/json"), Some("http://evil.example"), h));
        assert!(!post_ok(Some("application/json"), Some("http://127.0.0.1:8023"), None));
    }

    /// Sends `request` to `addr` and returns the answer, up to its end or (for the event
    /// stream) its first event.
    fn http(addr: SocketAddr, request: &str) -> String {
        use std::io::Read;
        let mut c = std::net::TcpStream::connect(addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        c.write_all(request.as_bytes()).unwrap();
        let (mut got, mut buf) = (Vec::new(), [0u8; 4096]);
        loop {
            let n = c.read(&mut buf).unwrap_or(0);
            got.extend_from_slice(&buf[..n]);
            let text = String::from_utf8_lossy(&got);
            if n == 0 || text.contains("data: {") && text.ends_with("\n\n") {
                return text.into_owned();
            }
        }
    }

    fn get(addr: SocketAddr, path: &str, host: &str) -> String {
        http(addr, &format!("GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"))
    }

    fn post(addr: SocketAddr, path: &str, ty: &str, body: &str) -> String {
        http(
            addr,
            &format!(
                "POST {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: {ty}\r\n\
                 Content-Length: {}\r\nConnection: close\r\n\r\n{body}",
                body.len()
            ),
        )
    }

    #[test]
    fn the_server_answers_the_page_its_events_and_its_requests() {
        use crate::watch::tests::{heartbeat, management};
        let server = Server::http("127.0.0.1:0").unwrap();
        let addr = server.server_addr().to_ip().unwrap();
        let open: Arc<Open> = Arc::new(|| {
            let frames = management(1, &heartbeat("psu", 1), 0);
            Ok(Session::new(Box::new(TraceLink::new("t.log".into(), frames))))
        });
        let bus = BusArgs {
            socketcand: None,
            socketcan: None,
            trace: Some("t.log".into()),
            channel: "vcan0".into(),
            timeout: Duration::from_secs(1),
            json: false,
        };
        let lax = rtcan::LaxityEncoding::Logarithmic { tick_us: 100 };
        let server = Arc::new(server);
        let s2 = server.clone();
        let t = std::thread::spawn(move || {
            serve(&s2, &bus, open, move || BusView::new(Duration::from_secs(1), lax));
        });
        let page = get(addr, "/", "127.0.0.1");
        assert!(
            page.starts_with("HTTP/1.1 200") && page.contains("<title>r2p ui</title>"),
            "{page}"
        );
        assert!(get(addr, "/vendor/uPlot.min.css", "localhost").contains("text/css"));
        assert!(get(addr, "/nothing", "127.0.0.1").starts_with("HTTP/1.1 404"));
        assert!(get(addr, "/", "evil.example").starts_with("HTTP/1.1 403"), "DNS rebinding");
        let events = get(addr, "/events", "127.0.0.1");
        assert!(
            events.contains("text/event-stream") && events.contains("\"name\":\"psu\""),
            "{events}"
        );
        let e = get(addr, "/api/params", "127.0.0.1");
        assert!(e.starts_with("HTTP/1.1 400") && e.contains("which module?"), "{e}");
        let e = get(addr, "/api/params?node=psu", "127.0.0.1");
        assert!(e.contains("needs a live bus, not the trace t.log"), "{e}");
        let set = r#"{"node": "psu", "index": 0, "type": "u32", "value": "-1"}"#;
        assert!(post(addr, "/api/param", "text/plain", set).starts_with("HTTP/1.1 403"));
        let e = post(addr, "/api/param", "application/json", set);
        assert!(e.starts_with("HTTP/1.1 400") && e.contains("does not fit uint32"), "{e}");
        let e = post(addr, "/api/param", "application/json", r#"{"node": "psu", "value": "1"}"#);
        assert!(e.contains("no parameter \\\"index\\\""), "{e}");
        let p = r#"{"topic": "speed", "type": "float32", "values": "fast"}"#;
        let e = post(addr, "/api/publish", "application/json", p);
        assert!(e.starts_with("HTTP/1.1 400") && e.contains("fast"), "{e}");
        let p = r#"{"topic": "speed", "type": "float32", "values": "1.5"}"#;
        let e = post(addr, "/api/publish", "application/json", p);
        assert!(e.contains("needs a live bus, not the trace"), "a good message goes on: {e}");
        let e = http(addr, "PUT / HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n");
        assert!(e.contains("not something r2p ui answers"), "{e}");
        server.unblock();
        t.join().unwrap();
    }

    fn trace_bus(path: &str) -> BusArgs {
        BusArgs {
            socketcand: None,
            socketcan: None,
            trace: Some(path.into()),
            channel: "vcan0".into(),
            timeout: Duration::from_secs(1),
            json: false,
        }
    }

    #[test]
    fn a_trace_that_cannot_be_read_is_refused_before_anything_is_served() {
        // The port is taken: had r2p ui tried to serve first, it would fail on the port.
        let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let port = taken.local_addr().unwrap().port().to_string();
        let cli = |trace: &str| {
            use clap::Parser;
            crate::cli::Cli::try_parse_from(["r2p", "ui", "--trace", trace, "--port", &port])
                .unwrap()
        };
        let mut out = Vec::new();
        let e = crate::cli::run(cli("/nonexistent.pcap"), &mut out).unwrap_err().to_string();
        assert!(e.starts_with("--trace: /nonexistent.pcap: "), "what and where: {e}");
        assert!(e.contains("No such file"), "{e}");
        assert!(e.contains("give a candump log or a pcap file"), "what to do: {e}");
        let junk =
            std::env::temp_dir().join(format!("r2p-ui-not-a-trace-{}.log", std::process::id()));
        std::fs::write(&junk, "this is not a candump log\n").unwrap();
        let e = crate::cli::run(cli(junk.to_str().unwrap()), &mut out).unwrap_err().to_string();
        std::fs::remove_file(&junk).unwrap();
        assert!(e.starts_with(&format!("--trace: {}: ", junk.display())), "{e}");
        assert!(out.is_empty(), "nothing was served: {}", String::from_utf8_lossy(&out));
        // A trace that reads is served: then the taken port is the error.
        let good = std::env::temp_dir().join(format!("r2p-ui-trace-{}.log", std::process::id()));
        std::fs::write(&good, "(1.000000) vcan0 1FFFFF00#C0FFEE\n").unwrap();
        let e = crate::cli::run(cli(good.to_str().unwrap()), &mut out).unwrap_err().to_string();
        std::fs::remove_file(&good).unwrap();
        assert!(e.contains(&format!("--port {port}: cannot serve there")), "{e}");
    }

    #[test]
    fn every_session_on_a_trace_reads_it_from_its_start() {
        let path = std::env::temp_dir().join(format!("r2p-ui-twice-{}.log", std::process::id()));
        std::fs::write(&path, "(1.000000) vcan0 1FFFFF00#C0FFEE\n(1.001000) vcan0 1FFFFF01#\n")
            .unwrap();
        let open = opener(&trace_bus(path.to_str().unwrap())).unwrap();
        std::fs::remove_file(&path).unwrap();
        for _ in 0..2 {
            let mut s = open().unwrap();
            assert!(s.is_trace() && s.describe().ends_with(".log"), "{}", s.describe());
            let mut n = 0;
            while !s.ended() {
                n += s.step(Duration::ZERO).unwrap().len();
            }
            assert_eq!(n, 2, "the file was read once, before it went away");
        }
    }

    #[test]
    fn query_parameters_are_decoded() {
        assert_eq!(query("/api/params?node=motor", "node").as_deref(), Some("motor"));
        assert_eq!(query("/p?a=1&node=left%20wheel+x", "node").as_deref(), Some("left wheel x"));
        assert_eq!(query("/p?node=%zz%4", "node").as_deref(), Some("%zz%4"));
        assert_eq!(query("/p?node=x%2", "node").as_deref(), Some("x%2"), "cut short at the end");
        assert_eq!(query("/p?node=abcd%41", "node").as_deref(), Some("abcdA"));
        assert_eq!(query("/p?a=1", "node"), None);
        assert_eq!(query("/p", "node"), None);
    }
}
