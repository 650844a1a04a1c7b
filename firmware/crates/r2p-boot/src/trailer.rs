//! The trailer of a signed image: 128 bytes after the image's code saying what it is for, which
//! key signed it and the signature. A signed image file is the image's bytes then its trailer; in
//! flash the trailer sits in the last 128 bytes of the slot, where embassy-boot's swap carries it
//! with the image, so a running image can report its own version and hash.
//!
//! Layout (little-endian):
//!
//! | bytes   | field                                                         |
//! |---------|---------------------------------------------------------------|
//! | 0..4    | magic `R2PI`                                                  |
//! | 4       | format (1)                                                    |
//! | 5..8    | zero                                                          |
//! | 8..12   | image length in bytes                                         |
//! | 12..16  | version: major << 24 \| minor << 16 \| patch                  |
//! | 16..32  | module kind (the manifest's name), zero-padded ASCII          |
//! | 32..48  | MCU (probe-rs's chip name), zero-padded ASCII                 |
//! | 48..56  | key id: the first 8 bytes of SHA-512(public key)              |
//! | 56..64  | digest: the first 8 bytes of SHA-512(image)                   |
//! | 64..128 | ed25519 signature of SHA-512(image ‖ bytes 0..64)             |
//!
//! The signature covers the digest rather than the image itself, as embassy-boot's own
//! `verify_and_mark_updated` does, so a verifier streams the image from flash through SHA-512 in
//! a small buffer.

use crate::Refusal;

/// Bytes of a trailer.
pub const TRAILER_LEN: usize = 128;
/// Bytes of the trailer the signature covers (all but the signature).
pub const SIGNED_LEN: usize = 64;
/// The trailer's first bytes.
pub const MAGIC: [u8; 4] = *b"R2PI";
/// The trailer format this crate writes and reads.
pub const FORMAT: u8 = 1;
/// Bytes of the kind and MCU names.
pub const NAME_LEN: usize = 16;

/// A version, as semantic versioning's major.minor.patch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Version {
    /// Incompatible changes.
    pub major: u8,
    /// Compatible additions.
    pub minor: u8,
    /// Fixes.
    pub patch: u16,
}

impl Version {
    const fn to_bits(self) -> u32 {
        (self.major as u32) << 24 | (self.minor as u32) << 16 | self.patch as u32
    }

    const fn from_bits(b: u32) -> Self {
        Self { major: (b >> 24) as u8, minor: (b >> 16) as u8, patch: b as u16 }
    }
}

/// A name of at most [`NAME_LEN`] ASCII bytes, zero-padded.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Name([u8; NAME_LEN]);

impl Name {
    /// `s` as a name, or `None` if it is longer than [`NAME_LEN`] bytes, empty, or not
    /// printable ASCII.
    pub fn new(s: &str) -> Option<Self> {
        let b = s.as_bytes();
        if b.is_empty() || b.len() > NAME_LEN || !b.iter().all(|c| c.is_ascii_graphic()) {
            return None;
        }
        let mut n = [0; NAME_LEN];
        n[..b.len()].copy_from_slice(b);
        Some(Self(n))
    }

    /// The name as text.
    pub fn as_str(&self) -> &str {
        let len = self.0.iter().position(|&c| c == 0).unwrap_or(NAME_LEN);
        // SAFETY: a Name holds printable ASCII only (checked where it is made), which is UTF-8.
        unsafe { core::str::from_utf8_unchecked(&self.0[..len]) }
    }

    fn from_bytes(b: &[u8]) -> Option<Self> {
        let mut n = [0; NAME_LEN];
        n.copy_from_slice(b);
        let len = n.iter().position(|&c| c == 0).unwrap_or(NAME_LEN);
        let valid = len > 0
            && n[..len].iter().all(|c| c.is_ascii_graphic())
            && n[len..].iter().all(|&c| c == 0);
        valid.then_some(Self(n))
    }
}

impl core::fmt::Debug for Name {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{:?}", self.as_str())
    }
}

/// What a trailer says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Trailer {
    /// Bytes of the image before the trailer (in a slot, from the slot's start).
    pub image_len: u32,
    /// The image's version.
    pub version: Version,
    /// The module kind it runs on (modules.toml's name: `motor`, `psu` …).
    pub kind: Name,
    /// The MCU it was built for (probe-rs's name: `STM32F103CB`).
    pub mcu: Name,
    /// Which key signed it: the first bytes of SHA-512 of its public key.
    pub key_id: [u8; 8],
    /// The first bytes of SHA-512 of the image: what `r2p sign` prints and `r2p nodes` shows
    /// (signed with the rest, so a module reports it without hashing its flash).
    pub digest: [u8; 8],
    /// ed25519 signature of SHA-512(image ‖ the trailer's first [`SIGNED_LEN`] bytes).
    pub signature: [u8; 64],
}

