//! The local transmit queue for SRT and NRT frames: what a node sends in the free slots.
//!
//! SRT entries go earliest deadline first; NRT entries go after every SRT entry, in the order
//! they were pushed, and are never promoted. Equal keys keep push order. A frame leaves the
//! queue with its laxity code recomputed from the time left to its deadline
//! ([`LaxityEncoding`]), so CAN arbitration sees its current urgency. Entries whose deadline
//! has passed are never sent: [`TxQueue::expire`] removes them and reports each missed message
//! once, so the middleware can signal its publisher.
//!
//! Whole messages: [`TxQueue::push_message`] queues all fragments of a message or none, with
//! one deadline, so they leave in order. Messages of one stream (message ID) never overtake each
//! other: a message pushed while an earlier one of the same stream is queued is ordered as if
//! its deadline were no earlier than that one's (its laxity still comes from its own deadline).
//! Different streams may interleave, which the receiver's per-stream reassembly allows.

use crate::controller::Micros;
use crate::fragment::{fragments, frame_count, FragmentError};
use crate::frame::Frame;
use crate::id::{FrameId, MessageId};
use crate::laxity::{Laxity, LaxityEncoding};

/// How urgent a queued message is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Urgency {
    /// Soft real-time: must be sent before `deadline` (absolute, in the node's microseconds).
    Srt {
        /// Absolute deadline; at or after it the message is dropped and reported.
        deadline: Micros,
    },
    /// Non-real-time: sent when nothing SRT is waiting, never expires, never promoted.
    Nrt,
}

/// A message that missed its deadline: removed from the queue, its publisher is to be told.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Missed {
    /// The stream of the message.
    pub message: MessageId,
    /// The deadline it missed.
    pub deadline: Micros,
    /// How many of its frames were still queued (fewer than its total if some had been sent).
    pub frames: usize,
}

/// Why a push was refused; nothing was queued.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PushError {
    /// Not enough free entries for the whole message.
    Full {
        /// Entries the message needs.
        needed: usize,
        /// Entries free.
        free: usize,
    },
    /// The payload is longer than a message can be.
    Fragment(FragmentError),
}

/// Names one queued frame as [`TxQueue::peek_ticket`] handed it out, so that exactly that frame
/// can be taken out later ([`TxQueue::remove`]) — once the controller says it went out —
/// whatever was pushed or expired in between.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Ticket {
    index: u16,
    group: u32,
    fragment: u8,
}

/// End of a list of entries.
const NIL: u16 = u16::MAX;

#[derive(Clone, Copy)]
struct Entry {
    frame: Frame,
    /// The following entry: in queue order while queued, in the free list otherwise.
    next: u16,
    urgency: Urgency,
    /// EDF sort key of an SRT entry: its deadline, or later to stay behind its own stream.
    order: Micros,
    /// Which push the entry came from, to report a missed message once.
    group: u32,
}

impl Entry {
    /// An unused entry (all zeros, so a new queue is cleared, not copied).
    const UNUSED: Entry = Entry {
        frame: Frame::EMPTY,
        next: 0,
        urgency: Urgency::Srt { deadline: 0 },
        order: 0,
        group: 0,
    };

    /// Sort key: SRT before NRT, SRT by `order`; ties keep push order (insertion is stable).
    fn key(&self) -> (bool, Micros) {
        match self.urgency {
            Urgency::Srt { .. } => (false, self.order),
            Urgency::Nrt => (true, 0),
        }
    }

    fn expired(&self, now: Micros) -> bool {
        matches!(self.urgency, Urgency::Srt { deadline } if deadline <= now)
    }
}

/// A fixed-capacity queue of up to `N` frames waiting for a free slot.
///
/// The entries stay where they were pushed and are linked in queue order, so pushing, sending
/// and expiring never move the others (no `memmove` on a microcontroller).
pub struct TxQueue<const N: usize> {
    /// Entry storage: the queued entries are linked from `head`, the freed ones from `free`;
    /// `entries[fresh..]` were never used.
    entries: [Entry; N],
    head: u16,
    free: u16,
    fresh: u16,
    len: usize,
    encoding: LaxityEncoding,
    next_group: u32,
    missed: u32,
}

