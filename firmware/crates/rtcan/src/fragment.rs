//! Fragmentation and reassembly. (being written)

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    r2p_testkit::suite! {}
}
