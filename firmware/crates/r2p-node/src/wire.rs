//! How a topic's message travels on the bus: a fixed number of bytes and a type hash.
//!
//! [`Wire`] has the shape of the generated message types' `R2pMessage` trait (`SIZE`,
//! `TYPE_HASH`, `encode(&self, &mut [u8]) -> Result<usize, _>`, `decode(&[u8]) -> Result<Self, _>`),
//! so [`impl_wire_via!`](crate::impl_wire_via) forwards a generated type to it in one line.
//! The primitive types and arrays of them implement it here: little-endian, packed, as
//! `firmware/msgs/*.msg` fields are.

/// Why a message could not be encoded or decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WireError {
    /// The output buffer is shorter than [`Wire::SIZE`].
    BufferTooSmall,
    /// The input is not exactly [`Wire::SIZE`] bytes.
    BadLength,
    /// The bytes are not a valid value (a `bool` other than 0 or 1, or what the type refuses).
    BadValue,
}

/// A message type that can travel on the bus: exactly [`SIZE`](Self::SIZE) bytes, identified by
/// [`TYPE_HASH`](Self::TYPE_HASH) (sent in ADVERTISE and SUBSCRIBE_REQUEST, so a subscriber
/// whose type differs is refused instead of misreading bytes).
pub trait Wire: Sized {
    /// Encoded size in bytes (fixed: RTCAN reassembles typed topics with `Expect::Exactly`).
    const SIZE: usize;
    /// FNV-1a hash of the type's canonical description.
    const TYPE_HASH: u32;
    /// Writes the message into `buf`; returns the bytes written ([`SIZE`](Self::SIZE)).
    fn encode(&self, buf: &mut [u8]) -> Result<usize, WireError>;
    /// Reads a message from exactly [`SIZE`](Self::SIZE) bytes.
    fn decode(bytes: &[u8]) -> Result<Self, WireError>;
}

/// FNV-1a (32-bit) of `bytes`, usable in constants.
pub const fn fnv1a(bytes: &[u8]) -> u32 {
    fnv1a_extend(0x811C_9DC5, bytes)
}

/// Continues an FNV-1a hash `h` over `bytes` (to combine a type's hash with more text).
pub const fn fnv1a_extend(mut h: u32, bytes: &[u8]) -> u32 {
    let mut i = 0;
    while i < bytes.len() {
        h ^= bytes[i] as u32;
        h = h.wrapping_mul(0x0100_0193);
        i += 1;
    }
    h
}

macro_rules! wire_number {
    ($($t:ty => $name:literal),* $(,)?) => {$(
        impl Wire for $t {
            const SIZE: usize = core::mem::size_of::<$t>();
            const TYPE_HASH: u32 = fnv1a($name.as_bytes());
            fn encode(&self, buf: &mut [u8]) -> Result<usize, WireError> {
                let out = buf.get_mut(..Self::SIZE).ok_or(WireError::BufferTooSmall)?;
                out.copy_from_slice(&self.to_le_bytes());
                Ok(Self::SIZE)
            }
            fn decode(bytes: &[u8]) -> Result<Self, WireError> {
                let b: [u8; core::mem::size_of::<$t>()] =
                    bytes.try_into().map_err(|_| WireError::BadLength)?;
                Ok(<$t>::from_le_bytes(b))
            }
        }
    )*};
}

// The names are the .msg field types, so a primitive topic hashes like its schema type.
wire_number! {
    u8 => "uint8", u16 => "uint16", u32 => "uint32", u64 => "uint64",
    i8 => "int8", i16 => "int16", i32 => "int32", i64 => "int64",
    f32 => "float32", f64 => "float64",
}

impl Wire for bool {
    const SIZE: usize = 1;
    const TYPE_HASH: u32 = fnv1a(b"bool");
    fn encode(&self, buf: &mut [u8]) -> Result<usize, WireError> {
        *buf.first_mut().ok_or(WireError::BufferTooSmall)? = u8::from(*self);
        Ok(1)
    }
    fn decode(bytes: &[u8]) -> Result<Self, WireError> {
        match bytes {
            [0] => Ok(false),
            [1] => Ok(true),
            [_] => Err(WireError::BadValue),
            _ => Err(WireError::BadLength),
        }
    }
}

/// The empty message (an event with no data): zero bytes.
impl Wire for () {
    const SIZE: usize = 0;
    const TYPE_HASH: u32 = fnv1a(b"empty");
    fn encode(&self, _buf: &mut [u8]) -> Result<usize, WireError> {
        Ok(0)
    }
    fn decode(bytes: &[u8]) -> Result<Self, WireError> {
        if bytes.is_empty() {
            Ok(())
        } else {
            Err(WireError::BadLength)
        }
    }
}

/// `N` elements back to back. The hash is the element's, extended with `[N]`.
impl<T: Wire + Copy, const N: usize> Wire for [T; N] {
    const SIZE: usize = T::SIZE * N;
    const TYPE_HASH: u32 = fnv1a_extend(
        fnv1a_extend(fnv1a_extend(T::TYPE_HASH, b"["), &(N as u32).to_le_bytes()),
        b"]",
    );
    fn encode(&self, buf: &mut [u8]) -> Result<usize, WireError> {
        let out = buf.get_mut(..Self::SIZE).ok_or(WireError::BufferTooSmall)?;
        if T::SIZE > 0 {
            for (x, chunk) in self.iter().zip(out.chunks_exact_mut(T::SIZE)) {
                x.encode(chunk)?;
            }
        }
        Ok(Self::SIZE)
    }
    fn decode(bytes: &[u8]) -> Result<Self, WireError> {
        if bytes.len() != Self::SIZE {
            return Err(WireError::BadLength);
        }
        let Some(head) = bytes.get(..T::SIZE) else {
            // Only when N = 0 (then SIZE = 0 and T::SIZE > 0): no element is ever made.
            return Ok(core::array::from_fn(|_| unreachable!("N = 0")));
        };
        let mut out = [T::decode(head)?; N];
        for (i, x) in out.iter_mut().enumerate().skip(1) {
            *x = T::decode(&bytes[i * T::SIZE..(i + 1) * T::SIZE])?;
        }
        Ok(out)
    }
}

