//! CDR (OMG XCDR1, little-endian) as ROS 2 sends it: a 4-byte encapsulation header
//! `00 01 00 00`, then each primitive aligned to its own size counted from after the header,
//! strings as a `u32` length (with the NUL) and the bytes, sequences as a `u32` count and the
//! elements, fixed arrays as the elements alone.
//!
//! R2P's bus format packs the same fields with no padding, so any R2P message becomes its
//! `r2p_msgs` CDR by inserting the padding ([`packed_to_cdr`]) and back ([`cdr_to_packed`]),
//! from the field layout `scripts/msggen ros` generates (`types.rs`).

use crate::codec::{Malformed, Overflow};

/// The encapsulation header: CDR, little-endian, no options.
pub const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// A primitive's kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `bool`: one byte, 0 or 1.
    Bool,
    /// `int8`.
    I8,
    /// `uint8`.
    U8,
    /// `int16`.
    I16,
    /// `uint16`.
    U16,
    /// `int32`.
    I32,
    /// `uint32`.
    U32,
    /// `int64`.
    I64,
    /// `uint64`.
    U64,
    /// `float32`.
    F32,
    /// `float64`.
    F64,
}

impl Kind {
    /// Bytes (and alignment).
    pub const fn size(self) -> usize {
        match self {
            Kind::Bool | Kind::I8 | Kind::U8 => 1,
            Kind::I16 | Kind::U16 => 2,
            Kind::I32 | Kind::U32 | Kind::F32 => 4,
            Kind::I64 | Kind::U64 | Kind::F64 => 8,
        }
    }
}

/// One field of a message: a primitive, or a fixed array of `count` of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Field {
    /// The element's kind.
    pub kind: Kind,
    /// Elements (1 for a scalar).
    pub count: u16,
}

/// Writes a CDR payload; on overflow the rest is dropped and [`CdrWriter::finish`] fails.
pub struct CdrWriter<'a> {
    buf: &'a mut [u8],
    pos: usize,
    overflow: bool,
}

impl<'a> CdrWriter<'a> {
    /// A payload in `buf`, its encapsulation header written.
    pub fn new(buf: &'a mut [u8]) -> Self {
        let mut w = Self { buf, pos: 0, overflow: false };
        w.raw(&CDR_LE);
        w
    }

    fn raw(&mut self, b: &[u8]) {
        match self.buf.get_mut(self.pos..self.pos + b.len()) {
            Some(dst) if !self.overflow => {
                dst.copy_from_slice(b);
                self.pos += b.len();
            }
            _ => self.overflow = true,
        }
    }

    /// Pads with zeros to a multiple of `n` after the header.
    pub fn align(&mut self, n: usize) {
        while !(self.pos - 4).is_multiple_of(n) && !self.overflow {
            self.raw(&[0]);
        }
    }

    /// Aligned little-endian bytes of a primitive of `b.len()` bytes.
    pub fn prim(&mut self, b: &[u8]) {
        self.align(b.len());
        self.raw(b);
    }

    /// A `uint8` (or `bool` as 0/1).
    pub fn u8(&mut self, v: u8) {
        self.raw(&[v]);
    }

    /// An `int32`.
    pub fn i32(&mut self, v: i32) {
        self.prim(&v.to_le_bytes());
    }

    /// A `uint32`.
    pub fn u32(&mut self, v: u32) {
        self.prim(&v.to_le_bytes());
    }

    /// A `float32`.
    pub fn f32(&mut self, v: f32) {
        self.prim(&v.to_le_bytes());
    }

    /// A `float64`.
    pub fn f64(&mut self, v: f64) {
        self.prim(&v.to_le_bytes());
    }

    /// A `string`: its length with the NUL, the bytes, the NUL.
    pub fn string(&mut self, s: &str) {
        self.u32(s.len() as u32 + 1);
        self.raw(s.as_bytes());
        self.raw(&[0]);
    }

    /// `float64[n]` of zeros (an unknown covariance, say).
    pub fn zeros_f64(&mut self, n: usize) {
        for _ in 0..n {
            self.f64(0.0);
        }
    }

    /// Bytes written, or [`Overflow`].
    pub fn finish(self) -> Result<usize, Overflow> {
        if self.overflow {
            Err(Overflow)
        } else {
            Ok(self.pos)
        }
    }
}

/// Reads a CDR payload (little-endian only; big-endian payloads are refused).
pub struct CdrReader<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl<'a> CdrReader<'a> {
    /// A reader past the encapsulation header, which must be CDR little-endian.
    pub fn new(buf: &'a [u8]) -> Result<Self, Malformed> {
        match buf.get(..4) {
            Some([0x00, 0x01, _, _]) => Ok(Self { buf, pos: 4 }),
            _ => Err(Malformed),
        }
    }

