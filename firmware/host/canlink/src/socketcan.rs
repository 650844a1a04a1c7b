//! Kernel CAN interfaces (Linux SocketCAN): a raw `CAN_RAW` socket on an interface such as
//! `can0` or `vcan0`, and a [`SocketCanBridge`] that makes the interface one participant of a
//! [`Hub`] — the emulated bus then reaches every SocketCAN tool (candump, cansend, Wireshark)
//! and real CAN adapters.
//!
//! The socket itself comes from the `socketcan` crate (frame layout, socket options and
//! timeouts, widely used); this module adds what the crate does not say: *why* an interface
//! cannot be opened. The crate resolves the interface name before it creates the socket, so on
//! a kernel without SocketCAN every name fails with "no such device". [`probe`] therefore
//! creates a bare `socket(AF_CAN, SOCK_RAW, CAN_RAW)` first, so that [`OpenError`] tells "this
//! kernel has no SocketCAN" (errno `EAFNOSUPPORT`) from "no such interface", "not a CAN
//! interface" and "not allowed", each with what to do.

use std::ffi::CString;
use std::fmt;
use std::io;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::Duration;

use socketcan::{EmbeddedFrame, ExtendedId, Id, Socket, StandardId};

use crate::frame::CanFrame;
use crate::hub::Hub;

/// Longest interface name (`IFNAMSIZ` − 1).
pub const IFNAME_MAX: usize = 15;
/// How to make a virtual CAN interface, for error messages.
pub const VCAN_HINT: &str = "modprobe vcan; ip link add dev vcan0 type vcan; ip link set up vcan0";

/// Why a CAN interface cannot be opened.
#[derive(Debug)]
pub enum OpenError {
    /// Not a possible interface name.
    BadName(String),
    /// The kernel has no SocketCAN: `socket(AF_CAN, …)` fails with `EAFNOSUPPORT`.
    NoKernelSupport,
    /// No network interface has this name.
    NoSuchInterface(String),
    /// The interface exists but is not a CAN interface.
    NotCan(String),
    /// Any other failure of `op` on the interface (permissions, resources).
    Os {
        /// The interface.
        iface: String,
        /// What failed.
        op: &'static str,
        /// The system's error.
        err: io::Error,
    },
}

impl fmt::Display for OpenError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OpenError::BadName(name) => write!(
                f,
                "{name:?} is not a network interface name (1 to {IFNAME_MAX} characters, no '/' \
                 or spaces), e.g. vcan0 or can0"
            ),
            OpenError::NoKernelSupport => write!(
                f,
                "this kernel has no SocketCAN (socket(AF_CAN, SOCK_RAW, CAN_RAW) fails: address \
                 family not supported). On a Linux kernel with CAN support, load it and create an \
                 interface as root: `{VCAN_HINT}`; or reach the bus over TCP with --socketcand"
            ),
            OpenError::NoSuchInterface(iface) => write!(
                f,
                "no network interface named {iface}: create a virtual CAN interface as root \
                 (`{}`) or name an existing one (`ip -br link show type can`)",
                VCAN_HINT.replace("vcan0", iface)
            ),
            OpenError::NotCan(iface) => write!(
                f,
                "{iface} is not a CAN interface (`ip -details link show {iface}` says what it is); \
                 CAN interfaces are listed by `ip -br link show type can`"
            ),
            OpenError::Os { iface, op, err } => {
                write!(f, "{op} on CAN interface {iface}: {err}")?;
                if matches!(err.kind(), io::ErrorKind::PermissionDenied) {
                    write!(f, " (run as a user allowed to open raw CAN sockets)")?;
                }
                Ok(())
            }
        }
    }
}

impl std::error::Error for OpenError {}

/// Whether this kernel can open CAN sockets: creates and closes a raw CAN socket.
pub fn probe() -> io::Result<()> {
    // SAFETY: plain system calls with constant arguments; the descriptor is closed at once.
    let fd = unsafe { libc::socket(libc::AF_CAN, libc::SOCK_RAW, libc::CAN_RAW) };
    if fd < 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: `fd` is a descriptor this function owns.
    unsafe { libc::close(fd) };
    Ok(())
}

/// True if `e` says the kernel has no SocketCAN.
pub fn is_no_kernel_support(e: &io::Error) -> bool {
    e.raw_os_error() == Some(libc::EAFNOSUPPORT)
}

fn check_name(iface: &str) -> Result<(), OpenError> {
    let ok = !iface.is_empty()
        && iface.len() <= IFNAME_MAX
        && !iface.contains(|c: char| c == '/' || c.is_whitespace() || c.is_control());
    if ok {
        Ok(())
    } else {
        Err(OpenError::BadName(iface.to_string()))
    }
}

