//! Zenoh's wire primitives (protocol version 0x09, Zenoh 1.x): variable-length integers
//! (LEB128, "zint"), length-prefixed byte strings and extension headers, on plain slices.
//!
//! Writing never panics: a [`Writer`] that runs out of room remembers it and
//! [`Writer::finish`] says so. Reading never panics either: every read is bounds-checked and a
//! malformed input is a [`Malformed`] error.

/// Input that is not a well-formed Zenoh message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Malformed;

/// The output buffer was too small for what was written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Overflow;

/// Extension header bits: `|Z|ENC|M|  ID  |`.
pub mod ext {
    /// Another extension follows.
    pub const MORE: u8 = 0x80;
    /// The receiver must understand it.
    pub const MANDATORY: u8 = 0x10;
    /// Encoding: no body.
    pub const UNIT: u8 = 0x00;
    /// Encoding: one zint.
    pub const Z64: u8 = 0x20;
    /// Encoding: length-prefixed bytes.
    pub const ZBUF: u8 = 0x40;
    /// The encoding bits.
    pub const ENC_MASK: u8 = 0x60;
}

/// Writes into a slice; on overflow the rest is dropped and [`Writer::finish`] fails.
pub struct Writer<'a> {
    buf: &'a mut [u8],
    pos: usize,
    overflow: bool,
}

impl<'a> Writer<'a> {
    /// A writer at the start of `buf`.
    pub fn new(buf: &'a mut [u8]) -> Self {
        Self { buf, pos: 0, overflow: false }
    }

    /// Bytes written so far.
    pub fn len(&self) -> usize {
        self.pos
    }

    /// Nothing written yet.
    pub fn is_empty(&self) -> bool {
        self.pos == 0
    }

    /// One byte.
    pub fn u8(&mut self, b: u8) {
        self.bytes(&[b]);
    }

    /// Raw bytes.
    pub fn bytes(&mut self, b: &[u8]) {
        match self.buf.get_mut(self.pos..self.pos + b.len()) {
            Some(dst) if !self.overflow => {
                dst.copy_from_slice(b);
                self.pos += b.len();
            }
            _ => self.overflow = true,
        }
    }

    /// A zint (LEB128, at most 9 bytes for a u64: the ninth holds 8 bits).
    pub fn zint(&mut self, mut v: u64) {
        let mut n = 0;
        while v > 0x7F && n < 8 {
            self.u8((v as u8) | 0x80);
            v >>= 7;
            n += 1;
        }
        self.u8(v as u8);
    }

    /// A zint length, then the bytes.
    pub fn zbytes(&mut self, b: &[u8]) {
        self.zint(b.len() as u64);
        self.bytes(b);
    }

    /// Overwrites 2 bytes at `at` (a length prefix written before its message).
    pub fn patch_u16_le(&mut self, at: usize, v: u16) {
        if let Some(dst) = self.buf.get_mut(at..at + 2) {
            dst.copy_from_slice(&v.to_le_bytes());
        } else {
            self.overflow = true;
        }
    }

    /// Bytes written, or [`Overflow`] if anything did not fit.
    pub fn finish(self) -> Result<usize, Overflow> {
        if self.overflow {
            Err(Overflow)
        } else {
            Ok(self.pos)
        }
    }
}

