//! A no-heap loopback bus for the behaviour suite (it runs on QEMU too): every frame a port
//! sends reaches every other port, in sending order, stamped with the bus's current time.

use core::cell::{Cell, RefCell};

use heapless::Deque;
use rtcan::controller::{BusState, ErrorCounters, Filter, Received, TxError};
use rtcan::{CanController, Frame, Micros};

use crate::Node;

/// Frames a port can hold before the bus drops (and counts) more.
pub const DEPTH: usize = 48;

pub struct Bus<const PORTS: usize> {
    queues: RefCell<[Deque<Received, DEPTH>; PORTS]>,
    unplugged: Cell<[bool; PORTS]>,
    pub now: Cell<Micros>,
    pub overflow: Cell<u32>,
}

impl<const PORTS: usize> Bus<PORTS> {
    pub fn new() -> Self {
        Self {
            queues: RefCell::new(core::array::from_fn(|_| Deque::new())),
            unplugged: Cell::new([false; PORTS]),
            now: Cell::new(0),
            overflow: Cell::new(0),
        }
    }

    pub fn port(&self, me: usize) -> Port<'_, PORTS> {
        Port { bus: self, me }
    }

    /// A port whose controller refuses to send (mailboxes full), e.g. a module cut off.
    pub fn unplug(&self, me: usize, unplugged: bool) {
        let mut u = self.unplugged.get();
        u[me] = unplugged;
        self.unplugged.set(u);
    }

    /// Puts `frame` on the bus as if some other module had sent it.
    pub fn inject(&self, frame: Frame) {
        self.send(usize::MAX, frame);
    }

    fn send(&self, from: usize, frame: Frame) {
        let at = self.now.get();
        for (i, q) in self.queues.borrow_mut().iter_mut().enumerate() {
            if i != from && q.push_back(Received { frame, at }).is_err() {
                self.overflow.set(self.overflow.get() + 1);
            }
        }
    }
}

pub struct Port<'b, const PORTS: usize> {
    bus: &'b Bus<PORTS>,
    me: usize,
}

impl<const PORTS: usize> CanController for Port<'_, PORTS> {
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        if self.bus.unplugged.get()[self.me] {
            return Err(TxError::MailboxesFull);
        }
        self.bus.send(self.me, *frame);
        Ok(())
    }
    fn try_receive(&mut self) -> Option<Received> {
        self.bus.queues.borrow_mut()[self.me].pop_front()
    }
    fn set_filters(&mut self, _filters: &[Filter]) {}
    fn abort_pending(&mut self) {}
    fn bus_state(&self) -> BusState {
        BusState::ErrorActive
    }
    fn error_counters(&self) -> ErrorCounters {
        ErrorCounters::default()
    }
}

/// The node type of the suite: 2 exports, 2 imports, 24 queued frames, 4 reassembly slots of
/// 64 bytes (about 1.7 KB: three fit QEMU's RAM easily).
pub type TestNode<'a> = Node<'a, 2, 2, 24, 4, 64>;

/// Polls every node (node i on port i) every millisecond from the bus's time until `until`.
pub fn run<const PORTS: usize>(bus: &Bus<PORTS>, nodes: &mut [&mut TestNode<'_>], until: Micros) {
    while bus.now.get() < until {
        let now = bus.now.get();
        for (i, n) in nodes.iter_mut().enumerate() {
            n.poll(now, &mut bus.port(i));
        }
        bus.now.set(now + 1_000);
    }
}

/// A unique ID that differs in its last bytes.
pub fn uid(n: u32) -> [u8; 12] {
    let mut u = [0u8; 12];
    u[8..].copy_from_slice(&n.to_be_bytes());
    u
}
