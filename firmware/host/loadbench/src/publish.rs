//! A node's publishers: released messages wait in their stream's queue until the node's
//! transmit queue has room for the whole message, as the node runtime's `drain_exports` moves
//! them (streams in order, whole messages only, SRT messages already past their deadline
//! dropped). The same for both protocols, so they differ only in how frames reach the bus.

use std::collections::VecDeque;

use r2p_node::node::nrt_reserve;

use crate::setup::{Setup, TX_QUEUE};
use crate::traffic::Traffic;

/// Why a released message never reached the transmit queue.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dropped {
    /// Its stream's publisher queue was full.
    Overflow,
    /// Its deadline passed while it waited.
    Expired,
}

/// One node's publisher queues.
pub struct Publishers {
    /// This node's releases not yet published, in release order.
    releases: VecDeque<u32>,
    /// (stream, its queue) in drain order.
    queues: Vec<(u16, VecDeque<u32>)>,
    capacity: usize,
    cycle_us: u32,
}

impl Publishers {
    /// The publishers of node `node` for the streams `include` accepts.
    pub fn new(
        traffic: &Traffic,
        setup: &Setup,
        node: usize,
        include: impl Fn(u16) -> bool,
    ) -> Self {
        let mine = |s: u16| traffic.streams[usize::from(s)].node == node && include(s);
        let releases = (0..traffic.messages.len() as u32)
            .filter(|&m| mine(traffic.messages[m as usize].stream))
            .collect();
        let queues = (0..traffic.streams.len() as u16)
            .filter(|&s| mine(s))
            .map(|s| (s, VecDeque::new()))
            .collect();
        Self { releases, queues, capacity: setup.backlog, cycle_us: setup.cycle.cycle_us }
    }

    /// Publishes every message released at or before `now_us`; a full stream queue loses it.
    pub fn release_until(
        &mut self,
        traffic: &Traffic,
        now_us: u64,
        mut lost: impl FnMut(u32, Dropped),
    ) {
        while let Some(&m) = self.releases.front() {
            let msg = &traffic.messages[m as usize];
            if msg.release_us > now_us {
                break;
            }
            self.releases.pop_front();
            let q = self.queues.iter_mut().find(|(s, _)| *s == msg.stream);
            match q {
                Some((_, q)) if q.len() < self.capacity => q.push_back(m),
                _ => lost(m, Dropped::Overflow),
            }
        }
    }

    /// When the next message is released, µs (none left: `None`).
    pub fn next_release(&self, traffic: &Traffic) -> Option<u64> {
        self.releases.front().map(|&m| traffic.messages[m as usize].release_us)
    }

    /// Moves whole messages into the transmit queue while `free` frames allow: `push(m)` queues
    /// message `m`; SRT messages whose deadline is at or before `now_us` go to `lost`. NRT
    /// messages leave half the queue free for SRT ones, as the node runtime's `drain_exports`
    /// does (`r2p_node::node::nrt_reserve`).
    pub fn drain(
        &mut self,
        traffic: &Traffic,
        now_us: u64,
        mut free: usize,
        mut push: impl FnMut(u32),
        mut lost: impl FnMut(u32, Dropped),
    ) {
        for (_, q) in &mut self.queues {
            while let Some(&m) = q.front() {
                let msg = &traffic.messages[m as usize];
                if traffic.deadline_us(msg, self.cycle_us).is_some_and(|d| d <= now_us) {
                    q.pop_front();
                    lost(m, Dropped::Expired);
                    continue;
                }
                let frames = usize::from(msg.frames);
                let reserve = match traffic.deadline_us(msg, self.cycle_us) {
                    None => nrt_reserve(TX_QUEUE, frames),
                    Some(_) => 0,
                };
                if frames + reserve > free {
                    break;
                }
                q.pop_front();
                free -= frames;
                push(m);
            }
        }
    }
}
