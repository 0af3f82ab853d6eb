//! The electronic-gearbox coupling law of the helical guide, Procedia CIRP 56 (2016) eq. (1), in velocity
//! form and in the drift-free position form.
//!
//! Sign conventions (fixed by this crate, see `docs/shaping.md`): C1 (workpiece) and C2
//! (cutter) are positive counter-clockwise seen from above (from the crank side), Z is
//! positive along the cutting stroke (downwards, away from the crank). With these, Procedia CIRP 56 (2016)
//! eq. (1) with β > 0 is a right-hand workpiece in external mesh (left-hand cutter).

use std::f64::consts::PI;

use crate::error::{check_range, Result, ShapingError};
use crate::ratio::Ratio;

/// Helix hand and external/internal workpiece: the gear vocabulary shared by all gear crates.
/// For the helical guide, [`Hand`] is the hand of the workpiece (the cutter has the opposite
/// hand in external mesh, the same hand in internal mesh); in [`Mesh::External`] cutter and
/// workpiece counter-rotate, in [`Mesh::Internal`] they turn the same way.
pub use gearcomp_geometry::{Hand, Mesh};

/// Largest helix angle accepted (ISO 1328-1:2013 scope is β ≤ 45°).
pub const MAX_HELIX_DEG: f64 = 45.0;
/// Largest helix-angle correction Δβ accepted, in degrees.
pub const MAX_DELTA_BETA_DEG: f64 = 2.0;

/// The gear being shaped and the shaper cutter: everything eq. (1) needs.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct GearCut {
    z_c1: u32,
    z_c2: u32,
    m_n_mm: f64,
    beta_rad: f64,
    delta_beta_rad: f64,
    hand: Hand,
    mesh: Mesh,
}

impl GearCut {
    /// Workpiece teeth Z_C1, cutter teeth Z_C2, normal module m_n, helix angle β (magnitude),
    /// helix-angle correction Δβ (signed, added to β in the helical term), hand and mesh.
    ///
    /// # Domain
    /// 1 ≤ Z_C1, Z_C2 ≤ 1000 (Z_C1 > Z_C2 for internal), 0.1 ≤ m_n ≤ 25 mm (FANUC EGB's
    /// range), 0 ≤ β ≤ 45°, |Δβ| ≤ 2°, 0 ≤ β + Δβ ≤ 45°.
    pub fn new(
        z_c1: u32,
        z_c2: u32,
        m_n_mm: f64,
        beta_rad: f64,
        delta_beta_rad: f64,
        hand: Hand,
        mesh: Mesh,
    ) -> Result<Self> {
        check_range("workpiece teeth T (Z_C1)", f64::from(z_c1), 1.0, 1000.0, "")?;
        check_range("cutter teeth L (Z_C2)", f64::from(z_c2), 1.0, 1000.0, "")?;
        if mesh == Mesh::Internal && z_c1 <= z_c2 {
            return Err(ShapingError::OutOfRange {
                field: "workpiece teeth T (Z_C1) of an internal gear",
                value: f64::from(z_c1),
                min: f64::from(z_c2) + 1.0,
                max: 1000.0,
                unit: "",
            });
        }
        check_range("normal module Q (m_n)", m_n_mm, 0.1, 25.0, "mm")?;
        let max_beta = MAX_HELIX_DEG.to_radians();
        check_range(
            "helix angle P (beta)",
            beta_rad.to_degrees(),
            0.0,
            MAX_HELIX_DEG,
            "deg",
        )?;
        check_range(
            "helix-angle correction D (delta beta)",
            delta_beta_rad.to_degrees(),
            -MAX_DELTA_BETA_DEG,
            MAX_DELTA_BETA_DEG,
            "deg",
        )?;
        let eff = beta_rad + delta_beta_rad;
        if !(0.0..=max_beta).contains(&eff) {
            return Err(ShapingError::OutOfRange {
                field: "corrected helix angle P + D (beta + delta beta)",
                value: eff.to_degrees(),
                min: 0.0,
                max: MAX_HELIX_DEG,
                unit: "deg",
            });
        }
        Ok(Self {
            z_c1,
            z_c2,
            m_n_mm,
            beta_rad,
            delta_beta_rad,
            hand,
            mesh,
        })
    }

    /// Workpiece teeth Z_C1.
    pub fn z_c1(&self) -> u32 {
        self.z_c1
    }
    /// Cutter teeth Z_C2.
    pub fn z_c2(&self) -> u32 {
        self.z_c2
    }
    /// Normal module m_n in mm.
    pub fn m_n_mm(&self) -> f64 {
        self.m_n_mm
    }
    /// Design helix angle β in rad.
    pub fn beta_rad(&self) -> f64 {
        self.beta_rad
    }
    /// Helix-angle correction Δβ in rad.
    pub fn delta_beta_rad(&self) -> f64 {
        self.delta_beta_rad
    }
    /// Workpiece helix hand.
    pub fn hand(&self) -> Hand {
        self.hand
    }
    /// External or internal workpiece.
    pub fn mesh(&self) -> Mesh {
        self.mesh
    }

    /// Helix angle actually cut: β' = β + Δβ.
    ///
    /// # Source
    /// Procedia CIRP 56 (2016) 173–177, abstract and §1 ("compensating helix angle value")
    /// [SEED]; applied to the helical term only, docs/shaping.md "Derivation: the control cycle
    /// and the position form" [RECONSTRUCTED]
    pub fn effective_beta_rad(&self) -> f64 {
        self.beta_rad + self.delta_beta_rad
    }

