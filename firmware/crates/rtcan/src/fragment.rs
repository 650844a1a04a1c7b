//! Fragmentation and reassembly: messages of up to [`MAX_MESSAGE_LEN`] bytes over 8-byte frames.
//!
//! A message of at most 8 bytes is one frame with fragment counter 0. A longer one travels as its
//! payload followed by its transfer CRC ([`crate::transfer_crc`], 2 bytes), cut into
//! [`frame_count`]`(n)` ≥ 2 frames: every frame but the last carries exactly 8 bytes, the last
//! the rest (1–8). The identifier's fragment counter says how many frames are left including this
//! one: the first frame of a multi-frame message carries the frame count, the last carries 1.
//! Counter 0 therefore always means a whole single-frame message and never the end of a longer
//! one, so a repeated last frame cannot be mistaken for a new message nor a new message for a
//! repeated last frame; the transfer CRC tells a receiver that the frames it joined are one
//! message (a lost frame, or the tail of a message taken for a whole one, changes it).
//!
//! [`Reassembler`] puts frames back together in a fixed number of slots, one per message ID
//! (a message ID is one publisher's stream, so it also names the source). It checks order,
//! times out stale partial messages and drops bad input, counting each kind separately in
//! [`ReassemblyStats`]. The rules, the slot state machine and their limits are in
//! docs/rtcan.md, "Fragmentation, reassembly and the transmit queue".

use crate::controller::Micros;
use crate::frame::{Frame, MAX_PAYLOAD};
use crate::id::{FrameId, MessageId, MAX_FRAGMENT};
use crate::transfer_crc::{self, CRC_LEN};

/// Most frames in one message: a multi-frame message's counter runs from 127 down to 1.
pub const MAX_FRAGMENTS: usize = MAX_FRAGMENT as usize;

/// Longest message: [`MAX_FRAGMENTS`] frames of 8 bytes less the transfer CRC.
pub const MAX_MESSAGE_LEN: usize = MAX_FRAGMENTS * MAX_PAYLOAD - CRC_LEN;

/// Bytes a message of `len` bytes takes on the wire: the payload, and the transfer CRC if it
/// needs more than one frame.
pub const fn wire_len(len: usize) -> usize {
    if len <= MAX_PAYLOAD {
        len
    } else {
        len + CRC_LEN
    }
}

/// How many frames a message of `len` bytes takes (1 for the empty message), or `None` if it is
/// longer than [`MAX_MESSAGE_LEN`].
pub const fn frame_count(len: usize) -> Option<usize> {
    if len > MAX_MESSAGE_LEN {
        None
    } else if len == 0 {
        Some(1)
    } else {
        Some(wire_len(len).div_ceil(MAX_PAYLOAD))
    }
}

/// True if a frame with fragment counter `fragment` ends its message: 0 (a single-frame
/// message) or 1 (the last frame of a longer one).
pub const fn is_last_frame(fragment: u8) -> bool {
    fragment <= 1
}

/// Why a payload cannot be fragmented.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FragmentError {
    /// The payload is longer than [`MAX_MESSAGE_LEN`] bytes (its length is given).
    TooLong(usize),
}

/// The frames of one message, first to last, produced on demand (no buffer).
///
/// Every frame has the template's laxity and message ID; the fragment counter is 0 for a
/// single-frame message and counts down from `frames` to 1 otherwise.
#[derive(Clone, Debug)]
pub struct Fragments<'a> {
    template: FrameId,
    payload: &'a [u8],
    crc: [u8; CRC_LEN],
    total: usize,
    remaining: usize,
}

/// Splits `payload` into the frames of one message with `template`'s laxity and message ID (its
/// fragment field is ignored).
pub fn fragments(template: FrameId, payload: &[u8]) -> Result<Fragments<'_>, FragmentError> {
    match frame_count(payload.len()) {
        Some(total) => Ok(Fragments {
            template,
            payload,
            crc: if total > 1 { transfer_crc::of(payload).to_be_bytes() } else { [0; CRC_LEN] },
            total,
            remaining: total,
        }),
        None => Err(FragmentError::TooLong(payload.len())),
    }
}

impl Fragments<'_> {
    /// Number of frames of the whole message (not only those still to come).
    pub const fn frame_count(&self) -> usize {
        self.total
    }
}

impl Iterator for Fragments<'_> {
    type Item = Frame;

    fn next(&mut self) -> Option<Frame> {
        if self.remaining == 0 {
            return None;
        }
        let index = self.total - self.remaining;
        let counter = if self.total == 1 { 0 } else { self.remaining };
        self.remaining -= 1;
        let start = index * MAX_PAYLOAD;
        let end = (start + MAX_PAYLOAD).min(wire_len(self.payload.len()));
        // The wire bytes start..end: payload bytes, then (multi-frame only) the CRC's.
        let mut chunk = [0u8; MAX_PAYLOAD];
        for (k, b) in chunk.iter_mut().enumerate().take(end.saturating_sub(start)) {
            let at = start + k;
            *b = match self.payload.get(at) {
                Some(&p) => p,
                None => self.crc.get(at - self.payload.len()).copied().unwrap_or(0),
            };
        }
        // `counter` ≤ MAX_FRAGMENT, so it fits the 7-bit counter and the chunk fits a frame.
        let id = FrameId { fragment: counter as u8, ..self.template };
        Frame::new(id, chunk.get(..end.saturating_sub(start))?).ok()
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.remaining, Some(self.remaining))
    }
}

impl ExactSizeIterator for Fragments<'_> {}
impl core::iter::FusedIterator for Fragments<'_> {}

/// What a receiver knows about the length of the messages of a stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Expect {
    /// Any length: the first frame's counter gives the number of frames (the transfer CRC
    /// rejects a message whose first frames were lost).
    Any,
    /// Every message of the stream is exactly this many bytes (a topic's fixed size): frames that
    /// cannot belong to such a message are dropped, so a lost first frame is always detected.
    Exactly(usize),
}

/// A completed message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Message<'a> {
    /// The stream it came on.
    pub id: MessageId,
    /// Its bytes (borrowed from the reassembler until its next call).
    pub data: &'a [u8],
}

