//! Conical (beveloid) worms and workpieces: beveloid flanks, the kinematic chains (29)–(31),
//! the contact path (50)–(85) with its roll-distance relation (58)/(71)/(86), the generating
//! coupling and the diagonal ratio for any combination of cylindrical and conical bodies.
//!
//! Conventions (fixed here, `docs/grinding.md` "Conical tool and workpiece"):
//! - A body's cone angle ϑ is positive when its reference cone grows towards +z of the body:
//!   the generating rack's reference plane is tilted by ϑ about the rack's travel direction, so
//!   the local profile shift is x(z) = x0 + z·tan ϑ/m_n (radial, in the transverse section z).
//! - The helix angle β of a beveloid is the angle of the rack's tooth lines to the cone
//!   generatrix, measured in the rack's (tilted) reference plane; m_t = m_n/cos β as for a
//!   cylinder.
//! - Chain: both bodies pivot about their reference-cylinder point at z = 0 on the mesh side
//!   (the pitch point C); at zero feeds and the reference setting d = r_w1 + r_w2 the two
//!   pivots coincide and both generating racks lie in the plane y = 0 of the frame S (origin
//!   at C, x along the rack travel of the worm, y the common perpendicular).

use nalgebra::{Isometry3, Matrix2, Matrix3, Translation3, UnitQuaternion, Vector2, Vector3};
use serde::{Deserialize, Serialize};

use crate::contact::MappedPoint;
use crate::error::{check_range, GrindError, Result};
use crate::flank::{Flank, InvoluteFlank, InvoluteGear};
use crate::kinematics::FeedCoupling;

/// Largest cone angle accepted, 50° (JP6903407B2's upper bound for a conical tool).
pub const MAX_CONE_ANGLE_RAD: f64 = 50.0 * std::f64::consts::PI / 180.0;

/// Smallest cos β_bF accepted for a beveloid flank (base helix angle below 89.9°).
const MIN_COS_BETA_B: f64 = 1.745e-3;

/// A cylindrical (ϑ = 0) or conical (beveloid, ϑ ≠ 0) involute gear or worm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BeveloidGear {
    /// Teeth (starts), module, profile angles, helix angle and the profile shift x0 at z = 0.
    pub body: InvoluteGear,
    /// Cone angle ϑ in rad (> 0: reference cone grows towards +z).
    pub cone_angle_rad: f64,
}

impl BeveloidGear {
    /// A validated beveloid.
    pub fn new(body: InvoluteGear, cone_angle_rad: f64) -> Result<Self> {
        // reported in degrees, the unit the user writes ("cone_angle_rad = 1.047…" read as
        // an internal value)
        if !(cone_angle_rad.is_finite() && cone_angle_rad.abs() <= MAX_CONE_ANGLE_RAD) {
            return Err(GrindError::OutOfRange {
                field: "cone_angle_deg",
                value: cone_angle_rad.to_degrees(),
                expected: "-50° ..= 50° (JP6903407B2: cone angle below 50°)",
            });
        }
        let bev = Self {
            body,
            cone_angle_rad,
        };
        // Tilting the rack turns one flank normal towards the axis; at |ϑ| ≈ α_n (worm) that
        // flank's base helix angle reaches 90° and the flank is no longer generated.
        for flank in [Flank::Left, Flank::Right] {
            let m = bev.rack_normal(flank);
            if m.x.hypot(m.y) < MIN_COS_BETA_B {
                return Err(GrindError::OutOfRange {
                    field: "cone_angle_deg",
                    value: cone_angle_rad.to_degrees(),
                    expected: "a cone angle that leaves both flanks a base helix angle below \
                               89.9° (for a worm: |ϑ| clearly below the normal pressure angles)",
                });
            }
        }
        Ok(bev)
    }

    /// A cylindrical body (ϑ = 0).
    pub fn cylindrical(body: InvoluteGear) -> Self {
        Self {
            body,
            cone_angle_rad: 0.0,
        }
    }

    /// Reference (pitch) radius at z = 0, r = z·m_n/(2·cos β), in mm.
    pub fn reference_radius_mm(&self) -> f64 {
        self.body.reference_radius_mm()
    }

    /// Local profile shift coefficient at width position z.
    ///
    /// # Formula
    /// x(z) = x0 + z·tan ϑ/m_n
    /// # Source
    /// Beveloid definition (rack tilted by the cone angle), docs/grinding.md "Conical tool and
    /// workpiece"
    /// (Zierau, TU Braunschweig report 32) [RECONSTRUCTED].
    pub fn local_profile_shift(&self, z_mm: f64) -> f64 {
        self.body.x_shift + z_mm * self.cone_angle_rad.tan() / self.body.m_n_mm
    }

