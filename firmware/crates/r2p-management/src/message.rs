//! Management messages and their wire format.
//!
//! A management message is one type byte followed by its fields, little-endian, strings as a
//! length byte and ASCII bytes. It travels as one RTCAN NRT message on the sender's management
//! stream (fragmented when longer than 8 bytes), so the sender is known from the message ID.
//! Requests name their target node; responses go out on the responder's own stream.
//! Decoding checks every length and value and returns a typed error; it never panics.

use heapless::String;

/// Longest module name.
pub const NAME_MAX: usize = 16;
/// Longest topic name.
pub const TOPIC_MAX: usize = 32;
/// Longest encoded management message (a buffer this long fits every message).
pub const ENCODED_MAX: usize = 64;
/// Bytes of an STM32 unique device ID.
pub const UID_LEN: usize = 12;
/// Longest panic report text: what is left of [`ENCODED_MAX`] after the type and length bytes.
pub const PANIC_TEXT_MAX: usize = ENCODED_MAX - 2;
/// Longest firmware-update payload: what is left after the type, target and length bytes.
pub const UPDATE_MAX: usize = ENCODED_MAX - 3;
/// Bytes of an image digest in [`Message::Firmware`].
pub const DIGEST_LEN: usize = 8;

/// Type bytes (docs/middleware.md, "Management protocol").
pub mod ty {
    /// [`super::Message::Heartbeat`]
    pub const HEARTBEAT: u8 = 0x11;
    /// [`super::Message::Reboot`]
    pub const REBOOT: u8 = 0x13;
    /// [`super::Message::PanicReport`]
    pub const PANIC_REPORT: u8 = 0x14;
    /// [`super::Message::Firmware`]
    pub const FIRMWARE: u8 = 0x15;
    /// [`super::Message::Advertise`]
    pub const ADVERTISE: u8 = 0x21;
    /// [`super::Message::SubscribeRequest`]
    pub const SUBSCRIBE_REQUEST: u8 = 0x22;
    /// [`super::Message::SubscribeResponse`]
    pub const SUBSCRIBE_RESPONSE: u8 = 0x23;
    /// [`super::Message::HrtRequest`]
    pub const HRT_REQUEST: u8 = 0x24;
    /// [`super::Message::HrtGrant`]
    pub const HRT_GRANT: u8 = 0x25;
    /// [`super::Message::ParamGet`]
    pub const PARAM_GET: u8 = 0x41;
    /// [`super::Message::ParamSet`]
    pub const PARAM_SET: u8 = 0x42;
    /// [`super::Message::ParamValue`]
    pub const PARAM_VALUE: u8 = 0x43;
    /// [`super::Message::ParamError`]
    pub const PARAM_ERROR: u8 = 0x44;
    /// [`super::Message::Update`]
    pub const UPDATE: u8 = 0x51;
}

/// Whether type byte `ty` is a reply only a tool reads: parameter answers (a node reads them
/// only after asking), a module's firmware and its panic report (`r2p` shows them).
pub const fn is_reply(ty: u8) -> bool {
    matches!(ty, ty::PARAM_VALUE | ty::PARAM_ERROR | ty::FIRMWARE | ty::PANIC_REPORT)
}

/// What a module is doing, as its heartbeat says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum ModuleState {
    /// Booting: node ID being claimed, topics being advertised.
    Starting = 0,
    /// Running its application.
    Running = 1,
    /// Application stopped on request or by a latched fault; still on the bus.
    Stopped = 2,
    /// In the bootloader, waiting for a firmware update.
    Bootloader = 3,
}

/// The traffic class a publisher asks for on the bus, as ADVERTISE carries it: the publisher's
/// `r2p_middleware::Class` with an HRT period counted in communication cycles (the unit the
/// master's calendar uses, fixed once the node has checked it is a power of two of its cycle)
/// rather than in µs. A frame's identifier only shows `rtcan::FrameClass`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusClass {
    /// Synchronous real-time: HRT, one message every `period_cycles` communication cycles.
    Hrt {
        /// Period in communication cycles.
        period_cycles: u16,
    },
    /// Asynchronous real-time: SRT with a relative deadline.
    Srt {
        /// Deadline after publication, µs.
        deadline_us: u32,
    },
    /// Non-real-time.
    Nrt,
}

/// The result of a subscription request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum SubscribeResult {
    /// Subscribed: the response carries the stream's message ID.
    Ok = 0,
    /// The target publishes no such topic.
    UnknownTopic = 1,
    /// The topic's message type differs (type hashes disagree).
    TypeMismatch = 2,
    /// The master could not reserve an HRT slot for the stream.
    NoSlot = 3,
}

