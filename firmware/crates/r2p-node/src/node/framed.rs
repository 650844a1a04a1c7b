//! Frame-sized reservations (issue 22; docs/rtcan.md "Frame-sized reservations"): with
//! [`NodeConfig::hrt_blocks`](super::NodeConfig) > 0 the master places each slot's reservation
//! with `rtcan::layout` (as long as its frames, back to back in blocks, never moved) and says
//! where in every HRT_GRANT; every node hears every grant and keeps the positions, which is
//! what it needs to fit its free frames around the reservations. With 0 (every image today) the
//! slot grid holds: a grant carries no position of its own.
//!
//! The positions are kept, not yet used: the slot path still sends on the grid (the next step
//! of issue 22). Compiled in with the feature `framed-reservations` only, so that no image pays
//! for it; without it, `hrt_blocks` > 0 is refused when the node is built.

#[cfg(feature = "framed-reservations")]
use super::hrt::MAX_HRT_MESSAGE;
use r2p_management::message::Message;
#[cfg(feature = "framed-reservations")]
use rtcan::layout::{Layout, Span};
#[cfg(feature = "framed-reservations")]
use rtcan::{fragment::fragments, FrameId, Laxity};
use rtcan::{schedule::Reject, MessageId, StreamSlots};

use super::Node;

/// A grant's position on the slot grid: none (the slot is the reservation).
pub(super) const GRID: (u16, u16) = (0, 0);

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
    /// As master: admits `stream`, `frames` frames of a `size`-byte message every
    /// `period_cycles` cycles, into the calendar (and places its slots, frame-sized).
    pub(super) fn admit_stream(
        &mut self,
        stream: MessageId,
        period_cycles: u32,
        frames: u8,
        size: u8,
    ) -> Result<StreamSlots, Reject> {
        #[cfg(feature = "framed-reservations")]
        if let Some(layout) = self.layout.as_mut() {
            let needs = reservation_us(layout, stream, frames, size).ok_or(Reject::Conflict)?;
            return layout.admit(&mut self.scheduler, stream, period_cycles, frames, needs);
        }
        let _ = size;
        self.scheduler.register_frames(stream, period_cycles, frames)
    }

    /// The calendar lost streams: their slots' time is free again.
    pub(super) fn calendar_released(&mut self) {
        #[cfg(feature = "framed-reservations")]
        if let Some(layout) = self.layout.as_mut() {
            layout.release_unused(&self.scheduler);
        }
    }

    /// The calendar starts anew (a new master, a new epoch): no position is known.
    pub(super) fn calendar_cleared(&mut self) {
        #[cfg(feature = "framed-reservations")]
        if let Some(layout) = self.layout.as_mut() {
            layout.clear();
        }
    }

    /// True unless a slot of the calendar's copy has no known position (frame-sized
    /// reservations): a standby continues a calendar only if it can grant where each lies.
    pub(super) fn positions_known(&self) -> bool {
        #[cfg(feature = "framed-reservations")]
        if let Some(layout) = self.layout.as_ref() {
            return self.scheduler.iter().all(|r| layout.span(r.phase.slot).is_some());
        }
        true
    }

    /// Where an HRT_GRANT of `slot` says its reservation lies: (start, length) µs.
    pub(super) fn grant_position(&self, slot: u8) -> (u16, u16) {
        #[cfg(feature = "framed-reservations")]
        if let Some(span) = self.layout.as_ref().and_then(|l| l.span(slot)) {
            return (span.start_us, span.len_us);
        }
        let _ = slot;
        GRID
    }

    /// An HRT_GRANT heard (any node's): true if its position fits this bus's layout — none on
    /// the grid; on frame-sized reservations one the master can have given, which this node
    /// then keeps (`Layout::take`). A grant of a refusal has none either way.
    pub(super) fn take_grant_position(&mut self, grant: &Message) -> bool {
        let Message::HrtGrant { slot, start_us, len_us, result, .. } = *grant else {
            return false;
        };
        #[cfg(feature = "framed-reservations")]
        if let (Some(layout), r2p_management::message::HrtResult::Ok) =
            (self.layout.as_mut(), result)
        {
            return layout.take(slot, Span { start_us, len_us }).is_ok();
        }
        let _ = (slot, result);
        (start_us, len_us) == GRID
    }

    /// Where slot `slot`'s reservation lies as this node knows it (frame-sized reservations:
    /// placed as master, heard in a grant otherwise); `None` on the slot grid or when not known.
    #[cfg(feature = "framed-reservations")]
    pub fn reservation(&self, slot: u8) -> Option<Span> {
        self.layout.as_ref()?.span(slot)
    }
}

/// The reservation `stream`'s slots need: the longest worst case among the frames of a
/// `size`-byte message (as `rtcan::fragment` cuts it: their lengths and fragment fields; the
/// worst case does not depend on the bytes). `None` unless that message is `frames` frames, as
/// the request says: the request contradicts itself.
#[cfg(feature = "framed-reservations")]
fn reservation_us(layout: &Layout, stream: MessageId, frames: u8, size: u8) -> Option<u16> {
    let template = FrameId { laxity: Laxity::HRT, message: stream, fragment: 0 };
    let payload = [0u8; MAX_HRT_MESSAGE];
    let cut = fragments(template, payload.get(..usize::from(size))?).ok()?;
    if cut.frame_count() != usize::from(frames) {
        return None;
    }
    cut.map(|f| layout.reservation_us(f.id().to_raw(), f.payload().len())).max()
}
