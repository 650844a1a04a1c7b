//! The CLI as a module on the bus: a real [`r2p_node::Node`] runs on the host, so `echo`
//! subscribes, `pub` publishes and `param` asks exactly as a module's firmware does (node ID
//! claim, heartbeats, ADVERTISE / SUBSCRIBE_REQUEST, PARAM_GET / PARAM_SET).
//!
//! A module's topics are typed statics; the CLI learns a topic's type only at run time, from
//! its advertisement. So the local ends of its import and export are [`DynImport`] and
//! [`DynExport`], which implement the node's type-erased `Import` and `Export` traits with
//! the advertised type hash and size and hand over raw bytes (decoded and encoded by
//! [`crate::types`]).
//!
//! The node is polled (unslotted): a tool reached over TCP cannot keep a TDMA slot, so its
//! NRT frames go out when the bus lets them, like an SRT/NRT frame that lost arbitration.
//! [`crate::session::Session`] drives it.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering::Relaxed};
use std::sync::{Mutex, MutexGuard};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use r2p_canlink::CanFrame;
use r2p_management::message::{Message, Value, UID_LEN};
use r2p_management::NodeId;
use r2p_middleware::{Class, Delivery};
use r2p_node::{Event, Export, Import, ImportError, NoParams, Node, NodeConfig, WireError};
use rtcan::controller::{
    BusState, ErrorCounters, Filter, Received, TxError, TxMode, TxOutcome, TxResult,
};
use rtcan::{CanController, Frame, Micros};

use crate::error::CliError;
use crate::link::Link;
use crate::types::MsgType;
use crate::watch::{Report, TopicInfo, What};

/// The largest message (one RTCAN message).
const BUF: usize = r2p_msgs::MAX_SIZE;
/// The host node: one export, one import, room for a whole 1 KiB message in the transmit
/// queue (plus a management message), 16 streams reassembled at once.
pub type CliNode = Node<'static, 1, 1, { BUF / 8 + 8 }, 16, BUF>;

/// The name the CLI's node gives in its heartbeats.
pub const NODE_NAME: &str = "r2p-cli";
/// Messages an import keeps for the CLI (and the queue length it asks publishers for).
pub const QUEUE: usize = 64;

pub use r2p_management::node_id::TOOL_UID_PREFIX;

/// A unique ID for this run: [`TOOL_UID_PREFIX`], `r2`, the process ID and the clock's
/// nanoseconds, so that two tools started together claim different node IDs.
fn run_uid() -> [u8; UID_LEN] {
    let mut uid = [0u8; UID_LEN];
    uid[..2].copy_from_slice(&TOOL_UID_PREFIX);
    uid[2..4].copy_from_slice(b"r2");
    uid[4..8].copy_from_slice(&std::process::id().to_be_bytes());
    let nanos = SystemTime::now().duration_since(UNIX_EPOCH).unwrap_or_default().subsec_nanos();
    uid[8..].copy_from_slice(&nanos.to_be_bytes());
    uid
}

/// The queue behind a lock: `Import` and `Export` are `Sync` (a module's node runs in another
/// context than its application); a panic elsewhere leaves the queue usable.
fn locked<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The local end of an import: keeps every message's bytes for the CLI.
pub struct DynImport {
    topic: &'static str,
    hash: u32,
    size: usize,
    got: Mutex<VecDeque<Vec<u8>>>,
}

impl Import for DynImport {
    fn topic(&self) -> &'static str {
        self.topic
    }
    fn type_hash(&self) -> u32 {
        self.hash
    }
    fn size(&self) -> usize {
        self.size
    }
    fn queue_len(&self) -> usize {
        QUEUE
    }
    fn publish_bytes(&self, bytes: &[u8]) -> Result<Delivery, ImportError> {
        if bytes.len() != self.size {
            return Err(ImportError::Decode(WireError::BadLength));
        }
        let mut q = locked(&self.got);
        if q.len() >= QUEUE {
            return Err(ImportError::PoolEmpty);
        }
        q.push_back(bytes.to_vec());
        Ok(Delivery { delivered: 1, missed: 0 })
    }
}