/// Counters of what the reassembler did, one per kind of outcome (all saturating).
///
/// `completed` counts messages delivered; the others count input dropped. Frame-level counters
/// (`duplicate`, `foreign`, `bad_length`, `no_slot`) count frames; message-level counters
/// (`out_of_order`, `truncated`, `timed_out`, `too_long`, `bad_crc`) count messages given up.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReassemblyStats {
    /// Messages delivered whole.
    pub completed: u32,
    /// Frames identical to the frame just taken for the stream (CAN's double reception):
    /// dropped, the message goes on.
    pub duplicate: u32,
    /// Frames that continue a message whose start was never taken (lost, dropped or abandoned),
    /// or whose counter cannot be the first of a message of the expected length.
    pub foreign: u32,
    /// Partial messages abandoned because a frame arrived with a lower counter than the next
    /// one expected (frames were lost in between); that frame is dropped too.
    pub out_of_order: u32,
    /// Partial messages abandoned because the first frame of a new message on the same stream
    /// arrived before they were complete.
    pub truncated: u32,
    /// Partial messages abandoned because no frame was taken for them for longer than the
    /// timeout.
    pub timed_out: u32,
    /// Messages refused because they do not fit the slot's buffer (or exceed
    /// [`MAX_MESSAGE_LEN`]).
    pub too_long: u32,
    /// First frames dropped because every slot was busy with a partial message.
    pub no_slot: u32,
    /// Frames whose length is wrong for their position: a non-last frame shorter than 8 bytes,
    /// a multi-frame message too short to need its frames, or a length that contradicts
    /// [`Expect::Exactly`]. Dropped without disturbing the message in progress.
    pub bad_length: u32,
    /// Multi-frame messages complete in shape whose transfer CRC did not match: frames of
    /// different messages joined (frames lost between them), never delivered.
    pub bad_crc: u32,
}

fn bump(counter: &mut u32) {
    *counter = counter.saturating_add(1);
}

/// Why a frame is refused as the first frame of a message.
#[derive(Clone, Copy)]
enum Refusal {
    Foreign,
    BadLength,
    TooLong,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    /// Not bound to a stream.
    Free,
    /// A message is being received: its first frame had counter `first`, `next` is expected.
    Receiving { first: u8, next: u8 },
    /// Between messages: the last frame seen on the stream had counter `last` ≥ 1 and is kept
    /// for duplicate detection. `last = 1` after a message ended; `last > 1` means the message
    /// it belonged to was given up: frames with counters from 1 to `last − 1` continue it and
    /// are foreign.
    Between { last: u8 },
}

#[derive(Clone, Copy)]
struct Slot<const BUF: usize> {
    state: State,
    id: MessageId,
    /// When a frame was last taken into this slot.
    last_at: Micros,
    last_len: u8,
    last_data: [u8; MAX_PAYLOAD],
    /// Transfer CRC over the message's bytes taken so far.
    crc: u16,
    /// The payload; the transfer CRC's bytes past `BUF` are checked, not stored.
    buf: [u8; BUF],
}

impl<const BUF: usize> Slot<BUF> {
    const FREE: Self = Slot {
        state: State::Free,
        id: MessageId(0),
        last_at: 0,
        last_len: 0,
        last_data: [0; MAX_PAYLOAD],
        // Not read until a message starts in the slot, which sets it to `INITIAL` first
        // (`start`). Zero keeps a free slot all zero bytes: a reassembler is then made by
        // clearing its memory, not by copying a slot-sized template from flash (~90 B).
        crc: 0,
        buf: [0; BUF],
    };

    fn record(&mut self, data: &[u8], at: Micros) {
        let n = data.len().min(MAX_PAYLOAD);
        self.last_data[..n].copy_from_slice(&data[..n]);
        self.last_len = n as u8;
        self.last_at = at;
    }

    fn last_frame_is(&self, data: &[u8]) -> bool {
        &self.last_data[..self.last_len as usize] == data
    }

    /// Stores the message bytes `off..off + data.len()` and runs the CRC over them; false if
    /// they reach past the buffer by more than the CRC.
    fn store(&mut self, off: usize, data: &[u8]) -> bool {
        if off + data.len() > BUF + CRC_LEN {
            return false;
        }
        for (k, &b) in data.iter().enumerate() {
            if let Some(dst) = self.buf.get_mut(off + k) {
                *dst = b;
            }
        }
        self.crc = transfer_crc::update(self.crc, data);
        true
    }
}

enum Outcome {
    Nothing,
    InSlot(usize, usize),
    Single,
}

/// Reassembles messages from up to `SLOTS` streams at once, each up to `BUF` bytes long.
///
/// Memory is `SLOTS × (BUF + ~26)` bytes, all inline. Feed it every data frame (not sync frames)
/// with [`Reassembler::accept`]; call [`Reassembler::expire`] now and then so that partial
/// messages of streams that went silent free their slots.
pub struct Reassembler<const SLOTS: usize, const BUF: usize> {
    slots: [Slot<BUF>; SLOTS],
    /// A single-frame message, copied so that the result borrows only the reassembler.
    single: [u8; MAX_PAYLOAD],
    single_len: usize,
    timeout_us: Micros,
    stats: ReassemblyStats,
}

impl<const SLOTS: usize, const BUF: usize> Reassembler<SLOTS, BUF> {
    /// A reassembler that gives up a partial message when no frame was taken for it for more
    /// than `timeout_us` microseconds.
    pub const fn new(timeout_us: Micros) -> Self {
        Self {
            slots: [Slot::<BUF>::FREE; SLOTS],
            single: [0; MAX_PAYLOAD],
            single_len: 0,
            timeout_us,
            stats: ReassemblyStats::new(),
        }
    }

    /// What happened so far.
    pub const fn stats(&self) -> ReassemblyStats {
        self.stats
    }

    /// Number of messages currently half received.
    pub fn partial_messages(&self) -> usize {
        self.slots.iter().filter(|s| matches!(s.state, State::Receiving { .. })).count()
    }

    /// Gives up partial messages that had no frame for more than the timeout at time `now`
    /// (each counted in `timed_out`) and forgets idle streams' history; returns how many
    /// messages timed out.
    pub fn expire(&mut self, now: Micros) -> u32 {
        let mut n = 0;
        for s in self.slots.iter_mut() {
            if s.state != State::Free && now.saturating_sub(s.last_at) > self.timeout_us {
                if matches!(s.state, State::Receiving { .. }) {
                    bump(&mut self.stats.timed_out);
                    n += 1;
                }
                s.state = State::Free;
            }
        }
        n
    }

