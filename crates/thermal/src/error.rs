//! Errors of the thermal compensation crate (configuration and model building only: the
//! per-cycle [`crate::Engine::step`] never returns an error, it reports a `Copy` status).

use thiserror::Error;

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, ThermalError>;

/// What can go wrong building an engine, a sensor conversion or a simulation.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ThermalError {
    /// A field holds a value outside its allowed range.
    #[error("invalid {field} = {value}: expected {expected}")]
    InvalidField {
        /// Dotted path of the field, e.g. `axes[0].terms[1].kz_um_per_c`.
        field: String,
        /// The offending value as text.
        value: String,
        /// The allowed range or form, with its unit.
        expected: String,
    },
    /// A law or model refers to a channel the configuration does not define.
    #[error("{field}: unknown channel {name:?}; configured channels are: {known}")]
    UnknownChannel {
        /// Dotted path of the referring field.
        field: String,
        /// The name that was not found.
        name: String,
        /// The configured channel names, comma separated.
        known: String,
    },
    /// The TOML text could not be parsed into the configuration structure.
    /// The parser's message, a long value in it (a 5000-character sensor kind) shown by
    /// its start and length ([`gearcomp_core::shorten`]); not kept as a source, whose
    /// message would print the value whole again.
    #[error("configuration is not valid: {0}")]
    Toml(String),
    /// A thermal model file could not be read or is invalid.
    #[error("thermal model: {0}")]
    Model(#[from] gearcomp_core::CoreError),
    /// Reading a file failed.
    #[error("cannot {action} {path}: {source}")]
    Io {
        /// What was attempted.
        action: &'static str,
        /// The file.
        path: String,
        /// The operating system's error.
        source: std::io::Error,
    },
}

/// Shorthand for [`ThermalError::InvalidField`].
pub(crate) fn invalid(
    field: impl Into<String>,
    value: impl ToString,
    expected: &str,
) -> ThermalError {
    ThermalError::InvalidField {
        field: field.into(),
        value: value.to_string(),
        expected: expected.to_string(),
    }
}

/// Checks `lo ≤ v ≤ hi` and finiteness, naming the field on failure.
pub(crate) fn check_range(field: &str, v: f64, lo: f64, hi: f64, expected: &str) -> Result<()> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(invalid(field, gearcomp_core::shorten::number(v), expected))
    }
}

impl From<toml::de::Error> for ThermalError {
    fn from(e: toml::de::Error) -> Self {
        ThermalError::Toml(gearcomp_core::shorten::shorten_message(&e.to_string()))
    }
}