    /// Generating ratio C2/C1 as an exact reduced fraction.
    ///
    /// # Formula
    /// ρ = −Z_C1/Z_C2 (external), +Z_C1/Z_C2 (internal)
    ///
    /// # Source
    /// Procedia CIRP 56 (2016), eq. (1) first term [SEED]; internal sign docs/shaping.md
    /// "Derivation: the control cycle and the position form" [DERIVED]
    pub fn generating_ratio(&self) -> Ratio {
        let sign: i128 = match self.mesh {
            Mesh::External => -1,
            Mesh::Internal => 1,
        };
        ratio_or_unit(sign * i128::from(self.z_c1), i128::from(self.z_c2))
    }

    /// Sign σ of the helical term of eq. (1) under this crate's axis conventions.
    ///
    /// # Formula
    /// σ = +1 for a right-hand external or a left-hand internal workpiece, −1 otherwise
    /// (σ follows the cutter's hand: the cutter is left-hand in both + cases).
    ///
    /// # Source
    /// convention fixed in docs/shaping.md [DERIVED from the mesh condition
    /// Z_C1·(C1 + g(Z)) ± Z_C2·C2 = const]
    pub fn helix_sign(&self) -> f64 {
        match (self.hand, self.mesh) {
            (Hand::Right, Mesh::External) | (Hand::Left, Mesh::Internal) => 1.0,
            _ => -1.0,
        }
    }

    /// Transverse pitch radius of the cutter, r_C2 = m_n·Z_C2/(2 cos β), in mm.
    ///
    /// # Source
    /// ISO 21771:2007, 5.2 (d = m_n·z/cos β) [STANDARD]
    pub fn cutter_pitch_radius_mm(&self) -> f64 {
        self.m_n_mm * f64::from(self.z_c2) / (2.0 * self.beta_rad.cos())
    }

    /// Transverse pitch radius of the workpiece, r_C1 = m_n·Z_C1/(2 cos β), in mm.
    ///
    /// # Source
    /// ISO 21771:2007, 5.2 [STANDARD]
    pub fn workpiece_pitch_radius_mm(&self) -> f64 {
        self.m_n_mm * f64::from(self.z_c1) / (2.0 * self.beta_rad.cos())
    }

    /// Cutter lead P_z: the Z travel during which the cutter turns one extra revolution.
    ///
    /// # Formula
    /// P_z = π·m_n·Z_C2 / sin β'   (infinite for a spur gear)
    ///
    /// # Units
    /// mm per revolution.
    ///
    /// # Source
    /// Procedia CIRP 56 (2016), eq. (1) second term and §2 ("one round while the cutter moves a helical
    /// lead") [SEED]
    pub fn cutter_lead_mm(&self) -> f64 {
        PI * self.m_n_mm * f64::from(self.z_c2) / self.effective_beta_rad().sin()
    }

    /// Workpiece lead P_w = π·m_n·Z_C1 / sin β' in mm (the design lead of the cut gear).
    ///
    /// # Source
    /// ISO 21771:2007, 5.5 (p_z = π·d/tan β = π·m_n·z/sin β) [STANDARD]
    pub fn workpiece_lead_mm(&self) -> f64 {
        PI * self.m_n_mm * f64::from(self.z_c1) / self.effective_beta_rad().sin()
    }

    /// Signed helical gain k_h: extra C2 rotation per mm of Z.
    ///
    /// # Formula
    /// k_h = σ·2π/P_z = σ·2·sin β' / (m_n·Z_C2)
    ///
    /// # Units
    /// rad/mm.
    ///
    /// # Source
    /// Procedia CIRP 56 (2016), eq. (1) [SEED]
    pub fn helical_gain_rad_per_mm(&self) -> f64 {
        self.helix_sign() * 2.0 * self.effective_beta_rad().sin()
            / (self.m_n_mm * f64::from(self.z_c2))
    }

    /// Cutter speed n_C2 from workpiece speed n_C1 and stroke speed v_Z (velocity form).
    ///
    /// # Formula
    /// n_C2 = ρ·n_C1 + σ·sin β' / (π·m_n·Z_C2)·v_Z,  ρ = ∓Z_C1/Z_C2
    ///
    /// # Units
    /// n in rpm, v_Z in mm/min, m_n in mm.
    ///
    /// # Source
    /// Procedia CIRP 56 (2016), eq. (1) [SEED]
    pub fn n_c2_rpm(&self, n_c1_rpm: f64, v_z_mm_min: f64) -> f64 {
        self.generating_ratio().to_f64() * n_c1_rpm
            + self.helix_sign() * self.effective_beta_rad().sin()
                / (PI * self.m_n_mm * f64::from(self.z_c2))
                * v_z_mm_min
    }

    /// Cutter angle from workpiece angle and stroke position (position form, floats).
    ///
    /// # Formula
    /// C2 − C2_0 = ρ·(C1 − C1_0) + k_h·(Z − Z_0) = ρ·ΔC1 + σ·2π·ΔZ/P_z
    ///
    /// # Units
    /// rad, mm.
    ///
    /// # Source
    /// Procedia CIRP 56 (2016) eq. (1) integrated over time; docs/shaping.md "Derivation: the
    /// control cycle and the position form", step 4 [RECONSTRUCTED]. The interpolator evaluates the same law with exact integer ratios.
    pub fn c2_delta_rad(&self, delta_c1_rad: f64, delta_z_mm: f64) -> f64 {
        self.generating_ratio().to_f64() * delta_c1_rad
            + self.helical_gain_rad_per_mm() * delta_z_mm
    }
}

fn ratio_or_unit(num: i128, den: i128) -> Ratio {
    // den ≥ 1 is guaranteed by GearCut::new, so the fallback is never taken.
    Ratio::new(num, den).unwrap_or(Ratio::ONE)
}
