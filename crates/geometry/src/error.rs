//! Errors of the gear geometry: every variant names the parameter, its value and the
//! allowed range, and is `Copy` so a caller on a hot path never allocates for it.

use crate::units::fmt_value;

/// Why a gear, a measurement or a pair cannot be computed.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GeometryError {
    /// A parameter is outside its allowed range (or not finite).
    #[error(
        "{name} = {v}{u} is outside the allowed range {lo} … {hi}{u}",
        v = short(*value),
        lo = short(*min),
        hi = short(*max),
        u = unit_suffix(unit)
    )]
    OutOfRange {
        /// The parameter's name, as in the API and the CLI.
        name: &'static str,
        /// The offending value (angles in degrees).
        value: f64,
        /// Lower end of the allowed range.
        min: f64,
        /// Upper end of the allowed range.
        max: f64,
        /// Unit of value, min and max ("mm", "°", "" for coefficients).
        unit: &'static str,
    },
    /// The generating rack undercuts the tooth (a warning: see `Gear::undercut`).
    #[error(
        "undercut: {name} = {value:.4} is below x_min = {min:.4} for z = {teeth} with this tool \
         (no undercut for {name} ≥ {min:.4}{or_teeth}); the rack tip \
         cuts away the involute above the base circle and weakens the root; the usable flank is \
         taken from the base circle, so check that measurement contacts lie above the undercut",
        or_teeth = if min_teeth.is_finite() && *min_teeth <= f64::from(crate::gear::MAX_TEETH) {
            format!(", or z ≥ {min_teeth:.1} at this shift")
        } else {
            format!("; no tooth count up to {} avoids it at this shift", crate::gear::MAX_TEETH)
        }
    )]
    Undercut {
        /// The profile shift that was checked ("profile_shift" or the generating shift).
        name: &'static str,
        /// The offending profile shift coefficient.
        value: f64,
        /// The smallest shift without undercut.
        min: f64,
        /// The gear's number of teeth.
        teeth: u32,
        /// The smallest number of teeth without undercut at this shift.
        min_teeth: f64,
    },
    /// The tooth comes to a point before the tip circle.
    #[error(
        "pointed tooth: normal tip thickness s_an = {value_mm:.4} mm with {name} = {shift:.4} \
         (allowed: s_an > {min_mm} mm; reduce {name} or the tip diameter)"
    )]
    PointedTooth {
        /// The profile shift responsible ("profile_shift" or the generating shift).
        name: &'static str,
        /// That profile shift coefficient.
        shift: f64,
        /// The normal tip thickness in mm.
        value_mm: f64,
        /// The smallest allowed tip thickness in mm.
        min_mm: f64,
    },
    /// A measuring element (ball, span anvils) would not touch the involute flank.
    #[error(
        "{name} = {value} does not touch the involute flanks: contact diameter {contact_diameter_mm:.4} mm \
         is outside the flank {min_mm:.4} … {max_mm:.4} mm"
    )]
    OffFlank {
        /// The parameter that places the contact ("ball_mm" or "span_k").
        name: &'static str,
        /// Its value (ball diameter in mm, or k).
        value: f64,
        /// The diameter where the contact would be, in mm (NaN if there is none).
        contact_diameter_mm: f64,
        /// Lowest diameter of the usable flank in mm.
        min_mm: f64,
        /// Highest diameter of the usable flank in mm.
        max_mm: f64,
    },
    /// A helical span whose anvils touch the flanks further apart axially than the face is
    /// wide (the span cannot be placed on the gear).
    #[error(
        "{name} = {k}: the anvils touch the helical flanks W_k·sin β_b = {axial_mm:.4} mm apart \
         axially (W_k = {span_mm:.4} mm, β_b = {base_helix_deg:.4}°), which does not fit in the \
         face width b = {face_width_mm} mm; a span over k needs b > W_k·sin β_b (measure over \
         balls, or give a smaller k if one touches the flanks)"
    )]
    SpanTooWide {
        /// The parameter ("span_k").
        name: &'static str,
        /// Number of teeth (spaces) spanned.
        k: u32,
        /// Span W_k in mm.
        span_mm: f64,
        /// Axial distance of the two contact points W_k·sin β_b in mm.
        axial_mm: f64,
        /// Face width b in mm.
        face_width_mm: f64,
        /// Base helix angle β_b in degrees.
        base_helix_deg: f64,
    },
    /// A ball that does not touch the usable involute flank, with the range of balls that do.
    #[error(
        "{name} = {ball_mm} mm does not touch the involute flanks (usable flank {flank_min_mm:.4} … \
         {flank_max_mm:.4} mm); balls from {lo} to {hi} mm touch it on this gear",
        lo = short(*min_ball_mm),
        hi = short(*max_ball_mm)
    )]
    BallOffFlank {
        /// The parameter ("ball_mm").
        name: &'static str,
        /// The ball diameter given, in mm.
        ball_mm: f64,
        /// Smallest ball diameter touching the usable flank, in mm.
        min_ball_mm: f64,
        /// Largest ball diameter touching the usable flank, in mm.
        max_ball_mm: f64,
        /// Lowest diameter of the usable flank in mm.
        flank_min_mm: f64,
        /// Highest diameter of the usable flank in mm.
        flank_max_mm: f64,
    },
    /// The basic rack's dedendum coefficient is not above its addendum coefficient or beyond
    /// its upper limit.
    #[error(
        "dedendum coefficient h_fP* = {v} must be above {lo} (the addendum coefficient h_aP*) \
         and {upper}",
        v = fmt_value(*value),
        lo = fmt_value(*addendum_coeff),
        upper = if *max_pointed {
            format!("below {} (the tool tooth is pointed there at this pressure angle: \
                     π/(4·tan α_n))", fmt_value(*max))
        } else {
            format!("at most {}", fmt_value(*max))
        }
    )]
    DedendumRange {
        /// The parameter ("dedendum_coeff").
        name: &'static str,
        /// The dedendum coefficient h_fP* given.
        value: f64,
        /// The addendum coefficient h_aP* (exclusive lower bound).
        addendum_coeff: f64,
        /// The upper bound.
        max: f64,
        /// The upper bound is where the tool tooth becomes pointed (exclusive), not the
        /// fixed limit 3 (inclusive).
        max_pointed: bool,
    },
    /// The tool tooth of the basic rack is pointed: its tip width π/2 − 2·h_fP*·tan α_n is
    /// not positive, so no gear can be generated at this pressure angle with this dedendum.
    #[error(
        "pressure angle α_n = {a}° with the rack dedendum h_fP* = {h}: the tool tooth is pointed \
         (π/2 − 2·h_fP*·tan α_n ≤ 0); with h_fP* = {h} the pressure angle must be below \
         {a_max}° (atan(π/(4·h_fP*))){alt}",
        a = fmt_value(*alpha_n_deg),
        h = fmt_value(*dedendum_coeff),
        a_max = fmt_value(*max_alpha_n_deg),
        alt = if *max_dedendum_coeff > *addendum_coeff {
            format!(", or at {}° h_fP* must be below {} (π/(4·tan α_n))",
                    fmt_value(*alpha_n_deg), fmt_value(*max_dedendum_coeff))
        } else {
            String::new()
        }
    )]
    PointedTool {
        /// The parameter ("normal_pressure_angle").
        name: &'static str,
        /// The normal pressure angle in degrees.
        alpha_n_deg: f64,
        /// The dedendum coefficient h_fP*.
        dedendum_coeff: f64,
        /// The addendum coefficient h_aP*.
        addendum_coeff: f64,
        /// The largest pressure angle for this dedendum (exclusive), in degrees.
        max_alpha_n_deg: f64,
        /// The largest dedendum coefficient at this pressure angle (exclusive).
        max_dedendum_coeff: f64,
    },
    /// Two gears that cannot mesh together.
    #[error("gears do not mesh: {name} differs ({value} vs {other}); they must be equal")]
    Mismatch {
        /// The parameter that differs.
        name: &'static str,
        /// Its value on the first gear.
        value: f64,
        /// Its value on the second gear.
        other: f64,
    },
}

