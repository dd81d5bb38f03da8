//! The one error type every setting's `FromStr` shares.

use std::fmt;

/// A setting's value that does not parse (`--accel`, `--shadows` and `[trace] shadows`,
/// `--order`, `--mode`, `--schedule`, `--clock`). The message names the value and says what was
/// expected; clap prints it as is, the TOML loader puts it at the value's line and column.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct ParseError {
    /// The setting the value was for: "accelerator", "shadow mode", "pixel order", "mode",
    /// "schedule" or "clock".
    pub setting: &'static str,
    /// What is wrong with the value and what was expected, as the user reads it.
    pub message: String,
}

impl ParseError {
    pub fn new(setting: &'static str, message: impl Into<String>) -> Self {
        ParseError { setting, message: message.into() }
    }

    /// A value that names none of the setting's choices: "unknown `setting` \`value\`: expected
    /// `expected`".
    pub fn unknown(setting: &'static str, value: &str, expected: impl fmt::Display) -> Self {
        Self::new(setting, format!("unknown {setting} `{value}`: expected {expected}"))
    }
}
