//! Signing and checking images as `r2p sign` and a module's update service do, with salty
//! checked against RustCrypto's ed25519-dalek.

use ed25519_dalek::{Signature, Verifier, VerifyingKey};
use r2p_boot::sign::{public_key, sign, Meta, SignError};
use r2p_boot::{verify_file, Expect, Refusal, Trailer, Version, SIGNED_LEN, TRAILER_LEN};

const SEED: [u8; 32] = [7; 32];
const OTHER_SEED: [u8; 32] = [8; 32];
const SLOT: u32 = 54 * 1024;

fn meta() -> Meta<'static> {
    Meta { version: Version { major: 0, minor: 3, patch: 1 }, kind: "motor", mcu: "STM32F103CB" }
}

/// An image-like byte string: a vector table's first words then varied bytes.
fn image(len: usize) -> Vec<u8> {
    (0..len).map(|i| (i as u32).wrapping_mul(2_654_435_761).to_le_bytes()[2]).collect()
}

fn expect(key: &[u8; 32]) -> Expect<'_> {
    Expect { mcu: "STM32F103CB", kind: Some("motor"), public_key: key }
}

#[test]
fn a_signed_image_verifies_and_says_what_it_is() {
    let key = public_key(&SEED);
    let signed = sign(&image(3000), &meta(), &SEED).unwrap();
    assert_eq!(signed.len(), 3000 + TRAILER_LEN);
    let t = verify_file(&signed, SLOT, &expect(&key)).unwrap();
    assert_eq!((t.image_len, t.kind.as_str(), t.mcu.as_str()), (3000, "motor", "STM32F103CB"));
    assert_eq!(t.version, Version { major: 0, minor: 3, patch: 1 });
}

#[test]
fn the_signature_is_standard_ed25519_of_the_digest() {
    // Any ed25519 implementation checks it: the signed message is SHA-512(image ‖ trailer[..64]).
    use sha2::{Digest, Sha512};
    let signed = sign(&image(1000), &meta(), &SEED).unwrap();
    let (img, tail) = signed.split_at(1000);
    let t = Trailer::parse(tail.try_into().unwrap()).unwrap();
    let digest = Sha512::new().chain_update(img).chain_update(&tail[..SIGNED_LEN]).finalize();
    let key = VerifyingKey::from_bytes(&public_key(&SEED)).unwrap();
    key.verify(&digest, &Signature::from_bytes(&t.signature))
        .expect("dalek accepts salty's signature");
    // The digest it carries (what `r2p nodes` shows) is the image's SHA-512, cut to 8 bytes.
    assert_eq!(t.digest[..], Sha512::digest(img)[..8]);
    // and the public key is the one RFC 8032 derives from the seed
    let dalek_key = ed25519_dalek::SigningKey::from_bytes(&SEED).verifying_key();
    assert_eq!(dalek_key.to_bytes(), public_key(&SEED));
}

#[test]
fn signing_is_deterministic() {
    assert_eq!(sign(&image(500), &meta(), &SEED), sign(&image(500), &meta(), &SEED));
}

#[test]
fn a_flipped_bit_anywhere_is_refused() {
    let key = public_key(&SEED);
    let signed = sign(&image(700), &meta(), &SEED).unwrap();
    let mut refused = 0;
    for i in 0..signed.len() {
        let mut bad = signed.clone();
        bad[i] ^= 1 << (i % 8);
        let r = verify_file(&bad, SLOT, &expect(&key));
        assert!(r.is_err(), "byte {i} flipped and still accepted");
        refused += 1;
    }
    println!("{refused} single-bit flips, every one refused");
    // Where the flip lands decides the reason: in the code, the signature catches it.
    let mut bad = signed.clone();
    bad[123] ^= 0x10;
    assert_eq!(verify_file(&bad, SLOT, &expect(&key)), Err(Refusal::BadSignature));
}

#[test]
fn each_refusal_names_its_reason() {
    let key = public_key(&SEED);
    let signed = sign(&image(2000), &meta(), &SEED).unwrap();
    let other = sign(&image(2000), &meta(), &OTHER_SEED).unwrap();
    assert_eq!(verify_file(&other, SLOT, &expect(&key)), Err(Refusal::UnknownKey));
    assert_eq!(verify_file(&image(2000), SLOT, &expect(&key)), Err(Refusal::NoTrailer));
    assert_eq!(verify_file(&signed, 2000, &expect(&key)), Err(Refusal::TooLarge));
    let wrong_mcu = Expect { mcu: "STM32F407VG", ..expect(&key) };
    assert_eq!(verify_file(&signed, SLOT, &wrong_mcu), Err(Refusal::WrongMcu));
    let wrong_kind = Expect { kind: Some("psu"), ..expect(&key) };
    assert_eq!(verify_file(&signed, SLOT, &wrong_kind), Err(Refusal::WrongKind));
    let any_kind = Expect { kind: None, ..expect(&key) };
    assert!(verify_file(&signed, SLOT, &any_kind).is_ok(), "the bootloader accepts any kind");
    // a file cut short keeps its trailer at the end only if cut inside the image: either way refused
    let mut cut = signed[..1500].to_vec();
    cut.extend_from_slice(&signed[signed.len() - TRAILER_LEN..]);
    assert_eq!(verify_file(&cut, SLOT, &expect(&key)), Err(Refusal::Truncated));
    assert_eq!(verify_file(&signed[..1900], SLOT, &expect(&key)), Err(Refusal::NoTrailer));
}

#[test]
fn signing_refuses_what_cannot_be_signed() {
    let signed = sign(&image(300), &meta(), &SEED).unwrap();
    assert_eq!(sign(&signed, &meta(), &SEED), Err(SignError::AlreadySigned));
    let long_kind = Meta { kind: "a-kind-far-too-long", ..meta() };
    assert_eq!(sign(&image(300), &long_kind, &SEED), Err(SignError::BadKind));
    let no_mcu = Meta { mcu: "", ..meta() };
    assert_eq!(sign(&image(300), &no_mcu, &SEED), Err(SignError::BadMcu));
}

#[test]
fn the_development_key_pair_is_a_pair() {
    use r2p_boot::sign::parse_key_file;
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../keys");
    let seed =
        parse_key_file(&std::fs::read_to_string(dir.join("development.key")).unwrap()).unwrap();
    let public =
        parse_key_file(&std::fs::read_to_string(dir.join("development.pub")).unwrap()).unwrap();
    assert_eq!(public_key(&seed), public);
    assert_eq!(ed25519_dalek::SigningKey::from_bytes(&seed).verifying_key().to_bytes(), public);
}

#[test]
fn key_files_are_hex_after_comments() {
    use r2p_boot::sign::parse_key_file;
    let k = parse_key_file(&format!("# a comment\n{}\n", "0a".repeat(32))).unwrap();
    assert_eq!(k, [0x0a; 32]);
    assert!(parse_key_file(&"0a".repeat(31)).is_err());
    assert!(parse_key_file(&format!("{}zz", "0a".repeat(31))).is_err());
}