    /// Outward unit normal m of flank `flank` of the generating rack, in the body frame with
    /// the rack at the +x side of the body (tooth centred at angle 0).
    ///
    /// # Formula
    /// e_n = (cos ϑ, 0, −sin ϑ) (rack reference-plane normal), e_g = (sin ϑ, 0, cos ϑ)
    /// (generatrix), u = cos β·e_y − sin β·e_g (normal to the tooth lines in the plane),
    /// m = −s·cos α_nF·u + sin α_nF·e_n.
    /// # Source
    /// Rack generation of beveloids, docs/grinding.md "Conical tool and workpiece" [RECONSTRUCTED].
    pub fn rack_normal(&self, flank: Flank) -> Vector3<f64> {
        let s = flank.sign();
        let (sa, ca) = self.body.alpha_n_rad(flank).sin_cos();
        let (sb, cb) = self.body.beta_rad.sin_cos();
        let (st, ct) = self.cone_angle_rad.sin_cos();
        let e_n = Vector3::new(ct, 0.0, -st);
        let e_g = Vector3::new(st, 0.0, ct);
        let u = Vector3::y() * cb - e_g * sb;
        -u * (s * ca) + e_n * sa
    }

    /// The flank generated by the tilted rack: an involute helicoid with its own r_bF, β_bF.
    ///
    /// # Formula
    /// sin β_bF = cos α_nF·sin β·cos ϑ − s·sin α_nF·sin ϑ;
    /// r_bF = r·cos α_nF·cos β/cos β_bF (so r_bF·cos β_bF, the normal base pitch, is that of
    /// the cylinder); τ* from N(τ*) = m; the rack flank plane m·p = c passes through
    /// ((r + x0·m_n), −s·π·m_n/(4 cos β), 0); η = τ* − s·c/(r_bF·cos β_bF).
    /// # Source
    /// Envelope of the rack plane under rolling on the reference cylinder (tangent planes of the
    /// helicoid N(τ)·p = s·r_b·cos β_b·(τ − η)), derived here [RECONSTRUCTED]; reduces to ISO
    /// 21771:2007 §4–5 [STANDARD] for ϑ = 0; docs/grinding.md "Derivation: flank and chain
    /// conventions" (the four combinations of cylindrical/conical tool and workpiece)
    /// [RECONSTRUCTED].
    pub fn flank(&self, flank: Flank) -> InvoluteFlank {
        let s = flank.sign();
        let m = self.rack_normal(flank);
        let r = self.reference_radius_mm();
        let mn = self.body.m_n_mm;
        let beta_b = (s * m.z).clamp(-1.0, 1.0).asin();
        let cbb = m.x.hypot(m.y);
        let r_b = -s * r * m.y / cbb;
        let tau_star = (s * m.x / cbb).atan2(-s * m.y / cbb);
        let q = Vector3::new(
            r + self.body.x_shift * mn,
            -s * std::f64::consts::PI * mn / (4.0 * self.body.beta_rad.cos()),
            0.0,
        );
        let c = m.dot(&q);
        InvoluteFlank {
            flank,
            r_b_mm: r_b,
            beta_b_rad: beta_b,
            eta_rad: tau_star - s * c / (r_b * cbb),
            w_ref_mm: (r * r - r_b * r_b).max(0.0).sqrt(),
        }
    }
}

fn iso(rot: UnitQuaternion<f64>, t: Vector3<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(t), rot)
}
fn rx(a: f64) -> Isometry3<f64> {
    iso(
        UnitQuaternion::from_euler_angles(a, 0.0, 0.0),
        Vector3::zeros(),
    )
}
fn ry(a: f64) -> Isometry3<f64> {
    iso(
        UnitQuaternion::from_euler_angles(0.0, a, 0.0),
        Vector3::zeros(),
    )
}
fn rz(a: f64) -> Isometry3<f64> {
    iso(
        UnitQuaternion::from_euler_angles(0.0, 0.0, a),
        Vector3::zeros(),
    )
}
fn ty(v: f64) -> Isometry3<f64> {
    Isometry3::translation(0.0, v, 0.0)
}
fn tz(v: f64) -> Isometry3<f64> {
    Isometry3::translation(0.0, 0.0, v)
}
fn rx_mat(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}
fn ry_mat(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

/// Fixed parameters of the kinematic chains (29)–(31) (and (28) for ϑ1 = ϑ2 = 0).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ConeChain {
    /// Axis distance d the chain has at ϑ1 = ϑ2 = 0, in mm (= r_w1 + r_w2 at the reference
    /// setting, where the two pivots coincide).
    pub centre_distance_mm: f64,
    /// Crossing angle γ of the two cone generatrices (of the axes for cylinders), rad.
    pub crossing_rad: f64,
    /// Worm pivot radius r_w1 (reference radius at z1 = 0), mm.
    pub r_w1_mm: f64,
    /// Worm cone angle ϑ1, rad.
    pub cone1_rad: f64,
    /// Workpiece pivot radius r_w2 (reference radius at z2 = 0), mm.
    pub r_w2_mm: f64,
    /// Workpiece cone angle ϑ2, rad.
    pub cone2_rad: f64,
}

