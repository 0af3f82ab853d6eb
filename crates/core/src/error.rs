//! Errors of the shared core types.

use thiserror::Error;

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, CoreError>;

/// What can go wrong reading, validating or writing the shared formats.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum CoreError {
    /// A field holds a value outside its allowed range.
    #[error("invalid {field} = {value}: expected {expected}")]
    InvalidField {
        /// Dotted path of the field, e.g. `axes[0].machine.terms[2].transform.tau_s`.
        field: String,
        /// The offending value as text.
        value: String,
        /// The allowed range or form.
        expected: String,
    },
    /// The file declares a format this build does not read.
    #[error("unsupported model format {found:?}: this build reads {expected:?}")]
    UnsupportedFormat {
        /// The `format` string found in the file.
        found: String,
        /// The format string this build reads.
        expected: String,
    },
    /// The TOML text could not be parsed into the model structure.
    #[error("model file is not valid TOML for the model format: {0}")]
    Toml(#[from] toml::de::Error),
    /// The model could not be serialised to TOML.
    #[error("cannot serialise model to TOML: {0}")]
    TomlSer(#[from] toml::ser::Error),
    /// The JSON text could not be parsed into the model structure.
    #[error("model file is not valid JSON for the model format: {0}")]
    Json(#[from] serde_json::Error),
    /// Reading or writing a file failed.
    #[error("{action} {path}: {source}")]
    Io {
        /// What was being done ("read", "write", "rename").
        action: &'static str,
        /// The file concerned.
        path: String,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
}
