//! The involute function and its inverse, written from the definition for the tests'
//! independent references (not the library's helpers).

/// inv α = tan α − α.
pub fn inv(a: f64) -> f64 {
    a.tan() - a
}

/// α with inv α = v (v ≥ 0), by bisection on [0, π/2).
pub fn inv_inverse(v: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, std::f64::consts::FRAC_PI_2 - 1e-12);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if inv(mid) < v {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}
