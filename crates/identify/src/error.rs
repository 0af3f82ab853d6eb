//! Errors of the identification crate.

use thiserror::Error;

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, IdentifyError>;

/// What can go wrong reading data, selecting sensors or fitting a model.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum IdentifyError {
    /// A parameter or input value is outside its allowed range.
    #[error("invalid {field} = {value}: expected {expected}")]
    InvalidInput {
        /// Name of the field or option.
        field: String,
        /// The offending value as text.
        value: String,
        /// The allowed range or form.
        expected: String,
    },
    /// The CSV text is malformed (header, field count) or holds bad values.
    #[error("{path}: {count} bad row(s) at line(s) {lines}: {first_reason}")]
    BadRows {
        /// File or data set name.
        path: String,
        /// Number of bad rows.
        count: usize,
        /// The first line numbers (1-based, header = line 1), comma separated.
        lines: String,
        /// Why the first bad row was rejected.
        first_reason: String,
    },
    /// A requested column or pattern matched nothing.
    #[error("column {pattern:?} not found: available columns are {available}")]
    ColumnNotFound {
        /// The name or glob pattern asked for.
        pattern: String,
        /// The header's column names.
        available: String,
    },
    /// The regression matrix is rank deficient.
    #[error("regression on {columns} is rank deficient (|R_jj| = {pivot:e} ≤ {tolerance:e}): remove a constant or duplicated column")]
    RankDeficient {
        /// The regressor names.
        columns: String,
        /// The smallest diagonal element of R.
        pivot: f64,
        /// The threshold used.
        tolerance: f64,
    },
    /// No candidate model of a target could be validated (every fold's training rows too
    /// few for its regressors, or every design singular on them).
    #[error("no candidate model of {target} could be validated on its {training_rows} training row(s) ({validation}): each fold must train on more rows than the model has terms, with inputs that vary on them; give more measured rows or runs, fewer --folds, --max-sensors, --tau-s/--delay-s, or --no-test to train on every row")]
    NothingValidated {
        /// The target column.
        target: String,
        /// Training rows (with the target measured).
        training_rows: usize,
        /// The validation scheme.
        validation: String,
    },
    /// Too few rows for the requested fit or validation.
    #[error("{what}: {rows} row(s), need at least {needed}")]
    TooFewRows {
        /// What was being computed.
        what: String,
        /// Rows available.
        rows: usize,
        /// Rows needed.
        needed: usize,
    },
    /// Reading the input failed.
    #[error("read {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// The model built does not validate against the model-file format.
    #[error(transparent)]
    Model(#[from] gearcomp_core::CoreError),
    /// The workpiece shrink formula rejected its inputs.
    #[error(transparent)]
    Shrink(#[from] gearcomp_geometry::shrink::ShrinkError),
}

/// Builds an [`IdentifyError::InvalidInput`].
pub(crate) fn invalid(field: &str, value: impl ToString, expected: &str) -> IdentifyError {
    IdentifyError::InvalidInput {
        field: field.to_string(),
        value: value.to_string(),
        expected: expected.to_string(),
    }
}
