//! Unit conversions at the interfaces, each in exactly one place.

/// Seconds per hour.
pub const S_PER_H: f64 = 3600.0;
/// Micrometres per millimetre.
pub const UM_PER_MM: f64 = 1000.0;
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

/// µm → mm.
pub fn um_to_mm(um: f64) -> f64 {
    um / UM_PER_MM
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