fn if_index(iface: &str) -> io::Result<u32> {
    let name = CString::new(iface).map_err(|_| io::Error::from(io::ErrorKind::InvalidInput))?;
    // SAFETY: `name` is a valid NUL-terminated string for the duration of the call.
    match unsafe { libc::if_nametoindex(name.as_ptr()) } {
        0 => Err(io::Error::last_os_error()),
        n => Ok(n),
    }
}

/// Turns the outcome of each step of opening `iface` into a result: the AF_CAN probe, the
/// interface lookup, then binding a socket to it (`open`, run only if the others succeeded).
pub fn diagnose<S>(
    iface: &str,
    probe: io::Result<()>,
    index: impl FnOnce() -> io::Result<u32>,
    open: impl FnOnce(u32) -> io::Result<S>,
) -> Result<S, OpenError> {
    check_name(iface)?;
    let os = |op, err| OpenError::Os { iface: iface.to_string(), op, err };
    match probe {
        Err(e) if is_no_kernel_support(&e) => return Err(OpenError::NoKernelSupport),
        Err(e) => return Err(os("creating a raw CAN socket", e)),
        Ok(()) => {}
    }
    let index = match index() {
        Ok(n) => n,
        Err(e) if e.raw_os_error() == Some(libc::ENODEV) => {
            return Err(OpenError::NoSuchInterface(iface.to_string()))
        }
        Err(e) => return Err(os("looking up the interface", e)),
    };
    open(index).map_err(|e| {
        // CAN_RAW's bind refuses an interface that is not ARPHRD_CAN with ENODEV.
        if e.raw_os_error() == Some(libc::ENODEV) {
            OpenError::NotCan(iface.to_string())
        } else {
            os("binding a raw CAN socket", e)
        }
    })
}

/// The kernel's frame for one of ours.
pub fn to_socketcan(f: &CanFrame) -> socketcan::CanFrame {
    let id: Id = if f.is_extended() {
        ExtendedId::new(f.id()).expect("29-bit by construction").into()
    } else {
        StandardId::new(f.id() as u16).expect("11-bit by construction").into()
    };
    socketcan::CanFrame::new(id, f.data()).expect("at most 8 bytes by construction")
}

/// Our frame for a kernel data frame; `None` for remote and error frames.
pub fn from_socketcan(f: &socketcan::CanFrame) -> Option<CanFrame> {
    let socketcan::CanFrame::Data(d) = f else { return None };
    match d.id() {
        Id::Standard(s) => CanFrame::standard(u32::from(s.as_raw()), d.data()).ok(),
        Id::Extended(e) => CanFrame::extended(e.as_raw(), d.data()).ok(),
    }
}

/// A raw CAN socket bound to one interface, sending and receiving classic data frames.
pub struct SocketCan {
    sock: socketcan::CanSocket,
    iface: String,
    skipped: AtomicU64,
}

impl SocketCan {
    /// Opens `iface` (e.g. `vcan0`), or says why not.
    pub fn open(iface: &str) -> Result<Self, OpenError> {
        let sock = diagnose(iface, probe(), || if_index(iface), socketcan::CanSocket::open_iface)?;
        Ok(Self { sock, iface: iface.to_string(), skipped: AtomicU64::new(0) })
    }

    /// The interface's name.
    pub fn iface(&self) -> &str {
        &self.iface
    }

    /// Remote and error frames received and skipped so far.
    pub fn skipped(&self) -> u64 {
        self.skipped.load(Ordering::Relaxed)
    }

    /// Sends a frame; a full transmit queue (`ENOBUFS`) is retried for up to 100 ms.
    pub fn send(&self, frame: &CanFrame) -> io::Result<()> {
        let f = to_socketcan(frame);
        for _ in 0..100 {
            match self.sock.write_frame(&f) {
                Err(e) if e.raw_os_error() == Some(libc::ENOBUFS) => {
                    thread::sleep(Duration::from_millis(1))
                }
                Err(e) if e.raw_os_error() == Some(libc::ENETDOWN) => {
                    return Err(io::Error::new(
                        e.kind(),
                        format!("{} is down: `ip link set up {}`", self.iface, self.iface),
                    ))
                }
                other => return other,
            }
        }
        Err(io::Error::other(format!("{}: transmit queue full", self.iface)))
    }

