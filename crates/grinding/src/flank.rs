//! Involute gears and worms as involute helicoids parameterised by roll distance w and
//! width position z (the (w, z) plane of JP6903407B2), one [`InvoluteFlank`] per flank.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use gearcomp_geometry::transverse_pressure_angle_rad;

use crate::error::{check_range, GrindError, Result};

pub use gearcomp_geometry::{Flank, Hand};

/// A cylindrical involute gear or worm (a worm is a gear with `teeth` = number of starts and a
/// helix angle close to 90°). Asymmetric teeth have different normal pressure angles per flank.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct InvoluteGear {
    /// Number of teeth (starts for a worm), z.
    pub teeth: u32,
    /// Normal module m_n in mm.
    pub m_n_mm: f64,
    /// Normal pressure angle of the right flank α_n,r in rad.
    pub alpha_n_right_rad: f64,
    /// Normal pressure angle of the left flank α_n,l in rad.
    pub alpha_n_left_rad: f64,
    /// Signed reference helix angle β in rad (> 0 right hand).
    pub beta_rad: f64,
    /// Profile shift coefficient x (only sets the angular position of the flanks).
    pub x_shift: f64,
}

impl InvoluteGear {
    /// A validated symmetric gear.
    pub fn new(teeth: u32, m_n_mm: f64, alpha_n_rad: f64, beta_rad: f64) -> Result<Self> {
        Self::asymmetric(teeth, m_n_mm, alpha_n_rad, alpha_n_rad, beta_rad, 0.0)
    }

    /// A validated gear with separate right/left normal pressure angles and a profile shift.
    pub fn asymmetric(
        teeth: u32,
        m_n_mm: f64,
        alpha_n_right_rad: f64,
        alpha_n_left_rad: f64,
        beta_rad: f64,
        x_shift: f64,
    ) -> Result<Self> {
        if teeth == 0 || teeth > 100_000 {
            return Err(GrindError::OutOfRange {
                field: "teeth",
                value: f64::from(teeth),
                expected: "1 ..= 100000",
            });
        }
        check_range("m_n_mm", m_n_mm, 1e-3, 1e3, "0.001 ..= 1000 mm")?;
        // angles are checked and reported in degrees, the unit the user wrote
        // (--pressure-angle-deg 50 read "alpha_n_right_rad = 0.8726646259971648 … 1° ..= 45°")
        let deg = f64::to_degrees;
        check_range(
            "alpha_n_right_deg",
            deg(alpha_n_right_rad),
            1.0,
            45.0,
            "1° ..= 45°",
        )?;
        check_range(
            "alpha_n_left_deg",
            deg(alpha_n_left_rad),
            1.0,
            45.0,
            "1° ..= 45°",
        )?;
        check_range("beta_deg", deg(beta_rad), -89.97, 89.97, "|β| ≤ 89.97°")?;
        check_range("x_shift", x_shift, -5.0, 5.0, "-5 ..= 5")?;
        Ok(Self {
            teeth,
            m_n_mm,
            alpha_n_right_rad,
            alpha_n_left_rad,
            beta_rad,
            x_shift,
        })
    }

