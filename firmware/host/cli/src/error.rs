//! The CLI's one error type: a message saying what went wrong and what to do. `r2p` prints it
//! as `r2p: error: MESSAGE` and exits with status 1 (2 is for usage errors, from clap).

use std::fmt;

/// An error for the user.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CliError(String);

impl CliError {
    /// An error saying `message`.
    pub fn new(message: impl Into<String>) -> Self {
        Self(message.into())
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for CliError {}