    /// The next data frame, waiting at most `timeout`; `None` if none came.
    pub fn recv_timeout(&self, timeout: Duration) -> io::Result<Option<CanFrame>> {
        match self.sock.read_frame_timeout(timeout) {
            Ok(f) => match from_socketcan(&f) {
                Some(f) => Ok(Some(f)),
                None => {
                    self.skipped.fetch_add(1, Ordering::Relaxed);
                    Ok(None)
                }
            },
            Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock) => {
                Ok(None)
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => Ok(None),
            Err(e) => Err(e),
        }
    }
}

/// Counters of a [`SocketCanBridge`].
#[derive(Debug, Default)]
pub struct BridgeStats {
    /// Frames from the interface put on the hub.
    pub to_hub: AtomicU64,
    /// Frames from the hub sent on the interface.
    pub to_iface: AtomicU64,
    /// Frames from the hub the interface refused (down, queue full).
    pub send_errors: AtomicU64,
    /// Receive errors on the interface.
    pub recv_errors: AtomicU64,
}

/// Connects a CAN interface to a [`Hub`] as one participant: what the interface receives goes
/// to the hub's other participants, what they send goes out on the interface. The kernel
/// does not echo a socket's own frames back (`CAN_RAW_RECV_OWN_MSGS` is off), so nothing
/// loops.
pub struct SocketCanBridge {
    iface: String,
    stop: Arc<AtomicBool>,
    stats: Arc<BridgeStats>,
    threads: Vec<JoinHandle<()>>,
}

const POLL: Duration = Duration::from_millis(100);

impl SocketCanBridge {
    /// Opens `iface` and starts forwarding both ways; the hub side queues `queue` frames.
    pub fn start(iface: &str, hub: Arc<dyn Hub>, queue: usize) -> Result<Self, OpenError> {
        let sock = Arc::new(SocketCan::open(iface)?);
        let stop = Arc::new(AtomicBool::new(false));
        let stats = Arc::new(BridgeStats::default());
        let me = hub.join();
        let sub = hub.subscribe(me, queue);
        let spawn = |name: &str, body: Box<dyn FnOnce() + Send>| {
            thread::Builder::new().name(name.into()).spawn(body).map_err(|err| OpenError::Os {
                iface: iface.to_string(),
                op: "starting the bridge thread",
                err,
            })
        };
        let (s, st, h, k) = (sock.clone(), stats.clone(), hub.clone(), stop.clone());
        let reader = spawn(
            "socketcan-rx",
            Box::new(move || {
                while !k.load(Ordering::SeqCst) {
                    match s.recv_timeout(POLL) {
                        Ok(Some(f)) => {
                            h.send(me, f);
                            st.to_hub.fetch_add(1, Ordering::Relaxed);
                        }
                        Ok(None) => {}
                        Err(_) => {
                            st.recv_errors.fetch_add(1, Ordering::Relaxed);
                            thread::sleep(POLL);
                        }
                    }
                }
            }),
        )?;
        let (st, k) = (stats.clone(), stop.clone());
        let writer = spawn(
            "socketcan-tx",
            Box::new(move || {
                while !k.load(Ordering::SeqCst) {
                    if let Ok(s) = sub.recv_timeout(POLL) {
                        let counter = match sock.send(&s.frame) {
                            Ok(()) => &st.to_iface,
                            Err(_) => &st.send_errors,
                        };
                        counter.fetch_add(1, Ordering::Relaxed);
                    }
                }
            }),
        )?;
        Ok(Self { iface: iface.to_string(), stop, stats, threads: vec![reader, writer] })
    }

    /// The interface's name.
    pub fn iface(&self) -> &str {
        &self.iface
    }

    /// The bridge's counters.
    pub fn stats(&self) -> &BridgeStats {
        &self.stats
    }

    /// Stops forwarding and waits for the threads (within about 100 ms).
    pub fn stop(mut self) {
        self.stop_and_join();
    }