/// The master's answer to an HRT reservation request (`rtcan::schedule::Reject`, on the wire).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum HrtResult {
    /// Admitted: the grant carries the phase.
    Ok = 0,
    /// The HRT slots' capacity (or the master's table) would be exceeded.
    Full = 1,
    /// The period is not a power of two from 1 to 256 cycles.
    NotHarmonic = 2,
    /// Capacity is left, but every phase collides (slots fragmented by removals).
    NoFreePhase = 3,
    /// The stream is admitted with another period, or its message ID is not the sender's.
    Conflict = 4,
    /// Messages of more frames than the master reserves per occurrence (one, for now).
    TooManyFrames = 5,
}

/// Why a parameter request failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum ParamFault {
    /// No parameter with that index.
    UnknownIndex = 0,
    /// The value is outside the parameter's range: refused, nothing changed.
    OutOfRange = 1,
    /// The parameter cannot be set over the bus.
    ReadOnly = 2,
    /// The value's type is not the parameter's.
    WrongType = 3,
    /// The value was valid but storing it in flash failed; the old value stays.
    StorageFailed = 4,
}

/// A typed parameter value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// On/off.
    Bool(bool),
    /// Unsigned integer.
    U32(u32),
    /// Signed integer.
    I32(i32),
    /// IEEE-754 single, carried by its bits so encoding is exact.
    F32(f32),
}

/// A management message.
#[derive(Clone, Debug, PartialEq)]
pub enum Message {
    /// Periodic "I am here", and the claim of the node ID of the stream it is sent on.
    Heartbeat {
        /// The MCU's unique device ID: breaks node-ID ties.
        uid: [u8; UID_LEN],
        /// Module name (e.g. "motor"); two modules may share a name.
        name: String<NAME_MAX>,
        /// What the module is doing.
        state: ModuleState,
        /// Seconds since boot.
        uptime_s: u32,
        /// CAN transmit error counter.
        tx_errors: u8,
        /// CAN receive error counter.
        rx_errors: u8,
        /// Malformed or unexpected frames dropped since boot.
        dropped: u16,
    },
    /// Asks `target` (or every node: 255) to reboot.
    Reboot {
        /// Node ID to reboot.
        target: u8,
    },
    /// "My last reset followed a panic": what the module kept of it across the reset, sent
    /// after the first heartbeat and every few after (until the next reset) so that a tool
    /// listening at any time hears it.
    PanicReport {
        /// Printable ASCII; from the modules' images, the calls found on the stack
        /// (r2p-panic: `panic, calls: 08002a1e 0800b3c2 …`, innermost first).
        text: String<PANIC_TEXT_MAX>,
    },
    /// "I run this image": the version and digest from its signed trailer (r2p-boot), sent
    /// after the first heartbeat and with every panic report's turn after it, so a tool that
    /// listens for a second (`r2p nodes`) hears it. Version 0 and a zero digest: an image
    /// flashed without a trailer (a development build).
    Firmware {
        /// major << 24 | minor << 16 | patch, as in the trailer.
        version: u32,
        /// The first [`DIGEST_LEN`] bytes of SHA-512 of the image (what `r2p sign` prints).
        digest: [u8; DIGEST_LEN],
        /// The module kind the image is for (modules.toml's name): what `r2p update --all`
        /// matches images against.
        kind: String<NAME_MAX>,
        /// Just swapped in and not yet confirmed healthy: the bootloader rolls it back if it
        /// resets before it confirms (r2p-boot's `trial`).
        on_trial: bool,
    },
    /// One message of a firmware-update transfer (r2p-boot's `transfer`: begin, block, end from
    /// the sender; status from the module) for node `target`. The management layer only
    /// carries it: the module's update sink reads it, and the sender the answers.
    Update {
        /// The module updated (a request) or the sender answered (a status).
        target: u8,
        /// The transfer message, at most [`UPDATE_MAX`] bytes.
        data: heapless::Vec<u8, UPDATE_MAX>,
    },
    /// "I publish `topic` on my stream `index`."
    Advertise {
        /// Topic name.
        topic: String<TOPIC_MAX>,
        /// The message type's schema hash.
        type_hash: u32,
        /// Encoded message size in bytes.
        size: u16,
        /// Stream index: the message ID is `node << 8 | index`.
        index: u8,
        /// Requested bus class.
        class: BusClass,
    },
    /// Asks `target` to send `topic` on the bus.
    SubscribeRequest {
        /// Publisher's node ID.
        target: u8,
        /// Topic name.
        topic: String<TOPIC_MAX>,
        /// The subscriber's message type hash.
        type_hash: u32,
        /// The subscriber's queue length (the longest one sizes the remote buffer).
        queue_len: u8,
    },
    /// The publisher's answer.
    SubscribeResponse {
        /// Subscriber's node ID.
        target: u8,
        /// Topic name.
        topic: String<TOPIC_MAX>,
        /// Outcome.
        result: SubscribeResult,
        /// The stream's message ID.
        message_id: u16,
    },
    /// Asks the bus master (whoever it is: there is no target) to reserve HRT slots for the
    /// sender's stream `message_id`: `frames` frames of a `size`-byte message every
    /// `period_cycles` cycles.
    HrtRequest {
        /// The stream (a stream of the sender: `sender << 8 | index`).
        message_id: u16,
        /// Period in communication cycles (a power of two, at most 256).
        period_cycles: u16,
        /// Frames per message.
        frames: u8,
        /// The message's payload bytes (its frames' lengths follow, transfer CRC included):
        /// a master that sizes reservations to their frames needs them.
        size: u8,
    },
    /// The master's answer on its own management stream: the stream may send in slot `slot` of
    /// every cycle c with c mod `period_cycles` = `offset` (when `result` is `Ok`).
    HrtGrant {
        /// The stream asked for.
        message_id: u16,
        /// Its period in cycles, as asked.
        period_cycles: u16,
        /// Cycle offset, less than the period (0 when refused).
        offset: u8,
        /// Slot index, at least 1 (0 when refused).
        slot: u8,
        /// Outcome.
        result: HrtResult,
        /// Where the slot's reservation starts, µs from the cycle's start (0 when refused).
        start_us: u16,
        /// How long it lasts, µs: its frame's worst case and a guard (0 when refused). Every
        /// node hears every grant, so each learns where each reservation lies.
        len_us: u16,
    },
    /// Reads parameter `index` of `target`.
    ParamGet {
        /// Node ID.
        target: u8,
        /// Parameter index.
        index: u16,
    },
    /// Sets parameter `index` of `target` (range-checked, stored in flash).
    ParamSet {
        /// Node ID.
        target: u8,
        /// Parameter index.
        index: u16,
        /// New value.
        value: Value,
    },
    /// A parameter's current value (answer to get and set).
    ParamValue {
        /// Parameter index.
        index: u16,
        /// Current value.
        value: Value,
    },
    /// A parameter request was refused, and why.
    ParamError {
        /// Parameter index.
        index: u16,
        /// Reason.
        fault: ParamFault,
    },
}

