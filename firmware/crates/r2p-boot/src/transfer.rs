//! Moving a signed image into a module's DFU slot over a lossy link: the messages, and the
//! receiver (the module's side). Sans-IO: the caller carries the messages (NRT management
//! traffic on the bus) and owns the flash; [`crate::sender`] is the other side.
//!
//! Go-back-N with cumulative acknowledgements: the receiver takes blocks only in order and
//! answers each message with a [`Status`] saying how many bytes it holds; the sender keeps a
//! window of blocks in flight and, when a status or a timeout says so, goes back to the
//! receiver's count. A lost, duplicated or late message costs a resend, never a wrong byte; a
//! bus partition only pauses the transfer (both sides keep their place), and a receiver that
//! lost its place (it rebooted) says so, and the sender starts again.
//!
//! In the slot, the image's bytes go from its start and the trailer to its last 128 bytes, where
//! the verifier and the swap expect it (see [`crate::trailer`]).

use embedded_storage::nor_flash::NorFlash;

use crate::{Refusal, TRAILER_LEN};

/// Most image bytes in one [`Msg::Block`]: a block and its header fit a 64-byte management
/// message.
pub const BLOCK_MAX: usize = 48;

/// Bytes the receiver holds before programming them: a block and a write unit's misalignment.
const PENDING: usize = BLOCK_MAX + 8;

/// A transfer's messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Msg<'a> {
    /// Sender: a new transfer of `len` bytes (the signed image: image then trailer).
    Begin {
        /// Names the transfer: a status of another transfer is ignored.
        id: u16,
        /// Bytes of the signed image.
        len: u32,
    },
    /// Sender: `data` at byte `offset` of the signed image.
    Block {
        /// The transfer.
        id: u16,
        /// Where `data` starts in the signed image.
        offset: u32,
        /// At most [`BLOCK_MAX`] bytes.
        data: &'a [u8],
    },
    /// Sender: every byte was sent; check the image.
    End {
        /// The transfer.
        id: u16,
    },
    /// Receiver: where the transfer stands.
    Status(Status),
}

/// The receiver's answer to every message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Status {
    /// The transfer it speaks of (0 when it has none).
    pub id: u16,
    /// Where it stands.
    pub state: State,
    /// Bytes received in order: the next block the receiver takes starts here.
    pub received: u32,
}

/// Where a transfer stands on the receiver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    /// No transfer (never begun, or forgotten by a reboot): begin again.
    Idle,
    /// Taking blocks.
    Receiving,
    /// Every byte in, the image verified: it may be marked for the swap.
    Verified,
    /// Refused, and why; the DFU slot holds nothing that will run.
    Refused(Refusal),
}

/// Why bytes are not a transfer message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// Unknown message type.
    UnknownType,
    /// Fewer or more bytes than the message has.
    BadLength,
    /// A state or refusal code with no meaning.
    BadValue,
}

const BEGIN: u8 = 0x51;
const BLOCK: u8 = 0x52;
const END: u8 = 0x53;
const STATUS: u8 = 0x54;

impl<'a> Msg<'a> {
    /// Writes the message into `buf` (64 bytes always suffice); returns its length.
    pub fn encode(&self, buf: &mut [u8; 64]) -> usize {
        match *self {
            Msg::Begin { id, len } => {
                buf[0] = BEGIN;
                buf[1..3].copy_from_slice(&id.to_le_bytes());
                buf[3..7].copy_from_slice(&len.to_le_bytes());
                7
            }
            Msg::Block { id, offset, data } => {
                let n = data.len().min(BLOCK_MAX);
                buf[0] = BLOCK;
                buf[1..3].copy_from_slice(&id.to_le_bytes());
                buf[3..7].copy_from_slice(&offset.to_le_bytes());
                buf[7..7 + n].copy_from_slice(&data[..n]);
                7 + n
            }
            Msg::End { id } => {
                buf[0] = END;
                buf[1..3].copy_from_slice(&id.to_le_bytes());
                3
            }
            Msg::Status(s) => {
                let (state, code) = match s.state {
                    State::Idle => (0, 0),
                    State::Receiving => (1, 0),
                    State::Verified => (2, 0),
                    State::Refused(r) => (3, r.code()),
                };
                buf[0] = STATUS;
                buf[1..3].copy_from_slice(&s.id.to_le_bytes());
                buf[3] = state;
                buf[4] = code;
                buf[5..9].copy_from_slice(&s.received.to_le_bytes());
                9
            }
        }
    }

