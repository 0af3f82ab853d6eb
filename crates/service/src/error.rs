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
    #[error("engine: {}", shorten_message(&.0.to_string()))]
    Engine(#[from] gearcomp_thermal::ThermalError),
    /// The engine configuration file (`engine.file`) could not be read or is not valid;
    /// the message says why (shown once: no source chain repeating it).
    #[error("invalid engine.file = {path}: {message}")]
    EngineFile {
        /// The file.
        path: String,
        /// The thermal crate's message (names the engine key and line).
        message: String,
    },
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
    #[error("replay {path}: line {line}, column {column}: {value}; expected {expected}")]
    Replay {
        /// The log file.
        path: String,
        /// 1-based line (the header is line 1).
        line: u64,
        /// The column name (or `(row)` for the row as a whole).
        column: String,
        /// The offending text, quoted (shortened as [`shorten_message`] does).
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

/// Builds [`ServiceError::Invalid`]; a long value (or a long name inside the key or the
/// expected form) is shortened as [`shorten_message`] does.
pub fn invalid(
    field: impl Into<String>,
    value: impl std::fmt::Display,
    expected: impl Into<String>,
) -> ServiceError {
    ServiceError::Invalid {
        field: shorten_message(&field.into()),
        value: shorten_value(&value.to_string()),
        expected: shorten_message(&expected.into()),
    }
}

pub use gearcomp_core::shorten::{shorten_message, shown, SHOWN_CHARS};

/// The value of an [`ServiceError::Invalid`]: quoted (`"name"`, a list of quoted names)
/// as [`shorten_message`] shortens it, written bare (a number, a name) as [`shown`].
fn shorten_value(value: &str) -> String {
    if value.contains(['"', '`']) {
        shorten_message(value)
    } else {
        shown(value)
    }
}

/// The index of the engine axis `name` among `axes`, or the error naming the config key
/// `field`, the value written and the axes there are.
pub fn engine_axis(field: impl Into<String>, name: &str, axes: &[String]) -> Result<usize> {
    axes.iter()
        .position(|a| a == name)
        .ok_or_else(|| invalid(field, name, format!("an engine axis: {}", axes.join(", "))))
}

/// Checks `lo ≤ v ≤ hi` (and finiteness), naming the field on failure.
pub fn check_range(field: &str, v: f64, lo: f64, hi: f64, expected: &str) -> Result<()> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(invalid(field, number(v), expected))
    }
}

pub use gearcomp_core::shorten::number;

#[cfg(test)]
mod tests {
    use super::{engine_axis, shorten_message, shown, ServiceError};

    #[test]
    fn long_values_keep_their_start_and_say_their_length() {
        let head = "q".repeat(80);
        assert_eq!(shown(&"q".repeat(80)), head);
        assert_eq!(shown(&"q".repeat(81)), format!("{head}… (81 characters)"));
        // Characters, not bytes: 81 'µ' are 162 bytes.
        assert_eq!(
            shown(&"µ".repeat(81)),
            format!("{}… (81 characters)", "µ".repeat(80))
        );
        // Quoted values inside a message, serde's `…` and a debug-printed "…" whose escapes
        // count as one character each and are not cut; short ones and the rest unchanged.
        let long = "q".repeat(5000);
        let m = format!("unknown variant `{long}`, expected `sqlite` or `postgres`");
        assert_eq!(
            shorten_message(&m),
            format!("unknown variant `{head}…` (5000 characters), expected `sqlite` or `postgres`")
        );
        let v = format!("{:?}", format!("{}\"{long}", "a\\".repeat(40)));
        assert_eq!(
            shorten_message(&format!("invalid x = {v}: expected y")),
            format!(
                "invalid x = \"{}…\" (5081 characters): expected y",
                "a\\\\".repeat(40)
            )
        );
        let v = format!("{:?}", format!("{}\"{long}", "a".repeat(60)));
        assert_eq!(
            shorten_message(&format!("invalid x = {v}: expected y")),
            format!(
                "invalid x = \"{}\\\"{}…\" (5061 characters): expected y",
                "a".repeat(60),
                "q".repeat(19)
            )
        );
        // A bare key of 5000 letters; a path of 150 characters is kept whole.
        assert_eq!(
            shorten_message(&format!("2 | {long} = 1")),
            format!("2 | {head}… (5000 characters) = 1")
        );
        let path = format!("/{}", "p".repeat(149));
        assert_eq!(
            shorten_message(&format!("cannot read {path}")),
            format!("cannot read {path}")
        );
        // A TOML parse error's source line and marker.
        let m = format!(
            "  |\n2 | backend = \"{long}\"\n  |           {}\nunknown",
            "^".repeat(5002)
        );
        assert_eq!(
            shorten_message(&m),
            format!(
                "  |\n2 | backend = \"{head}…\" (5000 characters)\n  |           {}…\nunknown",
                "^".repeat(82)
            )
        );
        // Unquoted, a line is cut at 400 characters.
        let m = shorten_message(&"w ".repeat(1000));
        assert_eq!(m, format!("{}… (2000 characters)", "w ".repeat(200)));
        let m = shorten_message(&"u".repeat(150).repeat(3).replace("uu", "u u"));
        assert!(m.ends_with("characters)") && m.chars().count() < 430, "{m}");
        assert_eq!(shorten_message("a `b` \"c\" `d"), "a `b` \"c\" `d");
    }

    #[test]
    fn engine_axis_finds_the_index_or_names_key_value_and_axes() {
        let axes = vec!["Z".to_string(), "X".to_string()];
        assert_eq!(
            engine_axis("input.positions[0].axis", "X", &axes).ok(),
            Some(1)
        );
        assert_eq!(
            engine_axis("input.positions[0].axis", "Z", &axes).ok(),
            Some(0)
        );
        match engine_axis("input.pulse_outputs[2].axis", "Y", &axes) {
            Err(ServiceError::Invalid {
                field,
                value,
                expected,
            }) => {
                assert_eq!(field, "input.pulse_outputs[2].axis");
                assert_eq!(value, "Y");
                assert_eq!(expected, "an engine axis: Z, X");
            }
            other => panic!("expected an Invalid error, got {other:?}"),
        }
        // Names are matched exactly (no case folding).
        assert!(engine_axis("k", "z", &axes).is_err());
    }
}