/// Why bytes are not a management message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// No bytes at all.
    Empty,
    /// The type byte is not a known message type.
    UnknownType(u8),
    /// The message ends before its fields do.
    Truncated,
    /// Bytes follow the last field.
    TrailingBytes,
    /// A name is too long or not printable ASCII, or a topic uses characters outside `A-Za-z0-9_/`.
    BadString,
    /// An enumeration or value tag has no meaning.
    BadValue(u8),
    /// A reply only a tool reads (PARAM_VALUE, PARAM_ERROR, FIRMWARE, PANIC_REPORT), left
    /// undecoded by [`Message::decode_requests`]: not malformed, not for this node.
    Reply(u8),
}

/// The buffer given to [`Message::encode`] is too small (use [`ENCODED_MAX`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BufferTooSmall;

struct Writer<'a> {
    buf: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    // What is left after `at` (never past the end), then `b`'s length of it: no sum to check
    // for overflow (20 B less in a module image, where every field's write inlines this).
    fn bytes(&mut self, b: &[u8]) -> Result<(), BufferTooSmall> {
        let rest = self.buf.get_mut(self.at..).ok_or(BufferTooSmall)?;
        rest.get_mut(..b.len()).ok_or(BufferTooSmall)?.copy_from_slice(b);
        self.at += b.len();
        Ok(())
    }
    fn u8(&mut self, v: u8) -> Result<(), BufferTooSmall> {
        self.bytes(&[v])
    }
    fn u16(&mut self, v: u16) -> Result<(), BufferTooSmall> {
        self.bytes(&v.to_le_bytes())
    }
    fn u32(&mut self, v: u32) -> Result<(), BufferTooSmall> {
        self.bytes(&v.to_le_bytes())
    }
    fn str(&mut self, s: &str) -> Result<(), BufferTooSmall> {
        self.u8(s.len() as u8)?;
        self.bytes(s.as_bytes())
    }
    fn value(&mut self, v: &Value) -> Result<(), BufferTooSmall> {
        let (tag, bits) = match *v {
            Value::Bool(b) => (0, b as u32),
            Value::U32(x) => (1, x),
            Value::I32(x) => (2, x as u32),
            Value::F32(x) => (3, x.to_bits()),
        };
        self.u8(tag)?;
        self.u32(bits)
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], DecodeError> {
        if self.bytes.len() < n {
            return Err(DecodeError::Truncated);
        }
        let (head, tail) = self.bytes.split_at(n);
        self.bytes = tail;
        Ok(head)
    }
    fn u8(&mut self) -> Result<u8, DecodeError> {
        Ok(self.take(1)?[0])
    }
    fn u16(&mut self) -> Result<u16, DecodeError> {
        let b = self.take(2)?;
        Ok(u16::from_le_bytes([b[0], b[1]]))
    }
    fn u32(&mut self) -> Result<u32, DecodeError> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn string<const N: usize>(&mut self, ok: fn(u8) -> bool) -> Result<String<N>, DecodeError> {
        let len = self.u8()? as usize;
        let b = self.take(len)?;
        if len > N || !b.iter().all(|&c| c.is_ascii() && ok(c)) {
            return Err(DecodeError::BadString);
        }
        // SAFETY: every byte is ASCII (checked just above), so `b` is valid UTF-8. Checking
        // ASCII instead of calling `str::from_utf8` keeps the UTF-8 decoder out of the image.
        let s = unsafe { core::str::from_utf8_unchecked(b) };
        String::try_from(s).map_err(|_| DecodeError::BadString)
    }
    fn value(&mut self) -> Result<Value, DecodeError> {
        let tag = self.u8()?;
        let bits = self.u32()?;
        Ok(match tag {
            0 if bits <= 1 => Value::Bool(bits == 1),
            1 => Value::U32(bits),
            2 => Value::I32(bits as i32),
            3 => Value::F32(f32::from_bits(bits)),
            _ => return Err(DecodeError::BadValue(tag)),
        })
    }
}