    /// Reads a message; never panics.
    pub fn decode(b: &'a [u8]) -> Result<Self, DecodeError> {
        let u16_at = |i: usize| u16::from_le_bytes([b[i], b[i + 1]]);
        let u32_at = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        match b.first() {
            Some(&BEGIN) if b.len() == 7 => Ok(Msg::Begin { id: u16_at(1), len: u32_at(3) }),
            Some(&BLOCK) if (8..=7 + BLOCK_MAX).contains(&b.len()) => {
                Ok(Msg::Block { id: u16_at(1), offset: u32_at(3), data: &b[7..] })
            }
            Some(&END) if b.len() == 3 => Ok(Msg::End { id: u16_at(1) }),
            Some(&STATUS) if b.len() == 9 => {
                let state = match (b[3], b[4]) {
                    (0, 0) => State::Idle,
                    (1, 0) => State::Receiving,
                    (2, 0) => State::Verified,
                    (3, c) => State::Refused(Refusal::from_code(c).ok_or(DecodeError::BadValue)?),
                    _ => return Err(DecodeError::BadValue),
                };
                Ok(Msg::Status(Status { id: u16_at(1), state, received: u32_at(5) }))
            }
            Some(&(BEGIN | BLOCK | END | STATUS)) => Err(DecodeError::BadLength),
            _ => Err(DecodeError::UnknownType),
        }
    }
}

/// The module's side: writes blocks into its DFU slot as they come, in order, and checks the
/// image at the end.
pub struct Receiver {
    slot_size: u32,
    id: u16,
    len: u32,
    received: u32,
    state: State,
    /// The last page erased (an index), so each page is erased once, before its first write.
    erased: Option<u32>,
    /// Bytes not yet programmed, from a write unit's start (the F1 programs half-words, the F4
    /// words): their slot offset, the bytes, how many.
    pending_at: u32,
    pending: [u8; PENDING],
    pending_len: usize,
}

impl Receiver {
    /// A receiver for a DFU slot whose image slot (the active partition) is `slot_size` bytes.
    pub const fn new(slot_size: u32) -> Self {
        Self {
            slot_size,
            id: 0,
            len: 0,
            received: 0,
            state: State::Idle,
            erased: None,
            pending_at: 0,
            pending: [0xFF; PENDING],
            pending_len: 0,
        }
    }

    /// The status to send now.
    pub fn status(&self) -> Status {
        Status { id: self.id, state: self.state, received: self.received }
    }

    /// Refuses transfer `id` for a reason of the module's own (it cannot take an update now):
    /// the status to answer its `Begin` with. Nothing is written.
    pub fn refuse(&mut self, id: u16, why: Refusal) -> Status {
        *self = Self::new(self.slot_size);
        self.id = id;
        self.state = State::Refused(why);
        self.status()
    }

