//! One node of the baseline: plain fixed-priority CAN. Every stream has a static identifier
//! (rate-monotonic rank, [`Stream::static_id`](crate::traffic::Stream::static_id)); there are
//! no cycle, no slots and no laxity.
//!
//! The node is as good as a fixed-priority node gets: its transmit queue is sorted by
//! identifier (FIFO within a stream), it keeps its most urgent frame in a mailbox at every
//! instant — loading the next one the moment the previous one's end of frame is reported, and
//! swapping a waiting frame for a more urgent one that arrives — so it never inverts
//! priorities locally. It gets the same publisher queues, transmit-queue size and deadline
//! expiry as an RTCAN node, so the two differ only in how frames reach the bus.

use std::collections::BTreeMap;

use r2p_vbus::Port;
use rtcan::{fragments, CanController, Frame};

use crate::publish::Publishers;
use crate::record::{Carried, Counters, Sent};
use crate::setup::{Setup, TX_QUEUE};
use crate::traffic::Traffic;

/// Queue order: static rank, then push order.
type Key = (u8, u64);

#[derive(Clone, Copy, Debug)]
struct Entry {
    msg: u32,
    frame: Frame,
    /// Absolute deadline of an SRT frame, µs.
    deadline: Option<u64>,
}

/// One fixed-priority node on a port of the virtual bus.
pub struct FixedNode<'t> {
    traffic: &'t Traffic,
    port: Port,
    queue: BTreeMap<Key, Entry>,
    seq: u64,
    loaded: Option<Key>,
    publishers: Publishers,
    cycle_us: u32,
    /// Frames this node's port sent, in order.
    pub sent: Vec<Sent>,
    /// What the node counted.
    pub counters: Counters,
}

impl<'t> FixedNode<'t> {
    /// Node `index` on `port`.
    pub fn new(traffic: &'t Traffic, setup: &Setup, index: usize, mut port: Port) -> Self {
        port.set_filters(&[]); // sends only
        Self {
            traffic,
            port,
            queue: BTreeMap::new(),
            seq: 0,
            loaded: None,
            publishers: Publishers::new(traffic, setup, index, |_| true),
            cycle_us: setup.cycle.cycle_us,
            sent: Vec::new(),
            counters: Counters::default(),
        }
    }

    /// Takes the port's results: the loaded frame went out (it leaves the queue) or was taken
    /// back (it stays queued).
    fn settle(&mut self) {
        while let Some(r) = self.port.take_tx_result() {
            let Some(k) = self.loaded else { continue };
            let e = self.queue[&k];
            if r.id != e.frame.id() {
                continue;
            }
            self.loaded = None;
            if r.sent() {
                self.queue.remove(&k);
                let fragment = e.frame.id().fragment;
                self.sent.push(Sent {
                    raw_id: e.frame.id().to_raw(),
                    what: Carried::Message { msg: e.msg, fragment },
                });
            }
        }
    }

    /// Brings the node up to date at `now_ns` (after a bus event or a release).
    pub fn service(&mut self, now_ns: u64) {
        self.counters.activations += 1;
        let now_us = now_ns / 1_000;
        self.settle();

        let traffic = self.traffic;
        let counters = &mut self.counters;
        self.publishers.release_until(traffic, now_us, |_, _| counters.overflows += 1);
        let (queue, seq) = (&mut self.queue, &mut self.seq);
        let free = TX_QUEUE - queue.len();
        let cycle_us = self.cycle_us;
        self.publishers.drain(
            traffic,
            now_us,
            free,
            |m| {
                let msg = &traffic.messages[m as usize];
                let stream = &traffic.streams[usize::from(msg.stream)];
                let deadline = traffic.deadline_us(msg, cycle_us);
                for frame in fragments(stream.static_id(0), &msg.payload).expect("≤ 64 bytes") {
                    queue.insert((stream.rank, *seq), Entry { msg: m, frame, deadline });
                    *seq += 1;
                }
            },
            |_, _| counters.expired += 1,
        );

        // Frames past their deadline are not sent (as RTCAN's queue drops them); one already on
        // the wire (or in an arbitration) finishes.
        let expired: Vec<Key> = self
            .queue
            .iter()
            .filter(|(_, e)| e.deadline.is_some_and(|d| d <= now_us))
            .map(|(k, _)| *k)
            .collect();
        let mut last_msg = None;
        for k in expired {
            if Some(k) == self.loaded {
                self.port.abort_pending();
                self.settle();
                if self.loaded.is_some() {
                    continue; // on the wire
                }
            }
            let Some(e) = self.queue.remove(&k) else { continue }; // it went out just now
            if last_msg != Some(e.msg) {
                self.counters.expired += 1;
                last_msg = Some(e.msg);
            }
        }

        // Keep the most urgent frame in the mailbox.
        if let (Some(k), Some((&head, _))) = (self.loaded, self.queue.first_key_value()) {
            if head < k {
                self.port.abort_pending();
                self.settle();
                if self.loaded.is_none() {
                    self.counters.retries += 1;
                }
            }
        }
        if self.loaded.is_none() {
            if let Some((&k, e)) = self.queue.first_key_value() {
                self.port.try_transmit(&e.frame).expect("one mailbox in use at most");
                self.loaded = Some(k);
            }
        }
    }
}
