//! Contact between a cylindrical worm flank and a cylindrical gear flank: common normal,
//! contact line in the plane of action, contact-path coefficients (39)/(40), the roll-distance
//! relation (R7) and the generating coupling (R4).

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{check_range, GrindError, Result};
use crate::flank::{Flank, InvoluteFlank, InvoluteGear};

/// Contact-path coefficients of one flank pair (cylindrical worm, cylindrical gear).
///
/// # Formula
/// worm (39): z_F1 = C_Fw1·w_F1 − z_V1 + C_Fc1; gear (40): z_F2 = C_Fw2·w_F2 − z_V2 + C_Fc2;
/// roll-distance relation (R7)/(45): w_F1 = a·w_F2 + b (a = −cos β_bF1/cos β_bF2 at reference
/// geometry), equivalently w_F1/cos β_bF1 + w_F2/cos β_bF2 = const.
/// # Source
/// JP6903407B2, eqs. (39)–(45) [SEED form; coefficients LOST]; docs/grinding.md "Derivation:
/// contact path and roll-distance relation"
/// [RECONSTRUCTED, VERIFIED]: C_Fw1 = s·tan β_bF1, C_Fw2 = s·tan β_bF2.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ContactPath {
    /// C_Fw1.
    pub c_w1: f64,
    /// C_Fc1 in mm.
    pub c_c1_mm: f64,
    /// C_Fw2.
    pub c_w2: f64,
    /// C_Fc2 in mm.
    pub c_c2_mm: f64,
    /// a = dw_F1/dw_F2 along the path.
    pub a: f64,
    /// b in mm (w_F1 = a·w_F2 + b).
    pub b_mm: f64,
    /// Constant of (R7): w_F1/cos β_bF1 + w_F2/cos β_bF2, in mm.
    pub r7_sum_mm: f64,
}

/// A worm flank meshing with a gear flank at a fixed centre distance and crossing angle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WormGearPair {
    /// Worm flank (index 1).
    pub worm: InvoluteFlank,
    /// Gear flank (index 2).
    pub gear: InvoluteFlank,
    /// Number of worm starts z1.
    pub worm_starts: u32,
    /// Number of gear teeth z2.
    pub gear_teeth: u32,
    /// Centre distance d in mm.
    pub centre_distance_mm: f64,
    /// Axis crossing angle γ in rad.
    pub crossing_rad: f64,
    /// Common normal n (outward normal of the worm flank; the gear's is −n), space frame.
    pub normal: [f64; 3],
    /// Contact-path coefficients.
    pub path: ContactPath,
    /// τ of the worm flank line with normal n (worm frame at φ1 = 0).
    tau1: f64,
    /// τ of the gear flank line with normal −n (gear frame at φ2 = 0).
    tau2: f64,
    /// n in the gear frame (R_y(−γ)·n).
    n2: [f64; 3],
    /// Point of the contact line L at λ = 0 (space frame, zero feeds).
    x0: [f64; 3],
}

/// A gear point with the worm point and the machine state that grind it (analytic mapping).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct MappedPoint {
    /// Worm roll distance w_F1 in mm.
    pub w1_mm: f64,
    /// Worm width position z_F1 in mm.
    pub z1_mm: f64,
    /// Worm shift z_V1 in mm.
    pub z_v1_mm: f64,
    /// Workpiece feed z_V2 in mm.
    pub z_v2_mm: f64,
    /// Worm rotation φ1 in rad.
    pub phi1_rad: f64,
    /// Workpiece rotation φ2 in rad.
    pub phi2_rad: f64,
}