impl Trailer {
    /// The trailer's bytes.
    pub fn to_bytes(&self) -> [u8; TRAILER_LEN] {
        let mut b = [0; TRAILER_LEN];
        b[0..4].copy_from_slice(&MAGIC);
        b[4] = FORMAT;
        b[8..12].copy_from_slice(&self.image_len.to_le_bytes());
        b[12..16].copy_from_slice(&self.version.to_bits().to_le_bytes());
        b[16..32].copy_from_slice(&self.kind.0);
        b[32..48].copy_from_slice(&self.mcu.0);
        b[48..56].copy_from_slice(&self.key_id);
        b[56..64].copy_from_slice(&self.digest);
        b[64..128].copy_from_slice(&self.signature);
        b
    }

    /// Reads a trailer; says which field is wrong if it is not one this crate writes.
    pub fn parse(b: &[u8; TRAILER_LEN]) -> Result<Self, Refusal> {
        if b[0..4] != MAGIC {
            return Err(Refusal::NoTrailer);
        }
        if b[4] != FORMAT || b[5..8] != [0; 3] {
            return Err(Refusal::UnknownFormat);
        }
        let word = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        let mut key_id = [0; 8];
        key_id.copy_from_slice(&b[48..56]);
        let mut digest = [0; 8];
        digest.copy_from_slice(&b[56..64]);
        let mut signature = [0; 64];
        signature.copy_from_slice(&b[64..128]);
        Ok(Self {
            image_len: word(8),
            version: Version::from_bits(word(12)),
            kind: Name::from_bytes(&b[16..32]).ok_or(Refusal::UnknownFormat)?,
            mcu: Name::from_bytes(&b[32..48]).ok_or(Refusal::UnknownFormat)?,
            key_id,
            digest,
            signature,
        })
    }
}

/// The digest a trailer carries for `image`: the first 8 bytes of its SHA-512.
pub fn image_digest(image: &[u8]) -> [u8; 8] {
    let digest = salty::Sha512::new().updated(image).finalize();
    let mut d = [0; 8];
    d.copy_from_slice(&digest[..8]);
    d
}

/// The key id of a public key: the first 8 bytes of its SHA-512, so a refusal can say "signed by
/// another key" rather than only "bad signature".
pub fn key_id(public_key: &[u8; 32]) -> [u8; 8] {
    let digest = salty::Sha512::new().updated(public_key).finalize();
    let mut id = [0; 8];
    id.copy_from_slice(&digest[..8]);
    id
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Trailer {
        Trailer {
            image_len: 56_008,
            version: Version { major: 1, minor: 2, patch: 300 },
            kind: Name::new("motor").unwrap(),
            mcu: Name::new("STM32F103CB").unwrap(),
            key_id: [1, 2, 3, 4, 5, 6, 7, 8],
            digest: [0xD1, 2, 3, 4, 5, 6, 7, 0xD8],
            signature: [9; 64],
        }
    }

    #[test]
    fn a_trailer_reads_back_as_written() {
        let t = sample();
        let b = t.to_bytes();
        assert_eq!(&b[0..5], b"R2PI\x01");
        assert_eq!(&b[8..12], &56_008u32.to_le_bytes());
        assert_eq!(&b[12..16], &[44, 1, 2, 1], "version 1.2.300");
        assert_eq!(&b[16..21], b"motor");
        assert_eq!(&b[56..64], &[0xD1, 2, 3, 4, 5, 6, 7, 0xD8]);
        assert_eq!(Trailer::parse(&b), Ok(t));
    }

    #[test]
    fn trailers_this_crate_does_not_write_are_refused() {
        let good = sample().to_bytes();
        let mut b = good;
        b[0] = b'X';
        assert_eq!(Trailer::parse(&b), Err(Refusal::NoTrailer));
        for i in [4, 5, 7] {
            let mut b = good;
            b[i] ^= 0x40;
            assert_eq!(Trailer::parse(&b), Err(Refusal::UnknownFormat), "byte {i}");
        }
        let mut b = good;
        b[16..32].fill(0); // no kind
        assert_eq!(Trailer::parse(&b), Err(Refusal::UnknownFormat));
        let mut b = good;
        b[22] = b'x'; // a byte after the name's end
        assert_eq!(Trailer::parse(&b), Err(Refusal::UnknownFormat));
        let mut b = good;
        b[33] = 0x07; // not printable
        assert_eq!(Trailer::parse(&b), Err(Refusal::UnknownFormat));
    }

    #[test]
    fn names_are_short_printable_ascii() {
        assert_eq!(Name::new("proximity").unwrap().as_str(), "proximity");
        assert_eq!(Name::new("sixteen-chars-ok").unwrap().as_str(), "sixteen-chars-ok");
        assert!(Name::new("seventeen-chars-x").is_none());
        assert!(Name::new("").is_none());
        assert!(Name::new("a b").is_none());
    }

    #[test]
    fn key_ids_are_the_start_of_the_keys_sha512() {
        // SHA-512 of 32 zero bytes begins 50 46 ad c1 db a8 38 86 (FIPS 180-4 test tooling).
        assert_eq!(key_id(&[0; 32]), [0x50, 0x46, 0xad, 0xc1, 0xdb, 0xa8, 0x38, 0x86]);
    }
}
