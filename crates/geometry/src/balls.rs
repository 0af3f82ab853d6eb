//! Dimension over (external) or between (internal) two balls M_dK, its inverse and the
//! recommended ball diameter.

use std::f64::consts::{FRAC_PI_2, PI};

use serde::Serialize;

use crate::error::{check_range, GeometryError, Result};
use crate::gear::{Gear, MAX_SHIFT};
use crate::involute::{inv, inv_inverse};

/// A measurement over two balls placed in one transverse plane.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BallMeasurement {
    /// Ball diameter D_M in mm.
    pub ball_mm: f64,
    /// Dimension over balls (external) or between balls (internal) M_dK in mm.
    pub dimension_mm: f64,
    /// Diameter of the circle through the ball centres d_K in mm.
    pub centre_diameter_mm: f64,
    /// Diameter where the ball touches the flanks in mm.
    pub contact_diameter_mm: f64,
    /// Whether the balls stand out beyond the tip circle, so the anvils touch only them.
    pub protrudes_beyond_tip: bool,
}

/// The recommended ball of [`Gear::recommended_ball`] and where it touches.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RecommendedBall {
    /// Ball diameter D_M in mm.
    pub ball_mm: f64,
    /// Diameter where the ball touches the flanks, in mm.
    pub contact_diameter_mm: f64,
    /// The circle d + 2·σ·x·m_n the ball is meant to touch, in mm.
    pub target_diameter_mm: f64,
    /// Whether the ball touches on that circle (false: it lies off the usable flank and the
    /// ball touches at the middle of the usable flank).
    pub at_target: bool,
}

impl Gear {
    /// inv α_Kt of the ball centre for ball diameter D_M and profile shift x.
    ///
    /// # Formula
    /// inv α_Kt = inv α_t + σ·[D_M/(d_b·cos β_b) − π/z + (π/2 + 2·x·tan α_n)/z]
    fn ball_centre_inv(&self, ball_mm: f64, shift: f64) -> f64 {
        let z = f64::from(self.spec().teeth);
        let q = (FRAC_PI_2 + 2.0 * shift * self.tan_alpha_n) / z;
        self.inv_alpha_t + self.sigma() * (ball_mm / self.base_normal_factor_mm() - PI / z + q)
    }

    /// 1 for an even tooth count, cos(π/(2z)) for an odd one (balls in gaps not opposite).
    fn odd_factor(&self) -> f64 {
        let z = self.spec().teeth;
        if z.is_multiple_of(2) {
            1.0
        } else {
            (FRAC_PI_2 / f64::from(z)).cos()
        }
    }

    /// Ball centre diameter d_K, contact diameter and the contact's roll length ℓ_c (signed
    /// distance from the base-circle tangent point, in the transverse plane) for D_M and x,
    /// without range checks (d_c NaN where the contact would lie inside the base circle, all
    /// NaN where the ball cannot sit in the gap).
    fn ball_geometry(&self, ball_mm: f64, shift: f64) -> (f64, f64, f64) {
        let v = self.ball_centre_inv(ball_mm, shift);
        let alpha_k = inv_inverse(v);
        let r_b = self.r_b();
        let d_k = self.dims().base_diameter_mm / alpha_k.cos();
        // The contact lies D_M/2 from the centre along the flank normal, which is tangent to
        // the base cylinder and inclined by β_b to the transverse plane.
        let l_k = r_b * alpha_k.tan();
        let l_c = l_k - self.sigma() * 0.5 * ball_mm * self.dims().base_helix_angle_rad.cos();
        let d_c = if l_c >= 0.0 {
            2.0 * (r_b * r_b + l_c * l_c).sqrt()
        } else {
            f64::NAN
        };
        (d_k, d_c, l_c)
    }

