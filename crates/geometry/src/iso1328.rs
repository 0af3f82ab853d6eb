//! ISO 1328-1:2013 flank tolerances of cylindrical gears: the tolerance formulas of the
//! flank tolerance classes, their rounding rule and the profile and helix evaluation ranges.
//! Shared by the shaping simulation (helix slope of a shaped gear) and the grinding flank
//! evaluation.

use crate::error::{GeometryError, Result};
use serde::{Deserialize, Serialize};

/// Rounds a calculated tolerance as ISO 1328-1:2013 prescribes.
///
/// # Formula
/// greater than 10 µm: to the nearest whole µm; 5 … 10 µm: to the nearest 0.5 µm; below
/// 5 µm: to the nearest 0.1 µm. At the boundaries both neighbouring rules give the same
/// value (10.0 and 5.0), so the open/closed choice cannot change a result.
/// # Source
/// ISO 1328-1:2013, 5.2.3 (rounding of calculated tolerance values) [STANDARD]. The clause's
/// wording ("if greater than 10 µm, round to the nearest integer micrometre", "… to the
/// nearest 0,5 µm", "… to the nearest 0,1 µm", page 34) was checked against a public
/// project that cites the standard's text layer page by page; the standard itself was not
/// at hand.
pub fn round_tolerance_um(value_um: f64) -> f64 {
    if value_um > 10.0 {
        value_um.round()
    } else if value_um >= 5.0 {
        (value_um * 2.0).round() / 2.0
    } else {
        (value_um * 10.0).round() / 10.0
    }
}

/// Tolerances of one flank tolerance class, in µm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Tolerances {
    /// Flank tolerance class A (1 … 11).
    pub class: u8,
    /// Single pitch tolerance f_pT.
    pub f_pt_um: f64,
    /// Total cumulative pitch tolerance F_pT.
    pub total_pt_um: f64,
    /// Profile slope tolerance f_HαT.
    pub f_h_alpha_t_um: f64,
    /// Profile form tolerance f_fαT.
    pub f_f_alpha_t_um: f64,
    /// Total profile tolerance F_αT.
    pub total_alpha_t_um: f64,
    /// Helix slope tolerance f_HβT.
    pub f_h_beta_t_um: f64,
    /// Helix form tolerance f_fβT.
    pub f_f_beta_t_um: f64,
    /// Total helix tolerance F_βT.
    pub total_beta_t_um: f64,
}

