//! Diagonal generating grinding: the diagonal ratio K_ZV1 that maps worm lines of direction
//! ρ_F1 onto gear lines of direction ρ_F2, the line-to-line map, the transfer of a worm
//! modification to the gear (first order) and back, and the variable diagonal ratio.

use serde::{Deserialize, Serialize};

use crate::contact::WormGearPair;
use crate::error::{check_range, GrindError, Result};
use crate::kinematics::FeedCoupling;
use crate::modification::{FlankModification, LineModification};

/// The affine map between line coordinates of worm and gear for a constant diagonal ratio.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LineMap {
    /// Worm line direction ρ_F1 in rad.
    pub rho1_rad: f64,
    /// Gear line direction ρ_F2 in rad.
    pub rho2_rad: f64,
    /// Diagonal ratio K_ZV1.
    pub k_zv1: f64,
    /// Shift offset z_V01 in mm.
    pub z_v01_mm: f64,
    /// Slope k of X_F1 = k·X_F2 + c0.
    pub k: f64,
    /// Offset c0 in mm.
    pub c0_mm: f64,
}

/// Planning estimate of the dresser contact-line direction ρ_F1 on a worm.
///
/// # Formula
/// tan ρ_F1 ≈ s/tan β_bF1 (an axial-section line, dz1/dw1 ≈ −s/tan β_b1).
/// # Source
/// docs/grinding.md "Derivation: axial-section estimate of ρ_F1" [RECONSTRUCTED, estimate
/// only]; the exact value comes from the dressing kinematics, JP6903407B2 eq. (37) [SEED].
pub fn rho1_estimate_rad(pair: &WormGearPair) -> f64 {
    (pair.worm.s() / pair.worm.beta_b_rad.tan()).atan()
}

/// Diagonal ratio that maps worm lines of direction ρ_F1 onto gear lines of direction ρ_F2.
///
/// # Formula
/// With T1 = sin ρ_F1 + C_Fw1·cos ρ_F1, T2 = sin ρ_F2 + C_Fw2·cos ρ_F2 and a = dw_F1/dw_F2:
/// K_ZV1 = a·T1·cos ρ_F2 / (cos ρ_F1·T2)
///       = −(cos β_bF1/cos β_bF2)·(tan ρ_F1 + C_Fw1)/(tan ρ_F2 + C_Fw2) (cylinder/cylinder).
/// # Domain
/// Singular for T2 = 0 (ρ_F2 = ρ_KF: no finite K; such modifications come from the kinematics)
/// and for cos ρ_F1 = 0; |K_ZV1| > 1e4 is reported as singular too.
/// # Source
/// JP6903407B2, text to eqs. (36)/(49), eq. (49) [SEED, equation LOST]; docs/grinding.md
/// "Derivation: diagonal ratio and line map"
/// [RECONSTRUCTED, VERIFIED].
pub fn diagonal_ratio(pair: &WormGearPair, rho1_rad: f64, rho2_rad: f64) -> Result<f64> {
    check_range("rho1_rad", rho1_rad, -3.2, 3.2, "-π ..= π")?;
    check_range("rho2_rad", rho2_rad, -3.2, 3.2, "-π ..= π")?;
    let p = &pair.path;
    let t1 = rho1_rad.sin() + p.c_w1 * rho1_rad.cos();
    let t2 = rho2_rad.sin() + p.c_w2 * rho2_rad.cos();
    let den = rho1_rad.cos() * t2;
    if den.abs() < 1e-12 {
        return Err(GrindError::Singular {
            what: "diagonal ratio",
            field: if t2.abs() < 1e-12 {
                "rho2_rad"
            } else {
                "rho1_rad"
            },
            value: if t2.abs() < 1e-12 { rho2_rad } else { rho1_rad },
            expected: "ρ_F2 ≠ ρ_KF (the gear contact-path direction) and ρ_F1 ≠ ±90°",
        });
    }
    let k = p.a * t1 * rho2_rad.cos() / den;
    // |K| beyond 1e4 means a worm shift of metres per mm of feed: the pole ρ_F2 = ρ_KF given
    // to finite precision, not a usable setting.
    if k.abs() > 1e4 {
        return Err(GrindError::Singular {
            what: "diagonal ratio",
            field: "rho2_rad",
            value: rho2_rad,
            expected: "ρ_F2 away from ρ_KF (the gear contact-path direction); |K_ZV1| ≤ 1e4",
        });
    }
    Ok(k)
}

