//! The involute grinding worm: a cylindrical involute helicoid per flank, its thread and radii.

use crate::error::{DressError, Result};
use crate::gear::worm_params;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Flank of the worm thread: the shared gear vocabulary's [`Flank`].
///
/// In the worm frame of this crate `Right` is the flank whose outward normal points towards +z
/// (the −z side of the gap that the dresser sits in at φ_S = 0), `Left` the other one; s_F =
/// [`Flank::sign`] (+1 right, −1 left). For the right-hand worm modelled here this is the same
/// flank as the grinding crate's end-face definition (docs/grinding.md "Dressed worm"), so the
/// two crates share one type. With this choice the right flank reproduces the signs of the
/// reference solution docs/dressing.md "Reference case G1-Z5".
pub use gearcomp_geometry::Flank;

/// A right-hand cylindrical involute worm at its current diameter.
///
/// The helicoid (r_b, β_b, lead) is fixed by the design diameter; redressing to a smaller
/// diameter d_S keeps it and only moves tip, root and the thread position.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Worm {
    /// Number of starts z_S.
    pub z_s: u32,
    /// Normal module m_nS of the design (mm).
    pub m_n_mm: f64,
    /// Normal profile angle α_nFS of the design (rad).
    pub alpha_n_rad: f64,
    /// Design reference diameter d_S0 (mm).
    pub d_s0_mm: f64,
    /// Current reference diameter d_S (mm).
    pub d_s_mm: f64,
    /// Base radius r_bFS (mm).
    pub r_b_mm: f64,
    /// Base helix angle β_bFS (rad).
    pub beta_b_rad: f64,
    /// Lead parameter p = p_z / (2π) = r_b / tan β_b (mm/rad).
    pub p_mm: f64,
    /// Tip radius r_aS (mm).
    pub r_a_mm: f64,
    /// Root radius r_fS (mm).
    pub r_f_mm: f64,
    /// Thread thickening per flank along the normal (mm); > 0 makes the gap narrower.
    pub thicken_mm: f64,
}

impl Worm {
    /// A new worm designed at d_S0 with addendum 1.0·m_n, dedendum 1.25·m_n, right hand.
    ///
    /// # Formula
    /// worm as helical gear (docs/dressing.md "Derivation: worm helicoid"); r_a = d_S0/2 + m_n, r_f = d_S0/2 − 1.25 m_n
    /// # Source
    /// docs/dressing.md "Derivation: worm helicoid" (worm proportions) [RECONSTRUCTED]
    pub fn design(z_s: u32, d_s0_mm: f64, m_n_mm: f64, alpha_n_rad: f64) -> Result<Self> {
        let h = worm_params(z_s, d_s0_mm, m_n_mm, alpha_n_rad)?;
        Ok(Self {
            z_s,
            m_n_mm,
            alpha_n_rad,
            d_s0_mm,
            d_s_mm: d_s0_mm,
            r_b_mm: h.r_b_mm,
            beta_b_rad: h.beta_b_rad,
            p_mm: h.lead_mm / (2.0 * PI),
            r_a_mm: d_s0_mm / 2.0 + m_n_mm,
            r_f_mm: d_s0_mm / 2.0 - 1.25 * m_n_mm,
            thicken_mm: 0.0,
        })
    }

    /// The same worm redressed to the smaller diameter `d_s_mm`: helicoid kept, tip and root
    /// lowered by (d_S0 − d_S)/2, thread again half the axial pitch at d_S/2.
    pub fn worn(&self, d_s_mm: f64) -> Result<Self> {
        DressError::check(
            "d_s_mm",
            d_s_mm,
            2.0 * (self.r_b_mm + 2.25 * self.m_n_mm),
            self.d_s0_mm,
        )?;
        let delta = (self.d_s0_mm - d_s_mm) / 2.0;
        Ok(Self {
            d_s_mm,
            r_a_mm: self.d_s0_mm / 2.0 + self.m_n_mm - delta,
            r_f_mm: self.d_s0_mm / 2.0 - 1.25 * self.m_n_mm - delta,
            ..*self
        })
    }

    /// The same worm (current diameter, tip and root) re-profiled to normal profile angle α_n at
    /// its current reference diameter d_S, the normal base pitch being kept so that it still
    /// grinds the same gear (eq. (20)): a different helicoid (r_b, β_b, lead) that the old
    /// dresser then dresses. Apply after [`Self::worn`] (which works from the design module).
    ///
    /// # Formula
    /// m_n′ = m_n cos α_n0 / cos α_n;  (r_b, β_b, p_z) = worm as helical gear (z_S, d_S, m_n′, α_n)
    /// # Domain
    /// 5° ≤ α_n ≤ 45°
    /// # Source
    /// JP6903407B2, claim 2, eq. (20), Fig. 19 [SEED]; docs/dressing.md "Derivation: worm life and zero-stretch angle" [RECONSTRUCTED]
    pub fn with_profile_angle(&self, alpha_n_rad: f64) -> Result<Self> {
        DressError::check(
            "alpha_n_rad",
            alpha_n_rad,
            5f64.to_radians(),
            45f64.to_radians(),
        )?;
        let m_n = crate::gear::normal_module_for_profile_angle(
            self.m_n_mm,
            self.alpha_n_rad,
            alpha_n_rad,
        );
        let h = worm_params(self.z_s, self.d_s_mm, m_n, alpha_n_rad)?;
        Ok(Self {
            m_n_mm: m_n,
            alpha_n_rad,
            r_b_mm: h.r_b_mm,
            beta_b_rad: h.beta_b_rad,
            p_mm: h.lead_mm / (2.0 * PI),
            ..*self
        })
    }

