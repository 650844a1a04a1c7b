//! The bits of a CAN 2.0B extended data frame: CRC-15, bit stuffing and exact frame length.

use rtcan::Frame;

/// The CAN CRC-15 generator polynomial x¹⁵+x¹⁴+x¹⁰+x⁸+x⁷+x⁴+x³+1 (ISO 11898-1), without x¹⁵.
pub const CRC15_POLY: u16 = 0x4599;
/// Unstuffed tail after the CRC sequence: CRC delimiter, ACK slot, ACK delimiter, 7 EOF bits.
pub const TAIL_BITS: u32 = 1 + 2 + 7;
/// Intermission between frames.
pub const INTERMISSION_BITS: u32 = 3;
/// Error flag (active: 6 dominant bits; passive: 6 recessive).
pub const ERROR_FLAG_BITS: u32 = 6;
/// Error delimiter (8 recessive bits).
pub const ERROR_DELIMITER_BITS: u32 = 8;
/// Consecutive recessive bits a bus-off node must see 128 times to recover.
pub const RECOVERY_RUN_BITS: u32 = 11;
/// Recessive runs of [`RECOVERY_RUN_BITS`] needed to leave bus-off.
pub const RECOVERY_RUNS: u32 = 128;

/// CRC-15 of a bit sequence (shift register initialised to 0, as ISO 11898-1 specifies).
pub fn crc15(bits: impl IntoIterator<Item = bool>) -> u16 {
    let mut crc: u16 = 0;
    for bit in bits {
        let feedback = bit ^ (crc & 0x4000 != 0);
        crc = (crc << 1) & 0x7fff;
        if feedback {
            crc ^= CRC15_POLY;
        }
    }
    crc
}

/// Unstuffed bits of the longest frame from SOF to the end of the CRC sequence (8 data bytes).
pub const MAX_UNSTUFFED_BITS: usize = 1 + 11 + 1 + 1 + 18 + 3 + 4 + 64 + 15;

/// A frame's unstuffed bits, on the stack: the bus counts them for every frame it carries and
/// twice for every lost arbitration, so a heap vector each time was a twentieth of a simulation.
#[derive(Clone, Copy)]
pub struct Bits {
    buf: [bool; MAX_UNSTUFFED_BITS],
    len: usize,
}

impl Bits {
    fn push(&mut self, bit: bool) {
        self.buf[self.len] = bit;
        self.len += 1;
    }

    fn push_value(&mut self, value: u32, width: u32) {
        for i in (0..width).rev() {
            self.push(value >> i & 1 == 1);
        }
    }
}

impl core::ops::Deref for Bits {
    type Target = [bool];
    fn deref(&self) -> &[bool] {
        &self.buf[..self.len]
    }
}

/// The unstuffed bits of an extended data frame from SOF to the end of the CRC sequence:
/// SOF, base ID (11), SRR, IDE, extended ID (18), RTR, r1, r0, DLC (4), data, CRC (15).
///
/// # Panics
/// If `data` is longer than a classic CAN frame's 8 bytes.
pub fn unstuffed_bits(raw_id: u32, data: &[u8]) -> Bits {
    assert!(
        data.len() <= 8,
        "a classic CAN frame carries at most 8 data bytes, not {}",
        data.len()
    );
    let mut bits = Bits { buf: [false; MAX_UNSTUFFED_BITS], len: 0 };
    bits.push(false); // SOF
    bits.push_value(raw_id >> 18 & 0x7ff, 11);
    bits.push(true); // SRR (recessive)
    bits.push(true); // IDE (recessive: extended)
    bits.push_value(raw_id & 0x3ffff, 18);
    bits.push(false); // RTR (dominant: data frame)
    bits.push(false); // r1
    bits.push(false); // r0
    bits.push_value(data.len() as u32, 4);
    for &byte in data {
        bits.push_value(u32::from(byte), 8);
    }
    let crc = crc15(bits.iter().copied());
    bits.push_value(u32::from(crc), 15);
    bits
}

/// Stuff bits a transmitter inserts into `bits`: one after every 5 equal bits (the stuff bit
/// itself starts the next run), including one after the CRC sequence if it ends in such a run.
pub fn stuff_count(bits: &[bool]) -> u32 {
    let mut count = 0;
    let mut last = None;
    let mut run = 0;
    for &bit in bits {
        if last == Some(bit) {
            run += 1;
        } else {
            last = Some(bit);
            run = 1;
        }
        if run == 5 {
            count += 1;
            last = Some(!bit);
            run = 1;
        }
    }
    count
}

/// Unstuffed bits of the arbitration field of an extended frame: SOF, base ID, SRR, IDE,
/// extended ID, RTR.
pub const ARBITRATION_BITS: usize = 1 + 11 + 1 + 1 + 18 + 1;

/// Bit times from SOF to the end of the bit at which a frame with identifier `loser` loses
/// arbitration to one with `winner` (stuff bits included: the two send the same bits up to
/// there, so they stuff alike). The loser sends a recessive bit and reads back the winner's
/// dominant one. Equal identifiers do not lose in the arbitration field: the count is then the
/// whole field (both send on; the data decide, which the bus does not model).
pub fn arbitration_loss_bits(winner: u32, loser: u32) -> u32 {
    let w = unstuffed_bits(winner, &[]);
    let l = unstuffed_bits(loser, &[]);
    let k = (0..ARBITRATION_BITS).find(|&i| w[i] != l[i]).unwrap_or(ARBITRATION_BITS - 1);
    (k as u32) + stuff_count(&w[..k]) + 1
}

/// Bit counts of one frame on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FrameBits {
    /// Unstuffed bits from SOF to the end of the CRC sequence.
    pub stuffable: u32,
    /// Stuff bits inserted in them.
    pub stuff: u32,
}

impl FrameBits {
    /// Counts the bits of `frame`.
    pub fn of(frame: &Frame) -> Self {
        Self::of_raw(frame.id().to_raw(), frame.payload())
    }

    /// Counts the bits of an extended data frame with identifier `raw_id` and `data`.
    pub fn of_raw(raw_id: u32, data: &[u8]) -> Self {
        let bits = unstuffed_bits(raw_id, data);
        Self { stuffable: bits.len() as u32, stuff: stuff_count(&bits) }
    }

    /// Bits from SOF to the end of the CRC sequence, stuffing included.
    pub const fn stuffed(&self) -> u32 {
        self.stuffable + self.stuff
    }

    /// Bits from SOF to the end of EOF: when receivers take the frame and the sender is done.
    pub const fn to_eof_end(&self) -> u32 {
        self.stuffed() + TAIL_BITS
    }

    /// Bit times the frame occupies the bus, intermission included (comparable with
    /// [`rtcan::cycle::WORST_CASE_FRAME_BITS`]).
    pub const fn total(&self) -> u32 {
        self.to_eof_end() + INTERMISSION_BITS
    }

    /// Bits from SOF to the end of the error delimiter when an error is signalled after the
    /// ACK slot (a CRC error or a missing ACK): the frame up to the ACK slot, then the error
    /// flag and delimiter.
    pub const fn to_error_end(&self) -> u32 {
        self.stuffed() + 2 + ERROR_FLAG_BITS + ERROR_DELIMITER_BITS
    }

    /// [`Self::to_error_end`] plus intermission.
    pub const fn error_total(&self) -> u32 {
        self.to_error_end() + INTERMISSION_BITS
    }
}
