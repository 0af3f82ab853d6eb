//! Interface units of the gear crates: the one place where the units users write (degrees,
//! µm, rpm, rev/s²) become the internal ones (rad, mm, rad/s, rad/s²) and back.
//!
//! Geometry, grinding, dressing, shaping and the CLI's gear commands all convert here. (The
//! thermal crate keeps its own temperature and inch conversions for the thermal model files.)

use std::f64::consts::PI;

/// Micrometres per millimetre.
pub const UM_PER_MM: f64 = 1000.0;

/// Degrees (interface) to radians (internal).
#[inline]
pub fn deg_to_rad(deg: f64) -> f64 {
    deg.to_radians()
}

/// Radians (internal) to degrees (interface).
#[inline]
pub fn rad_to_deg(rad: f64) -> f64 {
    rad.to_degrees()
}

/// Micrometres (interface) to millimetres (internal): um·10⁻³.
#[inline]
pub fn um_to_mm(um: f64) -> f64 {
    um * 1e-3
}

/// Millimetres (internal) to micrometres (interface): mm·10³.
#[inline]
pub fn mm_to_um(mm: f64) -> f64 {
    mm * 1e3
}

/// Revolutions per minute to radians per second: ω = 2π·n/60.
#[inline]
pub fn rpm_to_rad_s(rpm: f64) -> f64 {
    rpm * 2.0 * PI / 60.0
}

/// Radians per second to revolutions per minute: n = 60·ω/(2π).
#[inline]
pub fn rad_s_to_rpm(rad_s: f64) -> f64 {
    rad_s * 60.0 / (2.0 * PI)
}

/// Revolutions per second squared to radians per second squared.
#[inline]
pub fn rev_s2_to_rad_s2(rev_s2: f64) -> f64 {
    rev_s2 * 2.0 * PI
}

/// Radians per second squared to revolutions per second squared.
#[inline]
pub fn rad_s2_to_rev_s2(rad_s2: f64) -> f64 {
    rad_s2 / (2.0 * PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_values() {
        assert!((deg_to_rad(180.0) - PI).abs() < 1e-15);
        assert!((rad_to_deg(PI / 2.0) - 90.0).abs() < 1e-12);
        assert!((um_to_mm(2.5) - 0.0025).abs() < 1e-18);
        assert!((mm_to_um(0.0025) - 2.5).abs() < 1e-12);
        // 60 rpm is one revolution per second = 2π rad/s.
        assert!((rpm_to_rad_s(60.0) - 2.0 * PI).abs() < 1e-12);
        assert!((rad_s_to_rpm(2.0 * PI) - 60.0).abs() < 1e-12);
        assert!((rev_s2_to_rad_s2(1.0) - 2.0 * PI).abs() < 1e-12);
        assert!((rad_s2_to_rev_s2(2.0 * PI) - 1.0).abs() < 1e-12);
    }
}
