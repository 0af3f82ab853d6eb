//! ISO 1328-1:2013 helix slope tolerance f_HβT and its rounding rule.

use crate::error::{check_range, Result};

/// Unrounded helix slope tolerance f_HβT for flank tolerance class A.
///
/// # Formula
/// f_HβT = (0.05·√d + 0.35·√b + 4)·(√2)^(A − 5)
///
/// # Units
/// d reference diameter in mm, b facewidth in mm, result in µm.
///
/// # Domain
/// Classes A = 1…11; 5 ≤ d ≤ 15 000 mm; 4 ≤ b ≤ 1200 mm (ISO 1328-1:2013 scope, clause 1).
///
/// # Source
/// ISO 1328-1:2013, 5.3.2, formula (10) [STANDARD]; cross-checked against anchors.md TV4
/// (d = 80, b = 20, A = 6 → 8.503 µm)
pub fn helix_slope_tolerance_um(d_mm: f64, b_mm: f64, class: u8) -> Result<f64> {
    let d = check_range("reference diameter d", d_mm, 5.0, 15_000.0, "mm")?;
    let b = check_range("facewidth B", b_mm, 4.0, 1200.0, "mm")?;
    check_range(
        "ISO 1328-1 flank tolerance class",
        f64::from(class),
        1.0,
        11.0,
        "",
    )?;
    let step = std::f64::consts::SQRT_2.powi(i32::from(class) - 5);
    Ok((0.05 * d.sqrt() + 0.35 * b.sqrt() + 4.0) * step)
}

/// Rounds a computed tolerance as ISO 1328-1:2013 prescribes.
///
/// # Formula
/// ≥ 10 µm: to the nearest whole µm; 5–10 µm: to the nearest 0.5 µm; below 5 µm: to the nearest
/// 0.1 µm.
///
/// # Source
/// ISO 1328-1:2013, 5.2.4 (rounding of calculated tolerances) [STANDARD]; the rule as quoted
/// in anchors.md TV4 [SOURCE]
pub fn round_tolerance_um(value_um: f64) -> f64 {
    if value_um >= 10.0 {
        value_um.round()
    } else if value_um >= 5.0 {
        (value_um * 2.0).round() / 2.0
    } else {
        (value_um * 10.0).round() / 10.0
    }
}

/// Evaluation length L_β of a helix over facewidth b.
///
/// # Formula
/// L_β = b − 2·min(0.05·b, m_n): the facewidth less, at each end, the smaller of 5 % of the
/// facewidth and one module.
///
/// # Source
/// ISO 1328-1:2013, 3.3.2 / 5.1 (helix evaluation range) [STANDARD]
pub fn helix_evaluation_length_mm(b_mm: f64, m_n_mm: f64) -> f64 {
    b_mm - 2.0 * (0.05 * b_mm).min(m_n_mm)
}
