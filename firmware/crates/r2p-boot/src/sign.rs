//! Signing images and making keys, on the host (`r2p sign`, `r2p keygen`, `scripts/firmware`).
//! Signatures are deterministic (ed25519), so a committed signed image regenerates byte for byte.

extern crate std;
use std::vec::Vec;

use crate::{image_digest, key_id, Name, Trailer, Version, SIGNED_LEN};

/// What the signer states about an image.
#[derive(Clone, Copy, Debug)]
pub struct Meta<'a> {
    /// Its version.
    pub version: Version,
    /// The module kind it is for.
    pub kind: &'a str,
    /// The MCU it is built for.
    pub mcu: &'a str,
}

/// Why an image could not be signed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignError {
    /// The kind is not 1–16 printable ASCII characters.
    BadKind,
    /// The MCU name is not 1–16 printable ASCII characters.
    BadMcu,
    /// The image is already signed (it ends with a trailer).
    AlreadySigned,
}

/// The public key of a secret key's 32-byte seed.
pub fn public_key(seed: &[u8; 32]) -> [u8; 32] {
    salty::Keypair::from(seed).public.to_bytes()
}

/// `image` signed with the key of `seed`: the image's bytes then its trailer.
pub fn sign(image: &[u8], meta: &Meta<'_>, seed: &[u8; 32]) -> Result<Vec<u8>, SignError> {
    if image.len() >= crate::TRAILER_LEN
        && Trailer::parse(image[image.len() - crate::TRAILER_LEN..].try_into().unwrap()).is_ok()
    {
        return Err(SignError::AlreadySigned);
    }
    let keypair = salty::Keypair::from(seed);
    let mut trailer = Trailer {
        image_len: image.len() as u32,
        version: meta.version,
        kind: Name::new(meta.kind).ok_or(SignError::BadKind)?,
        mcu: Name::new(meta.mcu).ok_or(SignError::BadMcu)?,
        key_id: key_id(&keypair.public.to_bytes()),
        digest: image_digest(image),
        signature: [0; 64],
    };
    let unsigned = trailer.to_bytes();
    let digest = salty::Sha512::new().updated(image).updated(&unsigned[..SIGNED_LEN]).finalize();
    trailer.signature = keypair.sign(&digest).to_bytes();
    let mut out = Vec::with_capacity(image.len() + crate::TRAILER_LEN);
    out.extend_from_slice(image);
    out.extend_from_slice(&trailer.to_bytes());
    Ok(out)
}

/// Reads a key file as `r2p keygen` writes it (and firmware/keys/ holds): `#` comment lines, then
/// 64 hexadecimal digits (a 32-byte seed or public key).
pub fn parse_key_file(text: &str) -> Result<[u8; 32], &'static str> {
    let hex: std::string::String = text
        .lines()
        .filter(|l| !l.trim_start().starts_with('#'))
        .flat_map(|l| l.trim().chars())
        .collect();
    if hex.len() != 64 || !hex.bytes().all(|c| c.is_ascii_hexdigit()) {
        return Err(
            "expected 64 hexadecimal digits after the comment lines, as `r2p keygen` writes",
        );
    }
    let mut key = [0; 32];
    for (i, b) in key.iter_mut().enumerate() {
        *b = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).expect("checked hex digits");
    }
    Ok(key)
}
