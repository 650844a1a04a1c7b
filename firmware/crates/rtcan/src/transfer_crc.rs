//! The transfer CRC that ends every multi-frame message: CRC-16/CCITT-FALSE, as Cyphal's CAN
//! transport uses for the same purpose.
//!
//! A multi-frame message travels as its payload followed by the CRC of the payload, most
//! significant byte first. CAN checks each frame, not how frames join: the transfer CRC is what
//! tells a receiver that the frames it joined are one message (a lost frame between two messages
//! of a stream, or the tail of one message taken for a whole one, changes it). Because the CRC
//! has no final XOR and is sent MSB first, the CRC of payload and CRC together is 0: a receiver
//! runs it over every byte it takes and checks for [`RESIDUE`], without knowing where the payload
//! ends. Parameters (the catalogue's CRC-16/IBM-3740): polynomial 0x1021, initial value 0xFFFF,
//! no reflection, no final XOR; check value 0x29B1 (the CRC of the ASCII bytes "123456789").

/// Initial value of the CRC.
pub const INITIAL: u16 = 0xFFFF;

/// The CRC over a payload followed by its own CRC (MSB first).
pub const RESIDUE: u16 = 0;

/// Length of the transfer CRC on the wire, in bytes.
pub const CRC_LEN: usize = 2;

/// `crc` continued over `data` (start from [`INITIAL`]). Bitwise: 8 shifts per byte, no table,
/// so it costs no flash on the F103; a 1 024-byte message is ~80 µs at 72 MHz, spread over its
/// frames as they arrive.
pub const fn update(mut crc: u16, data: &[u8]) -> u16 {
    let mut i = 0;
    while i < data.len() {
        crc ^= (data[i] as u16) << 8;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 0x8000 != 0 { (crc << 1) ^ 0x1021 } else { crc << 1 };
            bit += 1;
        }
        i += 1;
    }
    crc
}

/// The transfer CRC of `payload`.
pub const fn of(payload: &[u8]) -> u16 {
    update(INITIAL, payload)
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    r2p_testkit::suite! {
        fn check_value_is_the_catalogues() {
            // CRC-16/IBM-3740 (alias CCITT-FALSE) in the CRC catalogue: check = 0x29B1.
            assert_eq!(of(b"123456789"), 0x29B1);
            assert_eq!(of(b""), INITIAL);
        }

        fn payload_followed_by_its_crc_leaves_the_residue() {
            let mut buf = [0u8; 40];
            for n in 0..38 {
                for (i, b) in buf[..n].iter_mut().enumerate() {
                    *b = (i as u8).wrapping_mul(37) ^ n as u8;
                }
                let crc = of(&buf[..n]);
                buf[n..n + 2].copy_from_slice(&crc.to_be_bytes());
                assert_eq!(of(&buf[..n + 2]), RESIDUE, "n = {}", n);
                // Split anywhere: the running CRC is the same.
                let k = n / 3;
                assert_eq!(update(update(INITIAL, &buf[..k]), &buf[k..n + 2]), RESIDUE);
                // One bit flipped anywhere: detected.
                buf[n / 2] ^= 0x10;
                assert_ne!(of(&buf[..n + 2]), RESIDUE, "n = {}", n);
            }
        }
    }
}
