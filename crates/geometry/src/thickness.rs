//! Tooth thickness and space width at any diameter, transverse and normal.

use std::f64::consts::{FRAC_PI_2, PI};

use crate::error::{check_range, GeometryError, Result};
use crate::gear::{Gear, MAX_SHIFT};
use crate::involute::inv;

impl Gear {
    /// Half the angle the tooth subtends at diameter d_y, ψ_y = s_yt/d_y, in rad.
    ///
    /// # Formula
    /// ψ_y = (π/2 + 2·x·tan α_n)/z + σ·(inv α_t − inv α_yt),  cos α_yt = d_b/d_y,
    /// σ = +1 external, −1 internal (the internal tooth widens towards its root)
    /// # Source
    /// ISO 21771:2007, 5.3.3 (internal gears with z < 0 rewritten) [STANDARD]
    pub(crate) fn tooth_half_angle(&self, diameter_mm: f64, shift: f64) -> Result<f64> {
        let d_b = self.dims().base_diameter_mm;
        check_range("diameter_mm", diameter_mm, d_b, 1e7, "mm", false)?;
        check_range("profile_shift", shift, -MAX_SHIFT, MAX_SHIFT, "", false)?;
        let alpha_y = (d_b / diameter_mm).min(1.0).acos();
        Ok(
            (FRAC_PI_2 + 2.0 * shift * self.tan_alpha_n) / f64::from(self.spec().teeth)
                + self.sigma() * (self.inv_alpha_t - inv(alpha_y)),
        )
    }

    /// Transverse (arc) tooth thickness s_yt at diameter d_y for profile shift x, in mm.
    ///
    /// Negative where the tooth has already come to a point.
    ///
    /// # Formula
    /// s_yt = d_y·[(π/2 + 2·x·tan α_n)/z + σ·(inv α_t − inv α_yt)]
    /// # Domain
    /// d_y ≥ d_b (the involute does not exist inside the base circle)
    /// # Source
    /// ISO 21771:2007, 5.3.3 [STANDARD]
    pub fn transverse_thickness_at_mm(&self, diameter_mm: f64, shift: f64) -> Result<f64> {
        Ok(diameter_mm * self.tooth_half_angle(diameter_mm, shift)?)
    }

    /// Normal (arc) tooth thickness s_yn at diameter d_y for profile shift x, in mm.
    ///
    /// # Formula
    /// s_yn = s_yt·cos β_y,  tan β_y = tan β·d_y/d
    /// # Source
    /// ISO 21771:2007, 5.3.3 [STANDARD]
    pub fn normal_thickness_at_mm(&self, diameter_mm: f64, shift: f64) -> Result<f64> {
        let s_yt = self.transverse_thickness_at_mm(diameter_mm, shift)?;
        let beta_y = (self.spec().helix_angle_rad.tan() * diameter_mm
            / self.dims().reference_diameter_mm)
            .atan();
        Ok(s_yt * beta_y.cos())
    }

    /// Transverse (arc) space width e_yt at diameter d_y for profile shift x, in mm; for an
    /// internal gear the gap the mating tooth enters.
    ///
    /// # Formula
    /// e_yt = π·d_y/z − s_yt
    /// # Source
    /// ISO 21771:2007, 5.3.4 [STANDARD]
    pub fn space_width_at_mm(&self, diameter_mm: f64, shift: f64) -> Result<f64> {
        let s = self.transverse_thickness_at_mm(diameter_mm, shift)?;
        Ok(PI * diameter_mm / f64::from(self.spec().teeth) - s)
    }

    /// Normal tooth thickness at the tip circle s_an for profile shift x, in mm.
    ///
    /// # Formula
    /// s_an = s_at·cos β_a with s_at from [`Gear::transverse_thickness_at_mm`] at d_a
    /// # Source
    /// ISO 21771:2007, 5.3.3 [STANDARD]; TV1: s_an = 0.6949 mm [PUBLISHED]
    pub fn tip_normal_thickness_mm(&self, shift: f64) -> Result<f64> {
        let d_a = self.dims().tip_diameter_mm;
        if d_a.is_nan() || d_a < self.dims().base_diameter_mm {
            return Err(GeometryError::OutOfRange {
                name: "tip diameter d_a",
                value: d_a,
                min: self.dims().base_diameter_mm,
                max: f64::INFINITY,
                unit: "mm",
            });
        }
        self.normal_thickness_at_mm(d_a, shift)
    }
}
