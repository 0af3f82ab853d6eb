//! DIN 3960 / ISO 21771 quantities of helical gears and of the worm seen as a helical gear.

use crate::error::{DressError, Result};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Derived quantities of a cylindrical involute helical gear (or worm, with z = starts).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HelicalParams {
    /// Reference radius r (mm).
    pub r_mm: f64,
    /// Transverse pressure angle α_t (rad).
    pub alpha_t_rad: f64,
    /// Base radius r_b (mm).
    pub r_b_mm: f64,
    /// Base helix angle β_b (rad).
    pub beta_b_rad: f64,
    /// Base module m_b = 2 r_b / z (mm).
    pub m_b_mm: f64,
    /// Lead p_z = 2π r_b / tan β_b (mm), for one full turn.
    pub lead_mm: f64,
}

/// DIN 3960 quantities from normal module, normal pressure angle, number of teeth and helix angle.
///
/// # Formula
/// m_t = m_n / cos β, r = z m_t / 2, tan α_t = tan α_n / cos β, r_b = r cos α_t,
/// tan β_b = tan β cos α_t, m_b = 2 r_b / z, p_z = 2π r_b / tan β_b
/// # Domain
/// m_n > 0, 0 < α_n < 90°, z ≥ 1, 0 < β < 90° (β = 0 gives an infinite lead)
/// # Source
/// ISO 21771:2007 4.3, 4.4 [STANDARD]; docs/dressing.md "Derivation: worm helicoid" [RECONSTRUCTED]
pub fn helical_params(
    m_n_mm: f64,
    alpha_n_rad: f64,
    z: f64,
    beta_rad: f64,
) -> Result<HelicalParams> {
    DressError::check("m_n_mm", m_n_mm, 1e-3, 1e3)?;
    DressError::check("alpha_n_rad", alpha_n_rad, 1e-3, PI / 2.0 - 1e-3)?;
    DressError::check("z", z, 1.0, 1e4)?;
    DressError::check("beta_rad", beta_rad, -(PI / 2.0 - 1e-6), PI / 2.0 - 1e-6)?;
    let cb = beta_rad.cos();
    let m_t = m_n_mm / cb;
    let r = z * m_t / 2.0;
    let alpha_t = gearcomp_geometry::transverse_pressure_angle_rad(alpha_n_rad, beta_rad);
    let r_b = r * alpha_t.cos();
    let beta_b = (beta_rad.tan() * alpha_t.cos()).atan();
    let lead = if beta_b.abs() < 1e-15 {
        f64::INFINITY
    } else {
        2.0 * PI * r_b / beta_b.tan()
    };
    Ok(HelicalParams {
        r_mm: r,
        alpha_t_rad: alpha_t,
        r_b_mm: r_b,
        beta_b_rad: beta_b,
        m_b_mm: 2.0 * r_b / z,
        lead_mm: lead,
    })
}

/// Worm as a helical gear: z = z_S starts, reference diameter d_S, cos β_S = z_S m_n / d_S.
///
/// # Formula
/// β_S = acos(z_S m_n / d_S) (lead angle γ_S = 90° − β_S), then [`helical_params`]
/// # Source
/// ISO 21771:2007 4.3, 4.4 (worm as helical gear) [STANDARD]; docs/dressing.md "Derivation: worm helicoid", docs/dressing.md "Reference case G1 and its worms" [RECONSTRUCTED]
pub fn worm_params(z_s: u32, d_s_mm: f64, m_n_mm: f64, alpha_n_rad: f64) -> Result<HelicalParams> {
    DressError::check("z_s", f64::from(z_s), 1.0, 20.0)?;
    DressError::check("d_s_mm", d_s_mm, f64::from(z_s) * m_n_mm * 1.0001, 1e4)?;
    let beta_s = (f64::from(z_s) * m_n_mm / d_s_mm).acos();
    helical_params(m_n_mm, alpha_n_rad, f64::from(z_s), beta_s)
}

/// Meshing condition of two involute gearings: equal normal base pitch.
///
/// # Formula
/// m_bF1 · cos β_bF1 = m_bF2 · cos β_bF2  (within `tol_mm`)
/// # Source
/// JP6903407B2, eqs. (20) and (93) [SEED]
pub fn meshes(a: &HelicalParams, b: &HelicalParams, tol_mm: f64) -> bool {
    (a.m_b_mm * a.beta_b_rad.cos() - b.m_b_mm * b.beta_b_rad.cos()).abs() <= tol_mm
}

/// Normal module of a worm with profile angle α_nS that still meshes with a gear (m_nV, α_nV).
///
/// # Formula
/// m_nS = m_nV cos α_nV / cos α_nS  (eq. (20) as equal normal base pitch)
/// # Source
/// JP6903407B2, eq. (20) [SEED]; normal-pitch form docs/dressing.md "Derivation: worm helicoid" [RECONSTRUCTED]
pub fn normal_module_for_profile_angle(m_nv_mm: f64, alpha_nv_rad: f64, alpha_ns_rad: f64) -> f64 {
    m_nv_mm * alpha_nv_rad.cos() / alpha_ns_rad.cos()
}
