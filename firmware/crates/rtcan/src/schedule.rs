//! HRT scheduling on the master. (being written)

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    r2p_testkit::suite! {}
}