impl<const N: usize> TxQueue<N> {
    /// An empty queue that encodes SRT laxity with `encoding`.
    pub const fn new(encoding: LaxityEncoding) -> Self {
        const { assert!(N < NIL as usize, "a TxQueue holds fewer than 65 535 frames") };
        Self {
            entries: [Entry::UNUSED; N],
            head: NIL,
            free: NIL,
            fresh: 0,
            len: 0,
            encoding,
            next_group: 0,
            missed: 0,
        }
    }

    /// Frames queued.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// True if nothing is queued.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Frames that can still be queued.
    pub const fn free(&self) -> usize {
        N - self.len
    }

    /// Messages reported missed since the queue was made (saturating).
    pub const fn missed_total(&self) -> u32 {
        self.missed
    }

    /// Queues one frame (its laxity is replaced when it is sent; its message ID and fragment
    /// counter are kept). A full queue refuses it.
    pub fn push_frame(&mut self, frame: Frame, urgency: Urgency) -> Result<(), PushError> {
        if self.free() == 0 {
            return Err(PushError::Full { needed: 1, free: 0 });
        }
        let order = self.order_for(frame.id().message, urgency);
        let group = self.take_group();
        let e = Entry { frame, next: NIL, urgency, order, group };
        let prev = self.insertion_point(e.key());
        self.link_after(prev, e);
        Ok(())
    }

    /// Queues every fragment of `payload` as message `message`, all or nothing.
    pub fn push_message(
        &mut self,
        message: MessageId,
        payload: &[u8],
        urgency: Urgency,
    ) -> Result<(), PushError> {
        let Some(needed) = frame_count(payload.len()) else {
            return Err(PushError::Fragment(FragmentError::TooLong(payload.len())));
        };
        if needed > self.free() {
            return Err(PushError::Full { needed, free: self.free() });
        }
        let template = FrameId { laxity: Laxity::NRT, message, fragment: 0 };
        let frames = fragments(template, payload).map_err(PushError::Fragment)?;
        let order = self.order_for(message, urgency);
        let group = self.take_group();
        let mut e = Entry { frame: Frame::EMPTY, next: NIL, urgency, order, group };
        // Every fragment has the same key: each goes right after the one before.
        let mut prev = self.insertion_point(e.key());
        for frame in frames {
            e.frame = frame;
            prev = self.link_after(prev, e);
        }
        Ok(())
    }

    /// The frame to send next at time `now`, with its laxity for `now`; expired entries are
    /// skipped (they wait for [`TxQueue::expire`]). [`TxQueue::pop`] with the same `now` takes
    /// this same frame.
    pub fn peek(&self, now: Micros) -> Option<Frame> {
        let (_, i) = self.next_index(now)?;
        Some(self.stamped(&self.entries[usize::from(i)], now))
    }

    /// [`TxQueue::peek`], with a ticket for the frame: a slotted node loads the frame into the
    /// controller, leaves it queued, and [`removes`](TxQueue::remove) it only once it went out;
    /// a frame that did not stays in its place (same deadline, laxity recomputed when it is
    /// peeked again).
    pub fn peek_ticket(&self, now: Micros) -> Option<(Ticket, Frame)> {
        self.upcoming(now).next()
    }

