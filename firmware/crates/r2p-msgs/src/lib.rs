//! R2P message types (docs/middleware.md, "Message types and code generation").
//!
//! Every topic payload is described once, in `firmware/msgs/*.msg`; `scripts/msggen rust`
//! turns those schemas into the structs of this crate (`src/generated.rs`, committed, checked
//! up to date by `scripts/msggen check`). Each struct is plain `Copy` data, so it can be a
//! middleware `Topic`'s `T`, and implements [`R2pMessage`]: its name, its size on the bus, its
//! type hash and its wire format — fields in schema order, little-endian, packed — the same
//! bytes `scripts/r2ptools/msgs.py` encodes and decodes on the host.
//!
//! ```
//! use r2p_msgs::{Obstacle, R2pMessage};
//!
//! let mut buf = [0u8; Obstacle::SIZE];
//! let n = Obstacle { channel: 3, distance: 0.5 }.encode(&mut buf).unwrap();
//! assert_eq!(&buf[..n], &[0x03, 0x00, 0x00, 0x00, 0x3F]);
//! assert_eq!(Obstacle::decode(&buf).unwrap().channel, 3);
//! ```
#![no_std]
#![warn(missing_docs)]

#[cfg(test)]
extern crate std;

/// Makes a generated type a node-runtime payload ([`r2p_node::Wire`]): a topic of any message
/// type can be exported and imported over the bus, with the message's own wire format and type
/// hash (the generated code invokes it once per type).
macro_rules! impl_wire {
    ($t:ty) => {
        impl r2p_node::Wire for $t {
            const SIZE: usize = <$t as $crate::R2pMessage>::SIZE;
            const TYPE_HASH: u32 = <$t as $crate::R2pMessage>::TYPE_HASH;
            fn encode(&self, buf: &mut [u8]) -> Result<usize, r2p_node::WireError> {
                $crate::R2pMessage::encode(self, buf)
                    .map_err(|_| r2p_node::WireError::BufferTooSmall)
            }
            fn decode(bytes: &[u8]) -> Result<Self, r2p_node::WireError> {
                <$t as $crate::R2pMessage>::decode(bytes).map_err(|e| match e {
                    $crate::DecodeError::WrongSize { .. } => r2p_node::WireError::BadLength,
                    _ => r2p_node::WireError::BadValue,
                })
            }
        }
    };
}
pub(crate) use impl_wire;

mod generated;
pub use generated::*;

/// Largest message a schema may describe: one RTCAN message (`MAX_SIZE` in msgs.py).
pub const MAX_SIZE: usize = 1014;

/// A message type generated from a `.msg` schema.
pub trait R2pMessage: Copy + Sized {
    /// The type's name: the schema's file name without `.msg`.
    const NAME: &'static str;
    /// The canonical text the type hash is taken over: `Name:type name;type[N] name;…`.
    const CANONICAL: &'static str;
    /// Bytes on the bus: the sum of the fields' sizes (packed, no padding).
    const SIZE: usize;
    /// FNV-1a of [`Self::CANONICAL`] ([`type_hash`]): publisher and subscriber must agree on it.
    const TYPE_HASH: u32;

    /// Writes the message into the first [`Self::SIZE`] bytes of `out`; returns [`Self::SIZE`].
    /// The rest of `out` is left as it was.
    fn encode(&self, out: &mut [u8]) -> Result<usize, BufferTooSmall>;

    /// Reads a message from exactly [`Self::SIZE`] bytes. A `bool` field must be 0 or 1.
    fn decode(bytes: &[u8]) -> Result<Self, DecodeError>;
}

/// The buffer given to [`R2pMessage::encode`] is shorter than the message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BufferTooSmall {
    /// Bytes the message needs ([`R2pMessage::SIZE`]).
    pub needed: usize,
    /// Bytes the buffer has.
    pub got: usize,
}

/// Why bytes are not a message of the type asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// The payload is not exactly [`R2pMessage::SIZE`] bytes long.
    WrongSize {
        /// The type's size.
        expected: usize,
        /// The payload's length.
        got: usize,
    },
    /// A `bool` field holds a byte other than 0 or 1.
    BadBool {
        /// Byte offset of the field in the payload.
        offset: usize,
        /// The byte found there.
        value: u8,
    },
}

/// FNV-1a (32-bit) of a canonical text: the type hash (as msgs.py computes it).
pub const fn type_hash(canonical: &str) -> u32 {
    let bytes = canonical.as_bytes();
    let mut hash: u32 = 0x811C_9DC5;
    let mut i = 0;
    while i < bytes.len() {
        hash = (hash ^ bytes[i] as u32).wrapping_mul(0x0100_0193);
        i += 1;
    }
    hash
}