    /// A symmetric cylindrical worm given its reference (pitch) radius r1.
    ///
    /// # Formula
    /// cos β1 = z1·m_n/(2·r1) (reference radius r = z·m_n/(2 cos β)); sign of β1 from the hand.
    /// # Source
    /// ISO 21771:2007 eq. for the reference diameter [STANDARD]; docs/grinding.md "Independent
    /// reference: reference example" (worm of the
    /// reference example) [RECONSTRUCTED].
    pub fn worm(
        starts: u32,
        m_n_mm: f64,
        alpha_n_rad: f64,
        reference_radius_mm: f64,
        hand: Hand,
    ) -> Result<Self> {
        check_range("m_n_mm", m_n_mm, 1e-3, 1e3, "0.001 ..= 1000 mm")?;
        check_range(
            "worm_reference_radius_mm",
            reference_radius_mm,
            1e-3,
            1e5,
            "0.001 ..= 100000 mm",
        )?;
        if starts == 0 {
            return Err(GrindError::OutOfRange {
                field: "worm starts",
                value: 0.0,
                expected: "1 ..= 100000",
            });
        }
        let cos_beta = f64::from(starts) * m_n_mm / (2.0 * reference_radius_mm);
        if !(cos_beta > 0.0 && cos_beta < 0.9) {
            return Err(GrindError::OutOfRange {
                field: "worm_reference_radius_mm",
                value: reference_radius_mm,
                expected: "larger than starts·m_n/1.8 (lead angle below 64°; fewer --worm-starts \
                           or a larger --worm-radius-mm)",
            });
        }
        Self::new(starts, m_n_mm, alpha_n_rad, hand.sign() * cos_beta.acos())
    }

    /// Reference radius r = z·m_n/(2·cos β) in mm.
    pub fn reference_radius_mm(&self) -> f64 {
        f64::from(self.teeth) * self.m_n_mm / (2.0 * self.beta_rad.cos())
    }

    /// Normal base pitch p_bn = π·m_n·cos α_n of one flank in mm.
    pub fn normal_base_pitch_mm(&self, flank: Flank) -> f64 {
        std::f64::consts::PI * self.m_n_mm * self.alpha_n_rad(flank).cos()
    }

    /// Normal pressure angle of a flank.
    pub fn alpha_n_rad(&self, flank: Flank) -> f64 {
        match flank {
            Flank::Right => self.alpha_n_right_rad,
            Flank::Left => self.alpha_n_left_rad,
        }
    }

    /// The involute helicoid of one flank.
    ///
    /// # Formula
    /// tan α_t = tan α_n / cos β; r_b = r·cos α_t; sin β_b = sin β·cos α_n (signed);
    /// ψ_b = s_t/(2r) + inv α_t with s_t = m_t·(π/2 + 2x·tan α_n); η = −s·ψ_b;
    /// w_P = r_b·tan α_t (roll distance of the reference circle).
    /// # Source
    /// ISO 21771:2007 §4–5 [STANDARD]; docs/grinding.md "Derivation: flank and chain conventions"
    /// [RECONSTRUCTED].
    pub fn flank(&self, flank: Flank) -> InvoluteFlank {
        let alpha_n = self.alpha_n_rad(flank);
        let r = self.reference_radius_mm();
        let alpha_t = transverse_pressure_angle_rad(alpha_n, self.beta_rad);
        let r_b = r * alpha_t.cos();
        let beta_b = (self.beta_rad.sin() * alpha_n.cos()).asin();
        let m_t = self.m_n_mm / self.beta_rad.cos();
        let s_t = m_t * (std::f64::consts::FRAC_PI_2 + 2.0 * self.x_shift * alpha_n.tan());
        let psi_b = s_t / (2.0 * r) + (alpha_t.tan() - alpha_t);
        InvoluteFlank {
            flank,
            r_b_mm: r_b,
            beta_b_rad: beta_b,
            eta_rad: -flank.sign() * psi_b,
            w_ref_mm: r_b * alpha_t.tan(),
        }
    }
}

/// The usable involute flank of a gear in roll distances of one flank.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FlankLimits {
    /// Roll distance of the root form circle d_Ff (0 if the involute starts at the base circle).
    pub w_root_form_mm: f64,
    /// Roll distance of the tip circle d_a.
    pub w_tip_mm: f64,
    /// Root form diameter d_Ff in mm (None: undercut, the flank starts at the base circle).
    pub root_form_diameter_mm: Option<f64>,
    /// Tip diameter d_a in mm.
    pub tip_diameter_mm: f64,
}