impl ConeChain {
    /// Relative pose K_R (workpiece coordinates → worm coordinates).
    ///
    /// # Formula
    /// K_R = R_z(−φ1)·T_y(r_w1)·R_x(−ϑ1)·T_z(−z_V1)·T_y(d − r_w1 − r_w2)·R_y(γ)·T_z(z_V2)
    ///       ·R_x(−ϑ2)·T_y(r_w2)·R_z(φ2)
    /// ϑ2 = 0: conical tool (29); ϑ1 = 0: conical workpiece (30); both: (31); ϑ1 = ϑ2 = 0 is
    /// (28) exactly. Relative to the printed chains of JP6903407B2: its VARθ1 = −ϑ1 (our ϑ > 0 widens
    /// the body towards +z on both bodies), and its T_y(−r_w2) pivots the workpiece on
    /// the side away from the worm, which leaves the axes at r_w1 + d − r_w2 for ϑ → 0; we pivot
    /// on the mesh side and write the axis distance d explicitly.
    /// # Units
    /// rad, mm.
    /// # Source
    /// JP6903407B2, eqs. (29)–(31) [SEED]; pivot and sign convention docs/grinding.md "Derivation:
    /// flank and chain conventions" and
    /// §10.2 [RECONSTRUCTED].
    pub fn pose(&self, phi1_rad: f64, z_v1_mm: f64, z_v2_mm: f64, phi2_rad: f64) -> Isometry3<f64> {
        rz(-phi1_rad)
            * ty(self.r_w1_mm)
            * rx(-self.cone1_rad)
            * tz(-z_v1_mm)
            * ty(self.centre_distance_mm - self.r_w1_mm - self.r_w2_mm)
            * ry(self.crossing_rad)
            * tz(z_v2_mm)
            * rx(-self.cone2_rad)
            * ty(self.r_w2_mm)
            * rz(phi2_rad)
    }

    /// Rotation Q1 (S → unrotated worm frame) and worm feed direction g1 in S (= e_z).
    fn worm_rot(&self) -> Matrix3<f64> {
        rx_mat(-self.cone1_rad)
    }
    /// Rotation Q2 (S → unrotated gear frame).
    fn gear_rot(&self) -> Matrix3<f64> {
        rx_mat(self.cone2_rad) * ry_mat(-self.crossing_rad)
    }
    /// Feed direction g2 of the workpiece in S.
    fn gear_feed_dir(&self) -> Vector3<f64> {
        ry_mat(self.crossing_rad) * Vector3::z()
    }
    fn pivot_gap_mm(&self) -> f64 {
        self.centre_distance_mm - self.r_w1_mm - self.r_w2_mm
    }
    /// Unrotated worm coordinates of a point of S at worm feed z_V1.
    fn worm_coords(&self, x: &Vector3<f64>, z_v1_mm: f64) -> Vector3<f64> {
        self.worm_rot() * (x - Vector3::z() * z_v1_mm) + Vector3::y() * self.r_w1_mm
    }
    /// Unrotated gear coordinates of a point of S at workpiece feed z_V2.
    fn gear_coords(&self, x: &Vector3<f64>, z_v2_mm: f64) -> Vector3<f64> {
        self.gear_rot() * (x - Vector3::y() * self.pivot_gap_mm() - self.gear_feed_dir() * z_v2_mm)
            - Vector3::y() * self.r_w2_mm
    }
}

/// Contact-path coefficients for cylindrical and/or conical worm and workpiece.
///
/// # Formula
/// worm (76): z_F1 = C_Fw1·w_F1 + C_FzV11·z_V1 + C_FzV21·z_V2 + C_Fc1;
/// gear (77): z_F2 = C_Fw2·w_F2 + C_FzV12·z_V1 + C_FzV22·z_V2 + C_Fc2;
/// roll distances (86): w_F1 = a·w_F2 + b_zv1·z_V1 + b_zv2·z_V2 + b, i.e. with
/// ^C_Fw1 = 1/cos β_bF1: ^C_Fw2 = −a/cos β_bF1, ^C_FzV1 = −b_zv1/cos β_bF1, … .
/// (29) uses C_FzV21 = 0, C_FzV22 = −1, b_zv2 = 0 ((50), (51), (58)); (30) uses C_FzV11 = −1,
/// C_FzV12 = 0, b_zv1 = 0 ((63), (64), (71)); cylinder/cylinder (39)/(40)/(45).
/// # Source
/// JP6903407B2, eqs. (50)–(91) [SEED form; coefficients LOST]; docs/grinding.md "Derivation:
/// contact path and roll-distance relation"
/// [RECONSTRUCTED]; closed vector forms in [`ConicalPair::new`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ConicalPath {
    /// C_Fw1.
    pub c_w1: f64,
    /// C_FzV11 (worm path per mm of worm feed).
    pub c_zv11: f64,
    /// C_FzV21 (worm path per mm of workpiece feed).
    pub c_zv21: f64,
    /// C_Fc1 in mm.
    pub c_c1_mm: f64,
    /// C_Fw2.
    pub c_w2: f64,
    /// C_FzV12 (workpiece path per mm of worm feed).
    pub c_zv12: f64,
    /// C_FzV22 (workpiece path per mm of workpiece feed).
    pub c_zv22: f64,
    /// C_Fc2 in mm.
    pub c_c2_mm: f64,
    /// a = ∂w_F1/∂w_F2 along the contact line.
    pub a: f64,
    /// ∂w_F1/∂z_V1 at fixed w_F2.
    pub b_zv1: f64,
    /// ∂w_F1/∂z_V2 at fixed w_F2.
    pub b_zv2: f64,
    /// Offset b in mm.
    pub b_mm: f64,
}

