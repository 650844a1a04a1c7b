//! One test suite, two runners.
//!
//! The core crates must pass the same tests on the host (libtest, `cargo test`) and on a
//! Cortex-M3 under QEMU, where there is no libtest. [`suite!`] declares the tests once: on the
//! host each becomes a `#[test]`; everywhere it also lists them in a `SUITE` slice of [`Case`]s
//! that a bare-metal runner (`firmware/targets/qemu`) calls one by one. A test fails by
//! panicking, as with libtest; the QEMU runner's panic handler reports the failure and exits
//! with a non-zero semihosting status.
#![no_std]
#![warn(missing_docs)]

/// One named test of a [`suite!`].
#[derive(Clone, Copy)]
pub struct Case {
    /// `module::path::test_name`, as libtest would print it.
    pub name: &'static str,
    /// Runs the test; returns normally on success and panics on failure.
    pub run: fn(),
}

/// Declares tests that run under libtest on the host and from `SUITE` on bare metal.
///
/// ```
/// mod tests {
///     r2p_testkit::suite! {
///         fn adds() { assert_eq!(1 + 1, 2); }
///     }
/// }
/// assert_eq!(tests::SUITE.len(), 1);
/// assert!(tests::SUITE[0].name.ends_with("tests::adds"));
/// (tests::SUITE[0].run)();
/// ```
#[macro_export]
macro_rules! suite {
    ($( $(#[$meta:meta])* fn $name:ident() $body:block )*) => {
        $(
            $(#[$meta])*
            #[cfg_attr(test, test)]
            #[allow(missing_docs)]
            pub fn $name() $body
        )*

        /// Every test of this suite, for runners without libtest (QEMU images).
        pub const SUITE: &[$crate::Case] = &[
            $( $crate::Case { name: concat!(module_path!(), "::", stringify!($name)), run: $name }, )*
        ];
    };
}
