//! The communication cycle: sync frames, slots, slot timing. (being written)

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    r2p_testkit::suite! {}
}
