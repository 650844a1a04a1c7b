//! HRT streams (docs/middleware.md, "The TDMA cycle and HRT streams"): an export of class
//! `SyncRealTime` asks the master for one slot per frame of its messages when its first remote
//! subscriber arrives (HRT_REQUEST / one HRT_GRANT per slot), the master answers from its
//! calendar, and the stream's newest message goes out frame by frame in its reserved slots.

use heapless::String;
use r2p_management::message::{HrtResult, Message, SubscribeResult};
use r2p_management::{NodeId, MANAGEMENT_INDEX};
use rtcan::fragment::{fragments, wire_len};
use rtcan::frame::MAX_PAYLOAD;
use rtcan::schedule::{Reject, MAX_HRT_FRAMES};
use rtcan::transfer_crc::CRC_LEN;
use rtcan::{CanController, Frame, FrameId, Laxity, MessageId, Micros, Period, Phase, StreamSlots};

use super::stats::bump;
use super::{Event, Node};
use crate::slot_tx::Slotted;
#[cfg(doc)]
use rtcan::Scheduler;

/// HRT reservations a node's calendar holds when it is master ([`Scheduler`] capacity): one
/// per frame of each stream.
pub const MASTER_STREAMS: usize = 16;

/// The longest HRT message: [`MAX_HRT_FRAMES`] frames less the transfer CRC.
pub const MAX_HRT_MESSAGE: usize = MAX_PAYLOAD * MAX_HRT_FRAMES as usize - CRC_LEN;

/// Bytes of an HRT message on the wire (payload and transfer CRC).
const HRT_WIRE_MAX: usize = wire_len(MAX_HRT_MESSAGE);

/// Where an HRT export's reservation stands ([`Node::hrt_state`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HrtState {
    /// No remote subscriber yet: nothing reserved.
    Idle,
    /// To be asked for at the next slot (first subscriber, or re-registration after a master
    /// change or a node-ID move) once a master is heard.
    Wanted,
    /// Asked the master at `since`; asked again every `request_timeout_us`.
    Requested {
        /// When the request was (last) queued.
        since: Micros,
        /// The slots granted so far (one HRT_GRANT per frame).
        got: StreamSlots,
    },
    /// Sending in the cycles c with c mod period = `slots.offset`, frame j in the j-th slot.
    Granted {
        /// The reserved slots.
        slots: StreamSlots,
    },
    /// The master refused (the subscriber got `NoSlot`); a new subscription asks again.
    Refused(HrtResult),
}

#[derive(Clone, Copy)]
pub(super) struct HrtStream {
    pub(super) period: Period,
    /// Frames of each message (slots it asks for).
    pub(super) frames: u8,
    /// Payload bytes of each message (the master sizes reservations by them).
    pub(super) size: u8,
    pub(super) state: HrtState,
    /// A subscriber waiting for the reservation before it is answered (others ask again).
    pub(super) waiting: Option<(NodeId, u8)>,
    /// The frame of the message in flight to load next (0: none in flight).
    pub(super) next_frame: u8,
}