/// The line map X_F1 = k·X_F2 + c0 for the diagonal ratio of (ρ_F1, ρ_F2).
///
/// # Formula
/// k = K·cos ρ_F1/cos ρ_F2 (or (a·T1 − K·cos ρ_F1·C_Fw2)/sin ρ_F2 when |sin ρ_F2| > |cos ρ_F2|),
/// c0 = b·T1 + cos ρ_F1·(C_Fc1 − K·C_Fc2 − z_V01).
/// # Source
/// docs/grinding.md "Derivation: diagonal ratio and line map" [RECONSTRUCTED, VERIFIED]; z_V01
/// selects the worm region (JP6903407B2, text to eq. (36) [SEED]).
pub fn line_map(
    pair: &WormGearPair,
    rho1_rad: f64,
    rho2_rad: f64,
    z_v01_mm: f64,
) -> Result<LineMap> {
    check_range("z_v01_mm", z_v01_mm, -1e6, 1e6, "finite")?;
    let k_zv1 = diagonal_ratio(pair, rho1_rad, rho2_rad)?;
    let p = &pair.path;
    let (s1, c1) = rho1_rad.sin_cos();
    let (s2, c2) = rho2_rad.sin_cos();
    let t1 = s1 + p.c_w1 * c1;
    let coef_w = p.a * t1 - k_zv1 * c1 * p.c_w2;
    let coef_z = k_zv1 * c1;
    let k = if c2.abs() >= s2.abs() {
        coef_z / c2
    } else {
        coef_w / s2
    };
    let c0 = p.b_mm * t1 + c1 * (p.c_c1_mm - k_zv1 * p.c_c2_mm - z_v01_mm);
    Ok(LineMap {
        rho1_rad,
        rho2_rad,
        k_zv1,
        z_v01_mm,
        k,
        c0_mm: c0,
    })
}

/// Gear modification ground by a modified worm at a gear point (first-order analytic map).
///
/// # Formula
/// f_Ft2(w_F2, z_F2) = −(cos β_bF1/cos β_bF2)·f_Ft1(w_F1, z_F1) at the associated worm point.
/// # Source
/// JP6903407B2, eq. (38) and its text (f_nF2 = −f_nF1) [SEED]; (95) [LOST] per docs/grinding.md
/// "Derivation: line-class transfer" [RECONSTRUCTED, VERIFIED
/// against a brute-force envelope to 0.2–0.6 %, docs/grinding.md "Independent reference:
/// brute-force envelope"].
#[inline]
pub fn predicted_gear_f_ft_mm(
    pair: &WormGearPair,
    coupling: &FeedCoupling,
    worm_mod: &(impl FlankModification + ?Sized),
    w2_mm: f64,
    z2_mm: f64,
) -> f64 {
    let m = pair.map_gear_point(coupling, w2_mm, z2_mm);
    -pair.transverse_ratio() * worm_mod.f_ft_mm(m.w1_mm, m.z1_mm)
}

/// Gear line modification ground by a worm line modification at the diagonal ratio that maps
/// its direction ρ_F1 onto ρ_F2.
///
/// # Formula
/// With w_F1 − w_01 = a·(w_F2 − w_02) (w_02 = (w_01 − b)/a) and X_F1 = k·X_F2 + c0:
/// F_2Q = −q·a²·F_1Q∘, F_2L = −q·a·F_1L∘, F_2C = −q·F_1C∘ (∘ = composed with the line map),
/// q = cos β_bF1/cos β_bF2.
/// # Source
/// docs/grinding.md "Derivation: line-class transfer" [RECONSTRUCTED]; the lost eqs. (49)/(92).
pub fn gear_modification_from_worm(
    pair: &WormGearPair,
    worm_mod: &LineModification,
    rho2_rad: f64,
    z_v01_mm: f64,
) -> Result<(LineMap, LineModification)> {
    let lm = line_map(pair, worm_mod.rho_rad, rho2_rad, z_v01_mm)?;
    let (q, a) = (pair.transverse_ratio(), pair.path.a);
    let comp = |p: &crate::modification::Poly| p.compose_affine(lm.k, lm.c0_mm);
    let gear = LineModification::new(
        rho2_rad,
        (worm_mod.w0_mm - pair.path.b_mm) / a,
        comp(&worm_mod.c).scaled(-q),
        comp(&worm_mod.l).scaled(-q * a),
        comp(&worm_mod.q).scaled(-q * a * a),
    )?;
    Ok((lm, gear))
}

