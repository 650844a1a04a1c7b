//! Exports and imports: the local topics a node offers on the bus and the remote ones it
//! subscribes to, where each subscription stands, and how published messages enter the
//! transmit queue with their publisher's class.

use r2p_management::message::{is_topic_char, SubscribeResult, TOPIC_MAX};
use r2p_management::NodeId;
use r2p_middleware::Class;
use rtcan::fragment::{frame_count, MAX_MESSAGE_LEN};
use rtcan::schedule::MAX_HRT_FRAMES;
use rtcan::{MessageId, Micros, Period, Urgency};

use super::hrt::{HrtStream, MAX_HRT_MESSAGE};
use super::stats::bump;
use super::subscribers::Subscribers;
use super::{HrtState, Node, NodeError};
use crate::remote::{Export, Import};

/// Where a local subscription to a remote topic stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImportState {
    /// No module advertised the topic yet.
    Waiting,
    /// Asked `from` (which advertised it on its stream `index`); asked again every
    /// `request_timeout_us` until it answers.
    Requested {
        /// The publisher's node.
        from: NodeId,
        /// The stream index it advertised.
        index: u8,
        /// When the request was (last) queued.
        since: Micros,
    },
    /// Receiving the topic on `message`.
    Subscribed {
        /// The publisher's node.
        from: NodeId,
        /// The stream's message ID, as the publisher assigned it.
        message: MessageId,
    },
    /// The publisher's topic has another type (checked locally from its ADVERTISE, or answered
    /// by the publisher), or it refused. A later ADVERTISE is looked at again.
    Refused {
        /// The publisher's node.
        from: NodeId,
        /// Why.
        result: SubscribeResult,
    },
    /// Unsubscribed by the application (`Node::unsubscribe`, feature `unsubscribe`): telling
    /// `from` (a request with queue length 0), again every `request_timeout_us` until it
    /// answers. Its frames are no longer taken in.
    Leaving {
        /// The publisher's node.
        from: NodeId,
        /// Its stream index.
        index: u8,
        /// When the unsubscription was (last) queued.
        since: Micros,
    },
    /// Unsubscribed, and the publisher (if one was known) answered: advertisements of the topic
    /// are only remembered, until `Node::resubscribe`.
    Unsubscribed {
        /// The last publisher that advertised the topic, and its stream index.
        publisher: Option<(NodeId, u8)>,
    },
}

impl ImportState {
    /// The stream whose frames this import takes in: the one it receives, or the one it asked
    /// for (its first frames may follow the publisher's answer back to back, or run already
    /// for other subscribers).
    pub(super) fn stream(&self) -> Option<MessageId> {
        match *self {
            ImportState::Subscribed { message, .. } => Some(message),
            ImportState::Requested { from, index, .. } => Some(from.message_id(index)),
            _ => None,
        }
    }
}

pub(super) struct ExportSlot<'a> {
    pub(super) export: &'a dyn Export,
    pub(super) advertise: bool,
    pub(super) hrt: Option<HrtStream>,
    /// Its remote subscribers, followed by their heartbeats (`subscribers.rs`).
    pub(super) subscribers: Subscribers,
}