/// A worm flank meshing with a workpiece flank, either of them conical.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ConicalPair {
    /// Worm flank (index 1).
    pub worm: InvoluteFlank,
    /// Workpiece flank (index 2).
    pub gear: InvoluteFlank,
    /// Number of worm starts z1.
    pub worm_starts: u32,
    /// Number of workpiece teeth z2.
    pub gear_teeth: u32,
    /// The chain.
    pub chain: ConeChain,
    /// Common normal n in S (outward normal of the worm flank; the workpiece's is −n).
    pub normal: [f64; 3],
    /// Contact-path coefficients.
    pub path: ConicalPath,
    tau1: f64,
    tau2: f64,
    /// Unrotated-frame normals ν1 = Q1·n (worm) and ν2 = −Q2·n (gear).
    nu1: [f64; 3],
    nu2: [f64; 3],
}

impl ConicalPair {
    /// Worm and workpiece at the reference setting: pivots coincide (d = r1 + r2) and the
    /// tooth lines of both racks coincide, γ = −(β1 + β2).
    ///
    /// # Formula
    /// γ + β_W1 + β_W2 = 0 (R3), with β measured from each cone generatrix in the common rack
    /// plane.
    /// # Source
    /// JP6903407B2, (R3) [SEED]; docs/grinding.md "Derivation: contact path and roll-distance
    /// relation" [RECONSTRUCTED].
    pub fn reference(worm: &BeveloidGear, gear: &BeveloidGear, flank: Flank) -> Result<Self> {
        let d = worm.reference_radius_mm() + gear.reference_radius_mm();
        let g = -(worm.body.beta_rad + gear.body.beta_rad);
        Self::new(worm, gear, flank, d, g)
    }

    /// Worm and workpiece flank `flank` at axis distance d (at ϑ = 0) and crossing angle γ.
    ///
    /// # Formula
    /// Axes in S: a1 = Q1ᵀe_z, a2 = Q2ᵀe_z. Common normal n: n·a1 = s·sin β_bF1,
    /// n·a2 = −s·sin β_bF2, |n| = 1 (root with positive roll distances at the pitch point).
    /// Planes of action P_i: ν̂_i·x = r_bi − e_r(τ_i*)·c_i + f_i·ν̂_i·g_i, ν̂_i = Q_iᵀe_r(τ_i*),
    /// f_i the feed along g_i. The contact line x(λ, z_V1, z_V2) = M⁻¹·(rhs1, rhs2, λ),
    /// M = [ν̂1; ν̂2; n], is affine: x = x0 + λ·n + z_V1·u1 + z_V2·u2. With
    /// ε_i = Q_iᵀe_t(τ_i*), ζ_i = a_i and body coordinates w_i = −s·ε_i·(x − f_i g_i) + …,
    /// z_i = ζ_i·(x − f_i g_i) + …:
    /// C_Fwi = ζ_i·n/(−s·ε_i·n); C_FzV11 = κ1·(u1 − g1), C_FzV21 = κ1·u2,
    /// C_FzV12 = κ2·u1, C_FzV22 = κ2·(u2 − g2), κ_i = ζ_i + s·C_Fwi·ε_i;
    /// a = (ε1·n)/(ε2·n); b_zv1 = −s·ε1·(u1 − g1) + s·a·ε2·u1; b_zv2 = −s·ε1·u2 + s·a·ε2·(u2 − g2).
    /// # Source
    /// docs/grinding.md "Derivation: contact path and roll-distance relation"
    /// [RECONSTRUCTED; VERIFIED for ϑ = 0]; the feed terms are the exact derivatives of the affine
    /// construction.
    pub fn new(
        worm: &BeveloidGear,
        gear: &BeveloidGear,
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
        let p1 = worm.body.normal_base_pitch_mm(flank);
        let p2 = gear.body.normal_base_pitch_mm(flank);
        if ((p1 - p2) / p2).abs() > 1e-9 {
            return Err(GrindError::MeshMismatch {
                worm_pbn_mm: p1,
                gear_pbn_mm: p2,
            });
        }
        let chain = ConeChain {
            centre_distance_mm,
            crossing_rad,
            r_w1_mm: worm.reference_radius_mm(),
            cone1_rad: worm.cone_angle_rad,
            r_w2_mm: gear.reference_radius_mm(),
            cone2_rad: gear.cone_angle_rad,
        };
        let f1 = worm.flank(flank);
        let f2 = gear.flank(flank);
        let s = flank.sign();
        let q1 = chain.worm_rot();
        let q2 = chain.gear_rot();
        let a1 = q1.transpose() * Vector3::z();
        let a2 = q2.transpose() * Vector3::z();
        let no_normal = GrindError::NoCommonNormal {
            crossing_rad,
            beta_b1_rad: f1.beta_b_rad,
            beta_b2_rad: f2.beta_b_rad,
        };
        let cross = a1.cross(&a2);
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
        let mut best: Option<(f64, Self)> = None;
        for sign_t in [1.0, -1.0] {
            let n = p + m * (sign_t * rest.sqrt());
            let Some(cand) = Self::with_normal(f1, f2, worm, gear, chain, n) else {
                continue;
            };
            // roll distances of the contact-line point nearest to the pitch point C (x·n = 0)
            let x = cand.contact_point(0.0, 0.0, 0.0);
            let w1 = cand.worm_wz(&x, 0.0).0;
            let w2 = cand.gear_wz(&x, 0.0).0;
            let score = w1.min(w2);
            if score > 0.0 && best.as_ref().is_none_or(|(b, _)| score > *b) {
                best = Some((score, cand));
            }
        }
        best.map(|(_, c)| c).ok_or(no_normal)
    }