    fn stop_and_join(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Drop for SocketCanBridge {
    fn drop(&mut self) {
        self.stop_and_join();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hub::BroadcastHub;

    fn errno(n: i32) -> io::Error {
        io::Error::from_raw_os_error(n)
    }

    fn open_with(
        iface: &str,
        probe: io::Result<()>,
        index: io::Result<u32>,
        bind: io::Result<()>,
    ) -> Result<(), OpenError> {
        diagnose(iface, probe, || index, |_| bind)
    }

    #[test]
    fn each_failure_gets_its_own_message_and_remedy() {
        let no_kernel = open_with("vcan0", Err(errno(libc::EAFNOSUPPORT)), Ok(1), Ok(()));
        let e = no_kernel.unwrap_err();
        assert!(matches!(e, OpenError::NoKernelSupport));
        let text = e.to_string();
        assert!(text.contains("no SocketCAN") && text.contains(VCAN_HINT), "{text}");
        assert!(text.contains("--socketcand"), "{text}");

        let e = open_with("vcan7", Ok(()), Err(errno(libc::ENODEV)), Ok(())).unwrap_err();
        assert!(matches!(&e, OpenError::NoSuchInterface(i) if i == "vcan7"));
        let text = e.to_string();
        assert!(text.contains("no network interface named vcan7"), "{text}");
        assert!(text.contains("ip link add dev vcan7 type vcan; ip link set up vcan7"), "{text}");

        let e = open_with("eth0", Ok(()), Ok(2), Err(errno(libc::ENODEV))).unwrap_err();
        assert!(e.to_string().starts_with("eth0 is not a CAN interface"), "{e}");

        let e = open_with("can0", Err(errno(libc::EPERM)), Ok(2), Ok(())).unwrap_err();
        let text = e.to_string();
        assert!(text.starts_with("creating a raw CAN socket on CAN interface can0"), "{text}");
        assert!(text.contains("allowed to open raw CAN sockets"), "{text}");

        for bad in ["", "a/b", "has space", "sixteen_chars_xx"] {
            let e = open_with(bad, Ok(()), Ok(1), Ok(())).unwrap_err();
            assert!(matches!(e, OpenError::BadName(_)), "{bad:?}");
        }
        assert!(open_with("vcan0", Ok(()), Ok(3), Ok(())).is_ok());
    }

    #[test]
    fn the_probe_tells_a_kernel_without_socketcan_from_a_missing_interface() {
        match probe() {
            Err(e) if is_no_kernel_support(&e) => {
                // This machine's kernel has no AF_CAN: opening any interface must say so.
                let e = SocketCan::open("vcan0").err().expect("cannot open without AF_CAN");
                assert!(matches!(e, OpenError::NoKernelSupport), "{e}");
                eprintln!(
                    "skipped: SocketCAN I/O (open, send, receive on an interface): this \
                     kernel has no AF_CAN (errno {})",
                    libc::EAFNOSUPPORT
                );
            }
            Err(e) => panic!("unexpected probe error: {e}"),
            Ok(()) => {
                let e = SocketCan::open("r2pnosuch0").err().expect("no such interface");
                assert!(matches!(e, OpenError::NoSuchInterface(_)), "{e}");
                let e = SocketCan::open("lo").err().expect("lo is not CAN");
                assert!(matches!(e, OpenError::NotCan(_)), "{e}");
            }
        }
    }

    #[test]
    fn frames_convert_both_ways() {
        for f in [
            CanFrame::extended(0x1F80_8003, &[0x11, 2, 3]).unwrap(),
            CanFrame::extended(0, &[]).unwrap(),
            CanFrame::standard(0x7FF, &[0xFF; 8]).unwrap(),
        ] {
            let k = to_socketcan(&f);
            assert_eq!(k.is_extended(), f.is_extended());
            assert_eq!(from_socketcan(&k), Some(f));
        }
        let remote = socketcan::CanFrame::new_remote(StandardId::new(1).unwrap(), 0).unwrap();
        assert_eq!(from_socketcan(&remote), None);
    }

    /// Needs a kernel with SocketCAN and an up `vcan0`; prints why it is skipped otherwise.
    #[test]
    fn a_bridge_carries_frames_between_vcan0_and_the_hub() {
        if let Err(e) = probe() {
            eprintln!("skipped: bridge over vcan0: SocketCAN unavailable ({e})");
            return;
        }
        let hub = Arc::new(BroadcastHub::new());
        let bridge = match SocketCanBridge::start("vcan0", hub.clone(), 64) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("skipped: bridge over vcan0: {e}");
                return;
            }
        };
        let tool = SocketCan::open("vcan0").expect("second socket on vcan0");
        let me = hub.join();
        let rx = hub.subscribe(me, 64);
        let out = CanFrame::extended(0x1234_5678, &[1, 2]).unwrap();
        hub.send(me, out);
        let seen = (0..50).find_map(|_| tool.recv_timeout(Duration::from_millis(100)).unwrap());
        assert_eq!(seen, Some(out));
        let back = CanFrame::standard(0x123, &[9]).unwrap();
        tool.send(&back).unwrap();
        assert_eq!(rx.recv_timeout(Duration::from_secs(5)).unwrap().frame, back);
        bridge.stop();
    }
}