/// Worm modification (and diagonal ratio) that grinds a wanted gear line modification.
///
/// # Formula
/// Inverse of [`gear_modification_from_worm`]: X_F2 = (X_F1 − c0)/k,
/// F_1Q = −F_2Q∘/(q·a²), F_1L = −F_2L∘/(q·a), F_1C = −F_2C∘/q, w_01 = a·w_02 + b.
/// # Domain
/// k ≠ 0 (the worm lines must not be parallel to the worm contact path).
/// # Source
/// docs/grinding.md "Derivation: line-class transfer" [RECONSTRUCTED].
pub fn worm_modification_for_gear(
    pair: &WormGearPair,
    wanted: &LineModification,
    rho1_rad: f64,
    z_v01_mm: f64,
) -> Result<(LineMap, LineModification)> {
    let lm = line_map(pair, rho1_rad, wanted.rho_rad, z_v01_mm)?;
    if lm.k.abs() < 1e-12 {
        return Err(GrindError::Singular {
            what: "worm modification for a gear modification",
            field: "rho1_rad",
            value: rho1_rad,
            expected: "worm lines not parallel to the worm contact path (tan ρ_F1 ≠ −C_Fw1)",
        });
    }
    let (q, a) = (pair.transverse_ratio(), pair.path.a);
    let comp = |p: &crate::modification::Poly| p.compose_affine(1.0 / lm.k, -lm.c0_mm / lm.k);
    let worm = LineModification::new(
        rho1_rad,
        a * wanted.w0_mm + pair.path.b_mm,
        comp(&wanted.c).scaled(-1.0 / q),
        comp(&wanted.l).scaled(-1.0 / (q * a)),
        comp(&wanted.q).scaled(-1.0 / (q * a * a)),
    )?;
    Ok((lm, worm))
}