/// " mm" for a unit, "" for a dimensionless value (so messages have no double spaces).
fn unit_suffix(unit: &str) -> String {
    if unit.is_empty() {
        String::new()
    } else {
        format!(" {unit}")
    }
}

/// A number with at most 6 decimals and no trailing zeros (60, 18.793852, -0.0843).
fn short(x: f64) -> String {
    if x.is_infinite() {
        return if x > 0.0 { "∞" } else { "−∞" }.to_string();
    }
    if x.is_nan() {
        return format!("{x}");
    }
    if x.abs() >= 1e9 {
        // Huge values (e.g. a width of 1e300) in exponent form, not 300 digits.
        return format!("{x:e}");
    }
    if x != 0.0 && x.abs() < 1e-4 {
        // Tiny values (e.g. a module of 1e-300) must not read back as 0.
        return format!("{x:e}");
    }
    let s = format!("{x:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// Result of the geometry functions.
pub type Result<T> = std::result::Result<T, GeometryError>;

/// Checks that `value` is finite and within `[min, max]` (closed unless `open` is set).
pub(crate) fn check_range(
    name: &'static str,
    value: f64,
    min: f64,
    max: f64,
    unit: &'static str,
    open: bool,
) -> Result<f64> {
    let inside = if open {
        value > min && value < max
    } else {
        value >= min && value <= max
    };
    if value.is_finite() && inside {
        Ok(value)
    } else {
        Err(GeometryError::OutOfRange {
            name,
            value,
            min,
            max,
            unit,
        })
    }
}

/// Like [`check_range`] for an angle given in rad, reported in degrees.
pub(crate) fn check_angle(
    name: &'static str,
    value_rad: f64,
    min_deg: f64,
    max_deg: f64,
    open_low: bool,
) -> Result<f64> {
    // Rounded to 1e-10° so a user's 60° reads back as 60, not 59.99999999999999.
    let deg = (value_rad.to_degrees() * 1e10).round() / 1e10;
    // Compare in rad: 60° → rad → ° lands just below 60 and would slip through.
    let (lo, hi) = (min_deg.to_radians(), max_deg.to_radians());
    let low_ok = if open_low {
        value_rad > lo
    } else {
        value_rad >= lo
    };
    if value_rad.is_finite() && low_ok && value_rad < hi {
        Ok(value_rad)
    } else {
        Err(GeometryError::OutOfRange {
            name,
            value: deg,
            min: min_deg,
            max: max_deg,
            unit: "°",
        })
    }
}