/// The local end of an export: messages the CLI publishes, as bytes.
pub struct DynExport {
    topic: &'static str,
    hash: u32,
    size: usize,
    class: Class,
    active: AtomicUsize,
    queue: Mutex<VecDeque<Vec<u8>>>,
    misses: AtomicU32,
}

impl DynExport {
    /// Queues a message for the bus; false if nobody is subscribed or the queue is full.
    fn publish(&self, bytes: Vec<u8>) -> bool {
        let mut q = locked(&self.queue);
        let active = self.active.load(Relaxed);
        if active == 0 || q.len() >= active {
            return false;
        }
        q.push_back(bytes);
        true
    }
}

impl Export for DynExport {
    fn topic(&self) -> &'static str {
        self.topic
    }
    fn type_hash(&self) -> u32 {
        self.hash
    }
    fn size(&self) -> usize {
        self.size
    }
    fn class(&self) -> Class {
        self.class
    }
    fn activate(&self, queue_len: u8) {
        let asked = usize::from(queue_len).clamp(1, QUEUE);
        self.active.fetch_max(asked, Relaxed);
    }
    fn deactivate(&self) {
        self.active.store(0, Relaxed);
        locked(&self.queue).clear();
    }
    fn active_len(&self) -> usize {
        self.active.load(Relaxed)
    }
    fn pending(&self) -> usize {
        locked(&self.queue).len()
    }
    fn peek_encoded(&self, buf: &mut [u8]) -> Option<Result<(usize, Option<Micros>), WireError>> {
        let queue = locked(&self.queue);
        let bytes = queue.front()?;
        Some(match buf.get_mut(..bytes.len()) {
            Some(out) => {
                out.copy_from_slice(bytes);
                Ok((bytes.len(), None))
            }
            None => Err(WireError::BufferTooSmall),
        })
    }
    fn drop_oldest(&self) -> bool {
        locked(&self.queue).pop_front().is_some()
    }
    fn report_deadline_miss(&self) {
        self.misses.fetch_add(1, Relaxed);
    }
}

/// The link as the node's CAN controller: frames it received this step, and sending with a
/// budget (see [`Link::tx_gap`]).
struct Controller<'l> {
    link: &'l mut dyn Link,
    rx: &'l mut VecDeque<Received>,
    budget: usize,
    sent: usize,
    error: Option<CliError>,
    /// Results of the frames handed to the link this step (all sent at once).
    done: VecDeque<TxResult>,
}

impl CanController for Controller<'_> {
    fn set_tx_mode(&mut self, _mode: TxMode) {} // the link sends each frame once, in order
    fn take_tx_result(&mut self) -> Option<TxResult> {
        self.done.pop_front()
    }
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        if self.sent >= self.budget || self.error.is_some() {
            return Err(TxError::MailboxesFull);
        }
        let f = CanFrame::extended(frame.id().to_raw(), frame.payload()).expect("an RTCAN frame");
        match self.link.send(&f) {
            Ok(()) => {
                self.sent += 1;
                self.done.push_back(TxResult::new(frame.id(), TxOutcome::Sent));
                Ok(())
            }
            Err(e) => {
                self.error = Some(e);
                Err(TxError::MailboxesFull)
            }
        }
    }
    fn try_receive(&mut self) -> Option<Received> {
        self.rx.pop_front()
    }
    fn set_filters(&mut self, _filters: &[Filter]) {}
    fn abort_pending(&mut self) -> usize {
        0 // frames go to the link at once: nothing is ever pending
    }
    fn bus_state(&self) -> BusState {
        BusState::ErrorActive
    }
    fn error_counters(&self) -> ErrorCounters {
        ErrorCounters::default()
    }
}