    /// The ball diameter D_M (0 < D_M ≤ 5·m_n) whose contact lies on the circle of diameter
    /// `contact_mm`, or None.
    ///
    /// Solved on the pressure angle α_K of the ball centre, not on D_M: D_M is affine in
    /// inv α_K, D_M = d_b·cos β_b·(σ·(inv α_K − inv α_t) + π/z − (π/2 + 2·x·tan α_n)/z), and the
    /// contact's roll length ℓ_c(α_K) = r_b·tan α_K − σ·(D_M/2)·cos β_b then has the derivative
    /// r_b·(sec²α_K − cos²β_b·tan²α_K) > 0 for both kinds of gear: one root, found by bisection
    /// over the whole of 0 ≤ α_K < π/2. (A scan over D_M missed it at small pressure angles,
    /// where ℓ_c rises by ~1/(2·tan²α) mm per mm of D_M and the root lies within one step of
    /// the smallest ball that fits the gap.)
    fn ball_for_contact_mm(&self, shift: f64, contact_mm: f64) -> Option<f64> {
        let m_n = self.spec().normal_module_mm;
        let r_b = self.r_b();
        let r_t = 0.5 * contact_mm;
        if !(r_t.is_finite() && r_t >= r_b) {
            return None;
        }
        let l_t = ((r_t - r_b) * (r_t + r_b)).sqrt();
        let z = f64::from(self.spec().teeth);
        let sigma = self.sigma();
        let q = (FRAC_PI_2 + 2.0 * shift * self.tan_alpha_n) / z;
        let factor = self.base_normal_factor_mm();
        let cos_bb = self.dims().base_helix_angle_rad.cos();
        let ball_at =
            |alpha_k: f64| factor * (sigma * (inv(alpha_k) - self.inv_alpha_t) + PI / z - q);
        let g = |alpha_k: f64| r_b * alpha_k.tan() - sigma * 0.5 * ball_at(alpha_k) * cos_bb - l_t;
        let (mut a, mut b) = (0.0, FRAC_PI_2 - 1e-9);
        if !(g(a) <= 0.0 && g(b) >= 0.0) {
            return None;
        }
        for _ in 0..200 {
            let mid = 0.5 * (a + b);
            if mid <= a || mid >= b {
                break;
            }
            if g(mid) <= 0.0 {
                a = mid;
            } else {
                b = mid;
            }
        }
        let alpha_k = 0.5 * (a + b);
        let ball = ball_at(alpha_k);
        (ball.is_finite() && ball > 0.0 && ball <= 5.0 * m_n).then_some(ball)
    }

    /// The range of ball diameters (within 0 < D_M ≤ 5·m_n) whose contact lies on the usable
    /// flank at shift x, in mm; (NaN, NaN) if none does.
    pub fn ball_range_mm(&self, shift: f64) -> (f64, f64) {
        let m_n = self.spec().normal_module_mm;
        let (lo, hi) = self.flank_range_mm(shift);
        let on_flank = |ball: f64| {
            let (d_k, d_c, _) = self.ball_geometry(ball, shift);
            d_k.is_finite() && d_c >= lo && d_c <= hi
        };
        // Scan (0, 5·m_n] for the run of balls on the flank (one run: d_c is monotone where
        // the ball fits), then refine both edges by bisection on the predicate.
        let n = 1000;
        let d_max = 5.0 * m_n;
        let at = |i: u32| d_max * f64::from(i) / f64::from(n);
        let mut first = None;
        let mut last = None;
        for i in 1..=n {
            if on_flank(at(i)) {
                first.get_or_insert(i);
                last = Some(i);
            }
        }
        let (Some(first), Some(last)) = (first, last) else {
            return (f64::NAN, f64::NAN);
        };
        let refine = |mut inside: f64, mut outside: f64| {
            for _ in 0..80 {
                let mid = 0.5 * (inside + outside);
                if on_flank(mid) {
                    inside = mid;
                } else {
                    outside = mid;
                }
            }
            inside
        };
        let mut a = if first == 1 {
            refine(at(1), 0.0)
        } else {
            refine(at(first), at(first - 1))
        };
        let mut b = if last == n {
            d_max
        } else {
            refine(at(last), at(last + 1))
        };
        // Round inwards to 1e-6 mm so every ball inside the printed range is accepted.
        if a.is_finite() {
            a = (a * 1e6).ceil() / 1e6;
        }
        if b.is_finite() {
            b = (b * 1e6).floor() / 1e6;
        }
        (a, b)
    }

