//! Span measurement (base tangent length) W_k over k teeth, its inverse and the
//! recommended k.

use std::f64::consts::{FRAC_PI_2, PI};

use serde::Serialize;

use crate::error::{check_range, GeometryError, Result};
use crate::gear::{Gear, Mesh, MAX_SHIFT};

/// A span measurement over k teeth (external) or k spaces (internal).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Span {
    /// Number of teeth (external) or spaces (internal) spanned.
    pub k: u32,
    /// Base tangent length W_k in mm.
    pub span_mm: f64,
    /// Diameter at which the anvils touch the flanks d_M, in mm.
    pub contact_diameter_mm: f64,
}

impl Gear {
    /// The part of W_k that does not depend on k: W_k = (k − 1)·p_bn + this, in mm.
    ///
    /// External: the normal base tooth thickness s_bn; internal: the normal base space
    /// width e_bn (the internal gear's gap has the shape of an external tooth).
    fn span_base_part_mm(&self, shift: f64) -> f64 {
        let z = f64::from(self.spec().teeth);
        let q = (FRAC_PI_2 + 2.0 * shift * self.tan_alpha_n) / z;
        let sigma = self.sigma();
        let gap = if self.spec().mesh == Mesh::Internal {
            PI / z
        } else {
            0.0
        };
        self.base_normal_factor_mm() * (sigma * q + self.inv_alpha_t + gap)
    }

    /// d_b·cos β_b = z·m_n·cos α_n, the base-cylinder length per radian in the normal plane.
    #[inline]
    pub(crate) fn base_normal_factor_mm(&self) -> f64 {
        self.dims().base_diameter_mm * self.dims().base_helix_angle_rad.cos()
    }

    /// Span W_k over k teeth (external) or k spaces (internal) for profile shift x, with the
    /// diameter where the anvils touch; checks that they touch the usable flank and that a
    /// helical span fits in the face width.
    ///
    /// # Formula
    /// external: W_k = m_n·cos α_n·[(k − 0.5)·π + z·inv α_t] + 2·x·m_n·sin α_n
    /// internal: W_k = m_n·cos α_n·[(k − 0.5)·π + z·inv α_t] − 2·x·m_n·sin α_n
    /// (evaluated as (k − 1)·p_bn + s_bn, s_bn = d_b·cos β_b·(s_t/d + inv α_t));
    /// d_M = √(d_b² + (W_k / cos β_b)²)
    /// # Domain
    /// 1 ≤ k ≤ z − 1
    /// # Source
    /// ISO 21771:2007, 5.5.1 [STANDARD]; TV1: W_2 = 4.7083 mm [PUBLISHED]
    pub fn span(&self, k: u32, shift: f64) -> Result<Span> {
        let z = self.spec().teeth;
        check_range("span_k", f64::from(k), 1.0, f64::from(z - 1), "", false)?;
        check_range("profile_shift", shift, -MAX_SHIFT, MAX_SHIFT, "", false)?;
        let w = f64::from(k - 1) * self.dims().normal_base_pitch_mm + self.span_base_part_mm(shift);
        let beta_b = self.dims().base_helix_angle_rad;
        let d_b = self.dims().base_diameter_mm;
        let w_t = w / beta_b.cos();
        let d_m = (d_b * d_b + w_t * w_t).sqrt();
        let (lo, hi) = self.flank_range_mm(shift);
        if !(w > 0.0 && d_m >= lo && d_m <= hi) {
            return Err(GeometryError::OffFlank {
                name: "span_k",
                value: f64::from(k),
                contact_diameter_mm: d_m,
                min_mm: lo,
                max_mm: hi,
            });
        }
        if let Some(b) = self.spec().face_width_mm {
            let axial = w * beta_b.sin();
            if axial >= b {
                return Err(GeometryError::OutOfRange {
                    name: "span axial extent W_k·sin β_b (must fit in the face width b)",
                    value: axial,
                    min: 0.0,
                    max: b,
                    unit: "mm",
                });
            }
        }
        Ok(Span {
            k,
            span_mm: w,
            contact_diameter_mm: d_m,
        })
    }

    /// Normal tooth thickness s_n at the reference circle that a measured span W_k means.
    ///
    /// # Formula
    /// s_bn = W_k − (k − 1)·p_bn (internal: e_bn); s_n = z·m_n·[σ·(s_bn/(d_b·cos β_b) − inv α_t − g)],
    /// g = 0 external, π/z internal
    /// # Source
    /// inverse of ISO 21771:2007, 5.5.1 [DERIVED]
    pub fn normal_thickness_from_span(&self, k: u32, span_mm: f64) -> Result<f64> {
        let z = self.spec().teeth;
        check_range("span_k", f64::from(k), 1.0, f64::from(z - 1), "", false)?;
        check_range("span_mm", span_mm, 0.0, 1e6, "mm", true)?;
        let zf = f64::from(z);
        let base = (span_mm - f64::from(k - 1) * self.dims().normal_base_pitch_mm)
            / self.base_normal_factor_mm();
        let gap = if self.spec().mesh == Mesh::Internal {
            PI / zf
        } else {
            0.0
        };
        let q = self.sigma() * (base - self.inv_alpha_t - gap);
        Ok(q * zf * self.spec().normal_module_mm)
    }

    /// Recommended k: the anvils touch nearest to the circle d + 2·σ·x·m_n (the reference
    /// circle moved with the profile shift), among the k whose contact is on the flank.
    ///
    /// # Formula
    /// k′ = (W* − s_bn)/p_bn + 1, W* = cos β_b·√(d*² − d_b²), d* = d + 2·σ·x·m_n;
    /// k = round(k′) limited to 1…z−1, then the neighbour with the nearer valid contact.
    /// For a spur gear with x = 0 this is k = round(z·α/180° + 0.5).
    /// # Source
    /// DIN 3960:1987, 3.6.4 (contact near the middle of the tooth height) [STANDARD],
    /// closed form for x = 0 [DERIVED]
    pub fn recommended_span_k(&self, shift: f64) -> Result<u32> {
        check_range("profile_shift", shift, -MAX_SHIFT, MAX_SHIFT, "", false)?;
        let d = self.dims().reference_diameter_mm;
        let d_b = self.dims().base_diameter_mm;
        let (lo, hi) = self.flank_range_mm(shift);
        let target = (d + 2.0 * self.sigma() * shift * self.spec().normal_module_mm).clamp(lo, hi);
        let w_star =
            self.dims().base_helix_angle_rad.cos() * (target * target - d_b * d_b).max(0.0).sqrt();
        let k_cont =
            (w_star - self.span_base_part_mm(shift)) / self.dims().normal_base_pitch_mm + 1.0;
        let z_max = f64::from(self.spec().teeth - 1);
        let k0 = k_cont.round().clamp(1.0, z_max);
        let mut best: Option<(f64, u32)> = None;
        for dk in [-1.0, 0.0, 1.0] {
            let kf = k0 + dk;
            if !(1.0..=z_max).contains(&kf) {
                continue;
            }
            // kf is an integer in 1..=z−1, so the cast is exact.
            let k = kf as u32;
            if let Ok(s) = self.span(k, shift) {
                let dist = (s.contact_diameter_mm - target).abs();
                if best.is_none_or(|(bd, _)| dist < bd - 1e-12) {
                    best = Some((dist, k));
                }
            }
        }
        best.map(|(_, k)| k).ok_or(GeometryError::OffFlank {
            name: "span_k",
            value: k0,
            contact_diameter_mm: target,
            min_mm: lo,
            max_mm: hi,
        })
    }
}
