//! Errors of the grinding crate.

use thiserror::Error;

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, GrindError>;

/// What can go wrong computing a worm–gear mesh, a mapping, a simulation or an evaluation.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum GrindError {
    /// A gear-geometry or ISO 1328 quantity is out of range.
    #[error(transparent)]
    Geometry(#[from] gearcomp_geometry::GeometryError),
    /// A parameter is outside its allowed range (or not finite).
    #[error("{field} = {v} is out of range: expected {expected}", v = short(*value))]
    OutOfRange {
        /// Name of the field, with its unit (e.g. `m_n_mm`).
        field: &'static str,
        /// The value given.
        value: f64,
        /// The allowed range, in words.
        expected: &'static str,
    },
    /// Worm and gear do not mesh: their normal base pitches differ (JP6903407B2 eq. (93)).
    #[error(
        "worm and gear do not mesh: normal base pitch {worm_pbn_mm} mm (worm) vs {gear_pbn_mm} mm \
         (gear); expected equal within 1e-9 relative (eq. (93): m_n·cos α_n must agree)"
    )]
    MeshMismatch {
        /// Normal base pitch of the worm.
        worm_pbn_mm: f64,
        /// Normal base pitch of the gear.
        gear_pbn_mm: f64,
    },
    /// The two base helices cannot share a common normal for this crossing angle.
    #[error(
        "no common flank normal for crossing angle {crossing_rad} rad: the base helix angles \
         {beta_b1_rad} rad (worm) and {beta_b2_rad} rad (gear) are incompatible with it"
    )]
    NoCommonNormal {
        /// Axis crossing angle γ.
        crossing_rad: f64,
        /// Base helix angle of the worm flank.
        beta_b1_rad: f64,
        /// Base helix angle of the gear flank.
        beta_b2_rad: f64,
    },
    /// A direction makes the requested mapping singular (e.g. ρ_F2 = ρ_KF has no finite K_ZV1).
    #[error("{what}: {field} = {value} is singular; expected {expected}")]
    Singular {
        /// The computation that is singular.
        what: &'static str,
        /// The offending field.
        field: &'static str,
        /// Its value.
        value: f64,
        /// What a valid value looks like.
        expected: &'static str,
    },
    /// An iterative solver did not converge.
    #[error("{what} did not converge in {iterations} iterations (residual {residual_mm} mm)")]
    NoConvergence {
        /// Which solver.
        what: &'static str,
        /// Iterations spent.
        iterations: usize,
        /// Last residual.
        residual_mm: f64,
    },
    /// No state of the search puts the worm thread on the gear point's normal.
    #[error(
        "no worm contact at gear point w = {w2_mm} mm, z = {z2_mm} mm: the analytic worm point \
         w1 = {w1_mm} mm lies outside the worm thread (roll distance {w1_min_mm} … {hi} mm \
         between root and tip{below}) or the worm meets another thread turn there",
        hi = if w1_max_mm.is_finite() { w1_max_mm.to_string() } else { "∞".to_string() },
        below = if *w1_mm < 0.0 {
            "; w1 < 0 is inside the worm's base cylinder, where the thread has no involute flank"
        } else {
            ""
        }
    )]
    NoWormContact {
        /// Gear roll distance.
        w2_mm: f64,
        /// Gear width position.
        z2_mm: f64,
        /// Worm roll distance of the analytic map.
        w1_mm: f64,
        /// Lowest worm roll distance (root).
        w1_min_mm: f64,
        /// Highest worm roll distance (tip).
        w1_max_mm: f64,
    },
    /// The envelope search failed at a gear point.
    #[error("envelope search over rotation and feed failed at gear point w = {w2_mm} mm, z = {z2_mm} mm")]
    EnvelopeFailed {
        /// Gear roll distance.
        w2_mm: f64,
        /// Gear width position.
        z2_mm: f64,
    },
    /// Input data are too few or inconsistent in size.
    #[error("{field}: got {got}, expected {expected}")]
    BadData {
        /// Which input.
        field: &'static str,
        /// What was given.
        got: usize,
        /// What is needed.
        expected: &'static str,
    },
    /// A 1-D root search found no sign change of its function in the allowed range.
    #[error(
        "{what}: no solution for {field} in [{min}, {max}] (function {at_min} at the minimum, \
         {at_max} at the maximum); widen the range or change the wanted directions"
    )]
    NoRoot {
        /// The search.
        what: &'static str,
        /// The searched field.
        field: &'static str,
        /// Lower end of the allowed range.
        min: f64,
        /// Upper end of the allowed range.
        max: f64,
        /// Function value at the lower end (NaN if undefined there).
        at_min: f64,
        /// Function value at the upper end (NaN if undefined there).
        at_max: f64,
    },
}

/// A value as written: up to 12 significant digits, huge and tiny ones in exponent form
/// (`--worm-c 1e300` printed 298 digits; a degree → rad → degree round trip 59.99999999999999).
fn short(x: f64) -> String {
    gearcomp_geometry::units::fmt_value(x)
}

/// Checks that `value` is finite and inside `[min, max]`.
pub(crate) fn check_range(
    field: &'static str,
    value: f64,
    min: f64,
    max: f64,
    expected: &'static str,
) -> Result<f64> {
    if value.is_finite() && value >= min && value <= max {
        Ok(value)
    } else {
        Err(GrindError::OutOfRange {
            field,
            value,
            expected,
        })
    }
}

#[cfg(test)]
mod no_contact_message_tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::GrindError;

    /// A conical run has no worm radii (upper bound ∞) and its analytic worm point can fall
    /// inside the worm's base cylinder (w1 < 0): the message said "roll distance 0 ..= inf mm".
    #[test]
    fn no_worm_contact_reads_without_inf() {
        let e = GrindError::NoWormContact {
            w2_mm: 78.4,
            z2_mm: 16.7,
            w1_mm: -2.5,
            w1_min_mm: 0.0,
            w1_max_mm: f64::INFINITY,
        }
        .to_string();
        assert!(e.contains("roll distance 0 … ∞ mm"), "{e}");
        assert!(
            e.contains("inside the worm's base cylinder") && !e.contains("inf "),
            "{e}"
        );
        let e = GrindError::NoWormContact {
            w2_mm: 20.0,
            z2_mm: 0.0,
            w1_mm: 40.0,
            w1_min_mm: 5.0,
            w1_max_mm: 30.0,
        }
        .to_string();
        assert!(
            e.contains("roll distance 5 … 30 mm") && !e.contains("base cylinder"),
            "{e}"
        );
    }

    #[test]
    fn huge_values_in_exponent_form() {
        let e = super::check_range("F_C coefficients", 1e297, -1e12, 1e12, "|c| ≤ 1e12")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "F_C coefficients = 1e297 is out of range: expected |c| ≤ 1e12"
        );
        let e = super::check_range("m_n_mm", 0.0, 1e-3, 1e3, "0.001 ..= 1000 mm")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "m_n_mm = 0 is out of range: expected 0.001 ..= 1000 mm");
    }
}