/// Reads from a slice.
#[derive(Clone)]
pub struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    /// A reader at the start of `buf`.
    pub fn new(buf: &'a [u8]) -> Self {
        Self { buf, pos: 0 }
    }

    /// Bytes left.
    pub fn remaining(&self) -> usize {
        self.buf.len() - self.pos
    }

    /// The next byte, not consumed.
    pub fn peek(&self) -> Option<u8> {
        self.buf.get(self.pos).copied()
    }

    /// One byte.
    pub fn u8(&mut self) -> Result<u8, Malformed> {
        let b = *self.buf.get(self.pos).ok_or(Malformed)?;
        self.pos += 1;
        Ok(b)
    }

    /// `n` raw bytes.
    pub fn bytes(&mut self, n: usize) -> Result<&'a [u8], Malformed> {
        let end = self.pos.checked_add(n).ok_or(Malformed)?;
        let b = self.buf.get(self.pos..end).ok_or(Malformed)?;
        self.pos = end;
        Ok(b)
    }

    /// A zint of at most 9 bytes.
    pub fn zint(&mut self) -> Result<u64, Malformed> {
        let mut v = 0u64;
        for i in 0..8 {
            let b = self.u8()?;
            v |= u64::from(b & 0x7F) << (7 * i);
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Ok(v | (u64::from(self.u8()?) << 56))
    }

    /// A zint that must fit `max`.
    pub fn zint_max(&mut self, max: u64) -> Result<u64, Malformed> {
        let v = self.zint()?;
        if v > max {
            Err(Malformed)
        } else {
            Ok(v)
        }
    }

    /// A zint length, then that many bytes.
    pub fn zbytes(&mut self) -> Result<&'a [u8], Malformed> {
        let n = self.zint_max(u64::from(u32::MAX))? as usize;
        self.bytes(n)
    }

    /// Skips a chain of extensions (the caller saw the message's Z flag).
    pub fn skip_extensions(&mut self) -> Result<(), Malformed> {
        self.extensions(|_, _| {})
    }

    /// Reads a chain of extensions, handing each ZBUF extension's id and body to `f`; unit and
    /// Z64 ones are skipped.
    pub fn extensions(&mut self, mut f: impl FnMut(u8, &'a [u8])) -> Result<(), Malformed> {
        loop {
            let h = self.u8()?;
            match h & ext::ENC_MASK {
                ext::UNIT => {}
                ext::Z64 => {
                    self.zint()?;
                }
                ext::ZBUF => {
                    let body = self.zbytes()?;
                    f(h & 0x0F, body);
                }
                _ => return Err(Malformed),
            }
            if h & ext::MORE == 0 {
                return Ok(());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zints_are_leb128_and_read_back() {
        let cases: &[(u64, &[u8])] = &[
            (0, &[0]),
            (0x7F, &[0x7F]),
            (0x80, &[0x80, 0x01]),
            (300, &[0xAC, 0x02]),
            (65535, &[0xFF, 0xFF, 0x03]),
        ];
        for &(v, bytes) in cases {
            let mut buf = [0u8; 9];
            let mut w = Writer::new(&mut buf);
            w.zint(v);
            let n = w.finish().unwrap();
            assert_eq!(&buf[..n], bytes, "{v}");
            assert_eq!(Reader::new(bytes).zint(), Ok(v));
        }
        for v in [u64::MAX, 1 << 56, (1 << 63) + 5] {
            let mut buf = [0u8; 9];
            let mut w = Writer::new(&mut buf);
            w.zint(v);
            assert_eq!(w.finish(), Ok(9));
            assert_eq!(Reader::new(&buf).zint(), Ok(v));
        }
    }

    #[test]
    fn short_input_and_small_buffers_are_errors_not_panics() {
        assert_eq!(Reader::new(&[0x80]).zint(), Err(Malformed));
        assert_eq!(Reader::new(&[5, 1, 2]).zbytes(), Err(Malformed));
        assert_eq!(Reader::new(&[0xFF; 12]).zbytes(), Err(Malformed));
        let mut buf = [0u8; 3];
        let mut w = Writer::new(&mut buf);
        w.zbytes(b"abc");
        assert_eq!(w.finish(), Err(Overflow));
    }

    #[test]
    fn extensions_are_skipped_by_encoding() {
        // unit (more) | z64 300 (more) | zbuf id 3 "hi"
        let bytes = [0x81, 0xA2, 0xAC, 0x02, 0x43, 2, b'h', b'i', 0xEE];
        let mut r = Reader::new(&bytes);
        let mut seen = None;
        r.extensions(|id, body| seen = Some((id, body))).unwrap();
        assert_eq!(seen, Some((3, &b"hi"[..])));
        assert_eq!(r.u8(), Ok(0xEE));
        assert_eq!(Reader::new(&[0x60]).skip_extensions(), Err(Malformed));
    }
}