    /// `n` bytes of a primitive of `n` bytes, after its alignment.
    pub fn prim(&mut self, n: usize) -> Result<&'a [u8], Malformed> {
        let start = 4 + (self.pos - 4).div_ceil(n) * n;
        let b = self.buf.get(start..start + n).ok_or(Malformed)?;
        self.pos = start + n;
        Ok(b)
    }

    /// A `float64`.
    pub fn f64(&mut self) -> Result<f64, Malformed> {
        let b = self.prim(8)?;
        Ok(f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]))
    }

    /// Bytes not read (trailing padding is allowed).
    pub fn remaining(&self) -> usize {
        self.buf.len() - self.pos
    }
}

/// Bytes of a message's CDR payload (with the header) for `fields`.
pub fn cdr_size(fields: &[Field]) -> usize {
    let mut pos: usize = 0;
    for f in fields {
        let n = f.kind.size();
        pos = pos.div_ceil(n) * n + n * usize::from(f.count);
    }
    4 + pos
}

/// Bytes of a message's packed R2P payload for `fields`.
pub fn packed_size(fields: &[Field]) -> usize {
    fields.iter().map(|f| f.kind.size() * usize::from(f.count)).sum()
}

/// An R2P payload (packed, little-endian) as CDR: returns the CDR's length in `out`.
pub fn packed_to_cdr(fields: &[Field], packed: &[u8], out: &mut [u8]) -> Result<usize, Overflow> {
    if packed.len() != packed_size(fields) {
        return Err(Overflow);
    }
    let mut w = CdrWriter::new(out);
    let mut at = 0;
    for f in fields {
        let n = f.kind.size();
        for _ in 0..f.count {
            w.prim(&packed[at..at + n]);
            at += n;
        }
    }
    w.finish()
}

/// A CDR payload as the packed R2P payload: returns its length in `out`. Bools must be 0 or 1
/// (the R2P decoder checks that again).
pub fn cdr_to_packed(fields: &[Field], cdr: &[u8], out: &mut [u8]) -> Result<usize, Malformed> {
    let mut r = CdrReader::new(cdr)?;
    let mut at = 0;
    for f in fields {
        let n = f.kind.size();
        for _ in 0..f.count {
            let b = r.prim(n)?;
            out.get_mut(at..at + n).ok_or(Malformed)?.copy_from_slice(b);
            at += n;
        }
    }
    Ok(at)
}

#[cfg(test)]
mod tests {
    use super::*;

    const PROXIMITY: &[Field] = &[
        Field { kind: Kind::F32, count: 4 },
        Field { kind: Kind::U8, count: 4 },
        Field { kind: Kind::Bool, count: 1 },
    ];
    const MIXED: &[Field] = &[
        Field { kind: Kind::U8, count: 1 },
        Field { kind: Kind::F32, count: 1 },
        Field { kind: Kind::U8, count: 1 },
        Field { kind: Kind::F64, count: 1 },
    ];

    #[test]
    fn packed_fields_get_cdr_alignment_and_come_back() {
        let packed = [7u8, 1, 2, 3, 4, 9, 1, 2, 3, 4, 5, 6, 7, 8];
        let mut cdr = [0xEEu8; 64];
        let n = packed_to_cdr(MIXED, &packed, &mut cdr).unwrap();
        assert_eq!(n, cdr_size(MIXED));
        assert_eq!(
            &cdr[..n],
            &[0, 1, 0, 0, 7, 0, 0, 0, 1, 2, 3, 4, 9, 0, 0, 0, 0, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8]
        );
        let mut back = [0u8; 14];
        assert_eq!(cdr_to_packed(MIXED, &cdr[..n], &mut back), Ok(14));
        assert_eq!(back, packed);
        // Proximity: the arrays are already aligned.
        assert_eq!(cdr_size(PROXIMITY), 4 + 21);
    }

    #[test]
    fn short_or_big_endian_cdr_is_refused() {
        let mut out = [0u8; 32];
        assert_eq!(cdr_to_packed(MIXED, &[0, 1, 0, 0, 7], &mut out), Err(Malformed));
        assert_eq!(cdr_to_packed(MIXED, &[0, 0, 0, 0], &mut out), Err(Malformed));
        assert_eq!(cdr_to_packed(MIXED, &[], &mut out), Err(Malformed));
        assert!(packed_to_cdr(MIXED, &[0; 13], &mut out).is_err());
        assert!(packed_to_cdr(MIXED, &[0; 14], &mut out[..20]).is_err());
    }

    #[test]
    fn strings_carry_their_nul_and_align_the_next_field() {
        let mut buf = [0u8; 32];
        let mut w = CdrWriter::new(&mut buf);
        w.string("odom");
        w.f64(1.0);
        let n = w.finish().unwrap();
        assert_eq!(&buf[4..13], &[5, 0, 0, 0, b'o', b'd', b'o', b'm', 0]);
        assert_eq!(n, 4 + 16 + 8);
    }
}
