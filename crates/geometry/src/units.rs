//! Interface units of the gear crates: the one place where the units users write (degrees,
//! µm, rpm, rev/s²) become the internal ones (rad, mm, rad/s, rad/s²) and back.
//!
//! Geometry, grinding, dressing, shaping, the thermal engine and the CLI all convert here:
//! besides the gear units, the time (h ↔ s) and imperial units (inch, °F) that the thermal
//! presets and model files use (EP0138375 works in inches and °F). `gearcomp_thermal::units`
//! re-exports this module.

use std::f64::consts::PI;

/// Micrometres per millimetre.
pub const UM_PER_MM: f64 = 1000.0;

/// A number for a message, as a user would write it: at most 12 significant digits with
/// trailing zeros trimmed (60, not the 59.99999999999999 of a degree → rad → degree round
/// trip; 0.6, not 0.6000000000000001), in exponent form from 1e9 on and below 1e-4 (1e300 and
/// 1e-300, not 300 digits; a tiny value never reads back as 0), ∞ for infinities.
pub fn fmt_value(x: f64) -> String {
    fn trim(s: &str) -> &str {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.')
        } else {
            s
        }
    }
    if x.is_nan() {
        return "NaN".to_string();
    }
    if x.is_infinite() {
        return if x > 0.0 { "∞" } else { "−∞" }.to_string();
    }
    if x == 0.0 {
        return "0".to_string();
    }
    let a = x.abs();
    if !(1e-4..1e9).contains(&a) {
        let s = format!("{x:.11e}");
        return match s.split_once('e') {
            Some((mantissa, exp)) => format!("{}e{exp}", trim(mantissa)),
            None => s,
        };
    }
    // decimals that leave 12 significant digits (a ≥ 1e-4: at most 15)
    let decimals = (11 - a.log10().floor() as i32).clamp(0, 15) as usize;
    let s = format!("{x:.decimals$}");
    let t = trim(&s);
    if t == "-0" {
        "0".to_string()
    } else {
        t.to_string()
    }
}

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

/// Seconds per hour.
pub const S_PER_H: f64 = 3600.0;
/// Seconds per minute.
pub const S_PER_MIN: f64 = 60.0;
/// Seconds per millisecond.
pub const S_PER_MS: f64 = 1e-3;
/// Micrometres per metre.
pub const UM_PER_M: f64 = 1e6;
/// Micrometres per nanometre.
pub const UM_PER_NM: f64 = 1e-3;
/// Micrometres per inch (exact by definition of the inch).
pub const UM_PER_INCH: f64 = 25_400.0;

/// Hours → seconds.
pub fn h_to_s(h: f64) -> f64 {
    h * S_PER_H
}

/// Seconds → hours.
pub fn s_to_h(s: f64) -> f64 {
    s / S_PER_H
}

/// Inches → µm (EP0138375 works in inches).
pub fn inch_to_um(inch: f64) -> f64 {
    inch * UM_PER_INCH
}

/// µm → inches.
pub fn um_to_inch(um: f64) -> f64 {
    um / UM_PER_INCH
}

/// A temperature in °F → °C.
pub fn f_to_c(temp_f: f64) -> f64 {
    (temp_f - 32.0) * 5.0 / 9.0
}

/// A coefficient per °F → per °C (a 1 °C step is 1.8 °F).
pub fn per_f_to_per_c(k_per_f: f64) -> f64 {
    k_per_f * 1.8
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
        // Time and imperial units by definition: 1 h = 3600 s, 1 in = 25.4 mm,
        // 212 °F = 100 °C, 32 °F = 0 °C.
        assert_eq!(h_to_s(2.0), 7200.0);
        assert_eq!(s_to_h(5400.0), 1.5);
        assert!((inch_to_um(0.0001) - 2.54).abs() < 1e-12);
        assert!((um_to_inch(25.4) - 0.001).abs() < 1e-15);
        assert!((f_to_c(212.0) - 100.0).abs() < 1e-12);
        assert_eq!(f_to_c(32.0), 0.0);
        assert!((per_f_to_per_c(1.0) - 1.8).abs() < 1e-15);
    }
}

#[cfg(test)]
mod fmt_value_tests {
    use super::fmt_value;

    #[test]
    fn values_read_as_written() {
        assert_eq!(fmt_value(60f64.to_radians().to_degrees()), "60");
        assert_eq!(fmt_value(0.2 * 3.0), "0.6");
        assert_eq!(fmt_value(1e-300), "1e-300");
        assert_eq!(fmt_value(1e300), "1e300");
        assert_eq!(fmt_value(-2.5e-7), "-2.5e-7");
        assert_eq!(fmt_value(89.99779631617203), "89.9977963162");
        assert_eq!(fmt_value(130.0), "130");
        assert_eq!(fmt_value(-120.0), "-120");
        assert_eq!(fmt_value(0.0005), "0.0005");
        assert_eq!(fmt_value(f64::NAN), "NaN");
        assert_eq!(fmt_value(f64::INFINITY), "∞");
    }
}