    fn with_normal(
        f1: InvoluteFlank,
        f2: InvoluteFlank,
        worm: &BeveloidGear,
        gear: &BeveloidGear,
        chain: ConeChain,
        n: Vector3<f64>,
    ) -> Option<Self> {
        let s = f1.s();
        let (q1, q2) = (chain.worm_rot(), chain.gear_rot());
        let nu1 = q1 * n;
        let nu2 = -(q2 * n);
        // N(τ*) = ν ⇒ sin τ* = s·ν_x/cos β_b, cos τ* = −s·ν_y/cos β_b
        let tau = |nu: &Vector3<f64>| (s * nu.x).atan2(-s * nu.y);
        let (tau1, tau2) = (tau(&nu1), tau(&nu2));
        let mut pair = Self {
            worm: f1,
            gear: f2,
            worm_starts: worm.body.teeth,
            gear_teeth: gear.body.teeth,
            chain,
            normal: [n.x, n.y, n.z],
            path: ConicalPath {
                c_w1: 0.0,
                c_zv11: 0.0,
                c_zv21: 0.0,
                c_c1_mm: 0.0,
                c_w2: 0.0,
                c_zv12: 0.0,
                c_zv22: 0.0,
                c_c2_mm: 0.0,
                a: 0.0,
                b_zv1: 0.0,
                b_zv2: 0.0,
                b_mm: 0.0,
            },
            tau1,
            tau2,
            nu1: [nu1.x, nu1.y, nu1.z],
            nu2: [nu2.x, nu2.y, nu2.z],
        };
        let minv = pair.line_matrix().try_inverse()?;
        let (e1, e2) = (pair.eps(1), pair.eps(2));
        let (z1, z2) = (q1.transpose() * Vector3::z(), q2.transpose() * Vector3::z());
        let (en1, en2) = (e1.dot(&n), e2.dot(&n));
        if en1.abs() < 1e-12 || en2.abs() < 1e-12 {
            return None;
        }
        let g1 = Vector3::z();
        let g2 = chain.gear_feed_dir();
        let (nh1, nh2) = (pair.nu_hat(1), pair.nu_hat(2));
        let u1 = minv * Vector3::new(nh1.dot(&g1), 0.0, 0.0);
        let u2 = minv * Vector3::new(0.0, nh2.dot(&g2), 0.0);
        let c_w1 = z1.dot(&n) / (-s * en1);
        let c_w2 = z2.dot(&n) / (-s * en2);
        let k1 = z1 + e1 * (s * c_w1);
        let k2 = z2 + e2 * (s * c_w2);
        let a = en1 / en2;
        let x0 = pair.contact_point(0.0, 0.0, 0.0);
        let (w10, z10) = pair.worm_wz(&x0, 0.0);
        let (w20, z20) = pair.gear_wz(&x0, 0.0);
        pair.path = ConicalPath {
            c_w1,
            c_zv11: k1.dot(&(u1 - g1)),
            c_zv21: k1.dot(&u2),
            c_c1_mm: z10 - c_w1 * w10,
            c_w2,
            c_zv12: k2.dot(&u1),
            c_zv22: k2.dot(&(u2 - g2)),
            c_c2_mm: z20 - c_w2 * w20,
            a,
            b_zv1: -s * e1.dot(&(u1 - g1)) + s * a * e2.dot(&u1),
            b_zv2: -s * e1.dot(&u2) + s * a * e2.dot(&(u2 - g2)),
            b_mm: w10 - a * w20,
        };
        Some(pair)
    }