    /// The frames to send from `now` on, in sending order, with their tickets and laxity for
    /// `now`; expired entries are skipped. The first is [`TxQueue::peek_ticket`]'s: a node whose
    /// controller sends its mailboxes in load order may load the next few at once.
    pub fn upcoming(&self, now: Micros) -> impl Iterator<Item = (Ticket, Frame)> + '_ {
        self.queued().filter(move |(_, e)| !e.expired(now)).map(move |(i, e)| {
            let ticket = Ticket { index: i, group: e.group, fragment: e.frame.id().fragment };
            (ticket, self.stamped(e, now))
        })
    }

    /// Removes the frame `ticket` names if it is still queued (false if it expired or was
    /// removed since).
    pub fn remove(&mut self, ticket: Ticket) -> bool {
        let mut prev = NIL;
        let mut found = None;
        for (i, e) in self.queued() {
            if i == ticket.index {
                found = Some(e.group == ticket.group && e.frame.id().fragment == ticket.fragment);
                break;
            }
            prev = i;
        }
        if found != Some(true) {
            return false;
        }
        self.unlink(prev, ticket.index);
        true
    }

    /// Takes the frame to send next at time `now`, with its laxity for `now`.
    pub fn pop(&mut self, now: Micros) -> Option<Frame> {
        let (prev, i) = self.next_index(now)?;
        let e = self.unlink(prev, i);
        Some(self.stamped(&e, now))
    }

    /// Removes every entry whose deadline is at or before `now` and calls `report` once per
    /// message they belonged to, in queue order; returns the number of frames removed.
    pub fn expire(&mut self, now: Micros, mut report: impl FnMut(Missed)) -> usize {
        let mut removed = 0;
        let mut pending: Option<(u32, Missed)> = None;
        let (mut prev, mut cur) = (NIL, self.head);
        while let Some(e) = self.entries.get(usize::from(cur)).copied() {
            if !e.expired(now) {
                (prev, cur) = (cur, e.next);
                continue;
            }
            self.unlink(prev, cur);
            cur = e.next;
            removed += 1;
            match &mut pending {
                Some((group, m)) if *group == e.group => m.frames += 1,
                _ => {
                    if let Some((_, m)) = pending.take() {
                        self.missed = self.missed.saturating_add(1);
                        report(m);
                    }
                    let deadline = match e.urgency {
                        Urgency::Srt { deadline } => deadline,
                        Urgency::Nrt => now,
                    };
                    let m = Missed { message: e.frame.id().message, deadline, frames: 1 };
                    pending = Some((e.group, m));
                }
            }
        }
        if let Some((_, m)) = pending {
            self.missed = self.missed.saturating_add(1);
            report(m);
        }
        removed
    }

    /// Removes every queued frame whose message ID `drop` selects, whatever its deadline (a
    /// node that moved to another node ID drops what it queued under the old one: those
    /// message IDs are another node's now); returns the number of frames removed.
    pub fn remove_messages(&mut self, mut drop: impl FnMut(MessageId) -> bool) -> usize {
        let mut removed = 0;
        let (mut prev, mut cur) = (NIL, self.head);
        while let Some(e) = self.entries.get(usize::from(cur)).copied() {
            if drop(e.frame.id().message) {
                self.unlink(prev, cur);
                removed += 1;
            } else {
                prev = cur;
            }
            cur = e.next;
        }
        removed
    }

    fn take_group(&mut self) -> u32 {
        let g = self.next_group;
        self.next_group = g.wrapping_add(1);
        g
    }

    /// The queued entries in queue order.
    fn queued(&self) -> impl Iterator<Item = (u16, &Entry)> + '_ {
        let mut cur = self.head;
        core::iter::from_fn(move || {
            let i = cur;
            let e = self.entries.get(usize::from(i))?;
            cur = e.next;
            Some((i, e))
        })
    }

    /// EDF key for a new SRT message of stream `message`: its deadline, but not before any
    /// queued SRT entry of the same stream (so it cannot overtake it).
    fn order_for(&self, message: MessageId, urgency: Urgency) -> Micros {
        match urgency {
            Urgency::Nrt => 0,
            Urgency::Srt { deadline } => self
                .queued()
                .filter(|(_, e)| {
                    matches!(e.urgency, Urgency::Srt { .. }) && e.frame.id().message == message
                })
                .fold(deadline, |acc, (_, e)| acc.max(e.order)),
        }
    }

    /// The last entry with a key less than or equal to `key` (a new entry goes after it, which
    /// keeps equal keys in push order), or `NIL` if the new entry goes first.
    fn insertion_point(&self, key: (bool, Micros)) -> u16 {
        let mut prev = NIL;
        for (i, e) in self.queued() {
            if e.key() > key {
                break;
            }
            prev = i;
        }
        prev
    }

    /// The link that points at the entry after `prev` (`head` if `prev` is `NIL`).
    fn link(&mut self, prev: u16) -> &mut u16 {
        match self.entries.get_mut(usize::from(prev)) {
            Some(e) => &mut e.next,
            None => &mut self.head,
        }
    }

    /// Queues `e` in a free entry right after `prev`; returns its index. The caller checked
    /// that there is room.
    fn link_after(&mut self, prev: u16, mut e: Entry) -> u16 {
        let i = match self.entries.get(usize::from(self.free)) {
            Some(freed) => core::mem::replace(&mut self.free, freed.next),
            None if usize::from(self.fresh) < N => {
                self.fresh += 1;
                self.fresh - 1
            }
            None => return prev,
        };
        e.next = *self.link(prev);
        *self.link(prev) = i;
        self.entries[usize::from(i)] = e;
        self.len += 1;
        i
    }

    /// Takes queued entry `i` (which follows `prev`) out of the queue and returns it.
    fn unlink(&mut self, prev: u16, i: u16) -> Entry {
        let e = self.entries[usize::from(i)];
        *self.link(prev) = e.next;
        self.entries[usize::from(i)].next = self.free;
        self.free = i;
        self.len -= 1;
        e
    }

    /// The first entry not expired at `now`, and the entry before it.
    fn next_index(&self, now: Micros) -> Option<(u16, u16)> {
        let mut prev = NIL;
        for (i, e) in self.queued() {
            if !e.expired(now) {
                return Some((prev, i));
            }
            prev = i;
        }
        None
    }

    /// The entry's frame with the laxity it has at `now` (not expired).
    fn stamped(&self, e: &Entry, now: Micros) -> Frame {
        let laxity = match e.urgency {
            Urgency::Nrt => Laxity::NRT,
            Urgency::Srt { deadline } => {
                let remaining = u32::try_from(deadline.saturating_sub(now)).unwrap_or(u32::MAX);
                // remaining > 0 because the entry is not expired; code 1 is the safe fallback.
                self.encoding.encode(remaining).unwrap_or(Laxity::from_code(1))
            }
        };
        e.frame.with_id(FrameId { laxity, ..e.frame.id() })
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    /// 100 µs per code: code = 1 + remaining / 100.
    const LIN: LaxityEncoding = LaxityEncoding::Linear { tick_us: 100 };

    fn one(message: u16, byte: u8) -> Frame {
        let id = FrameId { laxity: Laxity::NRT, message: MessageId(message), fragment: 0 };
        Frame::new(id, &[byte]).unwrap()
    }

    fn srt(deadline: Micros) -> Urgency {
        Urgency::Srt { deadline }
    }

    /// Pops everything at `now`; returns (message id, first payload byte) in order.
    fn drain<const N: usize>(q: &mut TxQueue<N>, now: Micros, out: &mut [(u16, u8)]) -> usize {
        let mut n = 0;
        while let Some(fr) = q.pop(now) {
            out[n] = (fr.id().message.0, fr.payload().first().copied().unwrap_or(0));
            n += 1;
        }
        n
    }

    r2p_testkit::suite! {
        fn srt_goes_earliest_deadline_first() {
            let mut q: TxQueue<8> = TxQueue::new(LIN);
            q.push_frame(one(0x101, 1), srt(5_000)).unwrap();
            q.push_frame(one(0x102, 2), srt(1_000)).unwrap();
            q.push_frame(one(0x103, 3), srt(3_000)).unwrap();
            q.push_frame(one(0x104, 4), srt(2_000)).unwrap();
            let mut out = [(0, 0); 8];
            assert_eq!(drain(&mut q, 0, &mut out), 4);
            assert_eq!(&out[..4], &[(0x102, 2), (0x104, 4), (0x103, 3), (0x101, 1)]);
            assert!(q.is_empty());
        }

        fn removing_a_nodes_messages_keeps_the_rest_in_order_and_frees_their_entries() {
            // Node 0x12's frames (two single frames and a three-fragment message) between node
            // 0x34's, SRT and NRT: removed wherever they are, the others left in their order.
            let mut q: TxQueue<8> = TxQueue::new(LIN);
            q.push_frame(one(0x1201, 1), srt(1_000)).unwrap();
            q.push_frame(one(0x3401, 2), srt(2_000)).unwrap();
            q.push_message(MessageId(0x1200), &[7; 20], Urgency::Nrt).unwrap();
            q.push_frame(one(0x3400, 3), Urgency::Nrt).unwrap();
            q.push_frame(one(0x1202, 4), srt(500)).unwrap();
            assert_eq!(q.len(), 7);
            let removed = q.remove_messages(|m| m.0 >> 8 == 0x12);
            assert_eq!((removed, q.len(), q.free()), (5, 2, 6));
            let mut out = [(0, 0); 8];
            assert_eq!(drain(&mut q, 0, &mut out), 2);
            assert_eq!(&out[..2], &[(0x3401, 2), (0x3400, 3)]);
            // The freed entries are reused: the queue holds eight again.
            for k in 0..8 {
                q.push_frame(one(0x5600 + k, k as u8), Urgency::Nrt).unwrap();
            }
            assert_eq!(q.remove_messages(|_| false), 0);
            assert_eq!(q.len(), 8);
        }

        fn equal_deadlines_keep_push_order() {
            let mut q: TxQueue<8> = TxQueue::new(LIN);
            for k in 0..5 {
                q.push_frame(one(0x200 + k, k as u8), srt(1_000)).unwrap();
            }
            q.push_frame(one(0x2FF, 9), srt(999)).unwrap();
            let mut out = [(0, 0); 8];
            assert_eq!(drain(&mut q, 0, &mut out), 6);
            assert_eq!(out[0], (0x2FF, 9));
            for k in 0..5 {
                assert_eq!(out[1 + k], (0x200 + k as u16, k as u8));
            }
        }

        fn nrt_waits_for_all_srt_in_fifo_order_and_is_never_promoted() {
            let mut q: TxQueue<8> = TxQueue::new(LIN);
            q.push_frame(one(0x301, 1), Urgency::Nrt).unwrap();
            q.push_frame(one(0x302, 2), srt(u64::MAX)).unwrap();
            q.push_frame(one(0x303, 3), Urgency::Nrt).unwrap();
            q.push_frame(one(0x304, 4), srt(10)).unwrap();
            // Even long after any SRT deadline, NRT keeps laxity 63.
            let first = q.pop(0).unwrap();
            assert_eq!((first.id().message.0, first.id().laxity.code()), (0x304, 1));
            let second = q.pop(0).unwrap();
            assert_eq!((second.id().message.0, second.id().laxity.code()), (0x302, 62));
            let third = q.pop(1 << 40).unwrap();
            assert_eq!((third.id().message.0, third.id().laxity), (0x301, Laxity::NRT));
            assert_eq!(q.pop(1 << 40).unwrap().id().message.0, 0x303);
            assert_eq!(q.pop(1 << 40), None);
        }

        fn laxity_is_recomputed_from_the_time_left() {
            let mut q: TxQueue<4> = TxQueue::new(LIN);
            q.push_frame(one(0x400, 0), srt(1_000)).unwrap();
            assert_eq!(q.peek(0).unwrap().id().laxity.code(), 11); // 1 + 1000/100
            assert_eq!(q.peek(950).unwrap().id().laxity.code(), 1); // 50 µs left
            assert_eq!(q.peek(999).unwrap().id().laxity.code(), 1);
            assert_eq!(q.peek(1_000), None); // deadline reached: not sent
            let log = LaxityEncoding::Logarithmic { tick_us: 100 };
            let mut q: TxQueue<4> = TxQueue::new(log);
            q.push_frame(one(0x400, 0), srt(1_000)).unwrap();
            assert_eq!(q.peek(600).unwrap().id().laxity, log.encode(400).unwrap());
            let peeked = q.peek(600);
            assert_eq!(q.pop(600), peeked);
            assert!(q.is_empty());
        }

        fn full_queue_refuses_and_messages_are_all_or_nothing() {
            let mut q: TxQueue<3> = TxQueue::new(LIN);
            q.push_message(MessageId(0x500), &[1; 14], srt(100)).unwrap(); // 2 frames with the CRC
            assert_eq!(
                q.push_message(MessageId(0x501), &[2; 9], srt(50)),
                Err(PushError::Full { needed: 2, free: 1 })
            );
            assert_eq!(q.len(), 2);
            q.push_frame(one(0x502, 3), Urgency::Nrt).unwrap();
            assert_eq!(q.push_frame(one(0x503, 4), srt(1)), Err(PushError::Full { needed: 1, free: 0 }));
            assert_eq!(
                q.push_message(MessageId(0x504), &[0; 1015], Urgency::Nrt),
                Err(PushError::Fragment(FragmentError::TooLong(1015)))
            );
            assert_eq!(q.len(), 3);
        }

        fn fragments_leave_in_order_and_a_stream_never_overtakes_itself() {
            let mut q: TxQueue<16> = TxQueue::new(LIN);
            let mut a = [0u8; 22]; // 3 frames with the transfer CRC
            for (i, b) in a.iter_mut().enumerate() {
                *b = i as u8;
            }
            q.push_message(MessageId(0x600), &a, srt(5_000)).unwrap();
            // The same stream's next message has an earlier deadline: it still waits its turn.
            q.push_message(MessageId(0x600), &[0xEE; 9], srt(1_000)).unwrap();
            // Another stream's earlier deadline goes first.
            q.push_message(MessageId(0x601), &[0xDD; 9], srt(2_000)).unwrap();
            let mut order = [(0u16, 0u8, 0u8); 7];
            for slot in order.iter_mut() {
                let fr = q.pop(0).unwrap();
                *slot = (fr.id().message.0, fr.id().fragment, fr.payload()[0]);
            }
            assert_eq!(
                order,
                [
                    (0x601, 2, 0xDD),
                    (0x601, 1, 0xDD),
                    (0x600, 3, 0),
                    (0x600, 2, 8),
                    (0x600, 1, 16),
                    (0x600, 2, 0xEE),
                    (0x600, 1, 0xEE),
                ]
            );
            // ...but its own deadline still sets its laxity.
            q.push_message(MessageId(0x700), &[1], srt(9_000)).unwrap();
            q.push_message(MessageId(0x700), &[2], srt(300)).unwrap();
            assert_eq!(q.pop(0).unwrap().id().laxity.code(), 62);
            assert_eq!(q.peek(0).unwrap().id().laxity.code(), 4);
        }

        fn a_ticket_removes_its_frame_whatever_came_in_between() {
            let mut q: TxQueue<8> = TxQueue::new(LIN);
            q.push_message(MessageId(0x500), &[1; 12], srt(2_000)).unwrap(); // 2 frames
            let (t, f) = q.peek_ticket(0).unwrap();
            assert_eq!((f.id().message.0, f.id().fragment, f.id().laxity.code()), (0x500, 2, 21));
            // Meanwhile: a more urgent message arrives, time passes.
            q.push_frame(one(0x501, 7), srt(500)).unwrap();
            assert_eq!(q.peek(100).unwrap().id().message.0, 0x501);
            assert!(q.remove(t));
            assert!(!q.remove(t), "removed once");
            let mut out = [(0, 0); 8];
            assert_eq!(drain(&mut q, 100, &mut out), 2);
            assert_eq!(&out[..2], &[(0x501, 7), (0x500, 1)]);
            // The frame after it is the message's last fragment, still queued in order.
        }

        fn a_ticket_of_an_expired_frame_removes_nothing() {
            let mut q: TxQueue<4> = TxQueue::new(LIN);
            q.push_frame(one(0x600, 1), srt(1_000)).unwrap();
            let (t, _) = q.peek_ticket(0).unwrap();
            assert_eq!(q.expire(1_000, |_| {}), 1);
            // The freed entry is reused by another frame: the old ticket does not take it.
            q.push_frame(one(0x601, 2), srt(5_000)).unwrap();
            assert!(!q.remove(t));
            assert_eq!(q.len(), 1);
            assert_eq!(q.peek_ticket(1_000).unwrap().1.id().message.0, 0x601);
        }

        fn the_spec_example_holds() {
            // docs/rtcan.md, "The SRT/NRT transmit queue".
            let mut q: TxQueue<4> = TxQueue::new(LIN);
            q.push_frame(one(0xA, 0), srt(5_000)).unwrap();
            q.push_frame(one(0xB, 0), srt(1_000)).unwrap();
            q.push_frame(one(0xC, 0), Urgency::Nrt).unwrap();
            q.push_frame(one(0xD, 0), srt(1_000)).unwrap();
            assert_eq!(q.peek(1_000).map(|f| (f.id().message.0, f.id().laxity.code())), Some((0xA, 41)));
            let mut order = [(0u16, 0u8); 4];
            let mut probe: TxQueue<4> = TxQueue::new(LIN);
            for (m, u) in [(0xA, srt(5_000)), (0xB, srt(1_000)), (0xC, Urgency::Nrt), (0xD, srt(1_000))] {
                probe.push_frame(one(m, 0), u).unwrap();
            }
            for o in order.iter_mut() {
                let f = probe.pop(0).unwrap();
                *o = (f.id().message.0, f.id().laxity.code());
            }
            assert_eq!(order, [(0xB, 11), (0xD, 11), (0xA, 51), (0xC, 63)]);
            let mut reported = [0u16; 2];
            let mut n = 0;
            assert_eq!(q.expire(1_000, |m| { reported[n] = m.message.0; n += 1; }), 2);
            assert_eq!(reported, [0xB, 0xD]);
        }

        fn expired_messages_are_removed_and_reported_once() {
            let mut q: TxQueue<16> = TxQueue::new(LIN);
            q.push_message(MessageId(0x800), &[1; 22], srt(1_000)).unwrap(); // 3 frames
            q.push_message(MessageId(0x801), &[2; 8], srt(1_000)).unwrap();
            q.push_message(MessageId(0x802), &[3; 8], srt(3_000)).unwrap();
            q.push_frame(one(0x803, 4), Urgency::Nrt).unwrap();
            assert_eq!(q.pop(0).unwrap().id().message.0, 0x800); // one fragment sent
            // Expired entries are never sent, even before expire() is called.
            assert_eq!(q.peek(1_000).unwrap().id().message.0, 0x802);
            let mut missed = [None; 4];
            let mut n = 0;
            let removed = q.expire(1_000, |m| {
                missed[n] = Some(m);
                n += 1;
            });
            assert_eq!(removed, 3);
            assert_eq!(n, 2);
            assert_eq!(missed[0], Some(Missed { message: MessageId(0x800), deadline: 1_000, frames: 2 }));
            assert_eq!(missed[1], Some(Missed { message: MessageId(0x801), deadline: 1_000, frames: 1 }));
            assert_eq!(q.missed_total(), 2);
            assert_eq!(q.len(), 2);
            assert_eq!(q.expire(2_999, |_| panic!("nothing is due")), 0);
            assert_eq!(q.expire(u64::MAX, |m| assert_eq!(m.message, MessageId(0x802))), 1);
            assert_eq!(q.pop(u64::MAX).unwrap().id().message.0, 0x803); // NRT never expires
        }
    }
}