/// Printable ASCII, for module names.
pub fn is_name_char(c: u8) -> bool {
    (0x20..0x7F).contains(&c)
}

/// Letters, digits, `_` and `/`, for topic names.
pub fn is_topic_char(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_' || c == b'/'
}

impl Message {
    /// The message's type byte.
    pub fn type_byte(&self) -> u8 {
        match self {
            Message::Heartbeat { .. } => ty::HEARTBEAT,
            Message::Reboot { .. } => ty::REBOOT,
            Message::PanicReport { .. } => ty::PANIC_REPORT,
            Message::Firmware { .. } => ty::FIRMWARE,
            Message::Update { .. } => ty::UPDATE,
            Message::Advertise { .. } => ty::ADVERTISE,
            Message::SubscribeRequest { .. } => ty::SUBSCRIBE_REQUEST,
            Message::SubscribeResponse { .. } => ty::SUBSCRIBE_RESPONSE,
            Message::HrtRequest { .. } => ty::HRT_REQUEST,
            Message::HrtGrant { .. } => ty::HRT_GRANT,
            Message::ParamGet { .. } => ty::PARAM_GET,
            Message::ParamSet { .. } => ty::PARAM_SET,
            Message::ParamValue { .. } => ty::PARAM_VALUE,
            Message::ParamError { .. } => ty::PARAM_ERROR,
        }
    }

    /// Writes the message into `buf`; returns its length.
    pub fn encode(&self, buf: &mut [u8]) -> Result<usize, BufferTooSmall> {
        let mut w = Writer { buf, at: 0 };
        w.u8(self.type_byte())?;
        match self {
            Message::Heartbeat { uid, name, state, uptime_s, tx_errors, rx_errors, dropped } => {
                w.bytes(uid)?;
                w.str(name)?;
                w.u8(*state as u8)?;
                w.u32(*uptime_s)?;
                w.u8(*tx_errors)?;
                w.u8(*rx_errors)?;
                w.u16(*dropped)?;
            }
            Message::Reboot { target } => w.u8(*target)?,
            Message::PanicReport { text } => w.str(text)?,
            Message::Firmware { version, digest, kind, on_trial } => {
                w.u32(*version)?;
                w.bytes(digest)?;
                w.str(kind)?;
                w.u8(u8::from(*on_trial))?;
            }
            Message::Update { target, data } => {
                w.u8(*target)?;
                w.u8(data.len() as u8)?;
                w.bytes(data)?;
            }
            Message::Advertise { topic, type_hash, size, index, class } => {
                w.str(topic)?;
                w.u32(*type_hash)?;
                w.u16(*size)?;
                w.u8(*index)?;
                match *class {
                    BusClass::Hrt { period_cycles } => {
                        w.u8(0)?;
                        w.u32(period_cycles as u32)?
                    }
                    BusClass::Srt { deadline_us } => {
                        w.u8(1)?;
                        w.u32(deadline_us)?
                    }
                    BusClass::Nrt => {
                        w.u8(2)?;
                        w.u32(0)?
                    }
                }
            }
            Message::SubscribeRequest { target, topic, type_hash, queue_len } => {
                w.u8(*target)?;
                w.str(topic)?;
                w.u32(*type_hash)?;
                w.u8(*queue_len)?;
            }
            Message::SubscribeResponse { target, topic, result, message_id } => {
                w.u8(*target)?;
                w.str(topic)?;
                w.u8(*result as u8)?;
                w.u16(*message_id)?;
            }
            Message::HrtRequest { message_id, period_cycles, frames, size } => {
                w.u16(*message_id)?;
                w.u16(*period_cycles)?;
                w.u8(*frames)?;
                w.u8(*size)?;
            }
            Message::HrtGrant {
                message_id,
                period_cycles,
                offset,
                slot,
                result,
                start_us,
                len_us,
            } => {
                w.u16(*message_id)?;
                w.u16(*period_cycles)?;
                w.u8(*offset)?;
                w.u8(*slot)?;
                w.u8(*result as u8)?;
                w.u16(*start_us)?;
                w.u16(*len_us)?;
            }
            Message::ParamGet { target, index } => {
                w.u8(*target)?;
                w.u16(*index)?;
            }
            Message::ParamSet { target, index, value } => {
                w.u8(*target)?;
                w.u16(*index)?;
                w.value(value)?;
            }
            Message::ParamValue { index, value } => {
                w.u16(*index)?;
                w.value(value)?;
            }
            Message::ParamError { index, fault } => {
                w.u16(*index)?;
                w.u8(*fault as u8)?;
            }
        }
        Ok(w.at)
    }

