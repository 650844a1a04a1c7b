//! The emulated gateway's network: its application's socketcand server — `r2p-app-gateway`'s
//! `serve`, the code the STM32F407 image runs over embassy-net sockets — over host TCP
//! streams, one thread per client (an `async-io` reactor drives each session; the sessions
//! share nothing but the gateway's `BusLink`, whose queues never block the emulated bus).
//!
//! The listening address stands in for the gateway's Ethernet port: while a [`GatewayServer`]
//! listens, the gateway sees its link up with that address (in `gateway/status` and on its
//! link LED). A gateway that reboots gets a new `BusLink`: the connections of the old one are
//! closed, as a reset MCU's are, and new connections are served on the new one.

use std::io;
use std::net::{IpAddr, Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::Duration;

use async_io::{Async, Timer};
use futures_lite::{AsyncReadExt, AsyncWriteExt};
use r2p_app_gateway::server::{serve, Config, CHANNEL};
use r2p_app_gateway::{BusLink, NetState};

/// The link of the gateway's current boot (replaced when it reboots); `None` before it boots.
pub type LinkSlot = Arc<Mutex<Option<&'static BusLink>>>;

/// The network as the emulated gateway's application sees it.
pub type NetSlot = Arc<Mutex<NetState>>;

/// A host TCP stream as an `embedded-io-async` stream (what embassy-net's sockets are on the
/// MCU).
struct HostStream(Async<TcpStream>);

impl embedded_io_async::ErrorType for HostStream {
    type Error = io::Error;
}

impl embedded_io_async::Read for HostStream {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, io::Error> {
        self.0.read(buf).await
    }
}

impl embedded_io_async::Write for HostStream {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, io::Error> {
        self.0.write(buf).await
    }

    async fn flush(&mut self) -> Result<(), io::Error> {
        self.0.flush().await
    }
}

/// The host's timer as the server's `DelayNs` (embassy-time's `Delay` on the MCU).
struct HostDelay;

impl embedded_hal_async::delay::DelayNs for HostDelay {
    async fn delay_ns(&mut self, ns: u32) {
        Timer::after(Duration::from_nanos(ns.into())).await;
    }
}

/// The emulated gateway's server, listening; [`GatewayServer::shutdown`] (or dropping it)
/// closes every connection and takes the link down.
pub struct GatewayServer {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    net: NetSlot,
}

impl GatewayServer {
    /// Listens on `addr` and serves each client on the gateway's current link.
    pub fn start(addr: SocketAddr, link: LinkSlot, net: NetSlot) -> io::Result<Self> {
        let listener = TcpListener::bind(addr)?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let s = stop.clone();
        let thread = thread::Builder::new()
            .name("gateway-accept".into())
            .spawn(move || accept_loop(listener, link, s))?;
        let ip = match addr.ip() {
            IpAddr::V4(v4) => Some(v4.octets()),
            IpAddr::V6(_) => None,
        };
        *net.lock().unwrap_or_else(|e| e.into_inner()) =
            NetState { link_up: true, ip, dhcp: false, ros_filtered: 0 };
        Ok(Self { addr, stop, thread: Some(thread), net })
    }

    /// The address bound (useful with port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Stops listening, closes every connection, waits for their threads.
    pub fn shutdown(mut self) {
        self.stop_and_join();
    }

    fn stop_and_join(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        *self.net.lock().unwrap_or_else(|e| e.into_inner()) = NetState::default();
    }
}

impl Drop for GatewayServer {
    fn drop(&mut self) {
        self.stop_and_join();
    }
}

fn accept_loop(listener: TcpListener, link: LinkSlot, stop: Arc<AtomicBool>) {
    let mut clients: Vec<(JoinHandle<()>, TcpStream)> = Vec::new();
    let mut serving = None;
    while !stop.load(Ordering::SeqCst) {
        let current = *link.lock().unwrap_or_else(|e| e.into_inner());
        if current.map(|l| l as *const BusLink) != serving {
            // The gateway rebooted: its connections went with its RAM.
            for (_, s) in &clients {
                let _ = s.shutdown(Shutdown::Both);
            }
            serving = current.map(|l| l as *const BusLink);
        }
        match listener.accept() {
            Ok((stream, _)) => {
                let (Some(l), Ok(keep)) = (current, stream.try_clone()) else { continue };
                match thread::Builder::new()
                    .name("gateway-client".into())
                    .spawn(move || serve_stream(stream, l))
                {
                    Ok(h) => clients.push((h, keep)),
                    Err(e) => eprintln!("r2p-emu: gateway: cannot start a client thread: {e}"),
                }
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                thread::sleep(Duration::from_millis(20))
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => {
                eprintln!("r2p-emu: gateway: accept: {e}");
                thread::sleep(Duration::from_millis(100));
            }
        }
        clients.retain(|(h, _)| !h.is_finished());
    }
    for (h, s) in clients {
        let _ = s.shutdown(Shutdown::Both);
        let _ = h.join();
    }
}

fn serve_stream(stream: TcpStream, link: &'static BusLink) {
    let _ = stream.set_nodelay(true);
    let Ok(stream) = Async::new(stream) else { return };
    let mut io = HostStream(stream);
    let _ = async_io::block_on(serve(&mut io, link, &Config { channel: CHANNEL }, &mut HostDelay));
}
