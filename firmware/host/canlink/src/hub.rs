//! Where frames meet: the [`Hub`] trait every participant (socketcand clients, the log, the
//! emulated bus) talks to, and [`BroadcastHub`], an in-memory bus on which every participant
//! sees every other participant's frames.
//!
//! Queues are bounded: a participant that does not keep up loses frames (counted in its
//! [`Subscription::dropped`]) and never slows the sender or anyone else.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TryRecvError, TrySendError};
use std::sync::{mpsc, Arc, Mutex};
use std::time::Duration;

use crate::frame::{now, CanFrame, Stamped};

/// Identifies a participant, so that it does not receive its own frames back (as on SocketCAN).
pub type ParticipantId = u64;

/// Queue length the server and tools use unless told otherwise.
pub const DEFAULT_QUEUE: usize = 1024;

/// A bus that participants send frames to and receive frames from.
///
/// The emulated bus implements this (or joins a [`BroadcastHub`] as one participant) so that
/// socketcand clients and logs see its traffic.
pub trait Hub: Send + Sync {
    /// A new participant identity (for sending, and for [`Hub::subscribe`]).
    fn join(&self) -> ParticipantId;
    /// Delivers every frame sent by others from now on, through a queue of `capacity` frames.
    fn subscribe(&self, id: ParticipantId, capacity: usize) -> Subscription;
    /// Puts `frame` on the bus, stamped with the current time. Never blocks on slow receivers.
    fn send(&self, from: ParticipantId, frame: CanFrame);
}

/// A participant's receive queue. Dropping it unsubscribes.
#[derive(Debug)]
pub struct Subscription {
    id: ParticipantId,
    rx: Receiver<Stamped>,
    dropped: Arc<AtomicU64>,
}

impl Subscription {
    /// A subscription fed through `rx`, counting overflow in `dropped` (for [`Hub`] implementors).
    pub fn new(id: ParticipantId, rx: Receiver<Stamped>, dropped: Arc<AtomicU64>) -> Self {
        Self { id, rx, dropped }
    }

    /// The subscriber's participant ID.
    pub fn id(&self) -> ParticipantId {
        self.id
    }

    /// Frames lost because this subscriber's queue was full.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }

    /// The next frame, waiting at most `timeout`.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<Stamped, RecvTimeoutError> {
        self.rx.recv_timeout(timeout)
    }

    /// The next frame if one is queued.
    pub fn try_recv(&self) -> Result<Stamped, TryRecvError> {
        self.rx.try_recv()
    }
}

struct Subscriber {
    id: ParticipantId,
    tx: SyncSender<Stamped>,
    dropped: Arc<AtomicU64>,
}

/// An in-memory broadcast bus: every subscriber gets every frame except its own.
#[derive(Default)]
pub struct BroadcastHub {
    next_id: AtomicU64,
    subscribers: Mutex<Vec<Subscriber>>,
    sent: AtomicU64,
    dropped: AtomicU64,
}

impl BroadcastHub {
    /// An empty hub.
    pub fn new() -> Self {
        Self::default()
    }

    /// Frames sent on the hub so far.
    pub fn sent(&self) -> u64 {
        self.sent.load(Ordering::Relaxed)
    }

    /// Deliveries lost to full queues so far, over all subscribers.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }

    /// Current number of subscribers.
    pub fn subscribers(&self) -> usize {
        self.lock().len()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Subscriber>> {
        // A panicking subscriber thread cannot leave the list inconsistent: recover it.
        self.subscribers.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl Hub for BroadcastHub {
    fn join(&self) -> ParticipantId {
        self.next_id.fetch_add(1, Ordering::Relaxed) + 1
    }

    fn subscribe(&self, id: ParticipantId, capacity: usize) -> Subscription {
        let (tx, rx) = mpsc::sync_channel(capacity.max(1));
        let dropped = Arc::new(AtomicU64::new(0));
        self.lock().push(Subscriber { id, tx, dropped: dropped.clone() });
        Subscription::new(id, rx, dropped)
    }

    fn send(&self, from: ParticipantId, frame: CanFrame) {
        let stamped = Stamped { time: now(), frame };
        self.sent.fetch_add(1, Ordering::Relaxed);
        self.lock().retain(|s| {
            if s.id == from {
                return true;
            }
            match s.tx.try_send(stamped) {
                Ok(()) => true,
                Err(TrySendError::Full(_)) => {
                    s.dropped.fetch_add(1, Ordering::Relaxed);
                    self.dropped.fetch_add(1, Ordering::Relaxed);
                    true
                }
                Err(TrySendError::Disconnected(_)) => false,
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(n: u8) -> CanFrame {
        CanFrame::standard(0x100, &[n]).unwrap()
    }

    #[test]
    fn everyone_but_the_sender_gets_each_frame() {
        let hub = BroadcastHub::new();
        let (a, b, c) = (hub.join(), hub.join(), hub.join());
        let (sa, sb) = (hub.subscribe(a, 8), hub.subscribe(b, 8));
        hub.send(a, frame(1));
        hub.send(c, frame(2));
        assert_eq!(sa.try_recv().unwrap().frame, frame(2));
        assert!(sa.try_recv().is_err());
        assert_eq!(sb.try_recv().unwrap().frame, frame(1));
        assert_eq!(sb.try_recv().unwrap().frame, frame(2));
        assert_eq!(hub.sent(), 2);
    }

    #[test]
    fn a_full_queue_drops_and_counts_without_blocking() {
        let hub = BroadcastHub::new();
        let (slow, fast, tx) = (hub.join(), hub.join(), hub.join());
        let s_slow = hub.subscribe(slow, 2);
        let s_fast = hub.subscribe(fast, 100);
        for n in 0..10 {
            hub.send(tx, frame(n));
        }
        assert_eq!(s_slow.dropped(), 8);
        assert_eq!(hub.dropped(), 8);
        assert_eq!(s_fast.dropped(), 0);
        assert_eq!(s_slow.try_recv().unwrap().frame, frame(0));
        assert_eq!((0..10).filter(|_| s_fast.try_recv().is_ok()).count(), 10);
    }

    #[test]
    fn dropping_a_subscription_unsubscribes() {
        let hub = BroadcastHub::new();
        let a = hub.join();
        drop(hub.subscribe(a, 4));
        hub.send(hub.join(), frame(0));
        assert_eq!(hub.subscribers(), 0);
    }
}