/// The CLI's node and its dynamic import and export.
pub struct HostNode {
    node: Box<CliNode>,
    start: Instant,
    rx: VecDeque<Received>,
    want: Option<String>,
    import: Option<(&'static DynImport, TopicInfo)>,
    import_error: Option<CliError>,
    export: Option<&'static DynExport>,
    events: VecDeque<Event>,
}

fn leak_name(s: &str) -> &'static str {
    Box::leak(s.to_string().into_boxed_str())
}

impl HostNode {
    /// A node called [`NODE_NAME`] with a unique ID for this run; `start` is its time zero.
    pub fn new(start: Instant) -> Result<Self, CliError> {
        Self::with_uid(start, run_uid())
    }

    /// A node with unique ID `uid` (tests force node-ID conflicts with it).
    pub(crate) fn with_uid(start: Instant, uid: [u8; UID_LEN]) -> Result<Self, CliError> {
        let config = NodeConfig::new(uid, NODE_NAME);
        let node = CliNode::new(config, &NoParams)
            .map_err(|e| CliError::new(format!("cannot start the host node: {e:?}")))?;
        Ok(Self {
            node: Box::new(node),
            start,
            rx: VecDeque::new(),
            want: None,
            import: None,
            import_error: None,
            export: None,
            events: VecDeque::new(),
        })
    }

    /// The node ID it holds now.
    pub fn node_id(&self) -> NodeId {
        self.node.node_id()
    }

    fn now(&self) -> Micros {
        self.start.elapsed().as_micros() as Micros
    }

    /// Subscribes to `topic` as soon as a module advertises it, with the advertised type.
    pub fn want_import(&mut self, topic: &str) {
        self.want = Some(topic.to_string());
    }

    /// The advertisement the import was made for, once made.
    pub fn imported(&self) -> Option<&TopicInfo> {
        self.import.as_ref().map(|(_, t)| t)
    }

    /// Why the import could not be made, if it could not.
    pub fn import_error(&self) -> Option<&CliError> {
        self.import_error.as_ref()
    }

    /// Messages received on the import since the last call, oldest first.
    pub fn take_messages(&mut self) -> Vec<Vec<u8>> {
        self.import.as_ref().map(|(i, _)| locked(&i.got).drain(..).collect()).unwrap_or_default()
    }

