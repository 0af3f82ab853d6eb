//! The one place where interface units (degrees, rpm, rev/s², µm) become SI-like internal
//! units (rad, rad/s, rad/s², mm) and back.

use std::f64::consts::PI;

/// Degrees to radians.
pub fn deg_to_rad(deg: f64) -> f64 {
    deg.to_radians()
}

/// Radians to degrees.
pub fn rad_to_deg(rad: f64) -> f64 {
    rad.to_degrees()
}

/// Revolutions per minute to radians per second: ω = 2π·n/60.
pub fn rpm_to_rad_s(rpm: f64) -> f64 {
    rpm * 2.0 * PI / 60.0
}

/// Radians per second to revolutions per minute: n = 60·ω/(2π).
pub fn rad_s_to_rpm(rad_s: f64) -> f64 {
    rad_s * 60.0 / (2.0 * PI)
}

/// Revolutions per second squared to radians per second squared.
pub fn rev_s2_to_rad_s2(rev_s2: f64) -> f64 {
    rev_s2 * 2.0 * PI
}

/// Radians per second squared to revolutions per second squared.
pub fn rad_s2_to_rev_s2(rad_s2: f64) -> f64 {
    rad_s2 / (2.0 * PI)
}

/// Millimetres to micrometres.
pub fn mm_to_um(mm: f64) -> f64 {
    mm * 1000.0
}