    /// Takes one received frame (received at `at`); returns the message it completes, if any.
    ///
    /// Expires stale slots first (as [`Reassembler::expire`] with `at`). Never panics: any frame
    /// sequence is either reassembled or dropped and counted.
    pub fn accept(&mut self, frame: &Frame, at: Micros, expect: Expect) -> Option<Message<'_>> {
        self.expire(at);
        let id = frame.id().message;
        match self.step(frame, at, expect) {
            Outcome::Nothing => None,
            Outcome::Single => Some(Message { id, data: self.single.get(..self.single_len)? }),
            Outcome::InSlot(i, len) => {
                let data = self.slots.get(i)?.buf.get(..len)?;
                Some(Message { id, data })
            }
        }
    }

    fn step(&mut self, frame: &Frame, at: Micros, expect: Expect) -> Outcome {
        let id = frame.id().message;
        let c = frame.id().fragment;
        let data = frame.payload();
        let found = self.slots.iter().position(|s| s.state != State::Free && s.id == id);
        if let Some(i) = found {
            let slot = &mut self.slots[i];
            match slot.state {
                State::Receiving { first, next } => {
                    return self.continue_message(i, first, next, frame, at, expect)
                }
                State::Between { last } => {
                    if c == last && slot.last_frame_is(data) {
                        bump(&mut self.stats.duplicate);
                        return Outcome::Nothing;
                    }
                    if c != 0 && c < last {
                        // Continues a message that was given up.
                        bump(&mut self.stats.foreign);
                        slot.state = State::Between { last: c };
                        slot.record(data, at);
                        return Outcome::Nothing;
                    }
                }
                State::Free => {}
            }
        }
        self.start(found, frame, at, expect)
    }

    /// A frame for stream slot `i`, which is receiving a message that began with counter
    /// `first` and expects `next`.
    fn continue_message(
        &mut self,
        i: usize,
        first: u8,
        next: u8,
        frame: &Frame,
        at: Micros,
        expect: Expect,
    ) -> Outcome {
        let c = frame.id().fragment;
        let data = frame.payload();
        let slot = &mut self.slots[i];
        if c == next {
            if !continuation_shape_ok(c, first, data.len(), expect) {
                bump(&mut self.stats.bad_length);
                return Outcome::Nothing;
            }
            let off = usize::from(first - c) * MAX_PAYLOAD;
            let end = off + data.len();
            slot.record(data, at);
            if !slot.store(off, data) {
                bump(&mut self.stats.too_long);
                slot.state = State::Between { last: c };
                return Outcome::Nothing;
            }
            if c > 1 {
                slot.state = State::Receiving { first, next: c - 1 };
                return Outcome::Nothing;
            }
            slot.state = State::Between { last: 1 };
            if slot.crc != transfer_crc::RESIDUE {
                bump(&mut self.stats.bad_crc);
                return Outcome::Nothing;
            }
            bump(&mut self.stats.completed);
            return Outcome::InSlot(i, end - CRC_LEN);
        }
        if c == next + 1 && slot.last_frame_is(data) {
            // The frame just taken, again: CAN's double reception.
            bump(&mut self.stats.duplicate);
            return Outcome::Nothing;
        }
        if c != 0 && c < next {
            // Frames next..c+1 are missing: this message cannot complete.
            bump(&mut self.stats.out_of_order);
            slot.state = State::Between { last: c };
            slot.record(data, at);
            return Outcome::Nothing;
        }
        // A single-frame message, or a first frame: the sender started a new message.
        if let Err(r) = first_frame_len(c, data.len(), expect) {
            // Cannot start a message: garbage, the message in progress goes on.
            if !matches!(r, Refusal::TooLong) {
                self.refuse(r);
                return Outcome::Nothing;
            }
        }
        bump(&mut self.stats.truncated);
        self.slots[i].state = State::Free;
        self.start(Some(i), frame, at, expect)
    }

    fn refuse(&mut self, r: Refusal) {
        let counter = match r {
            Refusal::Foreign => &mut self.stats.foreign,
            Refusal::BadLength => &mut self.stats.bad_length,
            Refusal::TooLong => &mut self.stats.too_long,
        };
        bump(counter);
    }

    /// `frame` as the first frame of a message; `found` is the stream's slot if it has one.
    fn start(
        &mut self,
        found: Option<usize>,
        frame: &Frame,
        at: Micros,
        expect: Expect,
    ) -> Outcome {
        let id = frame.id().message;
        let c = frame.id().fragment;
        let data = frame.payload();
        let min_len = match first_frame_len(c, data.len(), expect) {
            Ok(n) => n,
            Err(r) => {
                self.refuse(r);
                if matches!(r, Refusal::TooLong) {
                    self.skip_rest(found, id, c, data, at);
                }
                return Outcome::Nothing;
            }
        };
        if min_len > BUF {
            bump(&mut self.stats.too_long);
            self.skip_rest(found, id, c, data, at);
            return Outcome::Nothing;
        }
        if c == 0 {
            // A single-frame message: needs no slot, leaves the stream's history as it was
            // (a repetition of the last frame of a multi-frame message is still recognised).
            bump(&mut self.stats.completed);
            let n = data.len().min(MAX_PAYLOAD);
            self.single[..n].copy_from_slice(&data[..n]);
            self.single_len = n;
            return Outcome::Single;
        }
        let Some(i) = found.or_else(|| self.allocate()) else {
            bump(&mut self.stats.no_slot);
            return Outcome::Nothing;
        };
        let slot = &mut self.slots[i];
        slot.crc = transfer_crc::INITIAL;
        if !slot.store(0, data) {
            // Unreachable: BUF >= min_len > 8 = data.len(); refuse rather than panic.
            bump(&mut self.stats.too_long);
            return Outcome::Nothing;
        }
        slot.id = id;
        slot.state = State::Receiving { first: c, next: c - 1 };
        slot.record(data, at);
        Outcome::Nothing
    }

    /// Remembers that the rest of a refused message (frames below `c`) is to be dropped as
    /// foreign, if a slot can be had without giving up a partial message.
    fn skip_rest(&mut self, found: Option<usize>, id: MessageId, c: u8, data: &[u8], at: Micros) {
        let slot = found.or_else(|| if c > 1 { self.allocate() } else { None });
        if let Some(i) = slot {
            let s = &mut self.slots[i];
            s.id = id;
            s.state = if c > 1 { State::Between { last: c } } else { State::Free };
            s.record(data, at);
        }
    }

    /// A free slot, or else the one whose idle stream was heard from longest ago.
    fn allocate(&mut self) -> Option<usize> {
        if let Some(i) = self.slots.iter().position(|s| s.state == State::Free) {
            return Some(i);
        }
        self.slots
            .iter()
            .enumerate()
            .filter(|(_, s)| matches!(s.state, State::Between { .. }))
            .min_by_key(|(_, s)| s.last_at)
            .map(|(i, _)| i)
    }
}

impl ReassemblyStats {
    /// All counters at zero.
    pub const fn new() -> Self {
        Self {
            completed: 0,
            duplicate: 0,
            foreign: 0,
            out_of_order: 0,
            truncated: 0,
            timed_out: 0,
            too_long: 0,
            no_slot: 0,
            bad_length: 0,
            bad_crc: 0,
        }
    }
}

/// Fewest wire bytes of a multi-frame message: one more than a single frame holds, and the CRC.
const MIN_MULTI_WIRE: usize = MAX_PAYLOAD + 1 + CRC_LEN;