/// Implements [`Wire`] for generated message types by forwarding to a trait with the same
/// shape (the message generator's `R2pMessage`): `SIZE`, `TYPE_HASH`, `encode`, `decode`.
///
/// ```
/// # mod msgs {
/// #     pub trait R2pMessage: Sized {
/// #         const SIZE: usize; const TYPE_HASH: u32;
/// #         fn encode(&self, buf: &mut [u8]) -> Result<usize, ()>;
/// #         fn decode(bytes: &[u8]) -> Result<Self, ()>;
/// #     }
/// #     #[derive(Clone, Copy, Debug, PartialEq)]
/// #     pub struct Obstacle { pub channel: u8 }
/// #     impl R2pMessage for Obstacle {
/// #         const SIZE: usize = 1; const TYPE_HASH: u32 = 7;
/// #         fn encode(&self, buf: &mut [u8]) -> Result<usize, ()> { buf[0] = self.channel; Ok(1) }
/// #         fn decode(b: &[u8]) -> Result<Self, ()> { Ok(Obstacle { channel: b[0] }) }
/// #     }
/// # }
/// use r2p_node::Wire;
/// r2p_node::impl_wire_via!(msgs::R2pMessage => msgs::Obstacle);
/// assert_eq!(<msgs::Obstacle as Wire>::TYPE_HASH, 7);
/// ```
#[macro_export]
macro_rules! impl_wire_via {
    ($tr:path => $($t:ty),+ $(,)?) => {$(
        impl $crate::Wire for $t {
            const SIZE: usize = <$t as $tr>::SIZE;
            const TYPE_HASH: u32 = <$t as $tr>::TYPE_HASH;
            fn encode(&self, buf: &mut [u8]) -> Result<usize, $crate::WireError> {
                if buf.len() < Self::SIZE {
                    return Err($crate::WireError::BufferTooSmall);
                }
                <$t as $tr>::encode(self, buf).map_err(|_| $crate::WireError::BadValue)
            }
            fn decode(bytes: &[u8]) -> Result<Self, $crate::WireError> {
                if bytes.len() != Self::SIZE {
                    return Err($crate::WireError::BadLength);
                }
                <$t as $tr>::decode(bytes).map_err(|_| $crate::WireError::BadValue)
            }
        }
    )+};
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    fn roundtrip<T: Wire + PartialEq + core::fmt::Debug>(v: T) {
        let mut buf = [0u8; 64];
        assert_eq!(v.encode(&mut buf), Ok(T::SIZE));
        assert_eq!(T::decode(&buf[..T::SIZE]), Ok(v));
    }

    r2p_testkit::suite! {
        fn primitives_and_arrays_roundtrip_little_endian() {
            roundtrip(0x1234_5678u32);
            roundtrip(-5i16);
            roundtrip(1.5f32);
            roundtrip(-2.25f64);
            roundtrip(true);
            roundtrip(false);
            roundtrip(());
            roundtrip([(); 3]); // events in a batch: zero bytes, like one
            roundtrip([1.0f32, 2.0, 3.0, 4.0]);
            roundtrip([[1u8, 2], [3, 4]]);
            roundtrip::<[u32; 0]>([]);
            let mut buf = [0u8; 4];
            0x0102_0304u32.encode(&mut buf).unwrap();
            assert_eq!(buf, [4, 3, 2, 1]);
        }

        fn wrong_lengths_and_values_are_refused() {
            assert_eq!(u32::decode(&[1, 2, 3]), Err(WireError::BadLength));
            assert_eq!(u32::decode(&[1, 2, 3, 4, 5]), Err(WireError::BadLength));
            assert_eq!(bool::decode(&[2]), Err(WireError::BadValue));
            assert_eq!(<()>::decode(&[0]), Err(WireError::BadLength), "an event carries no bytes");
            assert_eq!(<[bool; 2]>::decode(&[1, 7]), Err(WireError::BadValue));
            assert_eq!(<[u16; 2]>::decode(&[0; 3]), Err(WireError::BadLength));
            assert_eq!(7u32.encode(&mut [0u8; 3]), Err(WireError::BufferTooSmall));
        }

        fn type_hashes_tell_types_apart() {
            assert_eq!(u32::TYPE_HASH, fnv1a(b"uint32"));
            assert_ne!(u32::TYPE_HASH, i32::TYPE_HASH);
            assert_ne!(u32::TYPE_HASH, f32::TYPE_HASH);
            assert_ne!(<[u32; 2]>::TYPE_HASH, <[u32; 3]>::TYPE_HASH);
            assert_ne!(<[u16; 2]>::TYPE_HASH, u32::TYPE_HASH);
            assert_eq!(<[f32; 4]>::SIZE, 16);
            // FNV-1a reference value ("a" → 0xE40C292C).
            assert_eq!(fnv1a(b"a"), 0xE40C_292C);
        }
    }
}
