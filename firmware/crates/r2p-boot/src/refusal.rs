//! Why an image is refused: one reason per check, each with the message a person reads.

/// Why an image was refused. The node keeps running its old image whatever the reason.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// No trailer where it must be: not a signed R2P image (sign it with `r2p sign`).
    NoTrailer,
    /// A trailer of a format this firmware does not read.
    UnknownFormat,
    /// The image does not fit the slot.
    TooLarge,
    /// The file holds fewer bytes than its trailer says the image has.
    Truncated,
    /// Built for another MCU.
    WrongMcu,
    /// Built for another kind of module.
    WrongKind,
    /// Signed with a key this bootloader does not trust.
    UnknownKey,
    /// The signature does not match the image: altered or damaged after signing.
    BadSignature,
    /// The flash could not be read.
    FlashRead,
    /// The module runs an image on trial (just swapped in, not yet confirmed): marking another
    /// update now would be taken for its rollback.
    OnTrial,
    /// An erase or write of the DFU slot failed.
    FlashWrite,
}

impl Refusal {
    /// What happened and what to do, for `r2p update`, the node's status and the logs.
    pub const fn message(self) -> &'static str {
        match self {
            Self::NoTrailer => "not a signed R2P image (no trailer): sign it with `r2p sign`",
            Self::UnknownFormat => "the image's trailer is of an unknown format: sign it again with this version's `r2p sign`",
            Self::TooLarge => "the image is larger than the module's image slot: make it smaller (docs/flashing.md, flash map)",
            Self::Truncated => "the image file is shorter than its trailer says: the file is incomplete, copy or build it again",
            Self::WrongMcu => "the image was built for another MCU",
            Self::WrongKind => "the image is for another kind of module",
            Self::UnknownKey => "the image is signed with a key the module's bootloader does not trust: sign it with the module's key",
            Self::BadSignature => "the image's signature does not match its contents: it was altered or damaged after signing",
            Self::FlashRead => "the module could not read the received image back from its flash",
            Self::OnTrial => "the module runs a new image that has not confirmed itself yet: try again once it has (within 15 s of its boot)",
            Self::FlashWrite => "the module could not erase or write its update slot: try again; if it persists, its flash is worn out",
        }
    }

    /// A stable code for the wire (management replies, the heartbeat's last refusal).
    pub const fn code(self) -> u8 {
        self as u8 + 1
    }

    /// The refusal a wire code names.
    pub const fn from_code(code: u8) -> Option<Self> {
        const ALL: [Refusal; 11] = [
            Refusal::NoTrailer,
            Refusal::UnknownFormat,
            Refusal::TooLarge,
            Refusal::Truncated,
            Refusal::WrongMcu,
            Refusal::WrongKind,
            Refusal::UnknownKey,
            Refusal::BadSignature,
            Refusal::FlashRead,
            Refusal::OnTrial,
            Refusal::FlashWrite,
        ];
        match code {
            1..=11 => Some(ALL[code as usize - 1]),
            _ => None,
        }
    }
}

impl core::fmt::Display for Refusal {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.message())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_name_their_refusal_and_nothing_else() {
        for code in 0..=255u8 {
            match Refusal::from_code(code) {
                Some(r) => assert_eq!(r.code(), code),
                None => assert!(code == 0 || code > 11, "code {code} names nothing"),
            }
        }
        assert_eq!(Refusal::from_code(8), Some(Refusal::BadSignature));
    }
}