impl InvoluteGear {
    /// The gear as the gear-geometry crate sees it (external teeth, DIN 867 basic rack with
    /// the root radius it carries at this pressure angle, `BasicRack::din_867_at`; the
    /// pressure angle of `flank`); this validates the gear as a gear (3 ≤ z ≤ 10 000,
    /// |β| < 60°, no pointed tooth, root circle above 0, no undercut by the rack where the
    /// geometry crate refuses it).
    pub fn geometry(&self, flank: Flank) -> Result<gearcomp_geometry::Gear> {
        use gearcomp_geometry::{BasicRack, Gear, GearSpec, Hand as GHand, Mesh};
        let spec = GearSpec {
            normal_module_mm: self.m_n_mm,
            normal_pressure_angle_rad: self.alpha_n_rad(flank),
            helix_angle_rad: self.beta_rad.abs(),
            hand: if self.beta_rad < 0.0 {
                GHand::Left
            } else {
                GHand::Right
            },
            teeth: self.teeth,
            mesh: Mesh::External,
            profile_shift: self.x_shift,
            face_width_mm: None,
            rack: BasicRack::din_867_at(self.alpha_n_rad(flank)),
        };
        Ok(Gear::new(spec)?)
    }

    /// Root form and tip of one flank as roll distances.
    ///
    /// # Formula
    /// d_a = d + 2·m_n·(1 + x); d_Ff from rack generation (DIN 867 rack), both from the
    /// gear-geometry crate; w = √(r² − r_b²).
    /// # Source
    /// ISO 21771:2007 5.2, 5.4.5 [STANDARD] (via `gearcomp_geometry::Gear`).
    pub fn flank_limits(&self, flank: Flank) -> Result<FlankLimits> {
        let g = self.geometry(flank)?;
        let rb = self.flank(flank).r_b_mm;
        let w = |d: f64| (0.25 * d * d - rb * rb).max(0.0).sqrt();
        let d = g.dims();
        Ok(FlankLimits {
            w_root_form_mm: d.root_form_diameter_mm.map_or(0.0, w),
            w_tip_mm: w(d.tip_diameter_mm),
            root_form_diameter_mm: d.root_form_diameter_mm,
            tip_diameter_mm: d.tip_diameter_mm,
        })
    }
}

/// One flank of an involute gear or worm: an involute helicoid.
///
/// # Formula
/// τ(w, z) = η + s·w/r_b + z·tan β_b/r_b;
/// E(w, z) = r_b·e_r(τ) − s·w·e_t(τ) + z·e_z, with e_r = (cos τ, sin τ, 0), e_t = (−sin τ, cos τ, 0);
/// outward unit normal N = s·(−cos β_b·e_t(τ) + sin β_b·e_z), so N·e_z = s·sin β_b.
/// # Units
/// mm, rad. w ≥ 0 is the roll distance (w = √(r² − r_b²)); z is the width position.
/// # Source
/// docs/grinding.md "Derivation: flank and chain conventions", the lost eq. (27) [RECONSTRUCTED,
/// VERIFIED by a Newton check of the mesh].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct InvoluteFlank {
    /// Which flank.
    pub flank: Flank,
    /// Base radius r_b in mm.
    pub r_b_mm: f64,
    /// Signed base helix angle β_b in rad (> 0 right hand).
    pub beta_b_rad: f64,
    /// Angular position η of the flank's base-circle start at z = 0, in rad.
    pub eta_rad: f64,
    /// Roll distance of the reference (pitch) circle w_P in mm.
    pub w_ref_mm: f64,
}

impl InvoluteFlank {
    /// Flank sign s.
    #[inline]
    pub fn s(&self) -> f64 {
        self.flank.sign()
    }

    /// Angle τ(w, z) of the base-circle tangent point.
    #[inline]
    pub fn tau(&self, w_mm: f64, z_mm: f64) -> f64 {
        self.eta_rad + (self.s() * w_mm + z_mm * self.beta_b_rad.tan()) / self.r_b_mm
    }

