//! Line-class transfer for conical (beveloid) worms and/or workpieces (chains (29)–(31)): the
//! map of gear lines of direction ρ_F2 onto worm lines of direction ρ_F1 at a constant diagonal
//! ratio, the gear modification ground by a worm modification of the class (25)/(26), and the
//! inverse (worm modification for a wanted gear modification).
//!
//! What stays constant along a line on beveloids (docs/grinding.md "Line-class transfer on
//! conical chains"): each beveloid flank is an involute helicoid with its own r_bF, β_bF, so the
//! ratio q = cos β_bF1/cos β_bF2 of (38) is one number for the whole flank, exactly as on
//! cylinders. What changes is the roll-distance relation: on a cylinder w_F1 = a·w_F2 + b does
//! not depend on the feeds, on a cone (86) does, and the feeds vary along a gear line. Along the
//! gear line X_F2 the worm roll distance is still affine in w_F2, w_F1 = a'·w_F2 + e·X_F2 + g,
//! with a slope a' ≠ a and an offset that moves with X_F2. The transfer therefore keeps the form
//! (25) (polynomials in X stay polynomials, one degree higher where e ≠ 0 multiplies them) and
//! is exact to first order in the modification, like the cylindrical one: the contact-point
//! shift a modification causes leaves a gap of second order (measured in the tests).

use serde::{Deserialize, Serialize};

use crate::conical::ConicalPair;
use crate::diagonal::LineMap;
use crate::error::{check_range, GrindError, Result};
use crate::kinematics::FeedCoupling;
use crate::modification::{FlankModification, LineModification, Poly};

/// Line map of a conical chain and the worm roll distance along a gear line.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ConicalLineMap {
    /// X_F1 = k·X_F2 + c0 with the diagonal ratio K_ZV1 (same fields as the cylindrical map).
    pub line: LineMap,
    /// a' = ∂w_F1/∂w_F2 along a gear line (X_F2 fixed).
    pub roll_slope: f64,
    /// e = ∂w_F1/∂X_F2 at w_F2 fixed (0 on cylindrical chains).
    pub roll_per_line: f64,
    /// g in w_F1 = a'·w_F2 + e·X_F2 + g, mm (b of (45) on cylindrical chains).
    pub roll_offset_mm: f64,
}

