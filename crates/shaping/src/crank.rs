//! Exact crank–connecting-rod (slider-crank) kinematics of the shaper's stroke drive.
//!
//! Convention (fixed by this crate, see `docs/shaping.md`): the crank angle θ is zero at the
//! near dead point (Procedia CIRP 56 (2016)'s "Dot 1", cutter nearest the crank = top dead point), θ grows in
//! the crank's running direction, and the stroke position Z is measured from that dead point,
//! positive along the cutting stroke (away from the crank). θ ∈ [0, π] is the cutting stroke,
//! θ ∈ [π, 2π) the return stroke.

use std::f64::consts::{PI, TAU};

use crate::error::{check_range, Result};

/// Which half of the crank revolution an inverse solution lies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Branch {
    /// θ ∈ [0, π]: the cutter moves away from the crank (cutting stroke).
    Cutting,
    /// θ ∈ [π, 2π): the cutter moves back towards the crank (return stroke).
    Return,
}

/// Crank radius R and connecting-rod length L of the stroke drive.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SliderCrank {
    r_mm: f64,
    l_mm: f64,
}

/// Largest accepted λ = R/L; beyond it the rod angle grows so steep that the drive is no
/// longer a practical shaper drive and the velocity peak moves far from 90°.
pub const MAX_LAMBDA: f64 = 0.5;

/// Largest crank radius R accepted, in mm.
pub const MAX_CRANK_RADIUS_MM: f64 = 500.0;

impl SliderCrank {
    /// A crank of radius `crank_radius_mm` (R) driving a rod of length `rod_length_mm` (L).
    ///
    /// # Domain
    /// 0.1 mm ≤ R ≤ 500 mm, R/λ_max ≤ L ≤ 10 000 mm with λ_max = [`MAX_LAMBDA`].
    pub fn new(crank_radius_mm: f64, rod_length_mm: f64) -> Result<Self> {
        let r = check_range(
            "crank radius R",
            crank_radius_mm,
            0.1,
            MAX_CRANK_RADIUS_MM,
            "mm",
        )?;
        let l = check_range(
            "rod length K (L)",
            rod_length_mm,
            r / MAX_LAMBDA,
            10_000.0,
            "mm",
        )?;
        Ok(Self { r_mm: r, l_mm: l })
    }

    /// Crank radius R in mm.
    pub fn crank_radius_mm(&self) -> f64 {
        self.r_mm
    }

    /// Rod length L in mm.
    pub fn rod_length_mm(&self) -> f64 {
        self.l_mm
    }

    /// Rod ratio λ = R/L.
    pub fn lambda(&self) -> f64 {
        self.r_mm / self.l_mm
    }

    /// Full stroke 2R in mm.
    pub fn stroke_mm(&self) -> f64 {
        2.0 * self.r_mm
    }

    /// √(L² − R² sin²θ) = L cos α, the rod's projection on the stroke axis.
    fn rod_projection_mm(&self, theta_rad: f64) -> f64 {
        let rs = self.r_mm * theta_rad.sin();
        ((self.l_mm - rs) * (self.l_mm + rs)).sqrt()
    }

    /// Rod angle α.
    ///
    /// # Formula
    /// L·sin α = R·sin θ  ⇒  α = asin(λ·sin θ)
    ///
    /// # Source
    /// Procedia CIRP 56 (2016), eq. (3) [SEED]
    pub fn rod_angle_rad(&self, theta_rad: f64) -> f64 {
        (self.lambda() * theta_rad.sin()).asin()
    }

    /// Distance H from the crank centre to the cutter-ram pin.
    ///
    /// # Formula
    /// H = L·cos α − R·cos θ = √(L² − R² sin²θ) − R·cos θ
    ///
    /// # Units
    /// mm; H(0) = L − R, H(π) = L + R.
    ///
    /// # Source
    /// Procedia CIRP 56 (2016), eqs. (2)–(3) [SEED]; closed form docs/shaping.md (K1) [DERIVED]
    pub fn h_mm(&self, theta_rad: f64) -> f64 {
        self.rod_projection_mm(theta_rad) - self.r_mm * theta_rad.cos()
    }

