//! Errors of the compensation service.

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, ServiceError>;

/// Everything that can go wrong in the service.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ServiceError {
    /// A configuration value is outside its allowed range or form.
    #[error("invalid {field} = {value}: expected {expected}")]
    Invalid {
        /// The key (dotted path in the configuration file, or the API field).
        field: String,
        /// The offending value as written.
        value: String,
        /// The allowed range or form.
        expected: String,
    },
    /// The configuration file is not valid TOML or has an unknown key.
    #[error("configuration {path}: {message}")]
    Config {
        /// The file.
        path: String,
        /// The parser's message (names the key and line).
        message: String,
    },
    /// A file could not be read or written.
    #[error("cannot {action} {path}: {source}")]
    Io {
        /// What was attempted.
        action: &'static str,
        /// The file or address.
        path: String,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The SQLite store failed.
    #[error("storage: {0}")]
    Storage(#[from] rusqlite::Error),
    /// The engine configuration was rejected.
    #[error("engine: {0}")]
    Engine(#[from] gearcomp_thermal::ThermalError),
    /// A background thread or task ended unexpectedly.
    #[error("{0} stopped unexpectedly")]
    Stopped(&'static str),
    /// An error of one machine of a multi-machine process.
    #[error("machine of {source_file}: {cause}")]
    Machine {
        /// The machine's configuration file.
        source_file: String,
        /// The error.
        cause: Box<ServiceError>,
    },
    /// The CSV export failed.
    #[error("csv export: {0}")]
    Csv(#[from] csv::Error),
    /// A row of a CSV replay log is malformed (checked before the replay starts).
    #[error("replay {path}: line {line}, column {column}: {value:?}; expected {expected}")]
    Replay {
        /// The log file.
        path: String,
        /// 1-based line (the header is line 1).
        line: u64,
        /// The column name (or `(row)` for the row as a whole).
        column: String,
        /// The offending text.
        value: String,
        /// What the cell must hold.
        expected: String,
    },
    /// Records could not be written before the service stopped (store unreachable).
    #[error("{records} records could not be written to {store} before stopping: {cause}")]
    Unflushed {
        /// Records left in memory.
        records: u64,
        /// The store (no password).
        store: String,
        /// The last error.
        cause: String,
    },
    /// The PostgreSQL store failed (the server, the connection or a statement).
    #[cfg(feature = "postgres")]
    #[error("postgresql: {0}")]
    Postgres(#[from] postgres::Error),
    /// The first connection to the record failed (server down, refused login, or TLS:
    /// certificate not trusted, name mismatch, server without TLS).
    #[error("cannot connect to {store}: {cause}")]
    Connect {
        /// The store and its TLS mode (no password).
        store: String,
        /// The error with its causes (e.g. why the TLS handshake failed).
        cause: String,
    },
}

/// Builds [`ServiceError::Invalid`].
pub fn invalid(
    field: impl Into<String>,
    value: impl std::fmt::Display,
    expected: impl Into<String>,
) -> ServiceError {
    ServiceError::Invalid {
        field: field.into(),
        value: value.to_string(),
        expected: expected.into(),
    }
}

/// Checks `lo ≤ v ≤ hi` (and finiteness), naming the field on failure.
pub fn check_range(field: &str, v: f64, lo: f64, hi: f64, expected: &str) -> Result<()> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(invalid(field, v, expected))
    }
}