/// The wire format's building blocks, used by the generated code.
mod wire {
    use super::{BufferTooSmall, DecodeError};

    /// A value with a fixed little-endian representation.
    pub(crate) trait Field: Sized {
        /// Bytes of the representation.
        const SIZE: usize;
        /// Writes the value into `out` (exactly `SIZE` bytes).
        fn put(&self, out: &mut [u8]);
        /// Reads a value from `bytes` (exactly `SIZE` bytes) found at `offset` in the payload.
        fn get(bytes: &[u8], offset: usize) -> Result<Self, DecodeError>;
    }

    macro_rules! number {
        ($($t:ty),*) => {$(
            impl Field for $t {
                const SIZE: usize = core::mem::size_of::<$t>();
                fn put(&self, out: &mut [u8]) {
                    out.copy_from_slice(&self.to_le_bytes());
                }
                fn get(bytes: &[u8], _offset: usize) -> Result<Self, DecodeError> {
                    let mut le = [0u8; core::mem::size_of::<$t>()];
                    le.copy_from_slice(bytes);
                    Ok(<$t>::from_le_bytes(le))
                }
            }
        )*};
    }
    number!(i8, u8, i16, u16, i32, u32, i64, u64, f32, f64);

    impl Field for bool {
        const SIZE: usize = 1;
        fn put(&self, out: &mut [u8]) {
            out[0] = u8::from(*self);
        }
        fn get(bytes: &[u8], offset: usize) -> Result<Self, DecodeError> {
            match bytes[0] {
                0 => Ok(false),
                1 => Ok(true),
                value => Err(DecodeError::BadBool { offset, value }),
            }
        }
    }

    impl<T: Field + Copy + Default, const N: usize> Field for [T; N] {
        const SIZE: usize = T::SIZE * N;
        fn put(&self, out: &mut [u8]) {
            for (v, chunk) in self.iter().zip(out.chunks_exact_mut(T::SIZE)) {
                v.put(chunk);
            }
        }
        fn get(bytes: &[u8], offset: usize) -> Result<Self, DecodeError> {
            let mut array = [T::default(); N];
            for (i, (v, chunk)) in array.iter_mut().zip(bytes.chunks_exact(T::SIZE)).enumerate() {
                *v = T::get(chunk, offset + i * T::SIZE)?;
            }
            Ok(array)
        }
    }

    /// Writes fields one after the other into a buffer of at least `size` bytes.
    pub(crate) struct Writer<'a> {
        out: &'a mut [u8],
        at: usize,
    }

    impl<'a> Writer<'a> {
        pub(crate) fn new(out: &'a mut [u8], size: usize) -> Result<Self, BufferTooSmall> {
            let got = out.len();
            match out.get_mut(..size) {
                Some(out) => Ok(Self { out, at: 0 }),
                None => Err(BufferTooSmall { needed: size, got }),
            }
        }

        pub(crate) fn put<F: Field>(&mut self, value: &F) {
            let end = self.at + F::SIZE;
            value.put(&mut self.out[self.at..end]);
            self.at = end;
        }

        /// Bytes written (the message's size once every field is in).
        pub(crate) fn finish(self) -> usize {
            debug_assert_eq!(self.at, self.out.len());
            self.at
        }
    }

    /// Reads fields one after the other from a payload of exactly `size` bytes.
    pub(crate) struct Reader<'a> {
        bytes: &'a [u8],
        at: usize,
    }

    impl<'a> Reader<'a> {
        pub(crate) fn new(bytes: &'a [u8], size: usize) -> Result<Self, DecodeError> {
            if bytes.len() == size {
                Ok(Self { bytes, at: 0 })
            } else {
                Err(DecodeError::WrongSize { expected: size, got: bytes.len() })
            }
        }

        pub(crate) fn get<F: Field>(&mut self) -> Result<F, DecodeError> {
            let end = self.at + F::SIZE;
            let value = F::get(&self.bytes[self.at..end], self.at)?;
            self.at = end;
            Ok(value)
        }
    }
}

/// The crate's test suite, compiled in for bare-metal runners (feature `selftest`).
#[cfg(any(test, feature = "selftest"))]
pub mod selftest {
    /// Every suite of the crate, in the order a runner should run them.
    pub const ALL: &[&[r2p_testkit::Case]] = &[crate::tests::SUITE];
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::wire::Reader;
    use super::*;
    use crate::generated::for_each_message;
    use core::fmt::Debug;