    /// Point E(w, z) in the body frame.
    #[inline]
    pub fn point(&self, w_mm: f64, z_mm: f64) -> Vector3<f64> {
        let (st, ct) = self.tau(w_mm, z_mm).sin_cos();
        let sw = self.s() * w_mm;
        Vector3::new(self.r_b_mm * ct + sw * st, self.r_b_mm * st - sw * ct, z_mm)
    }

    /// Outward unit normal N(w, z) in the body frame.
    #[inline]
    pub fn normal(&self, w_mm: f64, z_mm: f64) -> Vector3<f64> {
        self.normal_at_tau(self.tau(w_mm, z_mm))
    }

    /// Outward unit normal for a given τ (the normal depends on τ only).
    #[inline]
    pub fn normal_at_tau(&self, tau: f64) -> Vector3<f64> {
        let (st, ct) = tau.sin_cos();
        let (sb, cb) = self.beta_b_rad.sin_cos();
        let s = self.s();
        Vector3::new(s * cb * st, -s * cb * ct, s * sb)
    }

    /// Point, normal and their partial derivatives with respect to w and z:
    /// (E, N, ∂E/∂w, ∂E/∂z, ∂N/∂w, ∂N/∂z).
    ///
    /// # Formula
    /// ∂E/∂w = (w/r_b)·e_r; ∂E/∂z = tan β_b·e_t + s·w·tan β_b/r_b·e_r + e_z;
    /// ∂N/∂τ = s·cos β_b·e_r, ∂τ/∂w = s/r_b, ∂τ/∂z = tan β_b/r_b.
    #[inline]
    pub fn jet(&self, w_mm: f64, z_mm: f64) -> [Vector3<f64>; 6] {
        let tau = self.tau(w_mm, z_mm);
        let (st, ct) = tau.sin_cos();
        let e_r = Vector3::new(ct, st, 0.0);
        let e_t = Vector3::new(-st, ct, 0.0);
        let e_z = Vector3::new(0.0, 0.0, 1.0);
        let s = self.s();
        let (sb, cb) = self.beta_b_rad.sin_cos();
        let tb = sb / cb;
        let p = e_r * self.r_b_mm - e_t * (s * w_mm) + e_z * z_mm;
        let n = (e_t * (-cb) + e_z * sb) * s;
        let dp_dw = e_r * (w_mm / self.r_b_mm);
        let dp_dz = e_t * tb + e_r * (s * w_mm * tb / self.r_b_mm) + e_z;
        let dn_dtau = e_r * (s * cb);
        [
            p,
            n,
            dp_dw,
            dp_dz,
            dn_dtau * (s / self.r_b_mm),
            dn_dtau * (tb / self.r_b_mm),
        ]
    }