    fn tau_of(&self, body: u8) -> f64 {
        if body == 1 {
            self.tau1
        } else {
            self.tau2
        }
    }
    fn rot_of(&self, body: u8) -> Matrix3<f64> {
        if body == 1 {
            self.chain.worm_rot()
        } else {
            self.chain.gear_rot()
        }
    }
    /// ν̂_i = Q_iᵀ·e_r(τ_i*) (normal of the plane of action in S).
    fn nu_hat(&self, body: u8) -> Vector3<f64> {
        let t = self.tau_of(body);
        self.rot_of(body).transpose() * Vector3::new(t.cos(), t.sin(), 0.0)
    }
    /// ε_i = Q_iᵀ·e_t(τ_i*).
    fn eps(&self, body: u8) -> Vector3<f64> {
        let t = self.tau_of(body);
        self.rot_of(body).transpose() * Vector3::new(-t.sin(), t.cos(), 0.0)
    }
    fn line_matrix(&self) -> Matrix3<f64> {
        Matrix3::from_rows(&[
            self.nu_hat(1).transpose(),
            self.nu_hat(2).transpose(),
            self.normal_vec().transpose(),
        ])
    }

    /// Common normal n as a vector (frame S).
    pub fn normal_vec(&self) -> Vector3<f64> {
        Vector3::from(self.normal)
    }

    /// Point of the contact line at parameter λ = n·x (mm) for feeds z_V1, z_V2, frame S.
    ///
    /// # Formula
    /// x = M⁻¹·(r_b1 − e_r(τ1*)·A1(0), r_b2 − e_r(τ2*)·A2(0), λ) with the planes of action in
    /// S (see [`ConicalPair::new`]); A_i the S → unrotated-body maps at the given feeds.
    pub fn contact_point(&self, lambda_mm: f64, z_v1_mm: f64, z_v2_mm: f64) -> Vector3<f64> {
        let t1 = self.tau1;
        let t2 = self.tau2;
        let er1 = Vector3::new(t1.cos(), t1.sin(), 0.0);
        let er2 = Vector3::new(t2.cos(), t2.sin(), 0.0);
        let o = Vector3::zeros();
        let rhs = Vector3::new(
            self.worm.r_b_mm - er1.dot(&self.chain.worm_coords(&o, z_v1_mm)),
            self.gear.r_b_mm - er2.dot(&self.chain.gear_coords(&o, z_v2_mm)),
            lambda_mm,
        );
        self.line_matrix()
            .lu()
            .solve(&rhs)
            .unwrap_or_else(Vector3::zeros)
    }

    /// (w_F1, z_F1) of a point of the worm's plane of action (frame S) at worm feed z_V1.
    pub fn worm_wz(&self, x: &Vector3<f64>, z_v1_mm: f64) -> (f64, f64) {
        let q = self.chain.worm_coords(x, z_v1_mm);
        let et = Vector3::new(-self.tau1.sin(), self.tau1.cos(), 0.0);
        (-self.worm.s() * q.dot(&et), q.z)
    }

    /// (w_F2, z_F2) of a point of the workpiece's plane of action (frame S) at feed z_V2.
    pub fn gear_wz(&self, x: &Vector3<f64>, z_v2_mm: f64) -> (f64, f64) {
        let q = self.chain.gear_coords(x, z_v2_mm);
        let et = Vector3::new(-self.tau2.sin(), self.tau2.cos(), 0.0);
        (-self.gear.s() * q.dot(&et), q.z)
    }

    /// Direction of kinematic-correction modifications ρ_KF (tan ρ_KF = −C_Fw2).
    ///
    /// # Source
    /// JP6903407B2, eq. (99) [SEED]; docs/grinding.md "Derivation: contact path and roll-distance
    /// relation" [RECONSTRUCTED].
    pub fn rho_kf_rad(&self) -> f64 {
        (-self.path.c_w2).atan()
    }