impl<
        'a,
        const EXPORTS: usize,
        const IMPORTS: usize,
        const TXQ: usize,
        const RX: usize,
        const BUF: usize,
        const MASTER: bool,
    > Node<'a, EXPORTS, IMPORTS, TXQ, RX, BUF, MASTER>
{
    /// Where HRT export `export`'s reservation stands (`None` for other exports).
    pub fn hrt_state(&self, export: usize) -> Option<HrtState> {
        self.exports.get(export).and_then(|e| e.hrt).map(|h| h.state)
    }

    /// HRT_REQUEST (answered as master) and HRT_GRANT (for this node's streams).
    pub(super) fn on_hrt_management(&mut self, from: NodeId, msg: Message, now: Micros) {
        let me = self.ids.node_id();
        match msg {
            Message::HrtRequest { message_id, period_cycles, frames, size }
                if MASTER && self.master.is_some() =>
            {
                let message = MessageId(message_id);
                let owned = NodeId::of(message).is_some_and(|(owner, _)| owner == from);
                if period_cycles == 0 {
                    // A release (`subscribers.rs`): the stream's last subscriber left.
                    if owned && self.scheduler.remove(message).is_some() {
                        self.calendar_released();
                        bump(&mut self.stats.hrt_released);
                    }
                    return;
                }
                let granted = match NodeId::of(message) {
                    Some((owner, index)) if owner == from && index != MANAGEMENT_INDEX => self
                        .admit_stream(message, u32::from(period_cycles), frames, size)
                        .map_err(hrt_result),
                    _ => Err(HrtResult::Conflict),
                };
                // One grant per slot (a refusal: one, slot 0), all at one offset.
                let (got, result) = match granted {
                    Ok(got) => {
                        self.owner_granted(from, now);
                        (got, HrtResult::Ok)
                    }
                    Err(r) => (StreamSlots { offset: 0, slots: 1 }, r),
                };
                let mut slots = got.slots;
                while slots != 0 {
                    let phase = Phase { offset: got.offset, slot: slots.trailing_zeros() as u8 };
                    self.send_grant(message_id, period_cycles, phase, result);
                    slots &= slots - 1;
                }
            }
            Message::HrtGrant { message_id, period_cycles, offset, slot, result, .. } => {
                let Some((owner, index)) = NodeId::of(MessageId(message_id)) else {
                    bump(&mut self.stats.unexpected);
                    return;
                };
                // Where the reservation lies, as this bus lays them out (`framed.rs`).
                let placed = self.take_grant_position(&msg);
                if result == HrtResult::Ok && placed {
                    let phase = Phase { offset, slot };
                    self.follow_grant(owner, MessageId(message_id), period_cycles, phase, now);
                }
                if owner != me {
                    return; // another node's grant
                }
                let i = usize::from(index).wrapping_sub(1);
                let valid = result != HrtResult::Ok
                    || (u32::from(offset) < u32::from(period_cycles)
                        && slot > 0
                        && slot < self.config.cycle.slots
                        && placed);
                let Some(h) = self.exports.get_mut(i).and_then(|e| e.hrt.as_mut()) else {
                    bump(&mut self.stats.unexpected);
                    return;
                };
                let (frames, asked) = (h.frames, h.period.cycles() == u32::from(period_cycles));
                let answer = match &mut h.state {
                    // The master's calendar beacon repeating this node's grant.
                    HrtState::Granted { slots }
                        if slots.offset == offset && slots.frame_in(slot).is_some() =>
                    {
                        return
                    }
                    HrtState::Requested { got, .. } if valid && asked => {
                        if result != HrtResult::Ok {
                            Err(result)
                        } else {
                            // One grant per frame, all at one offset (a grant at another
                            // offset starts a new set: the master placed the stream again).
                            if got.offset != offset {
                                *got = StreamSlots { offset, slots: 0 };
                            }
                            got.slots |= 1 << slot;
                            if got.frames() < frames {
                                return;
                            }
                            Ok(*got)
                        }
                    }
                    _ => {
                        bump(&mut self.stats.unexpected);
                        return;
                    }
                };
                self.on_grant(i, answer, now);
            }
            _ => {}
        }
    }

    /// As master, once a heartbeat period: repeats the grant of the calendar's next table
    /// entry, so that a standby that missed a grant (it booted later, or dropped the frame)
    /// completes its copy within [`MASTER_STREAMS`] heartbeat periods (`calendar.rs`).
    pub(super) fn calendar_beacon(&mut self) {
        if !MASTER || self.master.is_none() {
            return;
        }
        let k = usize::from(self.beacon);
        self.beacon = self.beacon.wrapping_add(1) % MASTER_STREAMS as u8;
        if let Some(r) = self.scheduler.entry(k) {
            let period = r.period.cycles() as u16;
            self.send_grant(r.stream.0, period, r.phase, HrtResult::Ok);
        }
    }

    /// Sends an HRT_GRANT (an answer, or the beacon's repetition); true if it was queued.
    fn send_grant(
        &mut self,
        message_id: u16,
        period_cycles: u16,
        at: Phase,
        result: HrtResult,
    ) -> bool {
        let (offset, slot) = (at.offset, at.slot);
        let (start_us, len_us) = match result {
            HrtResult::Ok => self.grant_position(slot),
            _ => super::framed::GRID,
        };
        let grant =
            Message::HrtGrant { message_id, period_cycles, offset, slot, result, start_us, len_us };
        self.send(&grant).is_ok()
    }

    /// The calendar holding this node's reservations is gone (new master, new epoch) or their
    /// message IDs changed: ask again.
    pub(super) fn re_register(&mut self) {
        for e in self.exports.iter_mut() {
            if let Some(h) = e.hrt.as_mut() {
                if matches!(h.state, HrtState::Granted { .. } | HrtState::Requested { .. }) {
                    h.state = HrtState::Wanted;
                }
            }
        }
    }

    /// Asks for the reservations that are wanted (or whose request timed out) while a master
    /// is heard; as master, registers them in its own calendar.
    pub(super) fn register_hrt(&mut self, now: Micros) {
        if self.master.is_none() && !(self.failover.synced() && self.clock.hrt_allowed(now)) {
            return;
        }
        let timeout = Micros::from(self.config.request_timeout_us);
        let me = self.ids.node_id();
        for i in 0..self.exports.len() {
            let Some(h) = self.exports[i].hrt else { continue };
            let due = match h.state {
                HrtState::Wanted => true,
                HrtState::Requested { since, .. } => now.saturating_sub(since) >= timeout,
                _ => false,
            };
            if !due {
                continue;
            }
            let message = me.message_id(i as u8 + 1);
            let cycles = h.period.cycles();
            if MASTER && self.master.is_some() {
                // The master answers itself at once: `on_grant` sets the state.
                let r = self.admit_stream(message, cycles, h.frames, h.size);
                self.on_grant(i, r.map_err(hrt_result), now);
            } else {
                let msg = Message::HrtRequest {
                    message_id: message.0,
                    period_cycles: cycles as u16,
                    frames: h.frames,
                    size: h.size,
                };
                if self.send(&msg).is_err() {
                    break; // retried at the next slot
                }
                let got = StreamSlots { offset: 0, slots: 0 };
                self.exports[i].hrt =
                    Some(HrtStream { state: HrtState::Requested { since: now, got }, ..h });
            }
        }
    }

    /// The master answered HRT export `i`'s request; answers the subscriber waiting for it.
    fn on_grant(&mut self, i: usize, r: Result<StreamSlots, HrtResult>, now: Micros) {
        let Some(mut h) = self.exports[i].hrt else { return };
        let waiting = h.waiting.take();
        let e = self.exports[i].export;
        let me = self.ids.node_id();
        let (state, result, message_id) = match r {
            Ok(slots) => {
                (HrtState::Granted { slots }, SubscribeResult::Ok, me.message_id(i as u8 + 1).0)
            }
            Err(res) => {
                bump(&mut self.stats.hrt_refused);
                self.event(Event::StreamRefused { export: i, result: res });
                (HrtState::Refused(res), SubscribeResult::NoSlot, 0)
            }
        };
        h.state = state;
        self.exports[i].hrt = Some(h);
        let Some((from, queue_len)) = waiting else { return };
        if result == SubscribeResult::Ok {
            e.activate(queue_len);
            self.subscriber_added(i, from, now);
            self.event(Event::RemoteSubscriber { export: i, from, queue_len });
        }
        let _ = self.send(&Message::SubscribeResponse {
            target: from.get(),
            topic: String::try_from(e.topic()).unwrap_or_default(),
            result,
            message_id,
        });
    }

    /// Loads frame `frame` of HRT export `i`'s message in its reserved slot. At the first
    /// frame the newest message is taken; older ones missed their deadline (each occurrence
    /// carries one message: the implicit deadline is the period). It stays queued until its
    /// last frame is loaded, so a message the application publishes meanwhile waits for the
    /// next occurrence; if a frame cannot go, the rest of the message is dropped (a receiver
    /// cannot complete it).
    pub(super) fn send_hrt<C: CanController + ?Sized>(&mut self, i: usize, frame: u8, can: &mut C) {
        let e = self.exports[i].export;
        // Only these two: the slot path does not copy the whole stream state.
        let Some((frames, next_frame)) =
            self.exports[i].hrt.as_ref().map(|h| (h.frames, h.next_frame))
        else {
            return;
        };
        if frame == 0 {
            if next_frame != 0 {
                self.hrt_miss(i); // the previous message's last slots never came round
            }
            while e.pending() > 1 && e.drop_oldest() {
                bump(&mut self.stats.deadline_misses);
                e.report_deadline_miss(); // superseded by a newer message
            }
        } else if next_frame != frame {
            if next_frame != 0 {
                self.hrt_miss(i); // a slot of the message passed without its frame
            }
            return;
        }
        let id = FrameId {
            laxity: Laxity::HRT,
            message: self.ids.node_id().message_id(i as u8 + 1),
            fragment: 0,
        };
        let mut buf = [0u8; HRT_WIRE_MAX];
        let Some(encoded) = e.peek_encoded(&mut buf) else { return };
        // A one-frame message is its own frame: the slot path stays short for the usual case.
        let frame_of = |n: usize| match frames {
            1 => Frame::new(id, buf.get(..n)?).ok(),
            _ => fragments(id, buf.get(..n)?).ok()?.nth(usize::from(frame)),
        };
        let Some(f) = encoded.ok().and_then(|(n, _)| frame_of(n)) else {
            e.drop_oldest();
            bump(&mut self.stats.bad_payloads);
            return;
        };
        let last = frame + 1 >= frames;
        if let Some(x) = self.exports[i].hrt.as_mut() {
            x.next_frame = if last { 0 } else { frame + 1 };
        }
        let loaded = self.slot_tx.load_slotted(can, Slotted::Hrt(i), &f);
        if last {
            e.drop_oldest(); // its bytes are in the frame (after the request: off the slot path)
        }
        if loaded {
            bump(&mut self.stats.queued);
        } else {
            self.hrt_miss(i);
        }
    }

    /// A frame of HRT export `i` did not go out: the occurrence is missed, and the rest of its
    /// message is dropped.
    pub(super) fn hrt_miss(&mut self, i: usize) {
        bump(&mut self.stats.hrt_missed);
        bump(&mut self.stats.deadline_misses);
        self.exports[i].export.report_deadline_miss();
        self.hrt_abandon(i);
    }

    /// Drops HRT export `i`'s message in flight, if any (its miss is counted already).
    fn hrt_abandon(&mut self, i: usize) {
        if let Some(h) = self.exports[i].hrt.as_mut() {
            if h.next_frame != 0 {
                h.next_frame = 0;
                self.exports[i].export.drop_oldest();
            }
        }
    }
}

fn hrt_result(r: Reject) -> HrtResult {
    match r {
        Reject::NotHarmonic => HrtResult::NotHarmonic,
        Reject::NoFreePhase => HrtResult::NoFreePhase,
        Reject::Full => HrtResult::Full,
        Reject::ReservedId | Reject::Conflict => HrtResult::Conflict,
        Reject::TooManyFrames => HrtResult::TooManyFrames,
    }
}