    /// Normal profile angle of this worm's helicoid at radius r (the angle it has at d_S/2
    /// without re-profiling).
    ///
    /// # Formula
    /// cos α_t = r_b / r, tan β(r) = r / p, tan α_n = tan α_t · cos β(r)
    /// # Source
    /// ISO 21771:2007 4.3 (helical gear relations at any radius) [STANDARD]
    pub fn profile_angle_at(&self, r_mm: f64) -> f64 {
        let alpha_t = (self.r_b_mm / r_mm).clamp(-1.0, 1.0).acos();
        let beta = (r_mm / self.p_mm).atan();
        (alpha_t.tan() * beta.cos()).atan()
    }

    /// Normal base pitch p_bn = 2π r_b cos β_b / z_S (mm): what must match the gear (eq. (20)).
    pub fn normal_base_pitch_mm(&self) -> f64 {
        2.0 * PI * self.r_b_mm * self.beta_b_rad.cos() / f64::from(self.z_s)
    }

    /// Axial pitch p_x = p_z / z_S (mm).
    pub fn axial_pitch_mm(&self) -> f64 {
        2.0 * PI * self.p_mm / f64::from(self.z_s)
    }

    /// Lead angle at radius r: tan λ = p / r (rad).
    pub fn lead_angle_at(&self, r_mm: f64) -> f64 {
        (self.p_mm / r_mm).atan()
    }

    /// Roll distance of radius r on the involute: w = √(r² − r_b²).
    ///
    /// # Source
    /// docs/dressing.md "Derivation: worm helicoid" [RECONSTRUCTED]; ISO 21771:2007 4.3 [STANDARD]
    pub fn roll_from_radius(&self, r_mm: f64) -> f64 {
        (r_mm * r_mm - self.r_b_mm * self.r_b_mm).max(0.0).sqrt()
    }

    /// Radius of roll distance w: r = √(r_b² + w²).
    pub fn radius_from_roll(&self, w_mm: f64) -> f64 {
        (self.r_b_mm * self.r_b_mm + w_mm * w_mm).sqrt()
    }

    /// inv α at roll distance w, in roll form: w/r_b − atan(w/r_b).
    fn inv_at_roll(&self, w_mm: f64) -> f64 {
        let u = w_mm / self.r_b_mm;
        u - u.atan()
    }

    /// η_F, angular position of a flank: the gap is centred on z = 0 in the axial section at
    /// polar angle π, its axial width at d_S/2 being half the axial pitch (less the thickening).
    ///
    /// # Formula
    /// η = π − s·inv(r_ref) + s·(p_x/4 − t/sin β_b)/p,  r_ref = d_S/2, t = thickening
    /// # Source
    /// docs/dressing.md "Derivation: worm helicoid" (thread half the axial pitch) [RECONSTRUCTED]
    pub fn eta(&self, flank: Flank) -> f64 {
        let s = flank.sign();
        let r_ref = self.d_s_mm / 2.0;
        let half_gap = self.axial_pitch_mm() / 4.0 - self.thicken_mm / self.beta_b_rad.sin();
        PI - s * self.inv_at_roll(self.roll_from_radius(r_ref)) + s * half_gap / self.p_mm
    }

    /// E_F(w, b): point of the flank at roll distance w and axial position b (worm frame).
    ///
    /// # Formula
    /// E_F(w, b) = R_z(s_F w / r_b + b / p + η_F) · (r_b, −s_F w, b)
    /// # Source
    /// JP6903407B2, eq. (27) (drawing lost); form of docs/dressing.md "Derivation: worm helicoid" [RECONSTRUCTED]
    pub fn point(&self, flank: Flank, w_mm: f64, b_mm: f64) -> Vector3<f64> {
        let s = flank.sign();
        let th = s * w_mm / self.r_b_mm + b_mm / self.p_mm + self.eta(flank);
        let (sn, cs) = th.sin_cos();
        let (x, y) = (self.r_b_mm, -s * w_mm);
        Vector3::new(cs * x - sn * y, sn * x + cs * y, b_mm)
    }

    /// Outward unit normal (out of the thread material, into the gap) at E_F(w, b).
    ///
    /// # Formula
    /// n = s_F · R_z(θ) · (0, −cos β_b, sin β_b), θ = s_F w / r_b + b / p + η_F
    /// (∂E/∂w × ∂E/∂b normalised; |n_z| = sin β_b)
    /// # Source
    /// docs/dressing.md "Derivation: worm helicoid", eq. (27) [RECONSTRUCTED]
    pub fn normal(&self, flank: Flank, w_mm: f64, b_mm: f64) -> Vector3<f64> {
        let s = flank.sign();
        let th = s * w_mm / self.r_b_mm + b_mm / self.p_mm + self.eta(flank);
        let (sn, cs) = th.sin_cos();
        let (cb, sb) = (self.beta_b_rad.cos(), self.beta_b_rad.sin());
        Vector3::new(s * sn * cb, -s * cs * cb, s * sb)
    }

    /// Axial position b at which the point of roll distance w lies in the axial section ψ = π.
    pub fn b_axial_section(&self, flank: Flank, w_mm: f64) -> f64 {
        let s = flank.sign();
        self.p_mm * (PI - self.eta(flank) - s * self.inv_at_roll(w_mm))
    }
}