    /// Reads a message; every byte must be accounted for.
    pub fn decode(bytes: &[u8]) -> Result<Message, DecodeError> {
        Self::decode_with::<true>(bytes)
    }

    /// As [`Message::decode`], but a reply only a tool reads ([`is_reply`]) is
    /// [`DecodeError::Reply`], unread. What a node decodes until it asks another node something
    /// (r2p-node): a module never does, so its image carries no code for the replies (416 B of
    /// the motor's flash, measured).
    pub fn decode_requests(bytes: &[u8]) -> Result<Message, DecodeError> {
        Self::decode_with::<false>(bytes)
    }

    // Not inlined into the node's receive path: one copy, its result built in place (smaller).
    #[inline(never)]
    fn decode_with<const REPLIES: bool>(bytes: &[u8]) -> Result<Message, DecodeError> {
        let mut r = Reader { bytes };
        let ty = r.u8().map_err(|_| DecodeError::Empty)?;
        if !REPLIES && is_reply(ty) {
            return Err(DecodeError::Reply(ty));
        }
        let msg = match ty {
            ty::HEARTBEAT => {
                let mut uid = [0; UID_LEN];
                uid.copy_from_slice(r.take(UID_LEN)?);
                let name = r.string(is_name_char)?;
                let state = match r.u8()? {
                    0 => ModuleState::Starting,
                    1 => ModuleState::Running,
                    2 => ModuleState::Stopped,
                    3 => ModuleState::Bootloader,
                    other => return Err(DecodeError::BadValue(other)),
                };
                Message::Heartbeat {
                    uid,
                    name,
                    state,
                    uptime_s: r.u32()?,
                    tx_errors: r.u8()?,
                    rx_errors: r.u8()?,
                    dropped: r.u16()?,
                }
            }
            ty::REBOOT => Message::Reboot { target: r.u8()? },
            ty::PANIC_REPORT => Message::PanicReport { text: r.string(is_name_char)? },
            ty::FIRMWARE => {
                let version = r.u32()?;
                let mut digest = [0; DIGEST_LEN];
                digest.copy_from_slice(r.take(DIGEST_LEN)?);
                let kind = r.string(is_name_char)?;
                let on_trial = match r.u8()? {
                    b @ 0..=1 => b == 1,
                    other => return Err(DecodeError::BadValue(other)),
                };
                Message::Firmware { version, digest, kind, on_trial }
            }
            ty::UPDATE => {
                let target = r.u8()?;
                let len = r.u8()?;
                let data = r.take(usize::from(len))?;
                let data =
                    heapless::Vec::from_slice(data).map_err(|_| DecodeError::BadValue(len))?;
                Message::Update { target, data }
            }
            ty::ADVERTISE => {
                let topic = r.string(is_topic_char)?;
                let type_hash = r.u32()?;
                let size = r.u16()?;
                let index = r.u8()?;
                let tag = r.u8()?;
                let arg = r.u32()?;
                let class = match tag {
                    0 if arg <= u16::MAX as u32 && arg > 0 => {
                        BusClass::Hrt { period_cycles: arg as u16 }
                    }
                    1 => BusClass::Srt { deadline_us: arg },
                    2 if arg == 0 => BusClass::Nrt,
                    _ => return Err(DecodeError::BadValue(tag)),
                };
                Message::Advertise { topic, type_hash, size, index, class }
            }
            ty::SUBSCRIBE_REQUEST => Message::SubscribeRequest {
                target: r.u8()?,
                topic: r.string(is_topic_char)?,
                type_hash: r.u32()?,
                queue_len: r.u8()?,
            },
            ty::SUBSCRIBE_RESPONSE => {
                let target = r.u8()?;
                let topic = r.string(is_topic_char)?;
                let result = match r.u8()? {
                    0 => SubscribeResult::Ok,
                    1 => SubscribeResult::UnknownTopic,
                    2 => SubscribeResult::TypeMismatch,
                    3 => SubscribeResult::NoSlot,
                    other => return Err(DecodeError::BadValue(other)),
                };
                Message::SubscribeResponse { target, topic, result, message_id: r.u16()? }
            }
            ty::HRT_REQUEST => Message::HrtRequest {
                message_id: r.u16()?,
                period_cycles: r.u16()?,
                frames: r.u8()?,
                size: r.u8()?,
            },
            ty::HRT_GRANT => {
                let (message_id, period_cycles, offset, slot) =
                    (r.u16()?, r.u16()?, r.u8()?, r.u8()?);
                let result = match r.u8()? {
                    0 => HrtResult::Ok,
                    1 => HrtResult::Full,
                    2 => HrtResult::NotHarmonic,
                    3 => HrtResult::NoFreePhase,
                    4 => HrtResult::Conflict,
                    5 => HrtResult::TooManyFrames,
                    other => return Err(DecodeError::BadValue(other)),
                };
                let (start_us, len_us) = (r.u16()?, r.u16()?);
                Message::HrtGrant {
                    message_id,
                    period_cycles,
                    offset,
                    slot,
                    result,
                    start_us,
                    len_us,
                }
            }
            ty::PARAM_GET => Message::ParamGet { target: r.u8()?, index: r.u16()? },
            ty::PARAM_SET => {
                Message::ParamSet { target: r.u8()?, index: r.u16()?, value: r.value()? }
            }
            ty::PARAM_VALUE => Message::ParamValue { index: r.u16()?, value: r.value()? },
            ty::PARAM_ERROR => {
                let index = r.u16()?;
                let fault = match r.u8()? {
                    0 => ParamFault::UnknownIndex,
                    1 => ParamFault::OutOfRange,
                    2 => ParamFault::ReadOnly,
                    3 => ParamFault::WrongType,
                    4 => ParamFault::StorageFailed,
                    other => return Err(DecodeError::BadValue(other)),
                };
                Message::ParamError { index, fault }
            }
            other => return Err(DecodeError::UnknownType(other)),
        };
        if !r.bytes.is_empty() {
            return Err(DecodeError::TrailingBytes);
        }
        Ok(msg)
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn samples() -> [Message; 14] {
        [
            Message::Heartbeat {
                uid: [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12],
                name: String::try_from("motor").unwrap(),
                state: ModuleState::Running,
                uptime_s: 3600,
                tx_errors: 2,
                rx_errors: 0,
                dropped: 7,
            },
            Message::Reboot { target: 0x12 },
            Message::PanicReport {
                text: String::try_from("panic, calls: 08002a1e 0800b3c2 08004f16").unwrap(),
            },
            Message::Firmware {
                version: 0x0104_0002,
                digest: [0xA1, 2, 3, 4, 5, 6, 7, 0xF8],
                kind: String::try_from("motor").unwrap(),
                on_trial: true,
            },
            Message::Update { target: 0x12, data: heapless::Vec::from_slice(&[0x52; 55]).unwrap() },
            Message::Advertise {
                topic: String::try_from("motor1/speed").unwrap(),
                type_hash: 0xDEAD_BEEF,
                size: 12,
                index: 1,
                class: BusClass::Hrt { period_cycles: 1 },
            },
            Message::SubscribeRequest {
                target: 0x12,
                topic: String::try_from("proximity").unwrap(),
                type_hash: 7,
                queue_len: 4,
            },
            Message::SubscribeResponse {
                target: 0x20,
                topic: String::try_from("proximity").unwrap(),
                result: SubscribeResult::Ok,
                message_id: 0x1203,
            },
            Message::HrtRequest { message_id: 0x1201, period_cycles: 2, frames: 1, size: 6 },
            Message::HrtGrant {
                message_id: 0x1201,
                period_cycles: 2,
                offset: 1,
                slot: 3,
                result: HrtResult::Ok,
                start_us: 500,
                len_us: 167,
            },
            Message::ParamGet { target: 3, index: 9 },
            Message::ParamSet { target: 3, index: 9, value: Value::F32(0.25) },
            Message::ParamValue { index: 9, value: Value::I32(-5) },
            Message::ParamError { index: 9, fault: ParamFault::OutOfRange },
        ]
    }

    r2p_testkit::suite! {
        fn every_message_roundtrips() {
            let mut buf = [0u8; ENCODED_MAX];
            for m in samples() {
                let n = m.encode(&mut buf).unwrap();
                assert_eq!(buf[0], m.type_byte());
                assert_eq!(Message::decode(&buf[..n]), Ok(m));
            }
        }

        fn a_nodes_decoder_reads_every_request_and_leaves_the_replies() {
            let mut buf = [0u8; ENCODED_MAX];
            let kinds = [ty::PARAM_VALUE, ty::PARAM_ERROR, ty::FIRMWARE, ty::PANIC_REPORT];
            let mut seen = [false; 4];
            for m in samples() {
                let n = m.encode(&mut buf).unwrap();
                let ty = m.type_byte();
                if let Some(k) = kinds.iter().position(|&t| t == ty) {
                    seen[k] = true;
                    assert!(is_reply(ty));
                    assert_eq!(Message::decode_requests(&buf[..n]), Err(DecodeError::Reply(ty)));
                } else {
                    assert!(!is_reply(ty));
                    assert_eq!(Message::decode_requests(&buf[..n]), Ok(m));
                }
            }
            assert_eq!(seen, [true; 4], "the samples hold every kind of reply");
        }

        fn the_longest_update_fills_a_management_message_exactly() {
            let data = heapless::Vec::from_slice(&[7u8; UPDATE_MAX]).unwrap();
            let mut buf = [0u8; ENCODED_MAX];
            assert_eq!(Message::Update { target: 1, data }.encode(&mut buf), Ok(ENCODED_MAX));
        }

        fn heartbeat_layout_matches_spec() {
            let mut buf = [0u8; ENCODED_MAX];
            let n = samples()[0].encode(&mut buf).unwrap();
            // type, uid[12], len 5, "motor", state, uptime le32, tx, rx, dropped le16
            assert_eq!(n, 1 + 12 + 1 + 5 + 1 + 4 + 1 + 1 + 2);
            assert_eq!(&buf[13..19], b"\x05motor");
            assert_eq!(&buf[20..24], &3600u32.to_le_bytes());
        }

        fn every_truncation_is_rejected() {
            let mut buf = [0u8; ENCODED_MAX];
            for m in samples() {
                let n = m.encode(&mut buf).unwrap();
                for cut in 0..n {
                    let e = Message::decode(&buf[..cut]).unwrap_err();
                    assert!(matches!(e, DecodeError::Truncated | DecodeError::Empty), "{:?}", e);
                }
                let mut longer = buf;
                longer[n] = 0;
                assert_eq!(Message::decode(&longer[..n + 1]), Err(DecodeError::TrailingBytes));
            }
        }

        fn bad_bytes_get_specific_errors() {
            assert_eq!(Message::decode(&[]), Err(DecodeError::Empty));
            assert_eq!(Message::decode(&[0x99]), Err(DecodeError::UnknownType(0x99)));
            // A topic with a space.
            assert_eq!(
                Message::decode(&[ty::PARAM_ERROR, 1, 0, 9]),
                Err(DecodeError::BadValue(9))
            );
            assert_eq!(
                Message::decode(&[ty::SUBSCRIBE_REQUEST, 1, 2, b'a', b' ', 0, 0, 0, 0, 1]),
                Err(DecodeError::BadString)
            );
            assert_eq!(
                Message::decode(&[ty::PARAM_VALUE, 0, 0, 7, 0, 0, 0, 0]),
                Err(DecodeError::BadValue(7))
            );
        }

        fn update_and_firmware_layouts_match_spec() {
            let mut buf = [0u8; ENCODED_MAX];
            let block = [0x52, 7, 0, 0x30, 0, 0, 0, 0xAA];
            let m = Message::Update { target: 0x12, data: heapless::Vec::from_slice(&block).unwrap() };
            let n = m.encode(&mut buf).unwrap();
            assert_eq!(&buf[..n], &[0x51, 0x12, 8, 0x52, 7, 0, 0x30, 0, 0, 0, 0xAA]);
            // A block of 48 bytes with its 7-byte header fills the message to 58 of 64 bytes.
            let full = Message::Update { target: 1, data: heapless::Vec::from_slice(&[0; 55]).unwrap() };
            assert_eq!(full.encode(&mut buf), Ok(58));
            // A length past what a message holds is refused, not cut.
            let mut long = [0u8; 3 + UPDATE_MAX + 1];
            long[..3].copy_from_slice(&[ty::UPDATE, 1, UPDATE_MAX as u8 + 1]);
            assert_eq!(Message::decode(&long), Err(DecodeError::BadValue(UPDATE_MAX as u8 + 1)));
            let f = Message::Firmware {
                version: 0x0104_0002,
                digest: [1, 2, 3, 4, 5, 6, 7, 8],
                kind: String::try_from("psu").unwrap(),
                on_trial: false,
            };
            let n = f.encode(&mut buf).unwrap();
            assert_eq!(&buf[..n], &[0x15, 2, 0, 4, 1, 1, 2, 3, 4, 5, 6, 7, 8, 3, b'p', b's', b'u', 0]);
            let mut bad = buf;
            bad[n - 1] = 2;
            assert_eq!(Message::decode(&bad[..n]), Err(DecodeError::BadValue(2)));
        }

        fn hrt_layout_matches_spec() {
            let mut buf = [0u8; ENCODED_MAX];
            let request =
                Message::HrtRequest { message_id: 0x1201, period_cycles: 2, frames: 1, size: 6 };
            let n = request.encode(&mut buf).unwrap();
            assert_eq!(&buf[..n], &[0x24, 0x01, 0x12, 0x02, 0x00, 0x01, 0x06]);
            let grant = Message::HrtGrant {
                message_id: 0x1201,
                period_cycles: 4,
                offset: 3,
                slot: 7,
                result: HrtResult::Ok,
                start_us: 0x0489,
                len_us: 0x009b,
            };
            let n = grant.encode(&mut buf).unwrap();
            assert_eq!(&buf[..n], &[0x25, 0x01, 0x12, 0x04, 0x00, 3, 7, 0, 0x89, 0x04, 0x9b, 0]);
            assert_eq!(
                Message::decode(&[0x25, 0x01, 0x12, 0x04, 0x00, 0, 0, 6, 0, 0, 0, 0]),
                Err(DecodeError::BadValue(6))
            );
            // The reservation's position is part of the grant: one without it is cut short.
            assert!(Message::decode(&[0x25, 0x01, 0x12, 0x04, 0x00, 3, 7, 0]).is_err());
            let full = [0x25, 0x01, 0x12, 0x04, 0x00, 0, 0, 1, 0, 0, 0, 0];
            assert!(matches!(
                Message::decode(&full),
                Ok(Message::HrtGrant { result: HrtResult::Full, .. })
            ));
        }

        fn panic_report_layout_matches_spec() {
            let mut buf = [0u8; ENCODED_MAX];
            let report = Message::PanicReport { text: String::try_from("a.rs:7:1: x").unwrap() };
            let n = report.encode(&mut buf).unwrap();
            assert_eq!(&buf[..n], b"\x14\x0ba.rs:7:1: x");
            // The longest text fills a management message exactly.
            let long = [b'x'; PANIC_TEXT_MAX];
            let text = String::try_from(core::str::from_utf8(&long).unwrap()).unwrap();
            assert_eq!(Message::PanicReport { text }.encode(&mut buf), Ok(ENCODED_MAX));
            // A newline (or any control byte) is not printable: refused.
            assert_eq!(Message::decode(b"\x14\x03a\nb"), Err(DecodeError::BadString));
            let mut over = [b'x'; ENCODED_MAX + 1];
            over[..2].copy_from_slice(&[ty::PANIC_REPORT, PANIC_TEXT_MAX as u8 + 1]);
            assert_eq!(Message::decode(&over), Err(DecodeError::BadString));
        }

        fn small_buffers_are_refused_not_overrun() {
            let mut buf = [0u8; 8];
            assert_eq!(samples()[0].encode(&mut buf), Err(BufferTooSmall));
        }

        fn every_message_needs_exactly_its_length() {
            // A buffer one byte short of any message is refused, down to its last field.
            for m in samples() {
                let mut full = [0u8; ENCODED_MAX];
                let n = m.encode(&mut full).unwrap();
                let mut exact = [0u8; ENCODED_MAX];
                assert_eq!(m.encode(&mut exact[..n]), Ok(n), "{m:?}");
                assert_eq!(exact[..n], full[..n]);
                for short in 0..n {
                    assert_eq!(m.encode(&mut exact[..short]), Err(BufferTooSmall), "{m:?} in {short}");
                }
            }
        }
    }
}

#[cfg(test)]
mod proptests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..80)) {
            if let Ok(m) = Message::decode(&bytes) {
                // Whatever decodes re-encodes to the same bytes (one encoding per message).
                let mut buf = [0u8; ENCODED_MAX];
                let n = m.encode(&mut buf).unwrap();
                prop_assert_eq!(&buf[..n], &bytes[..]);
            }
        }

        #[test]
        fn params_roundtrip(index in any::<u16>(), bits in any::<u32>(), tag in 0u8..4) {
            let value = match tag {
                0 => Value::Bool(bits & 1 == 1),
                1 => Value::U32(bits),
                2 => Value::I32(bits as i32),
                _ => Value::F32(f32::from_bits(bits)),
            };
            let m = Message::ParamValue { index, value };
            let mut buf = [0u8; ENCODED_MAX];
            let n = m.encode(&mut buf).unwrap();
            let back = Message::decode(&buf[..n]).unwrap();
            // Compare by encoding: NaN payloads survive bit for bit.
            let mut buf2 = [0u8; ENCODED_MAX];
            let n2 = back.encode(&mut buf2).unwrap();
            prop_assert_eq!(&buf[..n], &buf2[..n2]);
        }
    }
}
