//! The template's parameters: the table the node serves over the bus (PARAM_GET / PARAM_SET,
//! ranges checked by the store), kept in flash by the image.

use r2p_node::{Param, ParamStore, Typed};

/// Rate of `count`, Hz.
pub const RATE_HZ: u16 = 0;

/// Number of parameters.
pub const COUNT: usize = 1;

/// The parameter table with its defaults and ranges (index = position = the constants above).
pub const DEFAULTS: [Param; COUNT] = [Param::u32("rate_hz", 10, 1, 100)];

/// The parameters as the application reads them: each as its type, the default from
/// [`DEFAULTS`] if the store lacks it.
pub fn typed(store: &dyn ParamStore) -> Typed<'_> {
    Typed::new(store, &DEFAULTS)
}

/// Time between two `count` messages, µs.
pub fn period_us(store: &dyn ParamStore) -> u64 {
    1_000_000 / u64::from(typed(store).u32(RATE_HZ).max(1))
}
