//! The emulated gateway's ROS 2 side: its application's Zenoh bridge
//! (`r2p_app_gateway::ros::RosBridge`, the code the STM32F407 image runs over embassy-net) on
//! a host TCP connection to a Zenoh router, in a thread of its own. The gateway's 1 kHz step
//! leaves the latest R2P values in a [`RosSlot`] and takes the `/cmd_vel` command from it; the
//! thread publishes, receives, keeps the session alive, and reconnects when the router goes
//! away (every 500 ms until it is back). The imports only ROS wants follow its subscribers as
//! on the MCU (r2p-app-gateway's `demand`): the step leaves their [`Feed`]s here, the thread's
//! bridge decides, and the step applies its `wanted` mask to the node.

use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use r2p_app_gateway::demand::Feed;
use r2p_app_gateway::ros::{zid_of, Latest, RosBridge, RosConfig, RosStats};
use r2p_msgs::Twist2D;

/// What the gateway's step and the Zenoh thread share.
#[derive(Debug, Default)]
pub struct RosShared {
    /// The latest R2P values (the step writes them).
    pub latest: Latest,
    /// A velocity command from ROS for the step to apply (the thread writes it).
    pub cmd: Option<Twist2D>,
    /// ROS drives the base now: the teleop script stays quiet.
    pub driving: bool,
    /// The bridge's counters.
    pub stats: RosStats,
    /// The session is open.
    pub open: bool,
    /// The imports the ROS side may give up (the step writes them).
    pub feeds: Vec<Feed<'static>>,
    /// Bit `k`: `feeds[k]` is wanted (the thread writes it; `None` until it has decided).
    pub wanted: Option<u32>,
}

/// The shared state, when the gateway is connected to a router.
pub type RosSlot = Arc<Mutex<Option<RosShared>>>;

/// The Zenoh client thread; [`ZenohClient::shutdown`] (or dropping it) closes the session.
pub struct ZenohClient {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    slot: RosSlot,
}

impl ZenohClient {
    /// Connects the gateway (Zenoh ID from `uid`) to the router at `router`, in ROS `domain`
    /// and `namespace`.
    pub fn start(
        router: SocketAddr,
        uid: [u8; 12],
        domain: u32,
        namespace: String,
        slot: RosSlot,
    ) -> io::Result<Self> {
        *slot.lock().unwrap_or_else(|e| e.into_inner()) = Some(RosShared::default());
        let stop = Arc::new(AtomicBool::new(false));
        let (s, sl) = (stop.clone(), slot.clone());
        let thread = thread::Builder::new().name("gateway-zenoh".into()).spawn(move || {
            let cfg = RosConfig { domain, namespace: &namespace, zid: zid_of(uid) };
            let Some(mut bridge) = RosBridge::new(&cfg) else {
                eprintln!("r2p-emu: gateway: namespace {namespace:?} makes keys too long");
                return;
            };
            let start = Instant::now();
            // The feeds the bridge follows, across sessions: a reconnection keeps its decisions.
            let mut followed: Vec<Feed<'static>> = Vec::new();
            while !s.load(Ordering::SeqCst) {
                if let Err(e) = session(&mut bridge, &mut followed, router, start, &s, &sl) {
                    eprintln!("r2p-emu: gateway: zenoh: {e}; reconnecting");
                }
                if let Some(sh) = sl.lock().unwrap_or_else(|e| e.into_inner()).as_mut() {
                    sh.open = false;
                }
                thread::sleep(Duration::from_millis(500));
            }
        })?;
        Ok(Self { stop, thread: Some(thread), slot })
    }

    /// Closes the session and waits for the thread.
    pub fn shutdown(mut self) {
        self.stop_and_join();
    }

    fn stop_and_join(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        *self.slot.lock().unwrap_or_else(|e| e.into_inner()) = None;
    }
}

impl Drop for ZenohClient {
    fn drop(&mut self) {
        self.stop_and_join();
    }
}

fn session(
    bridge: &mut RosBridge,
    followed: &mut Vec<Feed<'static>>,
    router: SocketAddr,
    start: Instant,
    stop: &AtomicBool,
    slot: &RosSlot,
) -> io::Result<()> {
    let mut tcp = TcpStream::connect_timeout(&router, Duration::from_millis(500))?;
    tcp.set_nodelay(true)?;
    tcp.set_read_timeout(Some(Duration::from_millis(5)))?;
    let now = || start.elapsed().as_micros() as u64;
    let mut out = vec![0u8; 16 * 1024];
    let err = |e| io::Error::other(format!("{e:?}"));
    let n = bridge.connect(now(), &mut out).map_err(err)?;
    tcp.write_all(&out[..n])?;
    let mut rx: Vec<u8> = Vec::new();
    let mut buf = [0u8; 4096];
    while !stop.load(Ordering::SeqCst) {
        match tcp.read(&mut buf) {
            Ok(0) => {
                return Err(io::Error::new(
                    io::ErrorKind::UnexpectedEof,
                    "the router closed the connection",
                ))
            }
            Ok(k) => rx.extend_from_slice(&buf[..k]),
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => {}
            Err(e) => return Err(e),
        }
        while rx.len() >= 2 {
            let len = usize::from(u16::from_le_bytes([rx[0], rx[1]]));
            if rx.len() < 2 + len {
                break;
            }
            let n = bridge.receive(now(), &rx[2..2 + len], &mut out).map_err(err)?;
            rx.drain(..2 + len);
            tcp.write_all(&out[..n])?;
        }
        let t = now();
        let stamp = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_nanos() as i64);
        let latest = {
            let mut g = slot.lock().unwrap_or_else(|e| e.into_inner());
            let Some(sh) = g.as_mut() else { return Ok(()) };
            if let Some(c) = bridge.take_cmd(t) {
                sh.cmd = Some(c);
            }
            sh.driving = bridge.driving();
            sh.stats = bridge.stats();
            sh.open = bridge.state() == r2p_zenoh_state_open();
            if sh.feeds != *followed {
                bridge.follow(&sh.feeds);
                followed.clone_from(&sh.feeds);
            }
            sh.latest
        };
        let n = bridge.poll(t, stamp, &latest, &mut out).map_err(err)?;
        tcp.write_all(&out[..n])?;
        if let Some(sh) = slot.lock().unwrap_or_else(|e| e.into_inner()).as_mut() {
            sh.wanted = Some(bridge.wanted());
        }
    }
    Ok(())
}

fn r2p_zenoh_state_open() -> r2p_zenoh::session::State {
    r2p_zenoh::session::State::Open
}
