//! The RTCAN identifier: how class, urgency, message and fragment share CAN's 29-bit ID.
//!
//! ```text
//!  28        23 22                          7 6         0
//! +------------+-----------------------------+-----------+
//! |  laxity 6  |       message ID 16         | fragment 7|
//! +------------+-----------------------------+-----------+
//! ```
//! CAN arbitration favours dominant (0) bits, so the laxity field decides first: 0 is HRT
//! (all dominant), 1..=62 is SRT (smaller = closer to its deadline), 63 is NRT (all
//! recessive). The fragment counter counts down to 0 on a message's last frame.
//! A sync frame is laxity 0 and a message ID below [`SYNC_MESSAGE_IDS`]: the message ID's low
//! byte carries the cycle counter, the fragment field the sender's master rank (0 to
//! [`MAX_SYNC_SENDER`]), so that standbys starting the same cycle's sync at once are told
//! apart by arbitration (the best rank wins) instead of colliding.

use crate::laxity::{FrameClass, Laxity};

/// Width of the laxity field.
pub const LAXITY_BITS: u32 = 6;
/// Width of the message ID field.
pub const MESSAGE_ID_BITS: u32 = 16;
/// Width of the fragment counter.
pub const FRAGMENT_BITS: u32 = 7;
/// Bit position of the laxity field's least significant bit.
pub const LAXITY_SHIFT: u32 = MESSAGE_ID_BITS + FRAGMENT_BITS;
/// Bit position of the message ID's least significant bit.
pub const MESSAGE_ID_SHIFT: u32 = FRAGMENT_BITS;
/// The largest fragment counter: a message has at most 128 frames.
pub const MAX_FRAGMENT: u8 = (1 << FRAGMENT_BITS) - 1;
/// Largest value of a CAN 2.0B extended identifier.
pub const EXTENDED_ID_MAX: u32 = (1 << 29) - 1;
/// Message IDs `0..SYNC_MESSAGE_IDS` are reserved for sync frames (cycle counter in the low byte).
pub const SYNC_MESSAGE_IDS: u16 = 0x100;
/// The largest master rank a sync frame's fragment field carries (`failover::MAX_RANK`).
pub const MAX_SYNC_SENDER: u8 = 15;

/// A message identifier: names one topic's stream on the bus (assigned by the management protocol).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct MessageId(pub u16);

impl MessageId {
    /// True for IDs that only sync frames may use.
    pub const fn is_reserved_for_sync(self) -> bool {
        self.0 < SYNC_MESSAGE_IDS
    }
}

/// A decoded RTCAN identifier.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FrameId {
    /// Urgency: HRT, an SRT laxity code, or NRT.
    pub laxity: Laxity,
    /// Which message stream this frame belongs to.
    pub message: MessageId,
    /// Fragments still to come after this one (0 on the last or only frame).
    pub fragment: u8,
}

/// Why a raw identifier is not an RTCAN identifier.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IdError {
    /// The value does not fit in 29 bits: it cannot be a CAN 2.0B extended identifier.
    NotExtended(u32),
    /// A fragment counter above [`MAX_FRAGMENT`] was asked for.
    FragmentTooLarge(u8),
}

impl FrameId {
    /// A frame of message `message` with `fragment` frames still to follow.
    pub const fn new(laxity: Laxity, message: MessageId, fragment: u8) -> Result<Self, IdError> {
        if fragment > MAX_FRAGMENT {
            return Err(IdError::FragmentTooLarge(fragment));
        }
        Ok(Self { laxity, message, fragment })
    }

    /// The sync frame of cycle `cycle` (only its low byte is sent) from the rank-0 master.
    pub const fn sync(cycle: u32) -> Self {
        Self::sync_from(cycle, 0)
    }

    /// The sync frame of cycle `cycle` sent by the master of rank `sender` (at most
    /// [`MAX_SYNC_SENDER`]; larger values are cut to it).
    pub const fn sync_from(cycle: u32, sender: u8) -> Self {
        let sender = if sender > MAX_SYNC_SENDER { MAX_SYNC_SENDER } else { sender };
        Self { laxity: Laxity::HRT, message: MessageId((cycle & 0xFF) as u16), fragment: sender }
    }