    /// Handles a sender's message, writing to `dfu` (the DFU partition); `verify` checks the
    /// complete slot (on a module, the bootloader's check). Returns the status to answer with.
    pub fn handle<F: NorFlash>(
        &mut self,
        msg: &Msg<'_>,
        dfu: &mut F,
        verify: impl FnOnce(&mut F) -> Result<(), Refusal>,
    ) -> Status {
        match *msg {
            Msg::Begin { id, len } => {
                *self = Self::new(self.slot_size);
                self.id = id;
                self.len = len;
                self.state = if len < TRAILER_LEN as u32 {
                    State::Refused(Refusal::NoTrailer)
                } else if len > self.slot_size {
                    State::Refused(Refusal::TooLarge)
                } else {
                    State::Receiving
                };
            }
            Msg::Block { id, offset, data } if id == self.id && self.state == State::Receiving => {
                let fits = offset.checked_add(data.len() as u32).is_some_and(|end| end <= self.len);
                if offset == self.received && fits && !data.is_empty() {
                    if self.write(dfu, data).is_err() {
                        self.state = State::Refused(Refusal::FlashWrite);
                    } else {
                        self.received += data.len() as u32;
                    }
                }
            }
            Msg::End { id }
                if id == self.id
                    && self.state == State::Receiving
                    && self.received == self.len
                    && self.flush(dfu).is_ok() =>
            {
                self.state = match verify(dfu) {
                    Ok(()) => State::Verified,
                    Err(r) => State::Refused(r),
                };
            }
            // Another transfer's message, a late one, or one after the end: the status says
            // where this receiver stands.
            _ => {}
        }
        self.status()
    }

    /// Where byte `at` of the signed image goes in the slot.
    fn slot_offset(&self, at: u32) -> u32 {
        let image_len = self.len - TRAILER_LEN as u32;
        if at < image_len {
            at
        } else {
            self.slot_size - TRAILER_LEN as u32 + (at - image_len)
        }
    }

    /// Takes a block's bytes into the pending buffer and programs the whole write units it
    /// holds: one flash write per block (the F1 programs it a half-word at a time either way),
    /// the unaligned rest kept for the next block.
    fn write<F: NorFlash>(&mut self, dfu: &mut F, data: &[u8]) -> Result<(), F::Error> {
        const { assert!(F::WRITE_SIZE <= 8, "write units up to 8 bytes (the STM32s': 2 and 4)") };
        for (i, &b) in data.iter().enumerate() {
            let at = self.slot_offset(self.received + i as u32);
            if self.pending_len > 0 && at != self.pending_at + self.pending_len as u32 {
                self.flush(dfu)?; // the image's last bytes, before the trailer's first
            }
            if self.pending_len == 0 {
                // Start at a write unit: the bytes before `at` in it stay erased.
                let lead = at % F::WRITE_SIZE as u32;
                self.pending_at = at - lead;
                self.pending[..lead as usize].fill(0xFF);
                self.pending_len = lead as usize;
            }
            self.pending[self.pending_len] = b;
            self.pending_len += 1;
            if self.pending_len == PENDING {
                self.program(dfu, PENDING)?;
            }
        }
        let whole = self.pending_len - self.pending_len % F::WRITE_SIZE;
        self.program(dfu, whole)
    }

    /// Programs everything pending, a partial last unit padded with erased bytes.
    fn flush<F: NorFlash>(&mut self, dfu: &mut F) -> Result<(), F::Error> {
        let padded = self.pending_len.next_multiple_of(F::WRITE_SIZE);
        self.pending[self.pending_len..padded].fill(0xFF);
        self.pending_len = padded;
        self.program(dfu, padded)
    }

    /// Programs the first `n` pending bytes (whole write units), erasing each page they reach
    /// before its first write, and keeps the rest pending.
    fn program<F: NorFlash>(&mut self, dfu: &mut F, n: usize) -> Result<(), F::Error> {
        if n == 0 {
            return Ok(());
        }
        let (first, last) = (self.pending_at, self.pending_at + n as u32 - 1);
        for page in first / F::ERASE_SIZE as u32..=last / F::ERASE_SIZE as u32 {
            if self.erased.is_none_or(|e| e < page) {
                let from = page * F::ERASE_SIZE as u32;
                dfu.erase(from, from + F::ERASE_SIZE as u32)?;
                self.erased = Some(page);
            }
        }
        dfu.write(self.pending_at, &self.pending[..n])?;
        self.pending.copy_within(n..self.pending_len, 0);
        self.pending_len -= n;
        self.pending_at += n as u32;
        Ok(())
    }
}