    /// Byte pattern `pattern` (0..8): zeros, ones, a counter, then pseudo-random bytes.
    pub(crate) fn fill(bytes: &mut [u8], pattern: u32) {
        let mut state = 0x9E37_79B9u32.wrapping_mul(pattern + 1);
        for (i, b) in bytes.iter_mut().enumerate() {
            *b = match pattern {
                0 => 0x00,
                1 => 0xFF,
                2 => i as u8,
                _ => {
                    state ^= state << 13;
                    state ^= state >> 17;
                    state ^= state << 5;
                    state as u8
                }
            };
        }
    }

    /// Decodes `bytes` as a `T`, first clearing every bool field's byte down to bit 0.
    pub(crate) fn decodable<T: R2pMessage + Debug>(bytes: &mut [u8]) -> T {
        loop {
            match T::decode(bytes) {
                Ok(value) => return value,
                Err(DecodeError::BadBool { offset, .. }) => bytes[offset] &= 1,
                Err(e) => panic!("{}: {:?}", T::NAME, e),
            }
        }
    }

    /// bytes -> value -> the same bytes, for several patterns; the rest of the buffer untouched.
    pub(crate) fn roundtrips<T: R2pMessage + Debug + Default + PartialEq>() {
        let mut input = [0u8; MAX_SIZE];
        let mut output = [0u8; MAX_SIZE + 1];
        for pattern in 0..8 {
            let input = &mut input[..T::SIZE];
            fill(input, pattern);
            let value: T = decodable(input);
            output.fill(0xA5);
            assert_eq!(value.encode(&mut output), Ok(T::SIZE), "{}", T::NAME);
            assert_eq!(&output[..T::SIZE], &input[..], "{} pattern {}", T::NAME, pattern);
            assert_eq!(output[T::SIZE], 0xA5, "{} wrote past its size", T::NAME);
            // And back again (bytes compared: NaN != NaN as a value).
            let again = T::decode(&output[..T::SIZE]).unwrap();
            let mut third = [0u8; MAX_SIZE];
            again.encode(&mut third).unwrap();
            assert_eq!(&third[..T::SIZE], &input[..], "{}", T::NAME);
        }
        // The default message is all zeros, and decodes from zeros.
        T::default().encode(&mut output).unwrap();
        assert!(output[..T::SIZE].iter().all(|&b| b == 0), "{}", T::NAME);
        assert_eq!(T::decode(&[0u8; MAX_SIZE][..T::SIZE]), Ok(T::default()), "{}", T::NAME);
    }

    pub(crate) fn wrong_sizes_are_refused<T: R2pMessage + Debug + Default>() {
        let bytes = [0u8; MAX_SIZE + 1];
        for got in [0, T::SIZE - 1, T::SIZE + 1] {
            assert_eq!(
                T::decode(&bytes[..got]).map(|_| ()),
                Err(DecodeError::WrongSize { expected: T::SIZE, got }),
                "{}",
                T::NAME
            );
        }
        let mut short = [0u8; MAX_SIZE];
        assert_eq!(
            T::default().encode(&mut short[..T::SIZE - 1]),
            Err(BufferTooSmall { needed: T::SIZE, got: T::SIZE - 1 })
        );
    }

    pub(crate) fn hash_is_fnv1a_of_canonical<T: R2pMessage + Default>() {
        assert_eq!(type_hash(T::CANONICAL), T::TYPE_HASH, "{}", T::NAME);
        assert!(T::CANONICAL.starts_with(T::NAME), "{}", T::CANONICAL);
        assert_eq!(T::CANONICAL.as_bytes()[T::NAME.len()], b':');
        assert!(T::SIZE > 0 && T::SIZE <= MAX_SIZE);
        let entry = ALL.iter().find(|e| e.0 == T::NAME).expect("every type is in ALL");
        assert_eq!((entry.1, entry.2), (T::TYPE_HASH, T::SIZE), "{}", T::NAME);
    }