    /// The 29-bit CAN identifier.
    pub const fn to_raw(self) -> u32 {
        ((self.laxity.code() as u32) << LAXITY_SHIFT)
            | ((self.message.0 as u32) << MESSAGE_ID_SHIFT)
            | self.fragment as u32
    }

    /// Decodes a 29-bit CAN identifier. Every 29-bit value is a valid RTCAN identifier.
    pub const fn from_raw(raw: u32) -> Result<Self, IdError> {
        if raw > EXTENDED_ID_MAX {
            return Err(IdError::NotExtended(raw));
        }
        Ok(Self {
            laxity: Laxity::from_code((raw >> LAXITY_SHIFT) as u8),
            message: MessageId((raw >> MESSAGE_ID_SHIFT) as u16),
            fragment: (raw & MAX_FRAGMENT as u32) as u8,
        })
    }

    /// The traffic class.
    pub const fn class(self) -> FrameClass {
        self.laxity.class()
    }

    /// The cycle counter's low byte if this is a sync frame.
    pub const fn sync_cycle(self) -> Option<u8> {
        if self.laxity.code() == 0
            && self.fragment <= MAX_SYNC_SENDER
            && self.message.is_reserved_for_sync()
        {
            Some(self.message.0 as u8)
        } else {
            None
        }
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    r2p_testkit::suite! {
        fn field_layout_matches_spec() {
            // docs/rtcan.md, example frame: SRT laxity 5, message 0x1234, fragment 2.
            let id = FrameId::new(Laxity::from_code(5), MessageId(0x1234), 2).unwrap();
            assert_eq!(id.to_raw(), (5 << 23) | (0x1234 << 7) | 2);
            assert_eq!(id.to_raw(), 0x0289_1A02);
            assert_eq!(id.class(), FrameClass::Srt);
        }

        fn every_extended_id_roundtrips() {
            // Walk the 29-bit space with a stride coprime to it, plus the edges.
            let mut raw: u32 = 0;
            for _ in 0..20_000 {
                let id = FrameId::from_raw(raw).unwrap();
                assert_eq!(id.to_raw(), raw);
                raw = (raw + 26_843) & EXTENDED_ID_MAX;
            }
            assert_eq!(FrameId::from_raw(EXTENDED_ID_MAX).unwrap().to_raw(), EXTENDED_ID_MAX);
        }

        fn rejects_what_is_not_extended() {
            assert_eq!(FrameId::from_raw(1 << 29), Err(IdError::NotExtended(1 << 29)));
            assert_eq!(
                FrameId::new(Laxity::NRT, MessageId(1), 128),
                Err(IdError::FragmentTooLarge(128))
            );
        }

        fn classes_follow_laxity_field() {
            assert_eq!(FrameId::from_raw(0x0000_1000).unwrap().class(), FrameClass::Hrt);
            assert_eq!(FrameId::from_raw(1 << 23).unwrap().class(), FrameClass::Srt);
            assert_eq!(FrameId::from_raw(62 << 23).unwrap().class(), FrameClass::Srt);
            assert_eq!(FrameId::from_raw(EXTENDED_ID_MAX).unwrap().class(), FrameClass::Nrt);
        }

        fn more_urgent_wins_arbitration() {
            // CAN sends the numerically smaller identifier first.
            let msg = MessageId(0xFFFF);
            let hrt = FrameId::new(Laxity::HRT, msg, MAX_FRAGMENT).unwrap().to_raw();
            let urgent = FrameId::new(Laxity::from_code(1), MessageId(0), 0).unwrap().to_raw();
            let relaxed = FrameId::new(Laxity::from_code(40), MessageId(0), 0).unwrap().to_raw();
            let nrt = FrameId::new(Laxity::NRT, MessageId(0), 0).unwrap().to_raw();
            assert!(hrt < urgent && urgent < relaxed && relaxed < nrt);
        }

        fn sync_frames_carry_the_cycle() {
            let sync = FrameId::sync(0x1_2345);
            assert_eq!(sync.to_raw(), 0x45 << 7);
            assert_eq!(FrameId::from_raw(sync.to_raw()).unwrap().sync_cycle(), Some(0x45));
            // The sender's rank in the fragment field: a better rank wins arbitration.
            let from_3 = FrameId::sync_from(0x45, 3);
            assert_eq!(from_3.to_raw(), (0x45 << 7) | 3);
            assert_eq!(FrameId::from_raw(from_3.to_raw()).unwrap().sync_cycle(), Some(0x45));
            assert!(sync.to_raw() < from_3.to_raw());
            assert_eq!(FrameId::sync_from(0, 200).fragment, MAX_SYNC_SENDER);
            // Not sync: a data message ID, an SRT laxity, or a fragment beyond the ranks.
            assert_eq!(FrameId::from_raw(0x100 << 7).unwrap().sync_cycle(), None);
            assert_eq!(FrameId::from_raw((1 << 23) | (3 << 7)).unwrap().sync_cycle(), None);
            assert_eq!(FrameId::from_raw((3 << 7) | 16).unwrap().sync_cycle(), None);
        }
    }
}

/// The shared vectors every implementation must pass (tests/vectors/rtcan/identifier.json).
#[cfg(test)]
mod vectors {
    use super::*;
    use serde::Deserialize;
    use std::{string::String, vec::Vec};