/// Line map and roll-distance relation along gear lines for a conical chain at the diagonal
/// ratio that maps worm lines ρ_F1 onto gear lines ρ_F2.
///
/// # Formula
/// K = [`ConicalPair::diagonal_ratio`]; z_V1 = K·z_V2 + z_V01. From (77):
/// z_V2 = (z_F2 − C_Fw2·w_F2 − C_FzV12·z_V01 − C_Fc2)/D, D = C_FzV12·K + C_FzV22.
/// With B = b_zv1·K + b_zv2 (86), E = C_FzV11·K + C_FzV21 (76), T1 = sin ρ_F1 + C_Fw1·cos ρ_F1,
/// G = T1·B + cos ρ_F1·E:
/// X_F1 = α·w_F2 + β·z_F2 + c0 with α = T1·a − G·C_Fw2/D, β = G/D, so k = β/cos ρ_F2
/// (= α/sin ρ_F2; the better conditioned one is used), c0 = X_F1 at (w_F2, z_F2) = (0, 0);
/// w_F1 = α_w·w_F2 + β_w·z_F2 + g with α_w = a − B·C_Fw2/D, β_w = B/D, hence along a gear
/// line (z_F2 = (X_F2 − w_F2·sin ρ_F2)/cos ρ_F2): a' = α_w − β_w·tan ρ_F2, e = β_w/cos ρ_F2.
/// Cylinder/cylinder (C_FzV11 = C_FzV22 = −1, C_FzV12 = C_FzV21 = b_zv = 0): a' = a, e = 0,
/// g = b, and k, c0 those of [`crate::diagonal::line_map`].
/// # Domain
/// D ≠ 0 (the workpiece feed moves the contact path); cos ρ_F2 ≠ 0 unless β_w = 0 (on a cone a
/// pure profile line w_F2 = const is ground by worm points of varying w_F1, which is not of the
/// form (25)).
/// # Source
/// JP6903407B2, text to eqs. (36)/(49), eqs. (36), (76), (77), (86), (49) [SEED form, LOST
/// coefficients]; docs/grinding.md "Derivation: diagonal ratio and line map" and "Derivation:
/// line-class transfer" (conical chains) [RECONSTRUCTED]; algebra derived here.
pub fn conical_line_map(
    pair: &ConicalPair,
    rho1_rad: f64,
    rho2_rad: f64,
    z_v01_mm: f64,
) -> Result<ConicalLineMap> {
    check_range("z_v01_mm", z_v01_mm, -1e6, 1e6, "finite")?;
    let k_zv1 = pair.diagonal_ratio(rho1_rad, rho2_rad)?;
    let p = &pair.path;
    let d = p.c_zv12 * k_zv1 + p.c_zv22;
    if d.abs() < 1e-12 {
        return Err(GrindError::Singular {
            what: "conical line map (workpiece path per feed C_FzV12·K + C_FzV22)",
            field: "rho2_rad",
            value: rho2_rad,
            expected: "a diagonal ratio at which the workpiece feed moves the contact path",
        });
    }
    let (s1, c1) = rho1_rad.sin_cos();
    let (s2, c2) = rho2_rad.sin_cos();
    let t1 = s1 + p.c_w1 * c1;
    let b_feed = p.b_zv1 * k_zv1 + p.b_zv2;
    let e_feed = p.c_zv11 * k_zv1 + p.c_zv21;
    let g = t1 * b_feed + c1 * e_feed;
    let alpha = t1 * p.a - g * p.c_w2 / d;
    let beta = g / d;
    let k = if c2.abs() >= s2.abs() {
        beta / c2
    } else {
        alpha / s2
    };
    // the point (w_F2, z_F2) = (0, 0)
    let z_v2_0 = -(p.c_zv12 * z_v01_mm + p.c_c2_mm) / d;
    let z_v1_0 = k_zv1 * z_v2_0 + z_v01_mm;
    let w1_0 = p.b_zv1 * z_v1_0 + p.b_zv2 * z_v2_0 + p.b_mm;
    let z1_0 = p.c_w1 * w1_0 + p.c_zv11 * z_v1_0 + p.c_zv21 * z_v2_0 + p.c_c1_mm;
    let c0 = s1 * w1_0 + c1 * z1_0;
    let alpha_w = p.a - b_feed * p.c_w2 / d;
    let beta_w = b_feed / d;
    let (roll_slope, roll_per_line) = if c2.abs() > 1e-9 {
        (alpha_w - beta_w * s2 / c2, beta_w / c2)
    } else if beta_w.abs() < 1e-12 {
        (alpha_w, 0.0)
    } else {
        return Err(GrindError::Singular {
            what: "conical line transfer (profile lines ρ_F2 = ±90° on a feed-dependent (86))",
            field: "rho2_rad",
            value: rho2_rad,
            expected: "|ρ_F2| < 90° on conical chains",
        });
    };
    Ok(ConicalLineMap {
        line: LineMap {
            rho1_rad,
            rho2_rad,
            k_zv1,
            z_v01_mm,
            k,
            c0_mm: c0,
        },
        roll_slope,
        roll_per_line,
        roll_offset_mm: w1_0,
    })
}

/// e·X·P(X) as a polynomial (P times the monomial e·X).
fn times_x(p: &Poly, e: f64) -> Poly {
    let mut v = Vec::with_capacity(p.0.len() + 1);
    v.push(0.0);
    v.extend(p.0.iter().map(|c| c * e));
    Poly(v)
}

/// Gear f_Ft2 in mm that a worm modification grinds at gear point (w_F2, z_F2) of a conical
/// chain (first-order pointwise map).
///
/// # Formula
/// f_Ft2(w_F2, z_F2) = −(cos β_bF1/cos β_bF2)·f_Ft1(w_F1, z_F1), (w_F1, z_F1) from
/// [`ConicalPair::map_gear_point`] ((77), (86), (76)).
/// # Source
/// JP6903407B2, eq. (38) and its text (f_nF2 = −f_nF1) [SEED]; (95) [LOST] per docs/grinding.md
/// "Derivation: line-class transfer" [RECONSTRUCTED].
pub fn predicted_gear_f_ft_mm(
    pair: &ConicalPair,
    coupling: &FeedCoupling,
    worm_mod: &(impl FlankModification + ?Sized),
    w2_mm: f64,
    z2_mm: f64,
) -> Result<f64> {
    let m = pair.map_gear_point(coupling, w2_mm, z2_mm)?;
    Ok(-pair.transverse_ratio() * worm_mod.f_ft_mm(m.w1_mm, m.z1_mm))
}