fn check(name: &'static str, value: f64, min: f64, max: f64, unit: &'static str) -> Result<f64> {
    if value.is_finite() && value >= min && value <= max {
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

/// Unrounded tolerances of class A for reference diameter d, normal module m_n, facewidth b.
///
/// # Formula
/// φ = (√2)^(A−5);
/// f_pT = (0.001·d + 0.4·m_n + 5)·φ; F_pT = (0.002·d + 0.55·√d + 0.7·m_n + 12)·φ;
/// f_HαT = (0.4·m_n + 0.001·d + 4)·φ; f_fαT = (0.55·m_n + 5)·φ; F_αT = √(f_HαT² + f_fαT²);
/// f_HβT = (0.05·√d + 0.35·√b + 4)·φ; f_fβT = (0.07·√d + 0.45·√b + 4)·φ;
/// F_βT = √(f_HβT² + f_fβT²)
/// # Domain
/// A = 1 … 11; 5 ≤ d ≤ 15 000 mm, 0.5 ≤ m_n ≤ 70 mm, 4 ≤ b ≤ 1200 mm (the standard's scope).
/// # Source
/// ISO 1328-1:2013, formulas (5)–(12) [STANDARD]; checked against TV4 of docs/geometry.md
/// "Published test vectors"
/// (d = 80, m_n = 2, b = 20, A = 6).
pub fn tolerances_unrounded(d_mm: f64, m_n_mm: f64, b_mm: f64, class: u8) -> Result<Tolerances> {
    let d = check("reference diameter d", d_mm, 5.0, 15_000.0, "mm")?;
    let m = check("normal module m_n", m_n_mm, 0.5, 70.0, "mm")?;
    let b = check("facewidth b", b_mm, 4.0, 1200.0, "mm")?;
    check(
        "ISO 1328-1 flank tolerance class",
        f64::from(class),
        1.0,
        11.0,
        "",
    )?;
    let phi = std::f64::consts::SQRT_2.powi(i32::from(class) - 5);
    let (sd, sb) = (d.sqrt(), b.sqrt());
    let fha = (0.4 * m + 0.001 * d + 4.0) * phi;
    let ffa = (0.55 * m + 5.0) * phi;
    let fhb = (0.05 * sd + 0.35 * sb + 4.0) * phi;
    let ffb = (0.07 * sd + 0.45 * sb + 4.0) * phi;
    Ok(Tolerances {
        class,
        f_pt_um: (0.001 * d + 0.4 * m + 5.0) * phi,
        total_pt_um: (0.002 * d + 0.55 * sd + 0.7 * m + 12.0) * phi,
        f_h_alpha_t_um: fha,
        f_f_alpha_t_um: ffa,
        total_alpha_t_um: fha.hypot(ffa),
        f_h_beta_t_um: fhb,
        f_f_beta_t_um: ffb,
        total_beta_t_um: fhb.hypot(ffb),
    })
}

/// Tolerances of class A, each rounded by [`round_tolerance_um`] (totals are formed from the
/// unrounded parts, then rounded).
///
/// # Source
/// ISO 1328-1:2013, formulas (5)–(12) and the rounding rule [STANDARD]
pub fn tolerances(d_mm: f64, m_n_mm: f64, b_mm: f64, class: u8) -> Result<Tolerances> {
    let t = tolerances_unrounded(d_mm, m_n_mm, b_mm, class)?;
    let r = round_tolerance_um;
    Ok(Tolerances {
        class,
        f_pt_um: r(t.f_pt_um),
        total_pt_um: r(t.total_pt_um),
        f_h_alpha_t_um: r(t.f_h_alpha_t_um),
        f_f_alpha_t_um: r(t.f_f_alpha_t_um),
        total_alpha_t_um: r(t.total_alpha_t_um),
        f_h_beta_t_um: r(t.f_h_beta_t_um),
        f_f_beta_t_um: r(t.f_f_beta_t_um),
        total_beta_t_um: r(t.total_beta_t_um),
    })
}

/// Profile evaluation range L_α from the active profile [start (SAP), end (tip)], as roll
/// lengths or diameters' roll distances in mm.
///
/// # Formula
/// L_α starts at the start of the active profile and covers 95 % of the active length L_AE
/// (the 5 % next to the tip are excluded).
/// # Source
/// ISO 1328-1:2013, profile evaluation range [STANDARD, as recalled; clause not verified]
pub fn profile_evaluation_range(active_mm: (f64, f64)) -> (f64, f64) {
    (
        active_mm.0,
        active_mm.0 + 0.95 * (active_mm.1 - active_mm.0),
    )
}

/// Helix evaluation range L_β of a face [z_start, z_end] in mm.
///
/// # Formula
/// Each end is shortened by the smaller of 5 % of the facewidth b and one module m_n.
/// # Source
/// ISO 1328-1:2013, helix evaluation range [STANDARD, as recalled; clause not verified]
pub fn helix_evaluation_range(face_mm: (f64, f64), m_n_mm: f64) -> (f64, f64) {
    let b = face_mm.1 - face_mm.0;
    let cut = (0.05 * b).min(m_n_mm);
    (face_mm.0 + cut, face_mm.1 - cut)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// TV4 of docs/geometry.md "Published test vectors": d = 80 mm, m_n = 2, b = 20 mm, class 6,
    /// with the unrounded values computed independently from the standard's formulas.
    #[test]
    fn class6_tolerances_tv4() {
        let u = tolerances_unrounded(80.0, 2.0, 20.0, 6).unwrap();
        for (got, want) in [
            (u.f_pt_um, 8.3156),
            (u.total_pt_um, 26.134),
            (u.f_h_alpha_t_um, 6.901),
            (u.f_f_alpha_t_um, 8.627),
            (u.total_alpha_t_um, 11.048),
            (u.f_h_beta_t_um, 8.503),
            (u.f_f_beta_t_um, 9.388),
            (u.total_beta_t_um, 12.667),
        ] {
            assert!((got - want).abs() < 6e-4, "{got} vs {want}");
        }
        let t = tolerances(80.0, 2.0, 20.0, 6).unwrap();
        assert_eq!(
            [
                t.f_pt_um,
                t.total_pt_um,
                t.f_h_alpha_t_um,
                t.f_f_alpha_t_um,
                t.total_alpha_t_um,
                t.f_h_beta_t_um,
                t.f_f_beta_t_um,
                t.total_beta_t_um
            ],
            [8.5, 26.0, 7.0, 8.5, 11.0, 8.5, 9.5, 13.0]
        );
    }

    #[test]
    fn rounding_rule_and_class_step() {
        assert_eq!(round_tolerance_um(26.134), 26.0);
        assert_eq!(round_tolerance_um(10.6), 11.0);
        assert_eq!(round_tolerance_um(8.627), 8.5);
        assert_eq!(round_tolerance_um(6.901), 7.0);
        assert_eq!(round_tolerance_um(4.87), 4.9);
        // The three bands meet without a jump: each boundary value is kept by both rules.
        assert_eq!(round_tolerance_um(10.0), 10.0);
        assert_eq!(round_tolerance_um(10.2), 10.0);
        assert_eq!(round_tolerance_um(9.8), 10.0);
        assert_eq!(round_tolerance_um(5.0), 5.0);
        assert_eq!(round_tolerance_um(4.96), 5.0);
        assert_eq!(round_tolerance_um(5.2), 5.0);
        let a6 = tolerances_unrounded(80.0, 2.0, 20.0, 6).unwrap();
        let a7 = tolerances_unrounded(80.0, 2.0, 20.0, 7).unwrap();
        assert!((a7.f_h_beta_t_um / a6.f_h_beta_t_um - std::f64::consts::SQRT_2).abs() < 1e-12);
    }

    #[test]
    fn out_of_scope_names_the_parameter() {
        let e = tolerances(80.0, 2.0, 20.0, 12).unwrap_err().to_string();
        assert!(e.contains("class") && e.contains("12"), "{e}");
        assert!(tolerances(f64::NAN, 2.0, 20.0, 6).is_err());
        assert!(tolerances(80.0, 0.1, 20.0, 6)
            .unwrap_err()
            .to_string()
            .contains("m_n"));
    }

    #[test]
    fn evaluation_ranges() {
        assert_eq!(helix_evaluation_range((0.0, 20.0), 2.0), (1.0, 19.0));
        assert_eq!(helix_evaluation_range((0.0, 40.0), 1.5), (1.5, 38.5));
        let (a, b) = profile_evaluation_range((10.0, 20.0));
        assert!((a - 10.0).abs() < 1e-12 && (b - 19.5).abs() < 1e-12);
    }
}