    /// Stroke position Z measured from the near dead point.
    ///
    /// # Formula
    /// Z = H − (L − R) = R(1 − cos θ) − L(1 − cos α)
    ///   = 2R·sin²(θ/2) − R² sin²θ / (L + √(L² − R² sin²θ))
    /// (the last form avoids cancellation near the dead points).
    ///
    /// # Units
    /// mm, 0 ≤ Z ≤ 2R.
    ///
    /// # Source
    /// Procedia CIRP 56 (2016), eq. (2) [SEED]; docs/shaping.md (K2) [DERIVED]
    pub fn z_mm(&self, theta_rad: f64) -> f64 {
        let half = (0.5 * theta_rad).sin();
        let rs = self.r_mm * theta_rad.sin();
        2.0 * self.r_mm * half * half - rs * rs / (self.l_mm + self.rod_projection_mm(theta_rad))
    }

    /// Stroke derivative dZ/dθ (the velocity per unit crank speed).
    ///
    /// # Formula
    /// dZ/dθ = R·sin θ − R²·sin θ·cos θ / √(L² − R² sin²θ) = R·sin(θ − α)/cos α
    ///
    /// # Units
    /// mm/rad.
    ///
    /// # Source
    /// docs/shaping.md (K3) [DERIVED, finite-difference checked]
    pub fn dz_dtheta_mm(&self, theta_rad: f64) -> f64 {
        let (s, c) = theta_rad.sin_cos();
        self.r_mm * s - self.r_mm * self.r_mm * s * c / self.rod_projection_mm(theta_rad)
    }

    /// Second stroke derivative d²Z/dθ².
    ///
    /// # Formula
    /// d²Z/dθ² = R·cos θ − R²(L² cos 2θ + R² sin⁴θ)/(L² − R² sin²θ)^(3/2)
    ///
    /// # Units
    /// mm/rad².
    ///
    /// # Source
    /// docs/shaping.md (K4) [DERIVED, finite-difference checked]
    pub fn d2z_dtheta2_mm(&self, theta_rad: f64) -> f64 {
        let (s, c) = theta_rad.sin_cos();
        let p = self.rod_projection_mm(theta_rad);
        let r2 = self.r_mm * self.r_mm;
        let s2 = s * s;
        self.r_mm * c
            - r2 * (self.l_mm * self.l_mm * (2.0 * theta_rad).cos() + r2 * s2 * s2) / (p * p * p)
    }

    /// Z, dZ/dθ and d²Z/dθ² in one evaluation (one sin/cos and one square root; the
    /// interpolator's per-cycle path).
    ///
    /// # Formula
    /// As [`SliderCrank::z_mm`], [`SliderCrank::dz_dtheta_mm`] and
    /// [`SliderCrank::d2z_dtheta2_mm`], with cos 2θ = cos²θ − sin²θ and 1 − cos θ
    /// written as sin²θ/(1 + cos θ) where cos θ > 0 to avoid cancellation near θ = 0.
    ///
    /// # Units
    /// (mm, mm/rad, mm/rad²).
    pub fn state(&self, theta_rad: f64) -> (f64, f64, f64) {
        let (s, c) = theta_rad.sin_cos();
        let (r, l) = (self.r_mm, self.l_mm);
        let rs = r * s;
        let p = ((l - rs) * (l + rs)).sqrt();
        // 1 − cos θ without cancellation near θ = 0.
        let one_minus_c = if c > 0.0 { s * s / (1.0 + c) } else { 1.0 - c };
        let z = r * one_minus_c - rs * rs / (l + p);
        let dz = r * s - r * rs * c / p;
        let s2 = s * s;
        let d2z = r * c - r * r * (l * l * (c * c - s2) + r * r * s2 * s2) / (p * p * p);
        (z, dz, d2z)
    }

    /// Cutter velocity along Z at crank speed ω.
    ///
    /// # Formula
    /// v_Z = ω·dZ/dθ; v_Z(90°) = ω·R exactly.
    ///
    /// # Units
    /// mm/s for ω in rad/s.
    ///
    /// # Source
    /// docs/shaping.md (K3) [DERIVED]
    pub fn velocity_mm_s(&self, theta_rad: f64, omega_rad_s: f64) -> f64 {
        omega_rad_s * self.dz_dtheta_mm(theta_rad)
    }

