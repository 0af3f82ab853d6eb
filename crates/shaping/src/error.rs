//! Errors of gearcomp-shaping: every variant names the offending field, its value and what
//! was expected, so a machine operator can fix the part program or machine data directly.

use thiserror::Error;

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, ShapingError>;

/// What can go wrong setting up or running the electronic helical guide.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum ShapingError {
    /// A gear-geometry or ISO 1328 quantity is out of range.
    #[error(transparent)]
    Geometry(#[from] gearcomp_geometry::GeometryError),
    /// A parameter is outside its allowed range (or not finite).
    #[error(
        "{field} = {v} {unit} is out of range: allowed {lo} ..= {hi} {unit}",
        v = short(*value),
        lo = short(*min),
        hi = short(*max)
    )]
    OutOfRange {
        /// Name of the parameter (with its G-code letter where it has one).
        field: &'static str,
        /// The value given.
        value: f64,
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
        /// Unit of value, min and max.
        unit: &'static str,
    },
    /// The set-up would need more from an axis than its limits allow; refused before start.
    #[error(
        "infeasible set-up: {axis} needs a peak {quantity} of {required:.4} {unit} but its limit \
         is {limit:.4} {unit} ({detail})"
    )]
    Infeasible {
        /// Axis name (C2, X, A).
        axis: &'static str,
        /// "speed" or "acceleration".
        quantity: &'static str,
        /// What the set-up requires.
        required: f64,
        /// The axis limit.
        limit: f64,
        /// Unit of required and limit.
        unit: &'static str,
        /// Where the requirement comes from and how to reduce it.
        detail: String,
    },
    /// The G-code text does not parse or a block is not acceptable.
    #[error("line {line}, column {column}: {message}")]
    Parse {
        /// 1-based line number in the program.
        line: usize,
        /// 1-based column (in characters) of the offending text.
        column: usize,
        /// What is wrong and what was expected.
        message: String,
    },
    /// An exact integer computation would overflow its 128-bit range.
    #[error("exact ratio arithmetic overflows for {what}: {detail}")]
    Overflow {
        /// Which quantity overflowed.
        what: &'static str,
        /// The operands.
        detail: String,
    },
    /// Too few samples to evaluate a quantity.
    #[error("cannot evaluate {what}: {got} samples, at least {need} needed")]
    InsufficientData {
        /// The quantity.
        what: &'static str,
        /// Samples available.
        got: usize,
        /// Samples required.
        need: usize,
    },
}

/// Checks that `value` is finite and within `[min, max]`.
pub(crate) fn check_range(
    field: &'static str,
    value: f64,
    min: f64,
    max: f64,
    unit: &'static str,
) -> Result<f64> {
    if value.is_finite() && value >= min && value <= max {
        Ok(value)
    } else {
        Err(ShapingError::OutOfRange {
            field,
            value,
            min,
            max,
            unit,
        })
    }
}

/// A number as a person writes it: up to 6 decimals without trailing zeros, tiny and huge
/// values in exponent form (5.4207e-5 rather than 0.00005420693404688031).
fn short(x: f64) -> String {
    if !x.is_finite() || x == 0.0 {
        return format!("{x}");
    }
    if x.abs() < 1e-3 || x.abs() >= 1e9 {
        return format!("{x:.4e}");
    }
    let s = format!("{x:.6}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}