#[cfg(test)]
mod proptests {
    extern crate std;

    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    const ENC: LaxityEncoding = LaxityEncoding::Logarithmic { tick_us: 10 };

    #[derive(Clone, Debug)]
    enum Op {
        /// Stream, deadline (None = NRT), payload length.
        Push(u16, Option<u64>, usize),
        Pop(u64),
        Expire(u64),
    }

    fn op() -> impl Strategy<Value = Op> {
        prop_oneof![
            3 => (0u16..4, prop::option::of(0u64..2_000), 0usize..=24).prop_map(|(s, d, n)| Op::Push(s, d, n)),
            2 => (0u64..2_000).prop_map(Op::Pop),
            1 => (0u64..2_000).prop_map(Op::Expire),
        ]
    }

    /// The reference: a plain list in push order; the next frame is the minimum of
    /// (class, EDF key, push number) over entries not expired.
    #[derive(Clone, Debug)]
    struct M {
        stream: u16,
        deadline: Option<u64>,
        key: u64,
        seq: usize,
        group: usize,
        fragment: u8,
        bytes: Vec<u8>,
    }

    fn model_next(model: &[M], now: u64) -> Option<usize> {
        (0..model.len())
            .filter(|&i| model[i].deadline.is_none_or(|d| d > now))
            .min_by_key(|&i| (model[i].deadline.is_none(), model[i].key, model[i].seq))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        #[test]
        fn queue_matches_the_reference(ops in prop::collection::vec(op(), 0..80)) {
            let mut q: TxQueue<12> = TxQueue::new(ENC);
            let mut model: Vec<M> = Vec::new();
            let mut seq = 0;
            for (g, op) in ops.into_iter().enumerate() {
                match op {
                    Op::Push(stream, deadline, n) => {
                        let payload: Vec<u8> = (0..n).map(|i| (g * 7 + i) as u8).collect();
                        let urgency = deadline.map_or(Urgency::Nrt, |d| Urgency::Srt { deadline: d });
                        let r = q.push_message(MessageId(stream), &payload, urgency);
                        let frames = crate::fragment::frame_count(n).unwrap();
                        if model.len() + frames > 12 {
                            prop_assert_eq!(r, Err(PushError::Full { needed: frames, free: 12 - model.len() }));
                            continue;
                        }
                        prop_assert_eq!(r, Ok(()));
                        // A stream never overtakes itself: key = max(own deadline, its queued SRT keys).
                        let key = deadline.map_or(0, |d| {
                            model.iter().filter(|m| m.stream == stream && m.deadline.is_some()).map(|m| m.key).fold(d, u64::max)
                        });
                        let mut wire = payload.clone();
                        if frames > 1 {
                            wire.extend_from_slice(&crate::transfer_crc::of(&payload).to_be_bytes());
                        }
                        let chunks: Vec<&[u8]> = if n == 0 { std::vec![&[][..]] } else { wire.chunks(8).collect() };
                        for (k, c) in chunks.iter().enumerate() {
                            let fragment = if frames == 1 { 0 } else { (chunks.len() - k) as u8 };
                            model.push(M { stream, deadline, key, seq, group: g, fragment, bytes: c.to_vec() });
                            seq += 1;
                        }
                    }
                    Op::Pop(now) => {
                        let got = q.pop(now);
                        match model_next(&model, now) {
                            None => prop_assert_eq!(got, None),
                            Some(i) => {
                                let m = model.remove(i);
                                let f = got.unwrap();
                                prop_assert_eq!(f.id().message, MessageId(m.stream));
                                prop_assert_eq!(f.id().fragment, m.fragment);
                                prop_assert_eq!(f.payload(), &m.bytes[..]);
                                let lax = m.deadline.map_or(Laxity::NRT, |d| ENC.encode((d - now) as u32).unwrap());
                                prop_assert_eq!(f.id().laxity, lax);
                            }
                        }
                    }
                    Op::Expire(now) => {
                        let mut reports = Vec::new();
                        let removed = q.expire(now, |m| reports.push(m));
                        let (gone, kept): (Vec<M>, Vec<M>) =
                            model.drain(..).partition(|m| m.deadline.is_some_and(|d| d <= now));
                        model = kept;
                        prop_assert_eq!(removed, gone.len());
                        // One report per message, in queue order, counting its queued frames.
                        let mut gone = gone;
                        gone.sort_by_key(|m| (m.key, m.seq));
                        let mut want: Vec<Missed> = Vec::new();
                        let mut last_group = None;
                        for m in &gone {
                            if last_group == Some(m.group) {
                                want.last_mut().unwrap().frames += 1;
                            } else {
                                want.push(Missed { message: MessageId(m.stream), deadline: m.deadline.unwrap(), frames: 1 });
                                last_group = Some(m.group);
                            }
                        }
                        prop_assert_eq!(reports, want);
                    }
                }
                prop_assert_eq!(q.len(), model.len());
            }
        }

        /// Distinct streams, single frames, popped with no time passing: SRT in non-decreasing
        /// deadline order (push order among equals), then NRT in push order.
        #[test]
        fn edf_then_fifo(items in prop::collection::vec(prop::option::of(1u64..50), 0..32)) {
            let mut q: TxQueue<32> = TxQueue::new(ENC);
            for (i, d) in items.iter().enumerate() {
                let id = FrameId { laxity: Laxity::NRT, message: MessageId(0x100 + i as u16), fragment: 0 };
                let urgency = d.map_or(Urgency::Nrt, |d| Urgency::Srt { deadline: d });
                q.push_frame(Frame::new(id, &[]).unwrap(), urgency).unwrap();
            }
            let popped: Vec<usize> = core::iter::from_fn(|| q.pop(0)).map(|f| usize::from(f.id().message.0 - 0x100)).collect();
            let mut want: Vec<usize> = (0..items.len()).collect();
            want.sort_by_key(|&i| (items[i].is_none(), items[i].unwrap_or(0)));
            prop_assert_eq!(popped, want);
        }
    }
}