    /// Worm rotation that keeps both flanks tangent (generating coupling (R4), conical chains).
    ///
    /// # Formula
    /// Tangent-plane offsets along n (frame S):
    /// h1 = s·r_b1·cos β_b1·(τ1* − φ1 − η1) + z_V1·n·g1 − r_w1·ν1_y,
    /// h2 = (d − r_w1 − r_w2)·n_y + z_V2·n·g2 − r_w2·ν2_y − s·r_b2·cos β_b2·(τ2* − φ2 − η2);
    /// h1 = h2 solved for φ1. For ϑ = 0 this is the cylindrical (R4) of [`crate::contact`].
    /// # Source
    /// JP6903407B2, (R4) [SEED, formula LOST]; docs/grinding.md "Derivation: generating coupling"
    /// [RECONSTRUCTED]; docs/grinding.md "Independent reference: brute-force envelope".
    #[inline]
    pub fn phi1_rad(&self, phi2_rad: f64, z_v1_mm: f64, z_v2_mm: f64) -> f64 {
        let s = self.worm.s();
        let n = self.normal_vec();
        let k1 = s * self.worm.r_b_mm * self.worm.beta_b_rad.cos();
        let k2 = s * self.gear.r_b_mm * self.gear.beta_b_rad.cos();
        let c = &self.chain;
        let h2 = c.pivot_gap_mm() * n.y + z_v2_mm * n.dot(&c.gear_feed_dir())
            - c.r_w2_mm * self.nu2[1]
            - k2 * (self.tau2 - phi2_rad - self.gear.eta_rad);
        let rest1 = z_v1_mm * n.z - c.r_w1_mm * self.nu1[1];
        self.tau1 - self.worm.eta_rad - (h2 - rest1) / k1
    }

    /// Workpiece feed at which the contact path passes gear point (w_F2, z_F2), given the feed
    /// coupling z_V1 = F_ZV1(z_V2).
    ///
    /// # Formula
    /// Solve z_F2 = C_Fw2·w_F2 + C_FzV12·F_ZV1(z_V2) + C_FzV22·z_V2 + C_Fc2 for z_V2 (one
    /// step for a constant diagonal ratio; Newton otherwise).
    /// # Source
    /// docs/grinding.md "Derivation: diagonal ratio and line map" [RECONSTRUCTED].
    pub fn contact_feed_mm(&self, coupling: &FeedCoupling, w2_mm: f64, z2_mm: f64) -> Result<f64> {
        check_range(
            "w2_mm",
            w2_mm,
            -1e6,
            1e6,
            "finite roll distance, |w2| ≤ 1e6 mm",
        )?;
        check_range(
            "z2_mm",
            z2_mm,
            -1e6,
            1e6,
            "finite width position, |z2| ≤ 1e6 mm",
        )?;
        let p = &self.path;
        let target = z2_mm - p.c_w2 * w2_mm - p.c_c2_mm;
        let mut z_v2 = 0.0;
        let mut resid = f64::INFINITY;
        for _ in 0..50 {
            resid = p.c_zv12 * coupling.z_v1_mm(z_v2) + p.c_zv22 * z_v2 - target;
            if resid.abs() < 1e-12 * (1.0 + target.abs()) {
                return Ok(z_v2);
            }
            let slope = p.c_zv12 * coupling.slope(z_v2) + p.c_zv22;
            if slope.abs() < 1e-14 || !slope.is_finite() {
                break;
            }
            z_v2 -= resid / slope;
        }
        Err(GrindError::NoConvergence {
            what: "contact feed on the conical workpiece path (77)",
            iterations: 50,
            residual_mm: resid,
        })
    }

    /// Worm point and machine state that grind gear point (w_F2, z_F2) (analytic mapping).
    ///
    /// # Formula
    /// z_V2 from (77) with z_V1 = F_ZV1(z_V2); w_F1 = a·w_F2 + b_zv1·z_V1 + b_zv2·z_V2 + b (86);
    /// z_F1 from (76); φ2 at which the gear flank line with normal −n passes the point, φ1 (R4).
    /// # Source
    /// docs/grinding.md "Derivation: diagonal ratio and line map" [RECONSTRUCTED].
    pub fn map_gear_point(
        &self,
        coupling: &FeedCoupling,
        w2_mm: f64,
        z2_mm: f64,
    ) -> Result<MappedPoint> {
        let p = &self.path;
        let z_v2 = self.contact_feed_mm(coupling, w2_mm, z2_mm)?;
        let z_v1 = coupling.z_v1_mm(z_v2);
        let w1 = p.a * w2_mm + p.b_zv1 * z_v1 + p.b_zv2 * z_v2 + p.b_mm;
        let z1 = p.c_w1 * w1 + p.c_zv11 * z_v1 + p.c_zv21 * z_v2 + p.c_c1_mm;
        let phi2 = self.tau2 - self.gear.tau(w2_mm, z2_mm);
        Ok(MappedPoint {
            w1_mm: w1,
            z1_mm: z1,
            z_v1_mm: z_v1,
            z_v2_mm: z_v2,
            phi1_rad: self.phi1_rad(phi2, z_v1, z_v2),
            phi2_rad: phi2,
        })
    }

