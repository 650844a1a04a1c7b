//! The background load: one node publishes 8-byte SRT messages (one frame each, 20 ms deadline)
//! at a set rate and another subscribes to them, so the load travels the bus as a module's
//! traffic does: in the free slots, by its laxity, never in another module's HRT slot.

use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering::Relaxed};
use std::sync::Mutex;

use r2p_middleware::{Class, Delivery};
use r2p_node::{Export, Import, ImportError, WireError};
use rtcan::Micros;

/// The load's topic.
pub const TOPIC: &str = "bench/load";
const TYPE_HASH: u32 = 0x4C4F_4144;
/// Bytes per message: one frame.
pub const SIZE: usize = 8;
/// Messages kept while the bus cannot take them; more are counted as dropped, as a module's
/// full publisher queue would.
const QUEUE: u32 = 8;

/// The publishing side: a token bucket filled at `rate` messages per second.
pub struct LoadPublisher {
    rate_per_s: f64,
    bucket: Mutex<(f64, Option<Micros>)>,
    due: AtomicU32,
    active: AtomicUsize,
    /// Messages dropped because the queue was full (the bus did not take them in time).
    pub dropped: AtomicU32,
    /// Messages whose deadline the node reported missed.
    pub missed: AtomicU32,
}

impl LoadPublisher {
    /// A publisher of `rate_per_s` messages per second (0: none).
    pub fn new(rate_per_s: f64) -> Self {
        Self {
            rate_per_s,
            bucket: Mutex::new((0.0, None)),
            due: AtomicU32::new(0),
            active: AtomicUsize::new(0),
            dropped: AtomicU32::new(0),
            missed: AtomicU32::new(0),
        }
    }

    /// Publishes what has come due by `now` (the node's application step, every millisecond).
    pub fn step(&self, now: Micros) {
        let mut b = self.bucket.lock().unwrap();
        let last = b.1.replace(now).unwrap_or(now);
        b.0 += self.rate_per_s * (now - last) as f64 / 1e6;
        while b.0 >= 1.0 {
            b.0 -= 1.0;
            if self.active.load(Relaxed) == 0 {
                continue; // nobody subscribed yet: the bus carries nothing
            }
            if self.due.load(Relaxed) < QUEUE {
                self.due.fetch_add(1, Relaxed);
            } else {
                self.dropped.fetch_add(1, Relaxed);
            }
        }
    }

    /// One message's bytes: every message is the same.
    fn fill(&self, buf: &mut [u8]) -> Result<(usize, Option<Micros>), WireError> {
        buf.get_mut(..SIZE).ok_or(WireError::BufferTooSmall)?.fill(0x55);
        Ok((SIZE, None))
    }
}

impl Export for LoadPublisher {
    fn topic(&self) -> &'static str {
        TOPIC
    }
    fn type_hash(&self) -> u32 {
        TYPE_HASH
    }
    fn size(&self) -> usize {
        SIZE
    }
    fn class(&self) -> Class {
        Class::AsyncRealTime { deadline_us: 20_000 }
    }
    fn activate(&self, queue_len: u8) {
        self.active.store(usize::from(queue_len.max(1)), Relaxed);
    }
    fn deactivate(&self) {
        self.active.store(0, Relaxed);
        self.due.store(0, Relaxed);
    }
    fn active_len(&self) -> usize {
        self.active.load(Relaxed)
    }
    fn pending(&self) -> usize {
        self.due.load(Relaxed) as usize
    }
    fn peek_encoded(&self, buf: &mut [u8]) -> Option<Result<(usize, Option<Micros>), WireError>> {
        (self.due.load(Relaxed) > 0).then(|| self.fill(buf))
    }
    fn drop_oldest(&self) -> bool {
        self.due.fetch_update(Relaxed, Relaxed, |d| d.checked_sub(1)).is_ok()
    }
    fn report_deadline_miss(&self) {
        self.missed.fetch_add(1, Relaxed);
    }
}

/// The subscribing side: counts what arrives.
#[derive(Default)]
pub struct LoadSubscriber {
    /// Messages received.
    pub received: AtomicU32,
}

impl Import for LoadSubscriber {
    fn topic(&self) -> &'static str {
        TOPIC
    }
    fn type_hash(&self) -> u32 {
        TYPE_HASH
    }
    fn size(&self) -> usize {
        SIZE
    }
    fn queue_len(&self) -> usize {
        QUEUE as usize
    }
    fn publish_bytes(&self, _bytes: &[u8]) -> Result<Delivery, ImportError> {
        self.received.fetch_add(1, Relaxed);
        Ok(Delivery { delivered: 1, missed: 0 })
    }
}