/// Width position z_F2 at roll distance w_F2 of the gear curve ground by worm line X_F1 under
/// a (possibly non-constant) feed coupling z_V1 = F_ZV1(z_V2).
///
/// # Formula
/// X_F1 = w_F1·T1 + cos ρ_F1·(C_Fc1 − F_ZV1(z_V2)), w_F1 = a·w_F2 + b ⇒ solve
/// F_ZV1(z_V2) = (w_F1·T1 + cos ρ_F1·C_Fc1 − X_F1)/cos ρ_F1 for z_V2 (Newton from the
/// linearised root), then z_F2 = C_Fw2·w_F2 + C_Fc2 − z_V2 (40).
/// # Source
/// JP6903407B2, (R20), eqs. (94), (96) [SEED]; docs/grinding.md "Derivation: variable diagonal
/// ratio" [RECONSTRUCTED].
pub fn worm_line_path_z2_mm(
    pair: &WormGearPair,
    coupling: &FeedCoupling,
    rho1_rad: f64,
    x1_mm: f64,
    w2_mm: f64,
) -> Result<f64> {
    let p = &pair.path;
    let (s1, c1) = rho1_rad.sin_cos();
    if c1.abs() < 1e-12 {
        return Err(GrindError::Singular {
            what: "worm line path",
            field: "rho1_rad",
            value: rho1_rad,
            expected: "ρ_F1 ≠ ±90°",
        });
    }
    let t1 = s1 + p.c_w1 * c1;
    let w1 = p.a * w2_mm + p.b_mm;
    let target = (w1 * t1 + c1 * p.c_c1_mm - x1_mm) / c1;
    let mut z_v2 = 0.0;
    let mut resid = f64::INFINITY;
    for _ in 0..60 {
        resid = coupling.z_v1_mm(z_v2) - target;
        if resid.abs() < 1e-12 * (1.0 + target.abs()) {
            return Ok(p.c_w2 * w2_mm + p.c_c2_mm - z_v2);
        }
        let slope = coupling.slope(z_v2);
        if slope.abs() < 1e-14 {
            break;
        }
        z_v2 -= resid / slope;
    }
    Err(GrindError::NoConvergence {
        what: "variable-diagonal path (F_ZV1(z_V2) = target)",
        iterations: 60,
        residual_mm: resid,
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::flank::{Flank, Hand, InvoluteGear};
    use crate::modification::Poly;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    fn pair(flank: Flank, alpha_r_deg: f64) -> WormGearPair {
        let a = alpha_r_deg.to_radians();
        let a20 = 20f64.to_radians();
        let gear = InvoluteGear::asymmetric(31, 3.0, a, a20, 15f64.to_radians(), 0.0).unwrap();
        // worm with the same normal base pitch on both flanks: same m_n, same α_n per flank
        let w = InvoluteGear::worm(1, 3.0, a20, 130.0, Hand::Right).unwrap();
        let worm = InvoluteGear::asymmetric(1, 3.0, a, a20, w.beta_rad, 0.0).unwrap();
        WormGearPair::reference(&worm, &gear, flank).unwrap()
    }

    /// T7: docs/grinding.md "Independent reference: reference example" diagonal ratios (independent
    /// calculation), 1e-6.
    #[test]
    fn t7_diagonal_ratio_values() {
        let p = pair(Flank::Right, 20.0);
        let r1 = 20f64.to_radians();
        for &(rho2, k) in &[
            (0.0, -4.375545),
            (30.0, -1.324882),
            (45.0, -0.877178),
            (60.0, -0.553322),
            (75.923905, -0.258819),
        ] {
            let got = diagonal_ratio(&p, r1, f64::to_radians(rho2)).unwrap();
            assert_relative_eq!(got, k, epsilon = 1e-6);
        }
        let near = diagonal_ratio(&p, r1, 89.999f64.to_radians()).unwrap();
        assert!(near.abs() < 2e-5 && near < 0.0, "{near}");
        assert_relative_eq!(
            diagonal_ratio(&p, 0.0, 0.0).unwrap(),
            -3.863446,
            epsilon = 1e-6
        );
        // pole at ρ_F2 = ρ_KF
        let e = diagonal_ratio(&p, r1, p.rho_kf_rad());
        assert!(matches!(e, Err(GrindError::Singular { .. })));
        // docs/grinding.md "Derivation: diagonal ratio and line map": b, k, c0 of the example
        let lm = line_map(&p, r1, 45f64.to_radians(), 5.0).unwrap();
        assert_relative_eq!(p.path.b_mm, 135.923125, epsilon = 1e-6);
        assert_relative_eq!(lm.k, -1.165704, epsilon = 1e-6);
        assert_relative_eq!(lm.c0_mm, 53.733653, epsilon = 1e-6);
    }

    /// T6: left/right symmetry — K(s=−1; −ρ1, −ρ2) = K(s=+1; ρ1, ρ2); asymmetric gear with
    /// α_n,r = 25°: K_r = −0.878547 ≠ K_l = −0.877178.
    #[test]
    fn t6_left_right_symmetry() {
        let r = pair(Flank::Right, 20.0);
        let l = pair(Flank::Left, 20.0);
        let (a, b) = (20f64.to_radians(), 45f64.to_radians());
        let kr = diagonal_ratio(&r, a, b).unwrap();
        let kl = diagonal_ratio(&l, -a, -b).unwrap();
        assert_relative_eq!(kr, -0.877178, epsilon = 1e-6);
        assert_relative_eq!(kl, kr, epsilon = 1e-9);
        let asym = pair(Flank::Right, 25.0);
        assert_relative_eq!(asym.worm.beta_b_rad.to_degrees(), 64.991822, epsilon = 1e-6);
        assert_relative_eq!(asym.gear.beta_b_rad.to_degrees(), 13.566260, epsilon = 1e-6);
        assert_relative_eq!(
            diagonal_ratio(&asym, a, b).unwrap(),
            -0.878547,
            epsilon = 1e-6
        );
        let asym_l = pair(Flank::Left, 25.0);
        assert_relative_eq!(
            diagonal_ratio(&asym_l, -a, -b).unwrap(),
            -0.877178,
            epsilon = 1e-6
        );
    }

    /// T8 (analytic values of docs/grinding.md "Independent reference: brute-force envelope"):
    /// predicted gear f_Ft2 in µm at four points.
    #[test]
    fn t8_analytic_map_values() {
        let p = pair(Flank::Right, 20.0);
        let k = diagonal_ratio(&p, 20f64.to_radians(), 45f64.to_radians()).unwrap();
        let cpl = FeedCoupling::linear(k, 5.0).unwrap();
        let worm = t8_worm(&p, 1e-5, -3e-5);
        for &(w2, z2, f_um) in &[
            (15.0, 0.0, -13.6314),
            (19.0, 8.0, -8.0171),
            (13.0, -10.0, -20.5812),
            (21.0, 12.0, -5.7488),
        ] {
            let got = predicted_gear_f_ft_mm(&p, &cpl, &worm, w2, z2) * 1e3;
            assert!((got - f_um).abs() < 5e-4, "({w2},{z2}): {got} vs {f_um}");
        }
    }

    /// T8 worm: f = D·X1 + A·X1² + B·X1·(w1 − w1P) + C_q·(w1 − w1P)², X1 along ρ1 = 20°.
    pub(crate) fn t8_worm(p: &WormGearPair, b: f64, cq: f64) -> LineModification {
        LineModification::new(
            20f64.to_radians(),
            p.worm.w_ref_mm,
            Poly(vec![0.0, 1e-4, 2e-5]),
            Poly(vec![0.0, b]),
            Poly(vec![cq]),
        )
        .unwrap()
    }

    /// The line-class transfer agrees with the pointwise map, and a worm modification constant
    /// along ρ1 lines gives a gear modification constant along ρ2 lines.
    #[test]
    fn line_transfer_matches_pointwise_map() {
        for flank in [Flank::Right, Flank::Left] {
            let p = pair(flank, 20.0);
            let s = flank.sign();
            let worm = t8_worm(&p, 1e-5, -3e-5);
            let worm = LineModification {
                rho_rad: s * worm.rho_rad,
                ..worm
            };
            let (lm, gear) =
                gear_modification_from_worm(&p, &worm, s * 45f64.to_radians(), 5.0).unwrap();
            let cpl = FeedCoupling::linear(lm.k_zv1, 5.0).unwrap();
            for &(w2, z2) in &[(12.0, -14.0), (16.0, 0.0), (22.0, 9.0)] {
                let a = predicted_gear_f_ft_mm(&p, &cpl, &worm, w2, z2);
                let b = gear.f_ft_mm(w2, z2);
                assert!((a - b).abs() < 1e-12, "{a} {b}");
            }
        }
    }

    proptest! {
        /// Inverse ∘ forward = identity on the gear modification, for any ρ1/ρ2 pair.
        #[test]
        fn worm_for_gear_round_trip(
            rho1 in 0.1f64..0.6, rho2 in 0.0f64..1.5,
            c in proptest::collection::vec(-1e-2f64..1e-2, 1..4),
            l in proptest::collection::vec(-1e-3f64..1e-3, 0..3),
            qq in proptest::collection::vec(-1e-4f64..1e-4, 0..2),
            w in 11.0f64..23.0, z in -15.0f64..15.0,
        ) {
            let p = pair(Flank::Right, 20.0);
            let wanted = LineModification::new(rho2, 17.0, Poly(c), Poly(l), Poly(qq)).unwrap();
            let (lm, worm) = worm_modification_for_gear(&p, &wanted, rho1, 3.0).unwrap();
            let cpl = FeedCoupling::linear(lm.k_zv1, 3.0).unwrap();
            let got = predicted_gear_f_ft_mm(&p, &cpl, &worm, w, z);
            prop_assert!((got - wanted.f_ft_mm(w, z)).abs() < 1e-9);
        }
    }

    /// T11: variable diagonal ratio F_ZV1 = 0.5·z_V2 + 0.01·z_V2², worm line X1 = 40 and
    /// X1 + 0.7: translates along (1, C_Fw2) by t = −0.678982 (docs/grinding.md "Independent
    /// reference: reference example"), 1e-6.
    #[test]
    fn t11_variable_diagonal_paths() {
        let p = pair(Flank::Right, 20.0);
        let cpl = FeedCoupling::Polynomial {
            coeffs: vec![0.0, 0.5, 0.01],
        };
        let r1 = 20f64.to_radians();
        let z_a = worm_line_path_z2_mm(&p, &cpl, r1, 40.0, 12.0).unwrap();
        assert_relative_eq!(z_a, -16.785047, epsilon = 1e-6);
        let z_b = worm_line_path_z2_mm(&p, &cpl, r1, 40.7, 11.321018).unwrap();
        assert_relative_eq!(z_b, -16.955295, epsilon = 1e-6);
        assert_relative_eq!(z_b, z_a + p.path.c_w2 * (11.321018 - 12.0), epsilon = 1e-6);
        // and the pointwise map says that these points are ground by those worm lines
        for &(w2, z2, x1) in &[(12.0, z_a, 40.0), (11.321018, z_b, 40.7)] {
            let m = p.map_gear_point(&cpl, w2, z2);
            assert_relative_eq!(m.w1_mm * r1.sin() + m.z1_mm * r1.cos(), x1, epsilon = 1e-9);
        }
    }
}