    /// Cutter acceleration along Z at crank speed ω and crank acceleration ω̇.
    ///
    /// # Formula
    /// a_Z = ω²·d²Z/dθ² + ω̇·dZ/dθ
    ///
    /// # Units
    /// mm/s² for ω in rad/s and ω̇ in rad/s².
    ///
    /// # Source
    /// docs/shaping.md (K4) [DERIVED]
    pub fn acceleration_mm_s2(
        &self,
        theta_rad: f64,
        omega_rad_s: f64,
        omega_dot_rad_s2: f64,
    ) -> f64 {
        omega_rad_s * omega_rad_s * self.d2z_dtheta2_mm(theta_rad)
            + omega_dot_rad_s2 * self.dz_dtheta_mm(theta_rad)
    }

    /// Crank angle at which the cutter is at stroke position `z_mm`, on the chosen branch.
    ///
    /// # Formula
    /// With H = Z + L − R, squaring H + R cos θ = √(L² − R² sin²θ) gives
    /// cos θ = (L² − R² − H²)/(2·H·R); θ = acos(·) on the cutting branch, 2π − acos(·) on the
    /// return branch.
    ///
    /// # Domain
    /// 0 ≤ Z ≤ 2R (mm); the result is in [0, π] or [π, 2π).
    ///
    /// # Source
    /// inverse of Procedia CIRP 56 (2016) eq. (2) [DERIVED]
    pub fn theta_from_z_rad(&self, z_mm: f64, branch: Branch) -> Result<f64> {
        let z = check_range("stroke position Z", z_mm, 0.0, self.stroke_mm(), "mm")?;
        let (r, l) = (self.r_mm, self.l_mm);
        let h = z + l - r;
        // L² − R² − H² = 2R(L − R) − Z(2(L − R) + Z): no cancellation near the dead points.
        let cos_theta = (2.0 * r * (l - r) - z * (2.0 * (l - r) + z)) / (2.0 * h * r);
        let base = cos_theta.clamp(-1.0, 1.0).acos();
        Ok(match branch {
            Branch::Cutting => base,
            Branch::Return => {
                if base == 0.0 {
                    0.0
                } else {
                    TAU - base
                }
            }
        })
    }

    /// Crank angle of the largest cutting-stroke speed and that speed per unit ω.
    ///
    /// # Formula
    /// Root of d²Z/dθ² = 0 on (π/2, π), found by bisection (d²Z/dθ² > 0 at π/2, < 0 at π);
    /// returns (θ*, dZ/dθ(θ*)). The return stroke mirrors it: θ = 2π − θ*, −dZ/dθ(θ*).
    ///
    /// # Units
    /// (rad, mm/rad).
    ///
    /// # Source
    /// docs/shaping.md (K5) (peak v_Z at 97.02° for λ = 0.125) [DERIVED]
    pub fn peak_velocity(&self) -> (f64, f64) {
        let (mut lo, mut hi) = (0.5 * PI, PI);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if self.d2z_dtheta2_mm(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let theta = 0.5 * (lo + hi);
        (theta, self.dz_dtheta_mm(theta))
    }

    /// Largest |d²Z/dθ²| over a revolution (used by the feasibility check).
    ///
    /// # Formula
    /// max over a 7200-point grid, then the larger of that and the dead-point values
    /// R(1 − λ) at θ = 0 and R(1 + λ) at θ = π, which are the extremes for λ ≤ 1/4.
    ///
    /// # Units
    /// mm/rad².
    pub fn max_abs_d2z_dtheta2_mm(&self) -> f64 {
        let mut m = self
            .d2z_dtheta2_mm(PI)
            .abs()
            .max(self.d2z_dtheta2_mm(0.0).abs());
        for i in 0..7200 {
            let th = TAU * f64::from(i) / 7200.0;
            m = m.max(self.d2z_dtheta2_mm(th).abs());
        }
        m
    }
}