pub(super) struct ImportSlot<'a> {
    pub(super) import: &'a dyn Import,
    pub(super) state: ImportState,
    /// When the publisher was last heard for this import (`publishers.rs`): a message of the
    /// stream, or (no period) one of its heartbeats; the low 32 bits of the µs clock.
    pub(super) heard: u32,
    /// The stream's period as advertised (HRT), µs; 0: the publisher's heartbeats tell.
    pub(super) period_us: u32,
    /// [`Event::PublisherSilent`](super::Event::PublisherSilent) was raised and nothing came since.
    pub(super) silent: bool,
    /// When the publisher was last heard at all (a message, an answer, a heartbeat): a gap of
    /// the peer timeout means one side was away and the publisher may have dropped us.
    pub(super) seen: u32,
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
    /// Offers a local topic on the bus through its remote subscriber; returns its stream index
    /// (1…): the stream's message ID is `node ID << 8 | index`. It is advertised at the next
    /// [`tick`](Self::tick).
    ///
    /// A `Class::SyncRealTime { period_us }` publisher becomes an HRT stream: its period must
    /// be a power of two (1…256) of cycles ([`NodeError::HrtPeriod`]) and its messages must fit
    /// [`MAX_HRT_FRAMES`] frames (62 bytes; one slot each). Its slots are asked of the master
    /// when the first remote module subscribes; it is sent only by
    /// [`slot_tick`](Self::slot_tick).
    pub fn export(&mut self, export: &'a dyn Export) -> Result<u8, NodeError> {
        check_topic(export.topic())?;
        let max = self.max_export_size();
        if export.size() > max {
            return Err(NodeError::TooLarge { size: export.size(), max });
        }
        let hrt = match export.class() {
            Class::SyncRealTime { period_us } => {
                let cycle_us = self.config.cycle.cycle_us;
                let bad = NodeError::HrtPeriod { period_us, cycle_us };
                if cycle_us == 0 || period_us % cycle_us != 0 {
                    return Err(bad);
                }
                let period = Period::from_cycles(period_us / cycle_us).map_err(|_| bad)?;
                let frames = frame_count(export.size())
                    .filter(|&n| n <= usize::from(MAX_HRT_FRAMES))
                    .ok_or(NodeError::TooLarge { size: export.size(), max: MAX_HRT_MESSAGE })?;
                Some(HrtStream {
                    period,
                    frames: frames as u8,
                    size: export.size() as u8,
                    state: HrtState::Idle,
                    waiting: None,
                    next_frame: 0,
                })
            }
            _ => None,
        };
        if self.exports.iter().any(|e| e.export.topic() == export.topic()) {
            return Err(NodeError::DuplicateTopic);
        }
        if self.exports.len() >= usize::from(u8::MAX) {
            return Err(NodeError::TooMany);
        }
        self.exports
            .push(ExportSlot { export, advertise: true, hrt, subscribers: Subscribers::default() })
            .map_err(|_| NodeError::TooMany)?;
        #[cfg(feature = "framed-reservations")]
        if let Some(wake) = self.release_wake {
            export.wake_on_release(wake);
        }
        Ok(self.exports.len() as u8)
    }

    /// Subscribes a local topic to the remote topic of the same name through its remote
    /// publisher; returns its import index. The subscription is asked for when a module
    /// advertises the topic with the same type hash and size.
    pub fn import(&mut self, import: &'a dyn Import) -> Result<usize, NodeError> {
        check_topic(import.topic())?;
        if import.size() > BUF {
            return Err(NodeError::TooLarge { size: import.size(), max: BUF });
        }
        if self.imports.iter().any(|i| i.import.topic() == import.topic()) {
            return Err(NodeError::DuplicateTopic);
        }
        self.imports
            .push(ImportSlot {
                import,
                state: ImportState::Waiting,
                heard: 0,
                seen: 0,
                period_us: 0,
                silent: false,
            })
            .map_err(|_| NodeError::TooMany)?;
        Ok(self.imports.len() - 1)
    }

    /// The largest message an export may have: it must fit the encoding buffer and, as one
    /// message, the transmit queue.
    fn max_export_size(&self) -> usize {
        BUF.min(TXQ * 8).min(MAX_MESSAGE_LEN)
    }

    /// Stops import `import` (a subscriber that stays up but no longer wants the topic): its
    /// publisher is told, and drops this node from the stream's subscribers — the last one
    /// leaving stops the stream and releases an HRT slot (`subscribers.rs`); its frames are no
    /// longer let through the filters. Nothing is lost on a bad index: [`NodeError::NoImport`].
    #[cfg(feature = "unsubscribe")]
    pub fn unsubscribe(&mut self, import: usize) -> Result<(), NodeError> {
        let s = self.imports.get_mut(import).ok_or(NodeError::NoImport)?;
        s.state = match s.state {
            // Told at the next tick (its retry is due at once).
            ImportState::Subscribed { from, message } => {
                ImportState::Leaving { from, index: message.0 as u8, since: 0 }
            }
            ImportState::Requested { from, index, .. } => {
                ImportState::Leaving { from, index, since: 0 }
            }
            ImportState::Refused { .. } | ImportState::Waiting => {
                ImportState::Unsubscribed { publisher: None }
            }
            left @ (ImportState::Leaving { .. } | ImportState::Unsubscribed { .. }) => left,
        };
        Ok(())
    }

    /// Undoes [`unsubscribe`](Self::unsubscribe): the publisher that advertised the topic last
    /// is asked again at the next tick (else the next advertisement is waited for).
    #[cfg(feature = "unsubscribe")]
    pub fn resubscribe(&mut self, import: usize) -> Result<(), NodeError> {
        let s = self.imports.get_mut(import).ok_or(NodeError::NoImport)?;
        s.state = match s.state {
            ImportState::Leaving { from, index, .. }
            | ImportState::Unsubscribed { publisher: Some((from, index)) } => {
                ImportState::Requested { from, index, since: 0 }
            }
            ImportState::Unsubscribed { publisher: None } => ImportState::Waiting,
            other => other,
        };
        Ok(())
    }

    /// The index of the import of `topic`, if this node imports it (an application that did
    /// not keep [`import`](Self::import)'s answer, such as the gateway finding the imports the
    /// ROS side follows).
    pub fn import_index(&self, topic: &str) -> Option<usize> {
        self.imports.iter().position(|i| i.import.topic() == topic)
    }

    /// Where import `import` stands.
    pub fn import_state(&self, import: usize) -> Option<ImportState> {
        self.imports.get(import).map(|i| i.state)
    }

    /// Moves published messages from the remote subscribers into the transmit queue, as far
    /// as it has room for whole messages (the rest wait in the remote subscriber's queue).
    ///
    /// NRT messages leave half the queue free ([`nrt_reserve`]): under overload NRT frames
    /// cannot leave, and without a reserve a backlog of them would fill the queue and keep an
    /// SRT message out of it — out of arbitration — until it expired (docs/rtcan.md, "Under
    /// load").
    pub(super) fn drain_exports(&mut self, now: Micros) {
        let me = self.ids.node_id();
        let mut buf = [0u8; BUF];
        for (i, slot) in self.exports.iter().enumerate() {
            let e = slot.export;
            if e.active_len() == 0 || slot.hrt.is_some() {
                continue; // HRT streams go in their reserved slots (`slot_tick`)
            }
            let frames = frame_count(e.size()).unwrap_or(usize::MAX);
            let reserve =
                if e.class().deadline_us().is_none() { nrt_reserve(TXQ, frames) } else { 0 };
            let message = me.message_id(i as u8 + 1);
            while e.pending() > 0 && self.tx.free() >= frames.saturating_add(reserve) {
                let Some(encoded) = e.pop_encoded(&mut buf) else { break };
                let Ok((n, at)) = encoded else {
                    bump(&mut self.stats.bad_payloads);
                    continue;
                };
                let urgency = match e.class().deadline_us() {
                    None => Urgency::Nrt,
                    Some(d) => {
                        Urgency::Srt { deadline: at.unwrap_or(now).saturating_add(Micros::from(d)) }
                    }
                };
                if matches!(urgency, Urgency::Srt { deadline } if deadline <= now) {
                    bump(&mut self.stats.deadline_misses);
                    e.report_deadline_miss();
                    continue;
                }
                match self.tx.push_message(message, &buf[..n], urgency) {
                    Ok(()) => bump(&mut self.stats.queued),
                    Err(_) => bump(&mut self.stats.tx_overflow),
                }
            }
        }
    }
}

/// Frames of a `txq`-frame transmit queue an NRT message of `frames` frames must leave free
/// for SRT messages: half the queue, less if the message could not enter an empty queue then.
pub const fn nrt_reserve(txq: usize, frames: usize) -> usize {
    let half = txq / 2;
    let room = txq.saturating_sub(frames);
    if half < room {
        half
    } else {
        room
    }
}

fn check_topic(name: &str) -> Result<(), NodeError> {
    if name.is_empty() || name.len() > TOPIC_MAX || !name.bytes().all(is_topic_char) {
        Err(NodeError::BadTopicName)
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::nrt_reserve;

    #[test]
    fn half_the_queue_unless_the_message_could_never_enter() {
        assert_eq!(nrt_reserve(32, 2), 16);
        assert_eq!(nrt_reserve(32, 8), 16);
        // A message of 6 frames in an 8-frame queue enters an empty queue: reserve 2, not 4.
        assert_eq!(nrt_reserve(8, 6), 2);
        assert_eq!(nrt_reserve(8, 8), 0);
        for txq in 8..64 {
            for frames in 1..=txq {
                assert!(frames + nrt_reserve(txq, frames) <= txq, "{txq} {frames}");
            }
        }
    }
}
