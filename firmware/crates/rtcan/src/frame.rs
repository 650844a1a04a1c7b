//! A CAN 2.0B data frame as RTCAN sends and receives it: an RTCAN identifier and 0–8 bytes.

use crate::id::{FrameId, IdError};

/// Largest payload of a classic CAN frame.
pub const MAX_PAYLOAD: usize = 8;

/// An extended-ID data frame carrying RTCAN traffic.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Frame {
    id: FrameId,
    len: u8,
    data: [u8; MAX_PAYLOAD],
}

/// Why bytes from the bus are not an RTCAN frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// More than 8 payload bytes.
    TooLong(usize),
    /// The identifier is not a 29-bit extended identifier.
    Id(IdError),
}

impl From<IdError> for FrameError {
    fn from(e: IdError) -> Self {
        FrameError::Id(e)
    }
}

impl Frame {
    /// An empty frame with identifier 0 (fills unused storage).
    pub(crate) const EMPTY: Frame = Frame { id: FrameId::sync(0), len: 0, data: [0; MAX_PAYLOAD] };

    /// A frame with identifier `id` and `payload` (at most 8 bytes).
    pub fn new(id: FrameId, payload: &[u8]) -> Result<Self, FrameError> {
        if payload.len() > MAX_PAYLOAD {
            return Err(FrameError::TooLong(payload.len()));
        }
        let mut data = [0; MAX_PAYLOAD];
        data[..payload.len()].copy_from_slice(payload);
        Ok(Self { id, len: payload.len() as u8, data })
    }

    /// Decodes a received frame from its raw 29-bit identifier and payload.
    pub fn from_raw(raw_id: u32, payload: &[u8]) -> Result<Self, FrameError> {
        Self::new(FrameId::from_raw(raw_id)?, payload)
    }

    /// The RTCAN identifier.
    pub const fn id(&self) -> FrameId {
        self.id
    }

    /// The same frame under identifier `id` (its payload copied as a whole, not re-checked).
    pub const fn with_id(self, id: FrameId) -> Frame {
        Frame { id, ..self }
    }

    /// The payload (0–8 bytes).
    pub fn payload(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }

    /// Payload length (the CAN DLC for classic CAN).
    pub const fn len(&self) -> usize {
        self.len as usize
    }

    /// True if the frame carries no payload.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;
    use crate::{Laxity, MessageId};

    r2p_testkit::suite! {
        fn payload_roundtrips() {
            let id = FrameId::new(Laxity::NRT, MessageId(0x100), 0).unwrap();
            let f = Frame::new(id, &[1, 2, 3]).unwrap();
            assert_eq!(f.payload(), &[1, 2, 3]);
            assert_eq!(f.len(), 3);
            assert_eq!(Frame::from_raw(id.to_raw(), &[1, 2, 3]).unwrap(), f);
        }

        fn rejects_long_payloads_and_standard_ids() {
            let id = FrameId::sync(0);
            assert_eq!(Frame::new(id, &[0; 9]), Err(FrameError::TooLong(9)));
            assert!(matches!(Frame::from_raw(1 << 29, &[]), Err(FrameError::Id(_))));
        }
    }
}
