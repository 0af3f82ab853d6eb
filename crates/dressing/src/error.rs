//! Errors of gearcomp-dressing.

use thiserror::Error;

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, DressError>;

/// Everything that can go wrong designing a dresser, simulating or solving a dressing.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum DressError {
    /// A parameter is outside its allowed range.
    #[error(
        "{field} = {v} is outside the allowed range {lo} ..= {hi}",
        v = gearcomp_geometry::units::fmt_value(*value),
        lo = gearcomp_geometry::units::fmt_value(*min),
        hi = gearcomp_geometry::units::fmt_value(*max)
    )]
    OutOfRange {
        /// Name of the field (with its unit suffix).
        field: &'static str,
        /// The value given.
        value: f64,
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
    },
    /// Geometry that cannot be built (e.g. jacket wider than the worm gap).
    #[error("invalid geometry: {0}")]
    Geometry(String),
    /// An inner numerical iteration (contact point, envelope) did not converge.
    #[error("{what} did not converge ({detail})")]
    NoConvergence {
        /// Which iteration.
        what: &'static str,
        /// Detail for the engineer.
        detail: String,
    },
    /// The requested modification has no root: it cannot be produced with this worm and dresser.
    #[error("not producible: no root found after {iterations} iterations (max |F| = {residual_um} um): {reason}")]
    NoRoot {
        /// Newton iterations done.
        iterations: usize,
        /// Largest residual left, in µm.
        residual_um: f64,
        /// Why the solver gave up.
        reason: String,
    },
    /// A value of the user's input (named by its TOML key, e.g. `[worm] profile_angle_deg`)
    /// is invalid; the detail states the value and the allowed range in the key's unit.
    #[error("{}", input_message(key, detail))]
    Input {
        /// The TOML key as the user wrote it, with its table.
        key: String,
        /// Value, allowed range and unit, or why the value cannot be used.
        detail: String,
    },
    /// The request is valid but this worm and dresser cannot produce it; the detail names the
    /// limit and the producible range at this geometry.
    #[error("not producible ({key}): {detail}")]
    NotProducible {
        /// The TOML key of the request (e.g. `[solve] crowning_um`).
        key: String,
        /// The limit reached and what is producible.
        detail: String,
    },
    /// A pose cannot be realised by the machine's axes.
    #[error("pose not reachable by the machine axes: {0}")]
    Unreachable(String),
    /// Under the axis correction ΔK the dresser's fillet/flank tangent point dresses no part of
    /// the active worm flank (the dressed range [w_Nf, w_Na] is empty).
    #[error(
        "the dresser does not reach the worm flank under ΔK: w_Nf = {w_nf_mm} mm ≥ w_Na = \
         {w_na_mm} mm"
    )]
    DresserMissesFlank {
        /// Roll distance where the dressing under ΔK begins (mm; NaN when not found).
        w_nf_mm: f64,
        /// Tip end of the active profile (mm).
        w_na_mm: f64,
    },
    /// A request whose keys do not go together or lie outside their range; the message names
    /// the TOML keys, the values and what is allowed.
    #[error("{0}")]
    Request(String),
    /// The TOML text cannot be read as the expected tables and keys (syntax, a missing or
    /// unknown key, a wrong type); the message names the key and its line.
    #[error("{0}")]
    Toml(String),
    /// `source` happened while doing `what` (a TOML key or a step of the computation).
    #[error("{what}")]
    During {
        /// The key or step, e.g. `[dressing] diameter_mm` or `dressed profile`.
        what: String,
        /// What went wrong.
        #[source]
        source: Box<DressError>,
    },
}

/// "`[worm] starts` = 0 is outside …" for range details (they start with "= "), else
/// "`key`: detail".
fn input_message(key: &str, detail: &str) -> String {
    if detail.starts_with("= ") {
        format!("{key} {detail}")
    } else {
        format!("{key}: {detail}")
    }
}

impl DressError {
    /// Wraps `self` as the cause of a failure while doing `what`.
    pub fn during(self, what: impl Into<String>) -> DressError {
        DressError::During {
            what: what.into(),
            source: Box::new(self),
        }
    }

    /// Checks `min ≤ value ≤ max` (and finiteness) for a named field.
    pub fn check(field: &'static str, value: f64, min: f64, max: f64) -> Result<f64> {
        if value.is_finite() && value >= min && value <= max {
            Ok(value)
        } else {
            Err(DressError::OutOfRange {
                field,
                value,
                min,
                max,
            })
        }
    }
}