/// Gear line modification ground on a conical chain by a worm line modification, at the
/// diagonal ratio that maps its direction ρ_F1 onto ρ_F2.
///
/// # Formula
/// With u_i = w_Fi − w_0i, w_02 = (w_01 − g)/a' (so u1 = a'·u2 + e·X_F2), X_F1 = k·X_F2 + c0,
/// q = cos β_bF1/cos β_bF2 and ∘ = composed with the line map:
/// F_2Q = −q·a'²·F_1Q∘,
/// F_2L = −q·a'·(F_1L∘ + 2e·X·F_1Q∘),
/// F_2C = −q·(F_1C∘ + e·X·F_1L∘ + e²·X²·F_1Q∘).
/// e = 0, a' = a on cylindrical chains gives [`crate::diagonal::gear_modification_from_worm`].
/// # Domain
/// a' ≠ 0; see [`conical_line_map`].
/// # Source
/// JP6903407B2, eqs. (25), (26), (38), (92)/(95) [SEED form, LOST]; docs/grinding.md "Derivation:
/// line-class transfer"
/// [RECONSTRUCTED], extended here by the feed-dependent (86).
pub fn gear_modification_from_worm(
    pair: &ConicalPair,
    worm_mod: &LineModification,
    rho2_rad: f64,
    z_v01_mm: f64,
) -> Result<(ConicalLineMap, LineModification)> {
    let lm = conical_line_map(pair, worm_mod.rho_rad, rho2_rad, z_v01_mm)?;
    let (a, e) = (lm.roll_slope, lm.roll_per_line);
    check_slope(a, rho2_rad)?;
    let q = pair.transverse_ratio();
    let comp = |p: &Poly| p.compose_affine(lm.line.k, lm.line.c0_mm);
    let (c1, l1, q1) = (comp(&worm_mod.c), comp(&worm_mod.l), comp(&worm_mod.q));
    let f2q = q1.scaled(-q * a * a);
    let f2l = l1.plus(&times_x(&q1, 2.0 * e)).scaled(-q * a);
    let f2c = c1
        .plus(&times_x(&l1, e))
        .plus(&times_x(&times_x(&q1, e), e))
        .scaled(-q);
    let gear = LineModification::new(
        rho2_rad,
        (worm_mod.w0_mm - lm.roll_offset_mm) / a,
        f2c,
        f2l,
        f2q,
    )?;
    Ok((lm, gear))
}

/// Worm modification (and diagonal ratio) that grinds a wanted gear line modification on a
/// conical chain.
///
/// # Formula
/// Inverse of [`gear_modification_from_worm`], as polynomials in X_F2 first:
/// P_Q = −F_2Q/(q·a'²), P_L = −F_2L/(q·a') − 2e·X·P_Q, P_C = −F_2C/q − e·X·P_L − e²·X²·P_Q,
/// then F_1· = P_·((X_F1 − c0)/k); w_01 = a'·w_02 + g.
/// # Domain
/// k ≠ 0 (worm lines not parallel to the worm contact path), a' ≠ 0.
/// # Source
/// docs/grinding.md "Derivation: line-class transfer" [RECONSTRUCTED], conical extension derived
/// here.
pub fn worm_modification_for_gear(
    pair: &ConicalPair,
    wanted: &LineModification,
    rho1_rad: f64,
    z_v01_mm: f64,
) -> Result<(ConicalLineMap, LineModification)> {
    let lm = conical_line_map(pair, rho1_rad, wanted.rho_rad, z_v01_mm)?;
    if lm.line.k.abs() < 1e-12 {
        return Err(GrindError::Singular {
            what: "worm modification for a gear modification (conical)",
            field: "rho1_rad",
            value: rho1_rad,
            expected: "worm lines not parallel to the worm contact path",
        });
    }
    let (a, e) = (lm.roll_slope, lm.roll_per_line);
    check_slope(a, wanted.rho_rad)?;
    let q = pair.transverse_ratio();
    let pq = wanted.q.scaled(-1.0 / (q * a * a));
    let pl = wanted
        .l
        .scaled(-1.0 / (q * a))
        .plus(&times_x(&pq, -2.0 * e));
    let pc = wanted
        .c
        .scaled(-1.0 / q)
        .plus(&times_x(&pl, -e))
        .plus(&times_x(&times_x(&pq, e), -e));
    let comp = |p: &Poly| p.compose_affine(1.0 / lm.line.k, -lm.line.c0_mm / lm.line.k);
    let worm = LineModification::new(
        rho1_rad,
        a * wanted.w0_mm + lm.roll_offset_mm,
        comp(&pc),
        comp(&pl),
        comp(&pq),
    )?;
    Ok((lm, worm))
}

fn check_slope(a: f64, rho2_rad: f64) -> Result<()> {
    if a.abs() < 1e-12 || !a.is_finite() {
        return Err(GrindError::Singular {
            what: "conical line transfer (worm roll distance along the gear line)",
            field: "rho2_rad",
            value: rho2_rad,
            expected: "gear lines along which the worm roll distance changes (∂w_F1/∂w_F2 ≠ 0)",
        });
    }
    Ok(())
}