/// Checks a frame with counter `c` and `len` bytes as a message's first frame (or a whole
/// single-frame message, `c` = 0); returns the fewest payload bytes the message can have.
fn first_frame_len(c: u8, len: usize, expect: Expect) -> Result<usize, Refusal> {
    match expect {
        Expect::Any => {
            if c == 0 {
                Ok(len)
            } else if c == 1 {
                // A last frame: its message's start was never taken.
                Err(Refusal::Foreign)
            } else if len != MAX_PAYLOAD {
                Err(Refusal::BadLength)
            } else {
                let fewest_wire = (usize::from(c) - 1) * MAX_PAYLOAD + 1;
                Ok(fewest_wire.max(MIN_MULTI_WIRE) - CRC_LEN)
            }
        }
        Expect::Exactly(n) => {
            let Some(frames) = frame_count(n) else {
                return Err(Refusal::TooLong);
            };
            let c = usize::from(c);
            if frames == 1 {
                // Single-frame messages: counter 0, n bytes.
                return if c == 0 && len == n { Ok(n) } else { Err(Refusal::BadLength) };
            }
            if c == 0 || c > frames || (c == frames && len != MAX_PAYLOAD) {
                Err(Refusal::BadLength)
            } else if c < frames {
                Err(Refusal::Foreign)
            } else {
                Ok(n)
            }
        }
    }
}