fn ry_mat(g: f64) -> Matrix3<f64> {
    let (s, c) = g.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

impl WormGearPair {
    /// Worm and gear at the reference setting: d = r1 + r2, γ = −(β1 + β2).
    ///
    /// # Formula
    /// γ + β_W1 + β_W2 = 0 (R3) with the reference helix angles; d = r1 + r2.
    /// # Source
    /// JP6903407B2, (R3) [SEED]; docs/grinding.md "Derivation: contact path and roll-distance
    /// relation" [RECONSTRUCTED].
    pub fn reference(worm: &InvoluteGear, gear: &InvoluteGear, flank: Flank) -> Result<Self> {
        let d = worm.reference_radius_mm() + gear.reference_radius_mm();
        let g = -(worm.beta_rad + gear.beta_rad);
        Self::new(worm, gear, flank, d, g)
    }

    /// Worm and gear flank `flank` (same flank sign on both bodies) at centre distance d and
    /// crossing angle γ.
    ///
    /// # Formula
    /// Common normal n = x·a1 + y·a2 + t·(a1×a2)/|a1×a2| with n·a1 = s·sin β_b1,
    /// n·a2 = −s·sin β_b2, |n| = 1; the root with positive roll distances at the contact point
    /// is taken. Planes of action P_i: e_r(τ_i*)·p = r_bi; contact line L = P1 ∩ P2 (direction
    /// n). Path coefficients are read off two points of L (the relations are exactly linear).
    /// # Source
    /// docs/grinding.md "Derivation: contact path and roll-distance relation"
    /// [RECONSTRUCTED, VERIFIED].
    pub fn new(
        worm: &InvoluteGear,
        gear: &InvoluteGear,
        flank: Flank,
        centre_distance_mm: f64,
        crossing_rad: f64,
    ) -> Result<Self> {
        check_range(
            "centre_distance_mm",
            centre_distance_mm,
            1e-3,
            1e6,
            "0.001 ..= 1e6 mm",
        )?;
        check_range("crossing_rad", crossing_rad, -3.2, 3.2, "-π ..= π")?;
        let p1 = worm.normal_base_pitch_mm(flank);
        let p2 = gear.normal_base_pitch_mm(flank);
        if ((p1 - p2) / p2).abs() > 1e-9 {
            return Err(GrindError::MeshMismatch {
                worm_pbn_mm: p1,
                gear_pbn_mm: p2,
            });
        }
        let f1 = worm.flank(flank);
        let f2 = gear.flank(flank);
        let s = flank.sign();
        let rg = ry_mat(crossing_rad);
        let a1 = Vector3::z();
        let a2 = rg * Vector3::z();
        let cross = a1.cross(&a2);
        let no_normal = GrindError::NoCommonNormal {
            crossing_rad,
            beta_b1_rad: f1.beta_b_rad,
            beta_b2_rad: f2.beta_b_rad,
        };
        if cross.norm() < 1e-9 {
            return Err(no_normal);
        }
        let m = cross.normalize();
        let c12 = a1.dot(&a2);
        let g = Matrix2::new(1.0, c12, c12, 1.0);
        let rhs = Vector2::new(s * f1.beta_b_rad.sin(), -s * f2.beta_b_rad.sin());
        let xy = g.lu().solve(&rhs).ok_or(no_normal.clone())?;
        let p = a1 * xy.x + a2 * xy.y;
        let rest = 1.0 - p.norm_squared();
        if rest < 0.0 {
            return Err(no_normal);
        }
        let c_ref = Vector3::new(
            0.0,
            centre_distance_mm * worm.reference_radius_mm()
                / (worm.reference_radius_mm() + gear.reference_radius_mm()),
            0.0,
        );
        let mut best: Option<(f64, Self)> = None;
        for sign_t in [1.0, -1.0] {
            let n = p + m * (sign_t * rest.sqrt());
            let Some(cand) = Self::with_normal(
                f1,
                f2,
                worm.teeth,
                gear.teeth,
                centre_distance_mm,
                crossing_rad,
                n,
                c_ref,
            ) else {
                continue;
            };
            let w1 = cand.worm_wz(&cand.x0(), 0.0).0;
            let w2 = cand.gear_wz(&cand.x0(), 0.0).0;
            let score = w1.min(w2);
            if score > 0.0 && best.as_ref().is_none_or(|(b, _)| score > *b) {
                best = Some((score, cand));
            }
        }
        best.map(|(_, c)| c).ok_or(no_normal)
    }

    #[allow(clippy::too_many_arguments)]
    fn with_normal(
        f1: InvoluteFlank,
        f2: InvoluteFlank,
        z1: u32,
        z2: u32,
        d: f64,
        gamma: f64,
        n: Vector3<f64>,
        c_ref: Vector3<f64>,
    ) -> Option<Self> {
        let s = f1.s();
        let rg = ry_mat(gamma);
        let (c1, c2) = (f1.beta_b_rad.cos(), f2.beta_b_rad.cos());
        // e_t(τ1*) = −s·n_t/cos β_b1 (worm outward normal +n)
        let et1 = Vector3::new(n.x, n.y, 0.0) * (-s / c1);
        let tau1 = (-et1.x).atan2(et1.y);
        let er1 = Vector3::new(tau1.cos(), tau1.sin(), 0.0);
        let n2 = rg.transpose() * n;
        // e_t(τ2*) = s·n2_t/cos β_b2 (gear outward normal −n)
        let et2 = Vector3::new(n2.x, n2.y, 0.0) * (s / c2);
        let tau2 = (-et2.x).atan2(et2.y);
        let er2 = Vector3::new(tau2.cos(), tau2.sin(), 0.0);
        let er2_s = rg * er2;
        let dy = Vector3::new(0.0, d, 0.0);
        let a = Matrix3::from_rows(&[er1.transpose(), er2_s.transpose(), n.transpose()]);
        let rhs = Vector3::new(f1.r_b_mm, f2.r_b_mm + er2_s.dot(&dy), n.dot(&c_ref));
        let x0 = a.lu().solve(&rhs)?;
        let mut pair = Self {
            worm: f1,
            gear: f2,
            worm_starts: z1,
            gear_teeth: z2,
            centre_distance_mm: d,
            crossing_rad: gamma,
            normal: [n.x, n.y, n.z],
            path: ContactPath {
                c_w1: 0.0,
                c_c1_mm: 0.0,
                c_w2: 0.0,
                c_c2_mm: 0.0,
                a: 0.0,
                b_mm: 0.0,
                r7_sum_mm: 0.0,
            },
            tau1,
            tau2,
            n2: [n2.x, n2.y, n2.z],
            x0: [x0.x, x0.y, x0.z],
        };
        let xa = x0;
        let xb = x0 + n;
        let (w1a, z1a) = pair.worm_wz(&xa, 0.0);
        let (w1b, z1b) = pair.worm_wz(&xb, 0.0);
        let (w2a, z2a) = pair.gear_wz(&xa, 0.0);
        let (w2b, z2b) = pair.gear_wz(&xb, 0.0);
        if (w1b - w1a).abs() < 1e-12 || (w2b - w2a).abs() < 1e-12 {
            return None;
        }
        let c_w1 = (z1b - z1a) / (w1b - w1a);
        let c_w2 = (z2b - z2a) / (w2b - w2a);
        let a_coef = (w1b - w1a) / (w2b - w2a);
        pair.path = ContactPath {
            c_w1,
            c_c1_mm: z1a - c_w1 * w1a,
            c_w2,
            c_c2_mm: z2a - c_w2 * w2a,
            a: a_coef,
            b_mm: w1a - a_coef * w2a,
            r7_sum_mm: w1a / c1 + w2a / c2,
        };
        Some(pair)
    }

    fn x0(&self) -> Vector3<f64> {
        Vector3::from(self.x0)
    }

    /// Common normal n as a vector.
    pub fn normal_vec(&self) -> Vector3<f64> {
        Vector3::from(self.normal)
    }

    /// Point of the contact line L at parameter λ (mm along n), zero feeds, space frame.
    pub fn contact_line_point(&self, lambda_mm: f64) -> Vector3<f64> {
        self.x0() + self.normal_vec() * lambda_mm
    }

    /// (w_F1, z_F1) of a space point of the worm's plane of action at worm shift z_V1.
    pub fn worm_wz(&self, x: &Vector3<f64>, z_v1_mm: f64) -> (f64, f64) {
        let s = self.worm.s();
        let et = Vector3::new(-self.tau1.sin(), self.tau1.cos(), 0.0);
        (-s * x.dot(&et), x.z - z_v1_mm)
    }

    /// (w_F2, z_F2) of a space point of the gear's plane of action at workpiece feed z_V2.
    pub fn gear_wz(&self, x: &Vector3<f64>, z_v2_mm: f64) -> (f64, f64) {
        let s = self.gear.s();
        let q = ry_mat(self.crossing_rad).transpose()
            * (x - Vector3::new(0.0, self.centre_distance_mm, 0.0));
        let et = Vector3::new(-self.tau2.sin(), self.tau2.cos(), 0.0);
        (-s * q.dot(&et), q.z - z_v2_mm)
    }

    /// Direction of kinematic-correction modifications ρ_KF (tan ρ_KF = −C_Fw2).
    ///
    /// # Source
    /// JP6903407B2, eq. (99) [SEED]; formula docs/grinding.md "Derivation: contact path and
    /// roll-distance relation" [RECONSTRUCTED].
    pub fn rho_kf_rad(&self) -> f64 {
        (-self.path.c_w2).atan()
    }

    /// Worm rotation that keeps worm and gear flank tangent (generating coupling, R4).
    ///
    /// # Formula
    /// Tangent-plane offsets measured along the common normal n (docs/grinding.md "Derivation:
    /// generating coupling"):
    /// h1 = s·r_b1·cos β_b1·(τ1* − φ1 − η1) + n_z·z_V1,
    /// h2 = d·n_y + n2_z·z_V2 − s·r_b2·cos β_b2·(τ2* − φ2 − η2); h1 = h2 solved for φ1.
    /// Consequences: dφ1/dφ2 = −z2/z1, dφ1/dz_V1 = tan β_b1/r_b1 (= 2π/p_z1 for s = +1),
    /// dφ1/dz_V2 = (z2/z1)·tan β_b2/r_b2.
    /// # Source
    /// JP6903407B2, (R4) [SEED, formula LOST]; docs/grinding.md "Derivation: generating coupling"
    /// [RECONSTRUCTED, VERIFIED];
    /// docs/grinding.md "Independent reference: brute-force envelope".
    #[inline]
    pub fn phi1_rad(&self, phi2_rad: f64, z_v1_mm: f64, z_v2_mm: f64) -> f64 {
        let s = self.worm.s();
        let k1 = s * self.worm.r_b_mm * self.worm.beta_b_rad.cos();
        let k2 = s * self.gear.r_b_mm * self.gear.beta_b_rad.cos();
        let h2 = self.centre_distance_mm * self.normal[1] + self.n2[2] * z_v2_mm
            - k2 * (self.tau2 - phi2_rad - self.gear.eta_rad);
        self.tau1 - self.worm.eta_rad - (h2 - self.normal[2] * z_v1_mm) / k1
    }

    /// Workpiece rotation at which gear point (w_F2, z_F2) lies on the flank line with normal
    /// −n (the rotation at which the contact path passes it).
    #[inline]
    pub fn contact_phi2_rad(&self, w2_mm: f64, z2_mm: f64) -> f64 {
        self.tau2 - self.gear.tau(w2_mm, z2_mm)
    }

    /// Workpiece feed at which the contact path (40) passes a gear point.
    ///
    /// # Formula
    /// z_V2 = C_Fw2·w_F2 + C_Fc2 − z_F2 (eq. (40) solved for z_V2).
    #[inline]
    pub fn contact_feed_mm(&self, w2_mm: f64, z2_mm: f64) -> f64 {
        self.path.c_w2 * w2_mm + self.path.c_c2_mm - z2_mm
    }

    /// Worm point and machine state that grind gear point (w_F2, z_F2) (first-order analytic
    /// mapping; exact for unmodified flanks).
    ///
    /// # Formula
    /// z_V2 from (40); z_V1 = F_ZV1(z_V2) (36)/(94); w_F1 = a·w_F2 + b (R7);
    /// z_F1 = C_Fw1·w_F1 − z_V1 + C_Fc1 (39); φ2 from the flank line, φ1 from (R4).
    /// # Source
    /// docs/grinding.md "Derivation: diagonal ratio and line map" [RECONSTRUCTED, VERIFIED].
    #[inline]
    pub fn map_gear_point(
        &self,
        coupling: &crate::kinematics::FeedCoupling,
        w2_mm: f64,
        z2_mm: f64,
    ) -> MappedPoint {
        let z_v2 = self.contact_feed_mm(w2_mm, z2_mm);
        let z_v1 = coupling.z_v1_mm(z_v2);
        let w1 = self.path.a * w2_mm + self.path.b_mm;
        let z1 = self.path.c_w1 * w1 - z_v1 + self.path.c_c1_mm;
        let phi2 = self.contact_phi2_rad(w2_mm, z2_mm);
        MappedPoint {
            w1_mm: w1,
            z1_mm: z1,
            z_v1_mm: z_v1,
            z_v2_mm: z_v2,
            phi1_rad: self.phi1_rad(phi2, z_v1, z_v2),
            phi2_rad: phi2,
        }
    }

    /// Ratio q = cos β_bF1/cos β_bF2 that turns a worm transverse modification into the gear's
    /// (f_Ft2 = −q·f_Ft1 at associated points).
    ///
    /// # Formula
    /// f_Fn = f_Ft·cos β_bF (38) and f_nF2 = −f_nF1 (JP6903407B2 text to eq. (38)).
    /// # Source
    /// JP6903407B2, eq. (38) and its text (f_nF2 = −f_nF1) [SEED].
    pub fn transverse_ratio(&self) -> f64 {
        self.worm.beta_b_rad.cos() / self.gear.beta_b_rad.cos()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::flank::Hand;
    use crate::kinematics::{chain_cyl_cyl, transform_point, FeedCoupling};
    use approx::assert_relative_eq;

    pub(crate) fn example(flank: Flank) -> WormGearPair {
        let gear = InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap();
        let worm = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
        WormGearPair::reference(&worm, &gear, flank).unwrap()
    }

    /// T4/T5: docs/grinding.md "Independent reference: reference example" numbers (independent
    /// calculation), tolerance 1e-6 as printed.
    #[test]
    fn t4_t5_contact_path_reference_example() {
        let p = example(Flank::Right);
        assert_relative_eq!(p.crossing_rad.to_degrees(), -104.338880, epsilon = 1e-6);
        assert_relative_eq!(p.centre_distance_mm, 178.140342, epsilon = 1e-6);
        let n = p.normal_vec();
        assert_relative_eq!(n.x, 0.010843, epsilon = 1e-6);
        assert_relative_eq!(n.y, 0.342020, epsilon = 1e-6);
        assert_relative_eq!(n.z, 0.939630, epsilon = 1e-6);
        assert_relative_eq!(p.path.c_w1, 2.745915, epsilon = 1e-6);
        assert_relative_eq!(p.path.c_c1_mm, -356.789715, epsilon = 1e-6);
        assert_relative_eq!(p.path.c_w2, 0.250739, epsilon = 1e-6);
        assert_relative_eq!(p.path.c_c2_mm, -4.256211, epsilon = 1e-6);
        assert_relative_eq!(p.path.r7_sum_mm, 397.213083, epsilon = 1e-6);
        assert_relative_eq!(p.path.a, -0.352785, epsilon = 1e-6);
        // The pitch point C = (0, r1, 0) lies on L (reference setting).
        let c = Vector3::new(0.0, 130.0, 0.0);
        let x0 = p.contact_line_point(0.0);
        assert!((x0 - c).norm() < 1e-9);
        // ρ_KF = −β_b2 for s = +1.
        assert_relative_eq!(p.rho_kf_rad().to_degrees(), -14.076095, epsilon = 1e-6);
    }

    /// Left flank: all C_Fw and C_Fc change sign (docs/grinding.md "Independent reference:
    /// reference example").
    #[test]
    fn t6_left_flank_mirrors_coefficients() {
        let r = example(Flank::Right);
        let l = example(Flank::Left);
        assert_relative_eq!(l.path.c_w1, -r.path.c_w1, epsilon = 1e-9);
        assert_relative_eq!(l.path.c_w2, -r.path.c_w2, epsilon = 1e-9);
        assert_relative_eq!(l.path.c_c1_mm, -r.path.c_c1_mm, epsilon = 1e-7);
        assert_relative_eq!(l.path.c_c2_mm, -r.path.c_c2_mm, epsilon = 1e-7);
        assert_relative_eq!(l.path.r7_sum_mm, r.path.r7_sum_mm, epsilon = 1e-7);
    }

    /// T10: generating coupling derivatives, by finite differences of φ1(φ2, z_V1, z_V2).
    #[test]
    fn t10_generating_coupling() {
        for flank in [Flank::Right, Flank::Left] {
            let p = example(flank);
            let h = 1e-3;
            let d_phi2 =
                (p.phi1_rad(0.2 + h, 1.0, 2.0) - p.phi1_rad(0.2 - h, 1.0, 2.0)) / (2.0 * h);
            let d_zv1 = (p.phi1_rad(0.2, 1.0 + h, 2.0) - p.phi1_rad(0.2, 1.0 - h, 2.0)) / (2.0 * h);
            let d_zv2 = (p.phi1_rad(0.2, 1.0, 2.0 + h) - p.phi1_rad(0.2, 1.0, 2.0 - h)) / (2.0 * h);
            assert_relative_eq!(d_phi2, -31.0, epsilon = 1e-9);
            // the same on both flanks: the coupling belongs to the bodies, not to a flank
            assert_relative_eq!(d_zv1, 0.666622, epsilon = 1e-6);
            assert_relative_eq!(
                d_zv1,
                2.0 * std::f64::consts::PI / p.worm.lead_mm().abs(),
                epsilon = 1e-9
            );
            assert_relative_eq!(d_zv2, 0.172546, epsilon = 1e-6);
        }
    }

    /// T5 cross-check (docs/grinding.md "Derivation: contact path and roll-distance relation"): at
    /// the mapped state both real surfaces pass through
    /// the predicted point, with normals +n (worm) and −n (gear), for arbitrary feeds.
    #[test]
    fn mapped_points_are_real_contacts() {
        for flank in [Flank::Right, Flank::Left] {
            let p = example(flank);
            let n = p.normal_vec();
            for &(w2, z2, k, zv01) in &[
                (12.0, -10.0, 0.0, 0.0),
                (17.0, 3.0, -0.877, 5.0),
                (22.5, 14.0, 1.3, -7.0),
            ] {
                let cpl = FeedCoupling::linear(k, zv01).unwrap();
                let m = p.map_gear_point(&cpl, w2, z2);
                let kr = chain_cyl_cyl(
                    m.phi1_rad,
                    m.z_v1_mm,
                    p.centre_distance_mm,
                    p.crossing_rad,
                    m.z_v2_mm,
                    m.phi2_rad,
                );
                let x1 = transform_point(&kr, &p.gear.point(w2, z2));
                let y1 = p.worm.point(m.w1_mm, m.z1_mm);
                assert!(
                    (x1 - y1).norm() < 1e-9,
                    "{flank:?} {w2} {z2}: {}",
                    (x1 - y1).norm()
                );
                // normals in the worm frame: gear normal = −worm normal
                let ng = kr.rotation * p.gear.normal(w2, z2);
                let nw = p.worm.normal(m.w1_mm, m.z1_mm);
                assert!((ng + nw).norm() < 1e-9);
                // and the worm normal, taken to space, is n
                let to_space = chain_cyl_cyl(m.phi1_rad, m.z_v1_mm, 0.0, 0.0, 0.0, 0.0).inverse();
                assert!((to_space.rotation * nw - n).norm() < 1e-9);
            }
        }
    }

    #[test]
    fn bad_pairs_are_rejected() {
        let gear = InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap();
        let worm = InvoluteGear::worm(1, 2.5, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
        assert!(matches!(
            WormGearPair::reference(&worm, &gear, Flank::Right),
            Err(GrindError::MeshMismatch { .. })
        ));
        let worm = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
        assert!(WormGearPair::new(&worm, &gear, Flank::Right, 178.0, 0.0).is_err());
        assert!(WormGearPair::new(&worm, &gear, Flank::Right, f64::NAN, -1.8).is_err());
    }
}