    /// Dimension over two balls (external) or between two balls (internal) M_dK for ball
    /// diameter D_M and profile shift x (balls in one transverse plane).
    ///
    /// # Formula
    /// inv α_Kt = inv α_t + σ·[D_M/(z·m_n·cos α_n) − (π/2 − 2·x·tan α_n)/z];
    /// d_K = d_b / cos α_Kt;
    /// M_dK = d_K + σ·D_M (z even), d_K·cos(90°/z) + σ·D_M (z odd);
    /// contact: ℓ_c = r_b·tan α_Kt − σ·(D_M/2)·cos β_b, d_c = 2·√(r_b² + ℓ_c²)
    /// # Domain
    /// 0 < D_M ≤ 5·m_n, and the contact must lie on the usable flank
    /// # Source
    /// ISO 21771:2007, 5.5.2 / DIN 3960:1987, 3.6.5 (z < 0 rewritten with σ) [STANDARD];
    /// contact diameter [DERIVED]; TV1: 22.2941 mm, TV2: 32.1641/32.2380 mm [PUBLISHED]
    pub fn ball_dimension(&self, ball_mm: f64, shift: f64) -> Result<BallMeasurement> {
        let m_n = self.spec().normal_module_mm;
        check_range("ball_mm", ball_mm, 0.0, 5.0 * m_n, "mm", false)?;
        if ball_mm <= 0.0 {
            return Err(GeometryError::OutOfRange {
                name: "ball_mm",
                value: ball_mm,
                min: 0.0,
                max: 5.0 * m_n,
                unit: "mm",
            });
        }
        check_range("profile_shift", shift, -MAX_SHIFT, MAX_SHIFT, "", false)?;
        let (d_k, d_c, _) = self.ball_geometry(ball_mm, shift);
        let (lo, hi) = self.flank_range_mm(shift);
        if !(d_k.is_finite() && d_c >= lo && d_c <= hi) {
            let (min_ball_mm, max_ball_mm) = self.ball_range_mm(shift);
            return Err(GeometryError::BallOffFlank {
                name: "ball_mm",
                ball_mm,
                min_ball_mm,
                max_ball_mm,
                flank_min_mm: lo,
                flank_max_mm: hi,
            });
        }
        let sigma = self.sigma();
        let d_a = self.dims().tip_diameter_mm;
        Ok(BallMeasurement {
            ball_mm,
            dimension_mm: d_k * self.odd_factor() + sigma * ball_mm,
            centre_diameter_mm: d_k,
            contact_diameter_mm: d_c,
            protrudes_beyond_tip: sigma * (d_k + sigma * ball_mm - d_a) > 0.0,
        })
    }

    /// Normal tooth thickness s_n at the reference circle that a measured M_dK means.
    ///
    /// # Formula
    /// d_K = (M_dK − σ·D_M)/c (c = 1 even z, cos(90°/z) odd z); cos α_Kt = d_b/d_K;
    /// s_n = z·m_n·[σ·(inv α_Kt − inv α_t) − D_M/(d_b·cos β_b) + π/z]
    /// # Source
    /// inverse of ISO 21771:2007, 5.5.2 [DERIVED]
    pub fn normal_thickness_from_ball_dimension(
        &self,
        ball_mm: f64,
        dimension_mm: f64,
    ) -> Result<f64> {
        let m_n = self.spec().normal_module_mm;
        check_range("ball_mm", ball_mm, 0.0, 5.0 * m_n, "mm", true)?;
        let d_b = self.dims().base_diameter_mm;
        let sigma = self.sigma();
        let d_k_max = 10.0 * self.dims().reference_diameter_mm;
        let d_k = (dimension_mm - sigma * ball_mm) / self.odd_factor();
        if !(d_k.is_finite() && d_k > d_b && d_k < d_k_max) {
            return Err(GeometryError::OutOfRange {
                name: "ball dimension M_dK (ball centres outside the base circle)",
                value: dimension_mm,
                min: d_b * self.odd_factor() + sigma * ball_mm,
                max: d_k_max * self.odd_factor() + sigma * ball_mm,
                unit: "mm",
            });
        }
        let z = f64::from(self.spec().teeth);
        let inv_k = inv((d_b / d_k).acos());
        let q =
            sigma * (inv_k - self.inv_alpha_t) - ball_mm / self.base_normal_factor_mm() + PI / z;
        Ok(q * z * m_n)
    }