/// True if `len` bytes is right for the frame with counter `c` of a multi-frame message whose
/// first frame had counter `first` (1 ≤ c < first).
fn continuation_shape_ok(c: u8, first: u8, len: usize, expect: Expect) -> bool {
    if c > 1 {
        return len == MAX_PAYLOAD;
    }
    let before = usize::from(first - 1) * MAX_PAYLOAD;
    match expect {
        Expect::Any => len >= 1 && before + len >= MIN_MULTI_WIRE,
        Expect::Exactly(n) => wire_len(n).checked_sub(before) == Some(len),
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;
    use crate::laxity::Laxity;

    const SRT5: Laxity = Laxity::from_code(5);
    const T: Micros = 10_000; // timeout used by these tests

    fn tmpl(message: u16) -> FrameId {
        FrameId { laxity: SRT5, message: MessageId(message), fragment: 0 }
    }

    fn f(message: u16, fragment: u8, data: &[u8]) -> Frame {
        Frame::new(FrameId { laxity: SRT5, message: MessageId(message), fragment }, data).unwrap()
    }

    /// A deterministic pattern of `len` bytes (no heap on the Cortex-M3).
    fn pattern(seed: u8, buf: &mut [u8]) -> &[u8] {
        for (i, b) in buf.iter_mut().enumerate() {
            *b = seed.wrapping_mul(31).wrapping_add(i as u8).wrapping_mul(7) ^ (i >> 8) as u8;
        }
        buf
    }

    /// Feeds every frame of `payload` in order; true if exactly the last frame completed the
    /// message and the message equals `payload`.
    fn roundtrip<const S: usize, const B: usize>(
        r: &mut Reassembler<S, B>,
        message: u16,
        payload: &[u8],
        at: Micros,
        expect: Expect,
    ) -> bool {
        let frames = fragments(tmpl(message), payload).unwrap();
        let n = frames.len();
        let mut ok = false;
        for (k, fr) in frames.enumerate() {
            let got = r.accept(&fr, at, expect);
            if k + 1 < n {
                if got.is_some() {
                    return false;
                }
            } else {
                ok = got == Some(Message { id: MessageId(message), data: payload });
            }
        }
        ok
    }

    r2p_testkit::suite! {
        fn empty_message_is_one_empty_frame() {
            let mut it = fragments(tmpl(0x1234), &[]).unwrap();
            assert_eq!(it.len(), 1);
            let only = it.next().unwrap();
            assert_eq!(only.id().fragment, 0);
            assert!(only.is_empty());
            assert_eq!(it.next(), None);
            let mut r: Reassembler<1, 8> = Reassembler::new(T);
            let m = r.accept(&only, 0, Expect::Any).unwrap();
            assert_eq!(m.data, &[] as &[u8]);
            let m = r.accept(&only, 1, Expect::Exactly(0)).unwrap();
            assert_eq!(m.data.len(), 0);
        }

        fn counter_counts_down_and_matches_the_spec_example() {
            // docs/rtcan.md's example: 20 bytes, SRT code 5, message 0x1234: 22 bytes with the
            // transfer CRC, 3 frames with counters 3, 2, 1 (0x0289_1A03 first).
            let payload = [0xAB; 20];
            let frames = fragments(tmpl(0x1234), &payload).unwrap();
            assert_eq!(frames.frame_count(), 3);
            let mut counters = [0u8; 3];
            let mut lens = [0usize; 3];
            let mut raws = [0u32; 3];
            let mut last = [0u8; 8];
            for (k, fr) in frames.enumerate() {
                counters[k] = fr.id().fragment;
                lens[k] = fr.len();
                raws[k] = fr.id().to_raw();
                last[..fr.len()].copy_from_slice(fr.payload());
            }
            assert_eq!(counters, [3, 2, 1]);
            assert_eq!(lens, [8, 8, 6]);
            assert_eq!(raws, [0x0289_1A03, 0x0289_1A02, 0x0289_1A01]);
            assert_eq!(&last[..4], &[0xAB; 4]);
            assert_eq!(last[4..6], transfer_crc::of(&payload).to_be_bytes());
        }

        fn lengths_take_the_crc_into_account() {
            assert_eq!(frame_count(0), Some(1));
            assert_eq!(frame_count(1), Some(1));
            assert_eq!(frame_count(8), Some(1));
            assert_eq!(frame_count(9), Some(2));
            assert_eq!(frame_count(14), Some(2));
            assert_eq!(frame_count(15), Some(3));
            assert_eq!(frame_count(16), Some(3));
            assert_eq!(frame_count(MAX_MESSAGE_LEN), Some(MAX_FRAGMENTS));
            assert_eq!(frame_count(MAX_MESSAGE_LEN + 1), None);
            assert_eq!((wire_len(8), wire_len(9)), (8, 11));
            // 14 bytes and the CRC fill two frames exactly: the last frame is full.
            let payload = [7u8; 14];
            let mut it = fragments(tmpl(0x300), &payload).unwrap();
            assert_eq!(it.next().map(|f| (f.id().fragment, f.len())), Some((2, 8)));
            assert_eq!(it.next().map(|f| (f.id().fragment, f.len())), Some((1, 8)));
            assert_eq!(it.next(), None);
            // 15 bytes: the CRC's second byte alone in a third frame.
            let payload = [7u8; 15];
            let it = fragments(tmpl(0x300), &payload).unwrap();
            assert_eq!(it.last().map(|f| (f.id().fragment, f.len())), Some((1, 1)));
        }

        fn longest_message_has_127_frames_and_longer_is_refused() {
            let mut buf = [0u8; MAX_MESSAGE_LEN + 1];
            assert_eq!(MAX_MESSAGE_LEN, 1014);
            assert_eq!(
                fragments(tmpl(1), &buf).unwrap_err(),
                FragmentError::TooLong(MAX_MESSAGE_LEN + 1)
            );
            let payload = pattern(3, &mut buf[..MAX_MESSAGE_LEN]);
            let mut it = fragments(tmpl(0x4321), payload).unwrap();
            assert_eq!(it.len(), 127);
            assert_eq!(it.next().unwrap().id().fragment, MAX_FRAGMENT);
        }

        fn every_length_roundtrips() {
            let mut buf = [0u8; MAX_MESSAGE_LEN];
            let mut r: Reassembler<1, MAX_MESSAGE_LEN> = Reassembler::new(T);
            let mut len = 0;
            while len <= MAX_MESSAGE_LEN {
                let payload = pattern(len as u8, &mut buf[..len]);
                assert!(roundtrip(&mut r, 0x200, payload, len as Micros, Expect::Any), "len {}", len);
                assert!(roundtrip(&mut r, 0x200, payload, len as Micros, Expect::Exactly(len)));
                len += if (40..=1000).contains(&len) { 13 } else { 1 };
            }
            let s = r.stats();
            assert_eq!(s, ReassemblyStats { completed: s.completed, ..ReassemblyStats::new() });
        }

        fn streams_interleave_without_mixing() {
            let a = [0xA0u8; 20];
            let b = [0xB0u8; 17];
            let mut r: Reassembler<2, 32> = Reassembler::new(T);
            let mut fa = fragments(tmpl(0x111), &a).unwrap();
            let mut fb = fragments(tmpl(0x222), &b).unwrap();
            let mut done = 0;
            for _ in 0..3 {
                for fr in [fa.next(), fb.next()].into_iter().flatten() {
                    if let Some(m) = r.accept(&fr, 5, Expect::Any) {
                        let want: &[u8] = if m.id == MessageId(0x111) { &a } else { &b };
                        assert_eq!(m.data, want);
                        done += 1;
                    }
                }
            }
            assert_eq!(done, 2);
            assert_eq!(r.stats().completed, 2);
        }

        fn duplicates_are_dropped_and_counted() {
            let mut r: Reassembler<1, 64> = Reassembler::new(T);
            let payload = [1, 1, 1, 1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2, 2, 2, 3, 3];
            let nth = |k| fragments(tmpl(0x500), &payload).unwrap().nth(k).unwrap();
            let (f3, f2, f1) = (nth(0), nth(1), nth(2));
            assert_eq!((f3.id().fragment, f1.id().fragment, f1.len()), (3, 1, 4));
            assert_eq!(r.accept(&f3, 0, Expect::Any), None);
            assert_eq!(r.accept(&f3, 1, Expect::Any), None); // the same first frame again
            assert_eq!(r.accept(&f2, 2, Expect::Any), None);
            assert_eq!(r.accept(&f2, 3, Expect::Any), None); // the frame just taken, again
            let m = r.accept(&f1, 4, Expect::Any).unwrap();
            assert_eq!(m.data, &payload);
            // CAN's classic double reception of a last frame: not a new message.
            assert_eq!(r.accept(&f1, 5, Expect::Any), None);
            let s = r.stats();
            assert_eq!((s.completed, s.duplicate), (1, 3));
            // A new single-frame message with the same bytes as that last frame has counter 0:
            // it is a message, never taken for a repetition (the splice limit of old).
            let same = f(0x500, 0, f1.payload());
            assert_eq!(r.accept(&same, 6, Expect::Any).map(|m| m.data.len()), Some(4));
            // Nor is a repeated last frame taken for one after a single-frame message.
            assert_eq!(r.accept(&f1, 6, Expect::Any), None);
            assert_eq!(r.stats().duplicate, 4);
            // A single-frame message cannot be told from its repetition: delivered again.
            let single = f(0x600, 0, &[9]);
            assert!(r.accept(&single, 6, Expect::Any).is_some());
            assert!(r.accept(&single, 6, Expect::Any).is_some());
            assert_eq!(r.stats().completed, 4);
        }

        fn a_gap_abandons_the_message_and_its_rest_is_foreign() {
            let mut r: Reassembler<1, 64> = Reassembler::new(T);
            let mut buf = [0u8; 38];
            let four = fragments(tmpl(7 << 8), pattern(1, &mut buf[..30])).unwrap();
            for (k, fr) in four.enumerate() {
                // Frame 2 (third of four) is lost; frame 1 reveals the gap.
                if k != 2 {
                    assert_eq!(r.accept(&fr, 0, Expect::Any), None);
                }
            }
            assert_eq!(r.stats().out_of_order, 1);
            // Next message of 2 frames, then a broken one whose rest must not pass as a message.
            assert!(roundtrip(&mut r, 7 << 8, pattern(2, &mut buf[..10]), 1, Expect::Any));
            let five = fragments(tmpl(7 << 8), pattern(3, &mut buf[..38])).unwrap();
            for (k, fr) in five.enumerate() {
                if k != 1 {
                    // 5, (4 lost), 3: gap, 2 and 1: foreign.
                    assert!(r.accept(&fr, 2, Expect::Any).is_none());
                }
            }
            let s = r.stats();
            assert_eq!((s.completed, s.out_of_order, s.foreign, s.bad_crc), (1, 2, 2, 0));
        }

        fn exact_length_rejects_a_message_whose_start_was_lost() {
            let mut r: Reassembler<1, 64> = Reassembler::new(T);
            let e = Expect::Exactly(20);
            let payload = [5u8; 20];
            let nth = |k| fragments(tmpl(0x900), &payload).unwrap().nth(k).unwrap();
            let (f3, f2, f1) = (nth(0), nth(1), nth(2));
            // Frame 3 lost: frames 2 and 1 would look like a complete 2-frame message.
            assert!(r.accept(&f2, 0, e).is_none());
            assert!(r.accept(&f1, 0, e).is_none());
            assert_eq!(r.stats().foreign, 2);
            // Without the length the transfer CRC rejects the tail.
            assert!(r.accept(&f2, 1, Expect::Any).is_none());
            assert!(r.accept(&f1, 1, Expect::Any).is_none());
            assert_eq!((r.stats().bad_crc, r.stats().completed), (1, 0));
            // Longer than expected, or a last frame of the wrong size: bad length.
            assert!(r.accept(&f(0x900, 4, &[1; 8]), 2, e).is_none());
            assert!(r.accept(&f3, 2, e).is_none());
            assert!(r.accept(&f2, 2, e).is_none());
            assert!(r.accept(&f(0x900, 1, &[3; 5]), 2, e).is_none());
            // A single frame on a stream of 20-byte messages.
            assert!(r.accept(&f(0x900, 0, &[3; 5]), 2, e).is_none());
            assert_eq!(r.stats().bad_length, 3);
            assert_eq!(r.accept(&f1, 2, e).map(|m| m.data), Some(&payload[..]));
        }

        fn frames_of_two_messages_joined_are_never_delivered() {
            // The splice: the last frame of one message and the first frames of the next one
            // of the stream are lost; the receiver sees 3, 2 of the first and 1 of the second.
            let mut r: Reassembler<1, 64> = Reassembler::new(T);
            let (a, b) = ([0x11u8; 20], [0x22u8; 20]);
            for e in [Expect::Any, Expect::Exactly(20)] {
                let mut fa = fragments(tmpl(0xA00), &a).unwrap();
                let fb = fragments(tmpl(0xA00), &b).unwrap();
                assert!(r.accept(&fa.next().unwrap(), 0, e).is_none());
                assert!(r.accept(&fa.next().unwrap(), 0, e).is_none());
                assert!(r.accept(&fb.last().unwrap(), 0, e).is_none());
            }
            let s = r.stats();
            assert_eq!((s.bad_crc, s.completed), (2, 0));
            // The stream goes on: its next message is delivered.
            assert!(roundtrip(&mut r, 0xA00, &b, 1, Expect::Exactly(20)));
        }

        fn a_new_first_frame_truncates_the_message_in_progress() {
            let mut r: Reassembler<1, 64> = Reassembler::new(T);
            let (a, b) = ([1u8; 20], [9u8; 20]);
            let mut fa = fragments(tmpl(0x700), &a).unwrap();
            assert!(r.accept(&fa.next().unwrap(), 0, Expect::Any).is_none());
            assert!(r.accept(&fa.next().unwrap(), 0, Expect::Any).is_none());
            // The sender gave up (deadline missed) and starts the next message.
            assert!(roundtrip(&mut r, 0x700, &b, 1, Expect::Any));
            assert_eq!(r.stats().truncated, 1);
            assert_eq!(r.stats().completed, 1);
        }

        fn stale_partial_messages_time_out() {
            let mut r: Reassembler<2, 64> = Reassembler::new(1_000);
            assert!(r.accept(&f(0x800, 2, &[1; 8]), 0, Expect::Any).is_none());
            assert_eq!(r.expire(1_000), 0); // exactly the timeout: still alive
            assert_eq!(r.partial_messages(), 1);
            assert_eq!(r.expire(1_001), 1);
            assert_eq!(r.partial_messages(), 0);
            // Timing out on arrival of a late frame: it then starts nothing useful.
            let payload = [1u8; 9];
            let mut it = fragments(tmpl(0x801), &payload).unwrap();
            assert!(r.accept(&it.next().unwrap(), 2_000, Expect::Exactly(9)).is_none());
            assert!(r.accept(&it.next().unwrap(), 3_001, Expect::Exactly(9)).is_none());
            let s = r.stats();
            assert_eq!((s.timed_out, s.foreign, s.completed), (2, 1, 0));
        }

        fn too_long_for_the_buffer_is_refused_with_its_rest() {
            let mut r: Reassembler<1, 16> = Reassembler::new(T);
            let payload = [5u8; 30];
            for fr in fragments(tmpl(0x1000), &payload).unwrap() {
                assert!(r.accept(&fr, 0, Expect::Any).is_none());
            }
            let s = r.stats();
            assert_eq!((s.too_long, s.foreign, s.completed), (1, 3, 0));
            // 16 bytes fit exactly (the CRC is checked, not stored).
            assert!(roundtrip(&mut r, 0x1000, &[6u8; 16], 1, Expect::Any));
            // 17 do not, and the last frame alone must not complete anything.
            let payload = [7u8; 17];
            for fr in fragments(tmpl(0x1000), &payload).unwrap() {
                assert!(r.accept(&fr, 2, Expect::Any).is_none());
            }
            assert_eq!(r.stats().too_long, 2);
        }

        fn no_free_slot_drops_and_counts_but_single_frames_still_pass() {
            let mut r: Reassembler<1, 32> = Reassembler::new(T);
            assert!(r.accept(&f(0x100, 2, &[1; 8]), 0, Expect::Any).is_none());
            assert!(r.accept(&f(0x101, 2, &[1; 8]), 0, Expect::Any).is_none());
            assert_eq!(r.stats().no_slot, 1);
            assert!(r.accept(&f(0x101, 0, &[1; 2]), 0, Expect::Any).is_some());
            assert!(r.accept(&f(0x100, 0, &[2; 2]), 0, Expect::Any).is_some());
            // A finished stream's history does not block a new stream.
            assert!(r.accept(&f(0x102, 2, &[1; 8]), 1, Expect::Any).is_none());
            assert_eq!(r.partial_messages(), 1);
            assert_eq!(r.stats().no_slot, 1);
        }

        fn short_middle_frames_are_bad_length() {
            let mut r: Reassembler<1, 32> = Reassembler::new(T);
            let payload = [4u8; 20];
            let nth = |k| fragments(tmpl(0x100), &payload).unwrap().nth(k).unwrap();
            assert!(r.accept(&f(0x100, 3, &[4; 7]), 0, Expect::Any).is_none());
            assert!(r.accept(&nth(0), 0, Expect::Any).is_none());
            assert!(r.accept(&f(0x100, 2, &[4; 3]), 0, Expect::Any).is_none());
            assert!(r.accept(&nth(1), 0, Expect::Any).is_none());
            assert!(r.accept(&f(0x100, 1, &[]), 0, Expect::Any).is_none());
            assert_eq!(r.stats().bad_length, 3);
            assert_eq!(r.accept(&nth(2), 0, Expect::Any).map(|m| m.data.len()), Some(20));
            // Two frames whose bytes fit one: 7 payload bytes and the CRC; never sent so.
            assert!(r.accept(&f(0x100, 2, &[4; 8]), 1, Expect::Any).is_none());
            assert!(r.accept(&f(0x100, 1, &[4; 1]), 1, Expect::Any).is_none());
            assert_eq!(r.stats().bad_length, 4);
        }

        fn arbitrary_frames_never_panic() {
            let mut r: Reassembler<3, 24> = Reassembler::new(50);
            let mut x: u32 = 0x1234_5678;
            let mut at: Micros = 0;
            let mut data = [0u8; 8];
            for _ in 0..20_000 {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                let message = 0x100 + (x & 3) as u16;
                let fragment = ((x >> 4) % 5) as u8;
                let len = ((x >> 8) % 9) as usize;
                data.fill((x >> 12) as u8 & 1);
                at += u64::from((x >> 16) % 20);
                let expect = if x & (1 << 20) == 0 { Expect::Any } else { Expect::Exactly(24) };
                let fr = f(message, fragment, &data[..len]);
                if let Some(m) = r.accept(&fr, at, expect) {
                    assert!(m.data.len() <= 24);
                }
            }
            assert!(r.stats().completed > 0);
        }
    }
}

#[cfg(test)]
mod proptests {
    extern crate std;

    use super::*;
    use crate::laxity::Laxity;
    use proptest::prelude::*;
    use std::vec::Vec;

    fn frames_of(message: u16, payload: &[u8]) -> Vec<Frame> {
        let t = FrameId { laxity: Laxity::from_code(9), message: MessageId(message), fragment: 0 };
        fragments(t, payload).unwrap().collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        #[test]
        fn roundtrip_any_payload(
            payload in prop::collection::vec(any::<u8>(), 0..=MAX_MESSAGE_LEN),
            message in any::<u16>(),
            exact in any::<bool>(),
        ) {
            let frames = frames_of(message, &payload);
            prop_assert_eq!(frames.len(), frame_count(payload.len()).unwrap());
            let joined: Vec<u8> = frames.iter().flat_map(|f| f.payload().iter().copied()).collect();
            let mut wire = payload.clone();
            if frames.len() > 1 {
                wire.extend_from_slice(&transfer_crc::of(&payload).to_be_bytes());
            }
            prop_assert_eq!(&joined, &wire);
            for (k, f) in frames.iter().enumerate() {
                let counter = if frames.len() == 1 { 0 } else { frames.len() - k };
                prop_assert_eq!(usize::from(f.id().fragment), counter);
                prop_assert!(k + 1 == frames.len() || f.len() == 8);
            }
            let expect = if exact { Expect::Exactly(payload.len()) } else { Expect::Any };
            let mut r: Reassembler<1, MAX_MESSAGE_LEN> = Reassembler::new(1_000);
            for (k, f) in frames.iter().enumerate() {
                let got = r.accept(f, k as Micros, expect).map(|m| m.data.to_vec());
                if k + 1 == frames.len() {
                    prop_assert_eq!(got.as_deref(), Some(&payload[..]));
                } else {
                    prop_assert_eq!(got, None);
                }
            }
            prop_assert_eq!(r.stats(), ReassemblyStats { completed: 1, ..ReassemblyStats::new() });
        }

        /// In-order streams, interleaved, with frames repeated right after themselves (CAN's
        /// double reception): exactly the messages, and every repetition counted.
        #[test]
        fn duplicates_in_order_are_harmless(
            msgs in prop::collection::vec((0u16..3, prop::collection::vec(any::<u8>(), 9..=64)), 1..12),
            dup_mask in prop::collection::vec(any::<bool>(), 0..200),
            exact in any::<bool>(),
        ) {
            // Each stream's frames in order; streams merged round-robin.
            let mut per_stream: [Vec<(usize, Frame)>; 3] = Default::default();
            for (n, (s, payload)) in msgs.iter().enumerate() {
                for f in frames_of(0x100 + s, payload) {
                    per_stream[usize::from(*s)].push((n, f));
                }
            }
            let mut merged = Vec::new();
            let mut iters: Vec<_> = per_stream.iter().map(|v| v.iter()).collect();
            while merged.len() < per_stream.iter().map(Vec::len).sum() {
                for it in iters.iter_mut() {
                    if let Some(x) = it.next() { merged.push(*x); }
                }
            }
            let mut r: Reassembler<3, 64> = Reassembler::new(1_000);
            let mut got = Vec::new();
            let mut dups = 0;
            for (k, (n, f)) in merged.iter().enumerate() {
                let expect = if exact { Expect::Exactly(msgs[*n].1.len()) } else { Expect::Any };
                let copies = if dup_mask.get(k).copied().unwrap_or(false) { 2 } else { 1 };
                dups += copies - 1;
                for _ in 0..copies {
                    if let Some(m) = r.accept(f, k as Micros, expect) {
                        got.push((m.id.0 - 0x100, m.data.to_vec()));
                    }
                }
            }
            let mut want: Vec<_> = msgs.clone();
            want.sort_by_key(|(s, _)| *s); // stable: per-stream order kept
            got.sort_by_key(|(s, _)| *s);
            prop_assert_eq!(got, want);
            let s = r.stats();
            prop_assert_eq!(s, ReassemblyStats { completed: msgs.len() as u32, duplicate: dups, ..ReassemblyStats::new() });
        }

        /// Frames of one message per stream, shuffled, repeated and dropped at will, with time
        /// jumps past the timeout: never a panic, never a wrong message. With the length known
        /// only whole messages come out; without it, at worst a suffix at a frame boundary.
        #[test]
        fn chaos_never_yields_a_wrong_message(
            msgs in prop::collection::vec(prop::collection::vec(any::<u8>(), 0..=80), 1..5),
            order in prop::collection::vec((any::<prop::sample::Index>(), 0u64..400), 0..120),
            exact in any::<bool>(),
        ) {
            let all: Vec<(usize, Frame)> = msgs
                .iter()
                .enumerate()
                .flat_map(|(s, p)| frames_of(0x100 + s as u16, p).into_iter().map(move |f| (s, f)))
                .collect();
            let mut r: Reassembler<2, 80> = Reassembler::new(300);
            let mut at = 0;
            let mut yields = 0u32;
            for (ix, dt) in order {
                let (s, f) = all[ix.index(all.len())];
                at += dt;
                let expect = if exact { Expect::Exactly(msgs[s].len()) } else { Expect::Any };
                if let Some(m) = r.accept(&f, at, expect) {
                    yields += 1;
                    let sent = &msgs[usize::from(m.id.0 - 0x100)];
                    if exact {
                        prop_assert_eq!(m.data, &sent[..]);
                    } else {
                        let skip = sent.len().checked_sub(m.data.len());
                        prop_assert!(skip.is_some_and(|k| k % 8 == 0), "not a suffix");
                        prop_assert_eq!(m.data, &sent[skip.unwrap()..]);
                    }
                }
            }
            prop_assert_eq!(r.stats().completed, yields);
        }

        /// Two messages per stream of one fixed length, frames in any order: the length known,
        /// whatever comes out has that length and every 8-byte chunk in its own place in one of
        /// the stream's messages (the splice RTCAN cannot detect, see the spec, is the worst).
        #[test]
        fn splices_are_the_worst_case(
            lens in prop::collection::vec(0usize..=40, 1..4),
            seed in any::<u8>(),
            order in prop::collection::vec(any::<prop::sample::Index>(), 0..100),
        ) {
            let msgs: Vec<[Vec<u8>; 2]> = lens
                .iter()
                .enumerate()
                .map(|(s, &n)| {
                    let m = |v: u8| (0..n).map(|i| (i as u8) ^ v.wrapping_mul(s as u8 + 1) ^ seed).collect();
                    [m(0x55), m(0xAA)]
                })
                .collect();
            let all: Vec<(usize, Frame)> = msgs
                .iter()
                .enumerate()
                .flat_map(|(s, pair)| pair.iter().flat_map(move |p| frames_of(0x100 + s as u16, p)).map(move |f| (s, f)))
                .collect();
            let mut r: Reassembler<3, 40> = Reassembler::new(1_000);
            for (k, ix) in order.iter().enumerate() {
                let (s, f) = all[ix.index(all.len())];
                if let Some(m) = r.accept(&f, k as Micros, Expect::Exactly(lens[s])) {
                    let pair = &msgs[usize::from(m.id.0 - 0x100)];
                    prop_assert_eq!(m.data.len(), pair[0].len());
                    for (c, chunk) in m.data.chunks(8).enumerate() {
                        let at = c * 8..c * 8 + chunk.len();
                        prop_assert!(pair.iter().any(|p| &p[at.clone()] == chunk));
                    }
                }
            }
        }

        /// Any frames at all (few streams, random counters, lengths, times and expectations).
        #[test]
        fn arbitrary_input_never_panics(
            input in prop::collection::vec(
                (0u16..4, 0u8..=MAX_FRAGMENT, prop::collection::vec(0u8..2, 0..=8), 0u64..100, prop::option::of(0usize..1100)),
                0..300,
            ),
        ) {
            let mut r: Reassembler<2, 24> = Reassembler::new(150);
            let mut at = 0;
            let mut yields = 0;
            for (m, c, data, dt, len) in input {
                at += dt;
                let f = Frame::new(FrameId { laxity: Laxity::NRT, message: MessageId(m), fragment: c }, &data).unwrap();
                let expect = len.map_or(Expect::Any, Expect::Exactly);
                if let Some(msg) = r.accept(&f, at, expect) {
                    yields += 1;
                    prop_assert!(msg.data.len() <= 24);
                    prop_assert_eq!(msg.id, MessageId(m));
                }
                prop_assert!(r.partial_messages() <= 2);
            }
            prop_assert_eq!(r.stats().completed, yields);
        }
    }
}

/// The shared test vectors (tests/vectors/rtcan/fragmentation.json), for every implementation.
#[cfg(test)]
mod vectors {
    extern crate std;

    use super::*;
    use crate::laxity::Laxity;
    use serde::Deserialize;
    use std::string::String;
    use std::vec::Vec;

    const JSON: &str = include_str!("../../../../tests/vectors/rtcan/fragmentation.json");

    #[derive(Deserialize)]
    struct Vectors {
        description: String,
        fragmentation: Vec<FragCase>,
        reassembly: Vec<ReasmCase>,
    }

    #[derive(Deserialize)]
    struct FragCase {
        name: String,
        laxity: u8,
        message_id: String,
        #[serde(default)]
        payload: Option<String>,
        #[serde(default)]
        payload_len: Option<usize>,
        #[serde(default)]
        frames: Vec<RawFrame>,
        #[serde(default)]
        error: Option<String>,
    }

    #[derive(Deserialize)]
    struct RawFrame {
        #[serde(default)]
        at: u64,
        id: String,
        data: String,
    }

    #[derive(Deserialize)]
    struct ReasmCase {
        name: String,
        slots: usize,
        buffer: usize,
        timeout_us: u64,
        expect_len: Option<usize>,
        frames: Vec<RawFrame>,
        messages: Vec<Completed>,
        stats: Stats,
    }

    #[derive(Deserialize)]
    struct Completed {
        after_frame: usize,
        message_id: String,
        data: String,
    }

    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Stats {
        completed: u32,
        duplicate: u32,
        foreign: u32,
        out_of_order: u32,
        truncated: u32,
        timed_out: u32,
        too_long: u32,
        no_slot: u32,
        bad_length: u32,
        bad_crc: u32,
    }

    fn hex_u32(s: &str) -> u32 {
        u32::from_str_radix(s.trim_start_matches("0x"), 16).unwrap()
    }

    fn bytes(s: &str) -> Vec<u8> {
        (0..s.len()).step_by(2).map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap()).collect()
    }

    fn run<const S: usize, const B: usize>(c: &ReasmCase) {
        let mut r: Reassembler<S, B> = Reassembler::new(c.timeout_us);
        let expect = c.expect_len.map_or(Expect::Any, Expect::Exactly);
        let mut got = Vec::new();
        for (k, f) in c.frames.iter().enumerate() {
            let frame = Frame::from_raw(hex_u32(&f.id), &bytes(&f.data)).unwrap();
            if let Some(m) = r.accept(&frame, f.at, expect) {
                got.push((k, m.id.0 as u32, m.data.to_vec()));
            }
        }
        let want: Vec<_> = c
            .messages
            .iter()
            .map(|m| (m.after_frame, hex_u32(&m.message_id), bytes(&m.data)))
            .collect();
        assert_eq!(got, want, "{}", c.name);
        let s = &c.stats;
        let want = ReassemblyStats {
            completed: s.completed,
            duplicate: s.duplicate,
            foreign: s.foreign,
            out_of_order: s.out_of_order,
            truncated: s.truncated,
            timed_out: s.timed_out,
            too_long: s.too_long,
            no_slot: s.no_slot,
            bad_length: s.bad_length,
            bad_crc: s.bad_crc,
        };
        assert_eq!(r.stats(), want, "{}", c.name);
    }

    #[test]
    fn every_vector_holds() {
        let v: Vectors = serde_json::from_str(JSON).unwrap();
        assert!(v.description.contains("docs/rtcan.md"));
        assert!(v.fragmentation.len() >= 10 && v.reassembly.len() >= 10);
        for c in &v.fragmentation {
            let t = FrameId {
                laxity: Laxity::from_code(c.laxity),
                message: MessageId(hex_u32(&c.message_id) as u16),
                fragment: 0,
            };
            let payload = match (&c.payload, c.payload_len) {
                (Some(p), _) => bytes(p),
                (None, Some(n)) => std::vec![0; n],
                (None, None) => panic!("{}: no payload", c.name),
            };
            match fragments(t, &payload) {
                Ok(frames) => {
                    assert_eq!(c.error, None, "{}", c.name);
                    let got: Vec<(u32, Vec<u8>)> =
                        frames.map(|f| (f.id().to_raw(), f.payload().to_vec())).collect();
                    let want: Vec<(u32, Vec<u8>)> =
                        c.frames.iter().map(|f| (hex_u32(&f.id), bytes(&f.data))).collect();
                    assert_eq!(got, want, "{}", c.name);
                }
                Err(FragmentError::TooLong(_)) => {
                    assert_eq!(c.error.as_deref(), Some("too_long"), "{}", c.name)
                }
            }
        }
        for c in &v.reassembly {
            match (c.slots, c.buffer) {
                (4, 1024) => run::<4, 1024>(c),
                (1, 64) => run::<1, 64>(c),
                (1, 16) => run::<1, 16>(c),
                other => panic!("{}: no reassembler of {:?} in this test", c.name, other),
            }
        }
    }
}