    #[derive(Deserialize)]
    struct Case {
        raw: String,
        laxity: u8,
        class: String,
        message_id: String,
        fragment: u8,
        sync_cycle: Option<u8>,
    }

    #[derive(Deserialize)]
    struct Vectors {
        valid: Vec<Case>,
        invalid: Vec<String>,
    }

    fn hex(s: &str) -> u32 {
        u32::from_str_radix(s.trim_start_matches("0x"), 16).unwrap()
    }

    #[test]
    fn identifier_vectors() {
        let v: Vectors =
            serde_json::from_str(include_str!("../../../../tests/vectors/rtcan/identifier.json"))
                .unwrap();
        assert!(v.valid.len() >= 10);
        for c in &v.valid {
            let id = FrameId::from_raw(hex(&c.raw)).unwrap();
            assert_eq!(id.laxity.code(), c.laxity, "{}", c.raw);
            assert_eq!(id.message, MessageId(hex(&c.message_id) as u16), "{}", c.raw);
            assert_eq!(id.fragment, c.fragment, "{}", c.raw);
            let class = match id.class() {
                FrameClass::Hrt => "HRT",
                FrameClass::Srt => "SRT",
                FrameClass::Nrt => "NRT",
            };
            assert_eq!(class, c.class, "{}", c.raw);
            assert_eq!(id.sync_cycle(), c.sync_cycle, "{}", c.raw);
            let rebuilt =
                FrameId::new(Laxity::from_code(c.laxity), id.message, c.fragment).unwrap();
            assert_eq!(rebuilt.to_raw(), hex(&c.raw));
        }
        for raw in &v.invalid {
            assert_eq!(FrameId::from_raw(hex(raw)), Err(IdError::NotExtended(hex(raw))));
        }
    }
}

#[cfg(test)]
mod proptests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn fields_roundtrip(laxity in 0u8..64, message in any::<u16>(), fragment in 0u8..=MAX_FRAGMENT) {
            let id = FrameId::new(Laxity::from_code(laxity), MessageId(message), fragment).unwrap();
            let back = FrameId::from_raw(id.to_raw()).unwrap();
            prop_assert_eq!(back, id);
            prop_assert!(id.to_raw() <= EXTENDED_ID_MAX);
        }

        #[test]
        fn any_u32_decodes_or_is_rejected(raw in any::<u32>()) {
            match FrameId::from_raw(raw) {
                Ok(id) => prop_assert_eq!(id.to_raw(), raw),
                Err(e) => prop_assert_eq!(e, IdError::NotExtended(raw)),
            }
        }
    }
}
