//! What a parameter means, for the module's README: the unit, whether it takes effect at the
//! next boot only, one sentence. An application keeps a `DOCS` table beside its `DEFAULTS`
//! (same order); [`readme::params_table`](crate::readme::params_table) renders both. Data only,
//! `no_std`: the table costs nothing in an image that never reads it.

/// One parameter's documentation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParamDoc {
    /// Unit, or "" for a plain number.
    pub unit: &'static str,
    /// Whether a change takes effect only at the next boot.
    pub at_boot: bool,
    /// One sentence.
    pub doc: &'static str,
}

/// A parameter that takes effect at once.
pub const fn doc(unit: &'static str, doc: &'static str) -> ParamDoc {
    ParamDoc { unit, at_boot: false, doc }
}

/// A parameter read at boot only (a change takes effect at the next boot).
pub const fn boot(unit: &'static str, doc: &'static str) -> ParamDoc {
    ParamDoc { unit, at_boot: true, doc }
}
