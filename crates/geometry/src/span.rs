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

    /// W_k for k (unchecked): (k − 1)·p_bn + s_bn (internal: e_bn), in mm.
    fn span_unchecked_mm(&self, k: u32, shift: f64) -> f64 {
        f64::from(k.saturating_sub(1)) * self.dims().normal_base_pitch_mm
            + self.span_base_part_mm(shift)
    }

    /// Diameter at which the anvils of a span W_k touch the flanks, in mm.
    ///
    /// The anvils are two parallel planes normal to a plane tangent to the base cylinder;
    /// in that plane each involute helicoid is a straight line inclined by β_b to the axis,
    /// and W_k is the distance between the two lines. The common perpendicular is inclined
    /// by β_b to the transverse direction, so the contact points lie W_k·cos β_b/2 on either
    /// side of the line where the plane touches the base cylinder (transverse offset) and
    /// W_k·sin β_b apart axially (docs/geometry.md, "Span k").
    ///
    /// # Formula
    /// d_M = √(d_b² + (W_k·cos β_b)²)
    /// # Source
    /// DIN 3960:1987, 3.6.4 [STANDARD]; construction in the base tangent plane [DERIVED]
    pub fn span_contact_diameter_mm(&self, span_mm: f64) -> f64 {
        let d_b = self.dims().base_diameter_mm;
        let w_t = span_mm * self.dims().base_helix_angle_rad.cos();
        (d_b * d_b + w_t * w_t).sqrt()
    }

    /// Span W_k over k teeth (external) or k spaces (internal) for profile shift x, with the
    /// diameter where the anvils touch; checks that they touch the usable flank and that a
    /// helical span fits in the face width.
    ///
    /// # Formula
    /// external: W_k = m_n·cos α_n·[(k − 0.5)·π + z·inv α_t] + 2·x·m_n·sin α_n
    /// internal: W_k = m_n·cos α_n·[(k − 0.5)·π + z·inv α_t] − 2·x·m_n·sin α_n
    /// (evaluated as (k − 1)·p_bn + s_bn, s_bn = d_b·cos β_b·(s_t/d + inv α_t));
    /// d_M = √(d_b² + (W_k·cos β_b)²); axial extent W_k·sin β_b < b
    /// # Domain
    /// 1 ≤ k ≤ z − 1
    /// # Source
    /// ISO 21771:2007, 5.5.1 [STANDARD]; DIN 3960:1987, 3.6.4 [STANDARD];
    /// TV1: W_2 = 4.7083 mm [PUBLISHED]
    pub fn span(&self, k: u32, shift: f64) -> Result<Span> {
        self.span_named("span_k", k, shift)
    }

    fn span_named(&self, name: &'static str, k: u32, shift: f64) -> Result<Span> {
        let z = self.spec().teeth;
        check_range(name, f64::from(k), 1.0, f64::from(z - 1), "", false)?;
        check_range("profile_shift", shift, -MAX_SHIFT, MAX_SHIFT, "", false)?;
        let w = self.span_unchecked_mm(k, shift);
        let d_m = self.span_contact_diameter_mm(w);
        let (lo, hi) = self.flank_range_mm(shift);
        if !(w > 0.0 && d_m >= lo && d_m <= hi) {
            return Err(GeometryError::OffFlank {
                name,
                value: f64::from(k),
                contact_diameter_mm: d_m,
                min_mm: lo,
                max_mm: hi,
            });
        }
        self.check_span_width(name, k, w)?;
        Ok(Span {
            k,
            span_mm: w,
            contact_diameter_mm: d_m,
        })
    }

    /// A helical span must fit in the face width: W_k·sin β_b < b.
    fn check_span_width(&self, name: &'static str, k: u32, span_mm: f64) -> Result<()> {
        if let Some(b) = self.spec().face_width_mm {
            let beta_b = self.dims().base_helix_angle_rad;
            let axial = span_mm * beta_b.sin();
            if axial >= b {
                return Err(GeometryError::SpanTooWide {
                    name,
                    k,
                    span_mm,
                    axial_mm: axial,
                    face_width_mm: b,
                    base_helix_deg: beta_b.to_degrees(),
                });
            }
        }
        Ok(())
    }

    /// The k whose anvils touch the usable flank at shift x, as an inclusive range
    /// (k_lo > k_hi when none does); the face width is not considered.
    fn span_k_flank_window(&self, shift: f64) -> (u32, u32) {
        let z_max = self.spec().teeth - 1;
        let (lo, hi) = self.flank_range_mm(shift);
        let ok = |k: u32| {
            let w = self.span_unchecked_mm(k, shift);
            let d_m = self.span_contact_diameter_mm(w);
            w > 0.0 && d_m >= lo && d_m <= hi
        };
        // d_M grows with k, so the valid k form one run; start from the closed form and
        // correct by whole steps (rounding at the ends).
        let d_b = self.dims().base_diameter_mm;
        let cb = self.dims().base_helix_angle_rad.cos();
        let p_bn = self.dims().normal_base_pitch_mm;
        let base = self.span_base_part_mm(shift);
        let k_of = |d: f64| ((d * d - d_b * d_b).max(0.0).sqrt() / cb - base) / p_bn + 1.0;
        let clamp = |k: f64| {
            if k.is_finite() {
                // Clamped to 1…z−1, so the cast is exact.
                k.clamp(1.0, f64::from(z_max)) as u32
            } else {
                1
            }
        };
        let mut k_lo = clamp(k_of(lo).ceil());
        while k_lo > 1 && ok(k_lo - 1) {
            k_lo -= 1;
        }
        while k_lo <= z_max && !ok(k_lo) {
            k_lo += 1;
        }
        let mut k_hi = clamp(k_of(hi).floor());
        while k_hi < z_max && ok(k_hi + 1) {
            k_hi += 1;
        }
        while k_hi >= 1 && !ok(k_hi) {
            k_hi -= 1;
        }
        (k_lo, k_hi)
    }

    /// Recommended k (DIN 3960): the k whose anvils touch nearest the circle
    /// d + 2·σ·x·m_n (the reference circle moved with the profile shift), limited to the k
    /// that touch the usable flank and fit in the face width.
    ///
    /// # Formula
    /// k = round(k′), k′ = (W* − s_bn)/p_bn + 1, W* = √(d*² − d_b²)/cos β_b,
    /// d* = d + 2·σ·x·m_n; for external gears this is DIN 3960's
    /// k′ = z/π·[tan α_Mt/cos²β_b − 2·x·tan α_n/z − inv α_t] + 0.5, cos α_Mt = d_b/d*.
    /// For a spur gear with x = 0: k = round(z·α/180° + 0.5).
    /// # Source
    /// DIN 3960:1987, 3.6.4 (contact near the middle of the tooth height) [STANDARD]
    pub fn recommended_span_k(&self, shift: f64) -> Result<u32> {
        self.recommended_span_k_for(shift, &[])
    }

    /// [`Gear::recommended_span_k`] for the nominal shift x, limited further to the k that
    /// are valid (on the flank, within the face width) at every shift in `also` (e.g. the
    /// generating shifts of the thickness allowances), so the recommended k never fails for
    /// any of them.
    ///
    /// # Source
    /// DIN 3960:1987, 3.6.4 [STANDARD]
    pub fn recommended_span_k_for(&self, shift: f64, also: &[f64]) -> Result<u32> {
        check_range("profile_shift", shift, -MAX_SHIFT, MAX_SHIFT, "", false)?;
        for &s in also {
            check_range("profile_shift", s, -MAX_SHIFT, MAX_SHIFT, "", false)?;
        }
        let d = self.dims().reference_diameter_mm;
        let d_b = self.dims().base_diameter_mm;
        let target = d + 2.0 * self.sigma() * shift * self.spec().normal_module_mm;
        let w_star =
            (target * target - d_b * d_b).max(0.0).sqrt() / self.dims().base_helix_angle_rad.cos();
        let k_cont =
            (w_star - self.span_base_part_mm(shift)) / self.dims().normal_base_pitch_mm + 1.0;
        let z_max = self.spec().teeth - 1;
        let (mut k_lo, mut k_hi) = self.span_k_flank_window(shift);
        for &s in also {
            let (a, b) = self.span_k_flank_window(s);
            k_lo = k_lo.max(a);
            k_hi = k_hi.min(b);
        }
        if k_lo > k_hi || k_lo < 1 || k_hi > z_max {
            let (lo, hi) = self.flank_range_mm(shift);
            return Err(GeometryError::OffFlank {
                name: "span_k (no k from 1 to z − 1 touches the usable flank; measure over balls)",
                value: k_cont.round(),
                contact_diameter_mm: target,
                min_mm: lo,
                max_mm: hi,
            });
        }
        // W_k·sin β_b grows with k: the widest fitting k bounds the window from above.
        let widest = |s: f64| self.span_unchecked_mm(k_lo, s);
        let name = "span_k (smallest k that touches the flank)";
        self.check_span_width(name, k_lo, widest(shift))?;
        for &s in also {
            self.check_span_width(name, k_lo, widest(s))?;
        }
        let fits = |k: u32| {
            self.check_span_width("span_k", k, self.span_unchecked_mm(k, shift))
                .is_ok()
                && also.iter().all(|&s| {
                    self.check_span_width("span_k", k, self.span_unchecked_mm(k, s))
                        .is_ok()
                })
        };
        while k_hi > k_lo && !fits(k_hi) {
            k_hi -= 1;
        }
        let k_din = if k_cont.is_finite() {
            k_cont.round().clamp(1.0, f64::from(z_max))
        } else {
            1.0
        };
        // Clamped to 1…z−1, so the cast is exact.
        Ok((k_din as u32).clamp(k_lo, k_hi))
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
}
