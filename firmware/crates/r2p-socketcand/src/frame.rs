//! A classic CAN data frame as the link carries it: standard or extended identifier, 0–8 bytes.

use core::fmt;

/// Largest payload of a classic CAN frame.
pub const MAX_DLC: usize = 8;
/// Largest standard (11-bit) identifier.
pub const MAX_STANDARD_ID: u32 = 0x7FF;
/// Largest extended (29-bit) identifier.
pub const MAX_EXTENDED_ID: u32 = 0x1FFF_FFFF;

/// A classic CAN data frame.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct CanFrame {
    id: u32,
    extended: bool,
    len: u8,
    data: [u8; MAX_DLC],
}

/// Why an identifier and payload are not a classic CAN frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// The identifier does not fit 11 (standard) or 29 (extended) bits.
    IdOutOfRange(u32),
    /// More than 8 payload bytes.
    TooLong(usize),
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameError::IdOutOfRange(id) => write!(f, "identifier {id:X} out of range"),
            FrameError::TooLong(n) => write!(f, "{n} data bytes (at most 8)"),
        }
    }
}

impl core::error::Error for FrameError {}

impl CanFrame {
    /// A frame with identifier `id` (extended if `extended`) and `payload`.
    pub fn new(id: u32, extended: bool, payload: &[u8]) -> Result<Self, FrameError> {
        let max = if extended { MAX_EXTENDED_ID } else { MAX_STANDARD_ID };
        if id > max {
            return Err(FrameError::IdOutOfRange(id));
        }
        if payload.len() > MAX_DLC {
            return Err(FrameError::TooLong(payload.len()));
        }
        let mut data = [0; MAX_DLC];
        data[..payload.len()].copy_from_slice(payload);
        Ok(Self { id, extended, len: payload.len() as u8, data })
    }

    /// A standard-identifier (11-bit) frame.
    pub fn standard(id: u32, payload: &[u8]) -> Result<Self, FrameError> {
        Self::new(id, false, payload)
    }

    /// An extended-identifier (29-bit) frame, as RTCAN sends.
    pub fn extended(id: u32, payload: &[u8]) -> Result<Self, FrameError> {
        Self::new(id, true, payload)
    }

    /// The identifier (11 or 29 bits).
    pub const fn id(&self) -> u32 {
        self.id
    }

    /// True for a 29-bit identifier.
    pub const fn is_extended(&self) -> bool {
        self.extended
    }

    /// The payload (0–8 bytes).
    pub fn data(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }

    /// Payload length (the DLC).
    pub const fn len(&self) -> usize {
        self.len as usize
    }

    /// True if the frame carries no payload.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The identifier as CAN tools print it: 3 hex digits (standard) or 8 (extended).
    pub const fn id_hex(&self) -> IdHex {
        IdHex { id: self.id, extended: self.extended }
    }
}

/// A frame's identifier as CAN tools print it ([`CanFrame::id_hex`]; `Display`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IdHex {
    id: u32,
    extended: bool,
}

impl fmt::Display for IdHex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.extended {
            write!(f, "{:08X}", self.id)
        } else {
            write!(f, "{:03X}", self.id)
        }
    }
}

impl fmt::Debug for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}#", self.id_hex())?;
        for b in self.data() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::format;

    use super::*;

    #[test]
    fn ids_are_range_checked() {
        assert!(CanFrame::standard(0x7FF, &[]).is_ok());
        assert_eq!(CanFrame::standard(0x800, &[]), Err(FrameError::IdOutOfRange(0x800)));
        assert!(CanFrame::extended(0x1FFF_FFFF, &[]).is_ok());
        assert_eq!(
            CanFrame::extended(0x2000_0000, &[]),
            Err(FrameError::IdOutOfRange(0x2000_0000))
        );
        assert_eq!(CanFrame::extended(1, &[0; 9]), Err(FrameError::TooLong(9)));
    }

    #[test]
    fn debug_is_candump_like() {
        let f = CanFrame::extended(0x1234_5678, &[0xDE, 0xAD]).unwrap();
        assert_eq!(format!("{f:?}"), "12345678#DEAD");
        assert_eq!(format!("{:?}", CanFrame::standard(0x12, &[]).unwrap()), "012#");
        assert_eq!(format!("{}", f.id_hex()), "12345678");
    }
}