    /// Offers `topic` of type `ty` on the bus with `class` (advertised at the next step).
    pub fn export(&mut self, topic: &str, ty: &MsgType, class: Class) -> Result<(), CliError> {
        let e: &'static DynExport = Box::leak(Box::new(DynExport {
            topic: leak_name(topic),
            hash: ty.hash,
            size: ty.size,
            class,
            active: AtomicUsize::new(0),
            queue: Mutex::new(VecDeque::new()),
            misses: AtomicU32::new(0),
        }));
        self.node
            .export(e)
            .map_err(|err| CliError::new(format!("cannot publish {topic:?}: {err:?}")))?;
        self.export = Some(e);
        Ok(())
    }

    /// Queues a message on the export; false if nobody subscribed yet or the queue is full.
    pub fn publish(&self, bytes: Vec<u8>) -> bool {
        self.export.is_some_and(|e| e.publish(bytes))
    }

    /// Deadline misses of published SRT messages.
    pub fn deadline_misses(&self) -> u32 {
        self.export.map_or(0, |e| e.misses.load(Relaxed))
    }

    /// Frames and messages not yet handed to the link.
    pub fn tx_pending(&self) -> usize {
        self.node.tx_pending() + self.export.map_or(0, |e| e.pending())
    }

    /// Asks `target` for parameter `index` (answer: an event).
    pub fn get_param(&mut self, target: NodeId, index: u16) -> Result<(), CliError> {
        self.node.get_param(target, index).map_err(|e| CliError::new(format!("{e:?}")))
    }

    /// Asks `target` to set parameter `index` (answer: an event).
    pub fn set_param(&mut self, target: NodeId, index: u16, value: Value) -> Result<(), CliError> {
        self.node.set_param(target, index, value).map_err(|e| CliError::new(format!("{e:?}")))
    }

    /// Sends firmware-update transfer message `data` to `target` (UPDATE).
    pub fn send_update(&mut self, target: NodeId, data: &[u8]) -> Result<(), CliError> {
        self.node.send_update(target, data).map_err(|e| CliError::new(format!("{e:?}")))
    }

    /// Asks `target` to reboot (REBOOT).
    pub fn request_reboot(&mut self, target: NodeId) -> Result<(), CliError> {
        self.node.request_reboot(target.get()).map_err(|e| CliError::new(format!("{e:?}")))
    }

    /// The next event of the node (subscriptions, parameter answers), oldest first.
    pub fn next_event(&mut self) -> Option<Event> {
        self.events.pop_front()
    }

    /// Takes a frame the watcher has decoded into `report`: makes the wanted import when its
    /// advertisement completes (before the node reads that same advertisement), then queues
    /// the frame for the node.
    pub(crate) fn take(&mut self, report: &Report) {
        if let What::Management {
            node,
            done: Some(Ok(Message::Advertise { topic, type_hash, size, index, class })),
        } = &report.what
        {
            let wanted = self.want.as_deref() == Some(topic.as_str());
            if wanted
                && self.import.is_none()
                && self.import_error.is_none()
                && *node != self.node_id().get()
            {
                let info = TopicInfo {
                    topic: topic.to_string(),
                    node: *node,
                    index: *index,
                    type_hash: *type_hash,
                    size: *size,
                    class: *class,
                };
                let i: &'static DynImport = Box::leak(Box::new(DynImport {
                    topic: leak_name(topic),
                    hash: *type_hash,
                    size: usize::from(*size),
                    got: Mutex::new(VecDeque::new()),
                }));
                match self.node.import(i) {
                    Ok(_) => self.import = Some((i, info)),
                    Err(e) => {
                        self.import_error =
                            Some(CliError::new(format!("cannot subscribe to {topic:?}: {e:?}")))
                    }
                }
            }
        }
        if report.frame.is_extended() {
            if let Ok(frame) = Frame::from_raw(report.frame.id(), report.frame.data()) {
                self.rx.push_back(Received { frame, at: self.now() });
            }
        }
    }

    /// Takes the queued frames without running the node's timers or sending: before it joins,
    /// the node learns from the heartbeats which node IDs are in use (and moves off its first
    /// choice if a module holds it) without a frame of its own on the bus.
    pub(crate) fn listen(&mut self) {
        while let Some(r) = self.rx.pop_front() {
            self.node.on_frame(&r);
        }
    }

    /// Runs the node: takes the queued frames, runs its timers, sends up to `budget` frames.
    /// Returns how many it sent.
    pub(crate) fn poll(&mut self, link: &mut dyn Link, budget: usize) -> Result<usize, CliError> {
        let now = self.now();
        let mut ctl = Controller {
            link,
            rx: &mut self.rx,
            budget,
            sent: 0,
            error: None,
            done: VecDeque::new(),
        };
        self.node.poll(now, &mut ctl);
        let (sent, error) = (ctl.sent, ctl.error);
        while let Some(e) = self.node.next_event() {
            self.events.push_back(e);
        }
        error.map_or(Ok(sent), Err)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::link::HubLink;
    use crate::session::Session;
    use r2p_canlink::{BroadcastHub, Hub};
    use r2p_management::message::ParamFault;
    use r2p_middleware::{pool_size, Publisher, Topic};
    use r2p_node::{Param, RamParams, RemoteSubscriber};
    use std::sync::Arc;
    use std::time::Duration;

    type Speed = Topic<'static, u32, { pool_size(&[8], 1) }, 1>;

    /// A module on the hub: a real node with an exported `u32` topic and two parameters,
    /// polled every millisecond on its own thread, publishing 1, 2, 3… every 5 ms. Each call
    /// makes its own topic and parameters (leaked: they live as long as the test process).
    pub(crate) fn spawn_module(
        hub: Arc<BroadcastHub>,
        stop: Arc<std::sync::atomic::AtomicBool>,
    ) -> std::thread::JoinHandle<()> {
        let speed: &'static Speed = Box::leak(Box::new(Topic::new("speed", 0)));
        let speed_pub: &'static Publisher<'static, u32> =
            Box::leak(Box::new(Publisher::new(speed, Class::NonRealTime)));
        let speed_out: &'static RemoteSubscriber<'static, u32, 8> =
            Box::leak(Box::new(RemoteSubscriber::new(speed_pub)));
        let params: &'static RamParams<2> = Box::leak(Box::new(RamParams::new([
            Param::u32("rate_hz", 100, 1, 1000),
            Param::f32("gain", 0.5, 0.0, 2.0),
        ])));
        speed.subscribe(speed_out).unwrap();
        let make = move || {
            let mut uid = [0u8; 12];
            uid[11] = 0x42;
            let mut node: Node<'static, 1, 1, 32, 4, 64> =
                Node::new(NodeConfig::new(uid, "sensor"), params).unwrap();
            node.export(speed_out).unwrap();
            node
        };
        let mut n = 0u32;
        drive(hub, stop, make, move |elapsed| {
            if elapsed.as_millis() as u32 / 5 > n {
                n += 1;
                speed_pub.publish_with(|v| *v = n);
            }
        })
    }

    /// Runs the node `make` makes as a module on the hub on its own thread until `stop`: every millisecond
    /// it takes the frames that came, calls `tick` with the time since the start, and polls.
    pub(crate) fn drive<
        const E: usize,
        const I: usize,
        const T: usize,
        const R: usize,
        const B: usize,
    >(
        hub: Arc<BroadcastHub>,
        stop: Arc<std::sync::atomic::AtomicBool>,
        make: impl FnOnce() -> Node<'static, E, I, T, R, B> + Send + 'static,
        mut tick: impl FnMut(Duration) + Send + 'static,
    ) -> std::thread::JoinHandle<()> {
        std::thread::spawn(move || {
            let mut node = make();
            let mut link = HubLink::join(hub, 1024);
            let start = Instant::now();
            let mut rx = VecDeque::new();
            while !stop.load(std::sync::atomic::Ordering::SeqCst) {
                while let Ok(crate::link::Recv::Frame(s)) = link.recv(Duration::ZERO) {
                    let frame = Frame::from_raw(s.frame.id(), s.frame.data()).unwrap();
                    rx.push_back(Received { frame, at: start.elapsed().as_micros() as u64 });
                }
                tick(start.elapsed());
                let mut ctl = Controller {
                    link: &mut link,
                    rx: &mut rx,
                    budget: usize::MAX,
                    sent: 0,
                    error: None,
                    done: VecDeque::new(),
                };
                node.poll(start.elapsed().as_micros() as u64, &mut ctl);
                std::thread::sleep(Duration::from_millis(1));
            }
        })
    }

    /// Steps `s` until `done` or 5 s pass.
    fn until(s: &mut Session, mut done: impl FnMut(&mut Session) -> bool) -> bool {
        let t0 = Instant::now();
        while t0.elapsed() < Duration::from_secs(5) {
            s.step(Duration::from_millis(1)).unwrap();
            if done(s) {
                return true;
            }
        }
        false
    }

    /// A tool's unique ID (as [`run_uid`] makes them) with serial `n`.
    fn tool_uid(n: u32) -> [u8; UID_LEN] {
        let mut u = [0u8; UID_LEN];
        u[..2].copy_from_slice(&TOOL_UID_PREFIX);
        u[8..].copy_from_slice(&n.to_be_bytes());
        u
    }

    /// Two tool uids that claim the same first node ID.
    fn colliding_uids() -> ([u8; UID_LEN], [u8; UID_LEN]) {
        use r2p_management::node_id::initial_node_id;
        let a = tool_uid(1);
        let b = (2..).map(tool_uid).find(|b| initial_node_id(b) == initial_node_id(&a)).unwrap();
        (a, b)
    }

    #[test]
    fn a_tool_listens_first_and_never_claims_a_running_modules_node_id() {
        use r2p_management::node_id::initial_node_id;
        let hub = Arc::new(BroadcastHub::new());
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let module = spawn_module(hub.clone(), stop.clone());
        let mut module_uid = [0u8; UID_LEN];
        module_uid[11] = 0x42; // spawn_module's
        let taken = initial_node_id(&module_uid);
        let uid = (1..).map(tool_uid).find(|u| initial_node_id(u) == taken).unwrap();
        std::thread::sleep(Duration::from_millis(50)); // the module is running

        // A listener sees every frame (a session does not get its own back from the hub).
        let mut observer = Session::new(Box::new(HubLink::join(hub.clone() as Arc<dyn Hub>, 8192)));
        let mut s = Session::new(Box::new(HubLink::join(hub.clone() as Arc<dyn Hub>, 4096)));
        let mine = s.join_with_uid(uid).unwrap().node_id();
        assert_ne!(mine, taken, "its first choice is the module's: it moved before claiming");
        // Not one heartbeat of the tool on the module's stream: the module never had to settle.
        let mut reports = Vec::new();
        for _ in 0..300 {
            s.step(Duration::from_millis(1)).unwrap();
            reports.extend(observer.step(Duration::ZERO).unwrap());
        }
        let on_taken: Vec<_> = reports
            .iter()
            .filter_map(|r| match &r.what {
                What::Management { node, done: Some(Ok(Message::Heartbeat { uid: u, .. })) } => {
                    Some((*node, *u))
                }
                _ => None,
            })
            .filter(|(n, _)| *n == taken.get())
            .collect();
        assert!(!on_taken.is_empty(), "the module heartbeats");
        assert!(on_taken.iter().all(|(_, u)| *u == module_uid), "only the module on its ID");
        assert!(
            reports.iter().any(|r| matches!(&r.what,
            What::Management { node, done: Some(Ok(Message::Heartbeat { uid: u, .. })) }
                if *node == mine.get() && *u == uid)),
            "the tool heartbeats on its own ID"
        );
        stop.store(true, std::sync::atomic::Ordering::SeqCst);
        module.join().unwrap();
    }

    #[test]
    fn a_tool_yields_a_contested_node_id_to_any_module() {
        use r2p_management::node_id::NodeIdAllocator;
        // The largest unique ID an MCU could have (its first bytes are not FF FF), against
        // this run's tool ID: both claim one node ID at once, and the module keeps it, even
        // while it is starting and the tool is running (a module rebooting under a tool).
        let module_uid = [0xFF, 0xFE, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF];
        let tool = run_uid();
        for (module_starting, tool_starting) in [(false, false), (true, false), (true, true)] {
            let mut module = NodeIdAllocator::new(module_uid);
            let mut t = NodeIdAllocator::new(tool);
            let at = module.node_id();
            let kept = module.on_heartbeat(at, &tool, tool_starting, module_starting);
            assert_eq!(kept, None, "the module stays");
            let before = t.node_id();
            let moved = t.on_heartbeat(before, &module_uid, module_starting, tool_starting);
            assert!(moved.is_some(), "the tool moves");
            assert_ne!(t.node_id(), before);
        }
    }

    #[test]
    fn a_publisher_and_a_subscriber_that_claim_one_node_id_still_meet() {
        for swap in [false, true] {
            let (a, b) = colliding_uids();
            let (pub_uid, sub_uid) = if swap { (b, a) } else { (a, b) };
            let hub = Arc::new(BroadcastHub::new());
            let mut sub = Session::new(Box::new(HubLink::join(hub.clone() as Arc<dyn Hub>, 4096)));
            let mut publ = Session::new(Box::new(HubLink::join(hub.clone() as Arc<dyn Hub>, 4096)));
            sub.join_with_uid(sub_uid).unwrap().want_import("wheel");
            for _ in 0..20 {
                sub.step(Duration::from_millis(1)).unwrap();
            }
            let ty = MsgType::by_name("uint32").unwrap();
            publ.join_with_uid(pub_uid).unwrap().export("wheel", &ty, Class::NonRealTime).unwrap();
            let t0 = Instant::now();
            let mut subscribed = false;
            while !subscribed && t0.elapsed() < Duration::from_secs(5) {
                sub.step(Duration::from_millis(1)).unwrap();
                publ.step(Duration::from_millis(1)).unwrap();
                while let Some(e) = publ.host().unwrap().next_event() {
                    subscribed |= matches!(e, Event::RemoteSubscriber { .. });
                }
            }
            let (p, s) = (publ.host().unwrap().node_id(), sub.host().unwrap().node_id());
            assert!(
                subscribed,
                "swap {swap}: no subscription in 5 s (publisher {p:?}, subscriber {s:?})"
            );
            assert_ne!(p, s);
        }
    }

    #[test]
    fn the_host_node_subscribes_by_advertised_type_and_reads_parameters() {
        let hub = Arc::new(BroadcastHub::new());
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let module = spawn_module(hub.clone(), stop.clone());
        let mut s = Session::new(Box::new(HubLink::join(hub.clone() as Arc<dyn Hub>, 4096)));
        s.join().unwrap().want_import("speed");

        // Joining makes the module re-advertise; the import follows the advertised type.
        let mut got = Vec::new();
        assert!(until(&mut s, |s| {
            got.extend(s.host().unwrap().take_messages());
            got.len() >= 3
        }));
        let info = s.host().unwrap().imported().unwrap().clone();
        assert_eq!((info.topic.as_str(), info.type_name().as_str()), ("speed", "uint32"));
        let ty = info.msg_type().unwrap();
        let values: Vec<u64> = got
            .iter()
            .map(|b| match ty.decode(b).unwrap() {
                crate::types::Decoded::Plain(crate::types::Value::One(
                    crate::types::Scalar::U(v),
                )) => v,
                other => panic!("{other:?}"),
            })
            .collect();
        assert!(values.windows(2).all(|w| w[1] == w[0] + 1), "consecutive: {values:?}");

        // Parameters: a value, and a refusal with its fault.
        assert!(until(&mut s, |s| s.watcher().nodes().any(|n| n.name == "sensor")));
        let sensor = s.watcher().nodes().find(|n| n.name == "sensor").unwrap().id;
        let sensor = NodeId::new(sensor).unwrap();
        s.host().unwrap().get_param(sensor, 1).unwrap();
        s.host().unwrap().set_param(sensor, 0, Value::U32(5000)).unwrap();
        let mut answers = Vec::new();
        assert!(until(&mut s, |s| {
            while let Some(e) = s.host().unwrap().next_event() {
                if matches!(e, Event::ParamValue { .. } | Event::ParamError { .. }) {
                    answers.push(e);
                }
            }
            answers.len() == 2
        }));
        assert_eq!(
            answers[0],
            Event::ParamValue { from: sensor, index: 1, value: Value::F32(0.5) }
        );
        assert_eq!(
            answers[1],
            Event::ParamError { from: sensor, index: 0, fault: ParamFault::OutOfRange }
        );
        stop.store(true, std::sync::atomic::Ordering::SeqCst);
        module.join().unwrap();
    }
}