    /// Recommended ball diameter D_M: the ball touches the flanks on the circle
    /// d + 2·σ·x·m_n (the reference circle moved with the profile shift); see
    /// [`Gear::recommended_ball`] for where it touches when that circle is off the flank.
    ///
    /// Exact value, not rounded to a catalogue ball: pick the nearest ball you own and check
    /// it with [`Gear::ball_dimension`]. For x = 0 spur gears it is 1.7244·m_n at z = 20,
    /// 1.6967·m_n at z = 40 and tends to π/(2·cos α_n)·m_n = 1.6716·m_n for a rack (the
    /// source of DIN 3960's rule of thumb D_M ≈ 1.68·m_n).
    ///
    /// # Formula
    /// find D_M with d_c(D_M) = d + 2·σ·x·m_n (d_c from [`Gear::ball_dimension`])
    /// # Source
    /// DIN 3960:1987, 3.6.5 (ball touching near the reference circle) [STANDARD]; solved
    /// exactly here [DERIVED]
    pub fn recommended_ball_mm(&self, shift: f64) -> Result<f64> {
        self.recommended_ball(shift).map(|b| b.ball_mm)
    }

    /// The recommended ball with the diameter it really touches.
    ///
    /// The ball touches on d + 2·σ·x·m_n when that circle lies on the usable flank
    /// ([`Gear::flank_range_mm`]). When it does not (an undercut gear with a negative shift,
    /// whose target circle lies below the usable flank that starts at the base circle), the
    /// ball touches instead at the middle of the usable flank, (d_Fmin + d_Fmax)/2: a
    /// documented fallback that keeps the contact off the base circle, where the involute
    /// has no curvature to measure on ([`RecommendedBall::at_target`] is then false).
    ///
    /// # Source
    /// DIN 3960:1987, 3.6.5 [STANDARD]; fallback contact [DERIVED]
    pub fn recommended_ball(&self, shift: f64) -> Result<RecommendedBall> {
        check_range("profile_shift", shift, -MAX_SHIFT, MAX_SHIFT, "", false)?;
        let m_n = self.spec().normal_module_mm;
        let (lo, hi) = self.flank_range_mm(shift);
        let target_mm = self.dims().reference_diameter_mm + 2.0 * self.sigma() * shift * m_n;
        let at_target = target_mm >= lo && target_mm <= hi;
        let aim = if at_target {
            target_mm
        } else {
            0.5 * (lo + hi)
        };
        let (b_lo, b_hi) = self.ball_range_mm(shift);
        let on_range = b_lo.is_finite() && b_hi >= b_lo;
        let ball_mm = match self.ball_for_contact_mm(shift, aim) {
            // The exact ball lies inside the accepted range unless the aim is within
            // rounding (1e-6 mm of ball) of a flank end: keep it measurable.
            Some(b) if on_range => b.clamp(b_lo, b_hi),
            Some(b) => b,
            None if on_range => {
                let dist = |b: f64| (self.ball_geometry(b, shift).1 - aim).abs();
                if dist(b_lo) <= dist(b_hi) {
                    b_lo
                } else {
                    b_hi
                }
            }
            None => {
                return Err(GeometryError::OffFlank {
                    name: "ball_mm (no ball up to 5·m_n touches the usable flank)",
                    value: 5.0 * m_n,
                    contact_diameter_mm: aim,
                    min_mm: lo,
                    max_mm: hi,
                })
            }
        };
        let contact_diameter_mm = self.ball_geometry(ball_mm, shift).1;
        Ok(RecommendedBall {
            ball_mm,
            contact_diameter_mm,
            target_diameter_mm: target_mm,
            at_target,
        })
    }
}
