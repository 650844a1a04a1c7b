//! The queues between the gateway's bus ([`crate::BusTap`], on the bus executor) and its
//! network clients ([`crate::server`], on the network executor), and their counters.
//!
//! Both queues are bounded and neither side ever waits for the other: a client that reads too
//! slowly loses the oldest frames (counted, as `lost`), a full queue towards the bus refuses the
//! client's frame (counted, and the client is told). The bus's timing never depends on a
//! client.

use core::sync::atomic::{AtomicU32, AtomicU8, Ordering};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::pubsub::{PubSubChannel, Subscriber};
use r2p_socketcand::CanFrame;

/// Clients served at once (each holds a TCP socket and a subscription).
pub const MAX_CLIENTS: usize = 4;
/// Frames queued for the clients: 8 ms of a fully loaded 1 Mbit/s bus (~8 frames per ms).
pub const TO_CLIENTS: usize = 64;
/// Frames queued from the clients towards the bus.
pub const FROM_CLIENTS: usize = 16;

/// Who a frame comes from: [`BUS`], or the client of that number (1..=[`MAX_CLIENTS`]).
pub type Source = u8;
/// Frames of the bus, the gateway's own node's included.
pub const BUS: Source = 0;

/// A frame on its way between the bus and the clients.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkFrame {
    /// The frame.
    pub frame: CanFrame,
    /// When it went on the bus (its start of frame where the controller stamps it), µs of the
    /// gateway's clock (since its boot).
    pub at_us: u64,
    /// Who sent it: clients do not get their own frames back.
    pub from: Source,
}

/// The subscription a raw-mode client reads the bus from.
pub type BusSubscriber<'a> =
    Subscriber<'a, CriticalSectionRawMutex, LinkFrame, TO_CLIENTS, MAX_CLIENTS, 0>;

/// Counters since boot (wrapping), as `gateway/status` reports them.
#[derive(Debug, Default)]
pub struct LinkStats {
    /// Frames written to clients (each client counted).
    pub frames_to_clients: AtomicU32,
    /// Client frames that went out on the bus.
    pub frames_from_clients: AtomicU32,
    /// Client messages answered with `< error … >`.
    pub client_errors: AtomicU32,
    /// Frames lost: a slow client's oldest, a client frame refused (queue full, standard
    /// identifier) or not sent after its tries.
    pub lost: AtomicU32,
}

impl LinkStats {
    /// Adds `n` to `counter`.
    pub fn add(counter: &AtomicU32, n: u32) {
        counter.fetch_add(n, Ordering::Relaxed);
    }
}

/// The queues and counters; one per gateway, `static` on the MCU.
pub struct BusLink {
    to_clients: PubSubChannel<CriticalSectionRawMutex, LinkFrame, TO_CLIENTS, MAX_CLIENTS, 0>,
    from_clients: Channel<CriticalSectionRawMutex, LinkFrame, FROM_CLIENTS>,
    /// Bit `n - 1` set: client number `n` is connected.
    clients: AtomicU8,
    /// The counters.
    pub stats: LinkStats,
}

impl Default for BusLink {
    fn default() -> Self {
        Self::new()
    }
}

/// Why a client's frame did not join the queue to the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refused {
    /// The queue is full (the bus is busier than the clients' rate): try again later.
    QueueFull,
    /// An 11-bit identifier: the R2P bus carries 29-bit (extended) frames only.
    StandardId,
}

impl core::fmt::Display for Refused {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Refused::QueueFull => "queue to the bus full, frame dropped",
            Refused::StandardId => "the R2P bus carries 29-bit identifiers only, frame dropped",
        })
    }
}

impl BusLink {
    /// Empty queues, no client.
    pub const fn new() -> Self {
        Self {
            to_clients: PubSubChannel::new(),
            from_clients: Channel::new(),
            clients: AtomicU8::new(0),
            stats: LinkStats {
                frames_to_clients: AtomicU32::new(0),
                frames_from_clients: AtomicU32::new(0),
                client_errors: AtomicU32::new(0),
                lost: AtomicU32::new(0),
            },
        }
    }

    /// A client number for a new connection, or `None` if [`MAX_CLIENTS`] are connected.
    pub fn join(&self) -> Option<Source> {
        let mut taken = self.clients.load(Ordering::Acquire);
        loop {
            let free = (0..MAX_CLIENTS as u8).find(|n| taken & (1 << n) == 0)?;
            match self.clients.compare_exchange(
                taken,
                taken | 1 << free,
                Ordering::AcqRel,
                Ordering::Acquire,
            ) {
                Ok(_) => return Some(free + 1),
                Err(now) => taken = now,
            }
        }
    }

    /// Client `client` left.
    pub fn leave(&self, client: Source) {
        if (1..=MAX_CLIENTS as u8).contains(&client) {
            self.clients.fetch_and(!(1 << (client - 1)), Ordering::AcqRel);
        }
    }

    /// Clients connected now.
    pub fn clients(&self) -> u8 {
        self.clients.load(Ordering::Relaxed).count_ones() as u8
    }

    /// A subscription to every frame of the bus from now on (`None` if [`MAX_CLIENTS`] hold
    /// one: not expected, one per joined client).
    pub fn subscribe(&self) -> Option<BusSubscriber<'_>> {
        self.to_clients.subscriber().ok()
    }

    /// From the bus side: a frame went on the bus (received, or sent by the node or for a
    /// client). Never waits: a subscriber that has not read the oldest frame loses it.
    pub fn publish(&self, f: LinkFrame) {
        self.to_clients.immediate_publisher().publish_immediate(f);
    }

    /// From a client: queues `frame` for the bus (stamped when it goes out). Never waits.
    pub fn send(&self, from: Source, frame: CanFrame) -> Result<(), Refused> {
        if !frame.is_extended() {
            return Err(Refused::StandardId);
        }
        self.from_clients
            .try_send(LinkFrame { frame, at_us: 0, from })
            .map_err(|_| Refused::QueueFull)
    }

    /// From the bus side: the oldest client frame waiting for the bus.
    pub fn next_for_bus(&self) -> Option<LinkFrame> {
        self.from_clients.try_receive().ok()
    }
}
