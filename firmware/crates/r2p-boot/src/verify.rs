//! Checking a signed image where it lies: in a slot of flash (the module, before it marks an
//! update for the swap) or in a file's bytes (the host, before it sends one).

use embedded_storage::nor_flash::ReadNorFlash;

use crate::{key_id, Refusal, Trailer, SIGNED_LEN, TRAILER_LEN};

/// What the verifier requires of an image besides a good signature.
#[derive(Clone, Copy, Debug)]
pub struct Expect<'a> {
    /// The MCU it runs on (probe-rs's name).
    pub mcu: &'a str,
    /// The module kind, or `None` to accept any (the bootloader does not know its module's kind).
    pub kind: Option<&'a str>,
    /// The trusted public key.
    pub public_key: &'a [u8; 32],
}

/// Bytes hashed per read: small enough for the bootloader's stack.
const CHUNK: usize = 256;

/// Checks the signed image in the slot of `slot_size` bytes at `offset` of `flash`: its trailer
/// (last [`TRAILER_LEN`] bytes of the slot), then the signature over the image's bytes from the
/// slot's start. Returns the trailer when every check passes.
pub fn verify_slot<F: ReadNorFlash>(
    flash: &mut F,
    offset: u32,
    slot_size: u32,
    expect: &Expect<'_>,
) -> Result<Trailer, Refusal> {
    let mut raw = [0; TRAILER_LEN];
    let at = offset + slot_size - TRAILER_LEN as u32;
    flash.read(at, &mut raw).map_err(|_| Refusal::FlashRead)?;
    let trailer = check_trailer(&raw, slot_size, expect)?;
    let mut hash = salty::Sha512::new();
    let mut buf = [0; CHUNK];
    let mut done = 0u32;
    while done < trailer.image_len {
        let n = CHUNK.min((trailer.image_len - done) as usize);
        flash.read(offset + done, &mut buf[..n]).map_err(|_| Refusal::FlashRead)?;
        hash.update(&buf[..n]);
        done += n as u32;
    }
    check_signature(hash, &raw, &trailer, expect)
}

/// Checks a signed image file (the image's bytes then its trailer) for a slot of `slot_size`.
pub fn verify_file(file: &[u8], slot_size: u32, expect: &Expect<'_>) -> Result<Trailer, Refusal> {
    if file.len() < TRAILER_LEN {
        return Err(Refusal::NoTrailer);
    }
    let (image, tail) = file.split_at(file.len() - TRAILER_LEN);
    let mut raw = [0; TRAILER_LEN];
    raw.copy_from_slice(tail);
    let trailer = check_trailer(&raw, slot_size, expect)?;
    match (trailer.image_len as usize).cmp(&image.len()) {
        core::cmp::Ordering::Greater => return Err(Refusal::Truncated),
        core::cmp::Ordering::Less => return Err(Refusal::NoTrailer),
        core::cmp::Ordering::Equal => {}
    }
    check_signature(salty::Sha512::new().updated(image), &raw, &trailer, expect)
}

fn check_trailer(
    raw: &[u8; TRAILER_LEN],
    slot_size: u32,
    expect: &Expect<'_>,
) -> Result<Trailer, Refusal> {
    let t = Trailer::parse(raw)?;
    if t.image_len > slot_size.saturating_sub(TRAILER_LEN as u32) {
        return Err(Refusal::TooLarge);
    }
    if t.mcu.as_str() != expect.mcu {
        return Err(Refusal::WrongMcu);
    }
    if expect.kind.is_some_and(|k| k != t.kind.as_str()) {
        return Err(Refusal::WrongKind);
    }
    if t.key_id != key_id(expect.public_key) {
        return Err(Refusal::UnknownKey);
    }
    Ok(t)
}

fn check_signature(
    hash: salty::Sha512,
    raw: &[u8; TRAILER_LEN],
    t: &Trailer,
    expect: &Expect<'_>,
) -> Result<Trailer, Refusal> {
    let digest = hash.updated(&raw[..SIGNED_LEN]).finalize();
    let key = salty::PublicKey::try_from(expect.public_key).map_err(|_| Refusal::UnknownKey)?;
    let signature = salty::Signature::from(&t.signature);
    key.verify(&digest, &signature).map_err(|_| Refusal::BadSignature)?;
    Ok(*t)
}