    /// Relative pose (gear body → worm body) at workpiece rotation φ2 and feeds, with φ1 from
    /// the generating coupling.
    pub fn pose(&self, phi2_rad: f64, z_v1_mm: f64, z_v2_mm: f64) -> Isometry3<f64> {
        let phi1 = self.phi1_rad(phi2_rad, z_v1_mm, z_v2_mm);
        self.chain.pose(phi1, z_v1_mm, z_v2_mm, phi2_rad)
    }

    /// Ratio q = cos β_bF1/cos β_bF2 (f_Ft2 = −q·f_Ft1 at associated points).
    ///
    /// # Source
    /// JP6903407B2, eq. (38) and its text (f_nF2 = −f_nF1) [SEED].
    pub fn transverse_ratio(&self) -> f64 {
        self.worm.beta_b_rad.cos() / self.gear.beta_b_rad.cos()
    }

    /// Diagonal ratio that maps worm lines of direction ρ_F1 onto workpiece lines of ρ_F2.
    ///
    /// # Formula
    /// T1 = sin ρ_F1 + C_Fw1·cos ρ_F1, T2 = sin ρ_F2 + C_Fw2·cos ρ_F2;
    /// K_ZV1 = [T2·(T1·b_zv2 + cos ρ_F1·C_FzV21) − T1·a·C_FzV22·cos ρ_F2]
    ///       / [T1·a·C_FzV12·cos ρ_F2 − T2·(T1·b_zv1 + cos ρ_F1·C_FzV11)]
    /// (the homogeneous form of docs/grinding.md "Derivation: diagonal ratio and line map" with
    /// ^C_Fw1·(a, b_zv1, b_zv2) = −(^C_Fw2, ^C_FzV1, ^C_FzV2));
    /// cylinder/cylinder: a·T1·cos ρ_F2/(cos ρ_F1·T2).
    /// # Domain
    /// Singular when the denominator vanishes (ρ_F2 = ρ_KF for cylinders) or |K| > 1e4.
    /// # Source
    /// JP6903407B2, text to eqs. (36)/(49), eq. (49) [SEED, LOST]; docs/grinding.md "Derivation:
    /// diagonal ratio and line map" [RECONSTRUCTED].
    pub fn diagonal_ratio(&self, rho1_rad: f64, rho2_rad: f64) -> Result<f64> {
        check_range("rho1_rad", rho1_rad, -3.2, 3.2, "-π ..= π")?;
        check_range("rho2_rad", rho2_rad, -3.2, 3.2, "-π ..= π")?;
        let p = &self.path;
        let (s1, c1) = rho1_rad.sin_cos();
        let (s2, c2) = rho2_rad.sin_cos();
        let t1 = s1 + p.c_w1 * c1;
        let t2 = s2 + p.c_w2 * c2;
        let num = t2 * (t1 * p.b_zv2 + c1 * p.c_zv21) - t1 * p.a * p.c_zv22 * c2;
        let den = t1 * p.a * p.c_zv12 * c2 - t2 * (t1 * p.b_zv1 + c1 * p.c_zv11);
        let singular = GrindError::Singular {
            what: "diagonal ratio (conical)",
            field: "rho2_rad",
            value: rho2_rad,
            expected: "ρ_F2 away from the workpiece contact-path direction; |K_ZV1| ≤ 1e4",
        };
        if den.abs() < 1e-12 {
            return Err(singular);
        }
        let k = num / den;
        if k.is_nan() || k.abs() > 1e4 {
            return Err(singular);
        }
        Ok(k)
    }

    /// Worm line coordinate X_F1 = w_F1·sin ρ_F1 + z_F1·cos ρ_F1 that grinds gear point
    /// (w_F2, z_F2) under `coupling` (pointwise map, for checks of the line-to-line property).
    pub fn worm_line_of(
        &self,
        coupling: &FeedCoupling,
        rho1_rad: f64,
        w2_mm: f64,
        z2_mm: f64,
    ) -> Result<f64> {
        let m = self.map_gear_point(coupling, w2_mm, z2_mm)?;
        Ok(m.w1_mm * rho1_rad.sin() + m.z1_mm * rho1_rad.cos())
    }
}

/// Planning estimate of the dresser contact-line direction ρ_F1 on a (conical) worm flank.
///
/// # Formula
/// tan ρ_F1 ≈ s/tan β_bF1 (axial-section line; β_bF1 of the conical flank).
/// # Source
/// docs/grinding.md "Derivation: axial-section estimate of ρ_F1" [RECONSTRUCTED, estimate
/// only]; exact value from the dressing kinematics, JP6903407B2 eq. (37).
pub fn rho1_estimate_rad(worm: &InvoluteFlank) -> f64 {
    (worm.s() / worm.beta_b_rad.tan()).atan()
}