    /// Lead p_z = 2π·r_b/tan β_b in mm (infinite for a spur gear).
    pub fn lead_mm(&self) -> f64 {
        2.0 * std::f64::consts::PI * self.r_b_mm / self.beta_b_rad.tan()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use approx::assert_relative_eq;

    fn gear() -> InvoluteGear {
        InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap()
    }

    /// docs/grinding.md "Independent reference: reference example" numbers (independent
    /// calculation), 1e-6 as printed.
    #[test]
    fn reference_example_dimensions() {
        let g = gear();
        assert_relative_eq!(g.reference_radius_mm(), 48.140342, epsilon = 1e-6);
        let f = g.flank(Flank::Right);
        assert_relative_eq!(f.r_b_mm, 45.048348, epsilon = 1e-6);
        assert_relative_eq!(f.beta_b_rad.to_degrees(), 14.076095, epsilon = 1e-6);
        assert_relative_eq!(f.eta_rad, -0.067124, epsilon = 1e-6);
        assert_relative_eq!(f.w_ref_mm, 16.974655, epsilon = 1e-6);
        let w = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
        assert_relative_eq!(w.beta_rad.to_degrees(), 89.338880, epsilon = 1e-6);
        let wf = w.flank(Flank::Right);
        assert_relative_eq!(wf.r_b_mm, 4.119147, epsilon = 1e-6);
        assert_relative_eq!(wf.beta_b_rad.to_degrees(), 69.989523, epsilon = 1e-6);
        assert_relative_eq!(wf.w_ref_mm, 129.934724, epsilon = 1e-6);
        assert_relative_eq!(wf.lead_mm(), 9.425405, epsilon = 1e-6);
        // Normal base pitch π·m_n·cos α_n = 8.856394 mm for both (docs/grinding.md "Independent
        // reference: reference example").
        assert_relative_eq!(
            g.normal_base_pitch_mm(Flank::Right),
            8.856394,
            epsilon = 1e-6
        );
    }

    /// The surface is an involute: radius² = r_b² + w², polar angle = η + s·inv α (z = 0);
    /// the normal is unit, orthogonal to both tangents and has axial part s·sin β_b.
    #[test]
    fn surface_is_an_involute_helicoid() {
        for flank in [Flank::Right, Flank::Left] {
            let f = gear().flank(flank);
            for &(w, z) in &[(11.0, -15.0), (17.0, 0.0), (23.0, 14.0)] {
                let p = f.point(w, z);
                assert_relative_eq!(p.x.hypot(p.y), f.r_b_mm.hypot(w), epsilon = 1e-12);
                let alpha = (w / f.r_b_mm).atan();
                let polar_expected =
                    f.eta_rad + f.s() * (alpha.tan() - alpha) + z * f.beta_b_rad.tan() / f.r_b_mm;
                let d = p.y.atan2(p.x) - polar_expected;
                assert!(d.sin().abs() < 1e-12);
                let [_, n, dw, dz, dnw, dnz] = f.jet(w, z);
                assert_relative_eq!(n.norm(), 1.0, epsilon = 1e-14);
                assert!(n.dot(&dw).abs() < 1e-12 && n.dot(&dz).abs() < 1e-12);
                assert_relative_eq!(n.z, f.s() * f.beta_b_rad.sin(), epsilon = 1e-14);
                // derivatives against central differences
                let h = 1e-5;
                let fdw = (f.point(w + h, z) - f.point(w - h, z)) / (2.0 * h);
                let fdz = (f.point(w, z + h) - f.point(w, z - h)) / (2.0 * h);
                let fnw = (f.normal(w + h, z) - f.normal(w - h, z)) / (2.0 * h);
                let fnz = (f.normal(w, z + h) - f.normal(w, z - h)) / (2.0 * h);
                assert!((fdw - dw).norm() < 1e-8 && (fdz - dz).norm() < 1e-8);
                assert!((fnw - dnw).norm() < 1e-8 && (fnz - dnz).norm() < 1e-8);
            }
        }
    }

    /// Outward: a step along N leaves the tooth (its polar angle moves away from the tooth
    /// centre at angle 0), for both flanks.
    #[test]
    fn normal_points_out_of_the_tooth() {
        for flank in [Flank::Right, Flank::Left] {
            let f = gear().flank(flank);
            let p = f.point(17.0, 0.0);
            let q = p + f.normal(17.0, 0.0) * 0.01;
            let half_angle = |v: Vector3<f64>| v.y.atan2(v.x).abs();
            assert!(half_angle(q) > half_angle(p));
        }
    }

    #[test]
    fn bad_input_is_rejected() {
        assert!(InvoluteGear::new(0, 3.0, 0.35, 0.2).is_err());
        assert!(InvoluteGear::new(31, f64::NAN, 0.35, 0.2).is_err());
        assert!(InvoluteGear::new(31, 3.0, 1.2, 0.2).is_err());
        assert!(InvoluteGear::worm(1, 3.0, 0.35, 1.0, Hand::Right).is_err());
    }

    /// Root form and tip of the default gear by hand (rack generation, DIN 867 rack):
    /// w_Ff = r·sin α_t − (h_FfP − x·m_n)/sin α_t with h_FfP = m_n·(1.25 − 0.25·(1 − sin α_n)),
    /// w_a = √(r_a² − r_b²), r_a = r + m_n·(1 + x). The tip of z = 31, m_n = 3, β = 15° is at
    /// w = 24.2 mm (the figure). z = 2 and a pointed tooth are refused.
    #[test]
    fn flank_limits_by_hand() {
        for x in [0.0, 0.3, -0.2] {
            let g = InvoluteGear::asymmetric(
                31,
                3.0,
                20f64.to_radians(),
                20f64.to_radians(),
                15f64.to_radians(),
                x,
            )
            .unwrap();
            let l = g.flank_limits(Flank::Left).unwrap();
            let f = g.flank(Flank::Left);
            let r = g.reference_radius_mm();
            let at = (20f64.to_radians().tan() / 15f64.to_radians().cos()).atan();
            let h = 3.0 * (1.25 - 0.25 * (1.0 - 20f64.to_radians().sin()));
            let w_ff = r * at.sin() - (h - x * 3.0) / at.sin();
            let ra = r + 3.0 * (1.0 + x);
            assert_relative_eq!(l.w_root_form_mm, w_ff, epsilon = 1e-9);
            assert_relative_eq!(
                l.w_tip_mm,
                (ra * ra - f.r_b_mm * f.r_b_mm).sqrt(),
                epsilon = 1e-9
            );
            if x == 0.0 {
                assert!((l.w_tip_mm - 24.2).abs() < 0.05, "{}", l.w_tip_mm);
            }
        }
        let two = InvoluteGear::new(2, 3.0, 0.35, 0.2).unwrap();
        assert!(two.flank_limits(Flank::Right).is_err());
        let pointed = InvoluteGear::asymmetric(12, 3.0, 0.35, 0.35, 0.0, 2.5).unwrap();
        assert!(pointed.flank_limits(Flank::Right).is_err());
    }

    /// Angles out of range are reported in degrees (the unit of the options), over random
    /// angles either side of the limits; zero worm starts are named as such.
    #[test]
    fn angle_errors_read_in_degrees() {
        use proptest::prelude::*;
        use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
        let mut runner = TestRunner::new_with_rng(
            Config {
                cases: 64,
                failure_persistence: None,
                ..Config::default()
            },
            TestRng::from_seed(RngAlgorithm::ChaCha, &[3; 32]),
        );
        let bad = prop_oneof![0.01..0.99f64, 45.01..89.0f64];
        runner
            .run(&(bad, 0usize..3), |(a_deg, which)| {
                let a = a_deg.to_radians();
                let ok = 20f64.to_radians();
                let e = match which {
                    0 => InvoluteGear::asymmetric(31, 3.0, a, ok, 0.0, 0.0),
                    1 => InvoluteGear::asymmetric(31, 3.0, ok, a, 0.0, 0.0),
                    _ => {
                        InvoluteGear::asymmetric(31, 3.0, ok, ok, (90.0 + a_deg).to_radians(), 0.0)
                    }
                }
                .unwrap_err()
                .to_string();
                let (name, v) = match which {
                    0 => ("alpha_n_right_deg", a_deg),
                    1 => ("alpha_n_left_deg", a_deg),
                    _ => ("beta_deg", 90.0 + a_deg),
                };
                // the value as written in degrees (to the rounding of the conversion)
                let shown: f64 = e
                    .split(" = ")
                    .nth(1)
                    .and_then(|t| t.split(' ').next())
                    .and_then(|t| t.parse().ok())
                    .unwrap_or(f64::NAN);
                prop_assert!(e.starts_with(name), "{}", e);
                prop_assert!((shown - v).abs() < 1e-9 * v, "{} vs {}", e, v);
                Ok(())
            })
            .unwrap();
        let e = InvoluteGear::worm(0, 3.0, 0.35, 130.0, Hand::Right)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("worm starts = 0"), "{e}");
    }
}