    r2p_testkit::suite! {
        fn every_type_roundtrips() {
            for_each_message!(roundtrips);
        }

        fn wrong_sizes_are_refused_for_every_type() {
            for_each_message!(wrong_sizes_are_refused);
        }

        fn type_hashes_are_fnv1a_of_the_canonical_text() {
            for_each_message!(hash_is_fnv1a_of_canonical);
            // tests/test_msgs.py's worked example, and every type in the table once.
            assert_eq!(
                Battery::CANONICAL,
                "Battery:float32 voltage;float32 current;float32 charge_used;uint32 remaining_s"
            );
            for (i, a) in ALL.iter().enumerate() {
                for b in &ALL[i + 1..] {
                    assert!(a.0 != b.0 && a.1 != b.1, "{} and {}", a.0, b.0);
                }
            }
        }

        fn layout_is_packed_little_endian_in_schema_order() {
            let mut buf = [0u8; 32];
            let n = Obstacle { channel: 3, distance: 0.5 }.encode(&mut buf).unwrap();
            assert_eq!(&buf[..n], &[0x03, 0x00, 0x00, 0x00, 0x3F]);
            let prox = Proximity {
                distance: [0.5, f32::NAN, 1.25, 0.0],
                status: [0, 2, 0, 3],
                supply_fault: true,
            };
            let n = prox.encode(&mut buf).unwrap();
            assert_eq!(n, 21);
            assert_eq!(&buf[..4], &[0x00, 0x00, 0x00, 0x3F]);
            assert_eq!(&buf[16..21], &[0, 2, 0, 3, 1]);
            let back = Proximity::decode(&buf[..n]).unwrap();
            assert!(back.distance[1].is_nan() && back.distance[2] == 1.25 && back.supply_fault);
            let battery = Battery { remaining_s: 0xFFFF_FFFF, ..Battery::default() };
            battery.encode(&mut buf).unwrap();
            assert_eq!(&buf[12..16], &[0xFF; 4]);
        }

        fn bools_decode_only_from_0_or_1() {
            let mut r = Reader::new(&[0, 1, 2], 3).unwrap();
            assert_eq!(r.get::<bool>(), Ok(false));
            assert_eq!(r.get::<bool>(), Ok(true));
            assert_eq!(r.get::<bool>(), Err(DecodeError::BadBool { offset: 2, value: 2 }));
            let mut r = Reader::new(&[7, 1, 0, 0xFF], 4).unwrap();
            assert_eq!(r.get::<u8>(), Ok(7));
            assert_eq!(r.get::<[bool; 3]>(), Err(DecodeError::BadBool { offset: 3, value: 0xFF }));
        }
    }
}

#[cfg(test)]
mod proptests {
    use super::tests::decodable;
    use super::*;
    use crate::generated::for_each_message;
    use proptest::prelude::*;
    use std::vec::Vec;

    fn bytes_roundtrip<T: R2pMessage + core::fmt::Debug>(mut bytes: Vec<u8>) {
        bytes.resize(T::SIZE, 0);
        let value: T = decodable(&mut bytes);
        let mut out = [0u8; MAX_SIZE];
        assert_eq!(value.encode(&mut out), Ok(T::SIZE));
        assert_eq!(&out[..T::SIZE], &bytes[..], "{}", T::NAME);
    }

    fn other_lengths_refused<T: R2pMessage + core::fmt::Debug>(len: usize) {
        let bytes = [0u8; MAX_SIZE + 8];
        if len != T::SIZE {
            assert_eq!(
                T::decode(&bytes[..len]).map(|_| ()),
                Err(DecodeError::WrongSize { expected: T::SIZE, got: len })
            );
        }
    }

    proptest! {
        #[test]
        fn random_payloads_roundtrip(bytes in proptest::collection::vec(any::<u8>(), MAX_SIZE)) {
            for_each_message!(bytes_roundtrip, bytes.clone());
        }

        #[test]
        fn any_other_length_is_refused(len in 0usize..MAX_SIZE + 8) {
            for_each_message!(other_lengths_refused, len);
        }
    }
}

#[cfg(test)]
mod wire_tests {
    use crate::{Obstacle, R2pMessage};
    use r2p_node::{Wire, WireError};

    #[test]
    fn every_message_is_a_node_payload_with_its_own_format() {
        const N: usize = <Obstacle as R2pMessage>::SIZE;
        let o = Obstacle { channel: 2, distance: 0.25 };
        let mut a = [0u8; 8];
        let mut b = [0u8; 8];
        assert_eq!(Wire::encode(&o, &mut a), Ok(N));
        assert_eq!(R2pMessage::encode(&o, &mut b), Ok(N));
        assert_eq!(a, b);
        assert_eq!(<Obstacle as Wire>::TYPE_HASH, <Obstacle as R2pMessage>::TYPE_HASH);
        assert_eq!(<Obstacle as Wire>::decode(&a[..N]), Ok(o));
        assert_eq!(<Obstacle as Wire>::decode(&a[..3]), Err(WireError::BadLength));
        assert_eq!(Wire::encode(&o, &mut a[..2]), Err(WireError::BufferTooSmall));
    }
}
