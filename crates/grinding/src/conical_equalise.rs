//! Two-flank diagonal grinding with a conical worm: the worm cone angle ϑ1 at which the
//! diagonal ratio needed by the left flank equals that of the right flank (A6, test T14).
//!
//! The worm's rack profile angles are not free here: the normal base pitches of worm and gear
//! must agree on each flank (eq. (93)), and with the same normal module this fixes the worm
//! rack's α_nF to the gear's. The crossing angle stays at the reference (R3). What ϑ1 changes
//! is each worm flank's base radius and base helix angle — differently on the two flanks
//! (docs/grinding.md "Derivation: equal diagonal ratio on both flanks") — and with them the path
//! coefficients and K_ZV1 of each flank.

use serde::{Deserialize, Serialize};

use crate::conical::{rho1_estimate_rad, BeveloidGear, ConicalPair, MAX_CONE_ANGLE_RAD};
use crate::error::{check_range, GrindError, Result};
use crate::flank::{Flank, InvoluteGear};

/// How the worm line direction ρ_F1 of each flank is obtained while ϑ1 varies.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum WormLines {
    /// Fixed directions (e.g. from the dressing kinematics (37)), in rad.
    Given {
        /// ρ_l1.
        left_rad: f64,
        /// ρ_r1.
        right_rad: f64,
    },
    /// The axial-section estimate tan ρ_F1 = s/tan β_bF1 of each conical worm flank.
    AxialSection,
}

/// What is wanted: the gear, the worm body, the modification directions and the search range.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EqualiseSpec {
    /// Worm body (starts, m_n, per-flank α_n equal to the gear's, β1, x0); its cone is sought.
    pub worm: InvoluteGear,
    /// Workpiece (cylindrical or conical).
    pub gear: BeveloidGear,
    /// Wanted modification direction on the gear's left flank ρ_l2, rad (raw flank convention
    /// of `docs/grinding.md`: a mirror-symmetric modification has ρ_l2 = −ρ_r2).
    pub rho2_left_rad: f64,
    /// Wanted modification direction on the gear's right flank ρ_r2, rad.
    pub rho2_right_rad: f64,
    /// Worm line directions.
    pub worm_lines: WormLines,
    /// Allowed worm cone angles [min, max], rad (within ±50°).
    pub cone_range_rad: (f64, f64),
}

/// A worm cone angle that gives both flanks the same diagonal ratio.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Equalised {
    /// Worm cone angle ϑ1, rad.
    pub cone1_rad: f64,
    /// The common diagonal ratio K_ZV1 (mean of the two flanks' values).
    pub k_zv1: f64,
    /// K_ZV1 needed by the left flank at ϑ1.
    pub k_left: f64,
    /// K_ZV1 needed by the right flank at ϑ1.
    pub k_right: f64,
    /// Worm line direction used on the left flank, rad.
    pub rho1_left_rad: f64,
    /// Worm line direction used on the right flank, rad.
    pub rho1_right_rad: f64,
}

/// Left and right diagonal ratios, and the worm line directions, for worm cone angle ϑ1.
///
/// # Formula
/// K_F(ϑ1) = K_ZV1 of [`ConicalPair::diagonal_ratio`] for flank F of the worm with cone ϑ1 at
/// the reference setting, with (ρ_F1, ρ_F2) of that flank.
/// # Source
/// JP6903407B2, conical worms for different directions on the two flanks [SEED]; docs/grinding.md
/// "Derivation: equal diagonal ratio on both flanks" [RECONSTRUCTED].
pub fn flank_ratios(spec: &EqualiseSpec, cone1_rad: f64) -> Result<(f64, f64, f64, f64)> {
    let worm = BeveloidGear::new(spec.worm, cone1_rad)?;
    let mut out = [0.0; 4];
    for (i, flank) in [Flank::Left, Flank::Right].into_iter().enumerate() {
        let pair = ConicalPair::reference(&worm, &spec.gear, flank)?;
        let rho1 = match spec.worm_lines {
            WormLines::Given {
                left_rad,
                right_rad,
            } => match flank {
                Flank::Left => left_rad,
                Flank::Right => right_rad,
            },
            WormLines::AxialSection => rho1_estimate_rad(&pair.worm),
        };
        let rho2 = match flank {
            Flank::Left => spec.rho2_left_rad,
            Flank::Right => spec.rho2_right_rad,
        };
        out[i] = pair.diagonal_ratio(rho1, rho2)?;
        out[2 + i] = rho1;
    }
    Ok((out[0], out[1], out[2], out[3]))
}

const SCAN_STEPS: usize = 64;

/// Bisects Δ on [a, b] (Δ(a) = fa, a sign change) to machine precision; `None` if the bracket
/// holds a pole of K instead of a root (a singular K on the way, or |Δ| = |K_l − K_r| at the
/// end above 1e-6).
fn bisect_root(
    delta: &impl Fn(f64) -> Result<f64>,
    mut a: f64,
    mut fa: f64,
    mut b: f64,
) -> Option<(f64, f64)> {
    if fa == 0.0 {
        return Some((a, a));
    }
    let mut fb = f64::NAN;
    for _ in 0..200 {
        if (b - a).abs() <= 4.0 * f64::EPSILON * (1.0 + a.abs().max(b.abs())) {
            break;
        }
        let m = 0.5 * (a + b);
        let fm = delta(m).ok()?;
        if fm == 0.0 {
            return Some((m, m));
        }
        if fa * fm < 0.0 {
            b = m;
            fb = fm;
        } else {
            a = m;
            fa = fm;
        }
    }
    // a root leaves |Δ| at rounding level; a pole leaves it large (growing as the bracket shrinks)
    (fa.abs().min(fb.abs()) <= 1e-6).then_some((a, b))
}

/// The worm cone angle in the allowed range at which K_ZV1,l = K_ZV1,r.
///
/// # Formula
/// Root of Δ(ϑ1) = K_l(ϑ1) − K_r(ϑ1): Δ is sampled at 65 points of the range, the sign change
/// nearest to ϑ1 = 0 is bracketed and bisected to machine precision; a sign change across a
/// pole of K (a flank's K through ±∞, which ended the search with "diagonal ratio (conical):
/// … is singular") is passed over for the next one.
/// # Domain
/// Returns [`GrindError::NoRoot`] when Δ does not change sign in the range, or only across
/// poles (no cone angle in it equalises the two flanks); a sample where a flank's K is
/// singular is skipped.
/// # Source
/// JP6903407B2, conical worms for different directions on the two flanks, conical worm on a conical
/// workpiece [SEED]; docs/grinding.md "Derivation: equal diagonal ratio on both flanks",
/// docs/grinding.md "Independent reference: reference example" [RECONSTRUCTED].
pub fn equalise_worm_cone_angle(spec: &EqualiseSpec) -> Result<Equalised> {
    let (lo, hi) = spec.cone_range_rad;
    check_range(
        "cone_range_min_rad",
        lo,
        -MAX_CONE_ANGLE_RAD,
        MAX_CONE_ANGLE_RAD,
        "-50° ..= 50°, below the range maximum",
    )?;
    check_range(
        "cone_range_max_rad",
        hi,
        lo + 1e-9,
        MAX_CONE_ANGLE_RAD,
        "above the range minimum, at most 50°",
    )?;
    check_range("rho2_left_rad", spec.rho2_left_rad, -3.2, 3.2, "-π ..= π")?;
    check_range("rho2_right_rad", spec.rho2_right_rad, -3.2, 3.2, "-π ..= π")?;
    let delta = |t: f64| flank_ratios(spec, t).map(|(l, r, _, _)| l - r);
    // exact hit at zero (e.g. symmetric gear and modification) before any scanning
    let mut samples = [(0.0, f64::NAN); SCAN_STEPS + 1];
    for (i, s) in samples.iter_mut().enumerate() {
        let t = lo + (hi - lo) * i as f64 / SCAN_STEPS as f64;
        *s = (t, delta(t).unwrap_or(f64::NAN));
    }
    // brackets of a sign change, nearest to ϑ1 = 0 first; a sign change may be a pole of K
    // (a flank's denominator through 0) instead of a root: its bisection meets a singular K
    // or ends on a large |Δ|, and the next bracket is tried
    // fixed storage: the search allocates nothing (tests/conical_no_alloc.rs)
    let mut store = [(0.0, 0.0, 0.0, f64::MAX); SCAN_STEPS];
    let mut count = 0;
    for pair in samples.windows(2) {
        let ((ta, da), (tb, db)) = (pair[0], pair[1]);
        if !(da.is_finite() && db.is_finite()) || da * db > 0.0 {
            continue;
        }
        let dist = ta
            .abs()
            .min(tb.abs())
            .min(if ta * tb <= 0.0 { 0.0 } else { f64::MAX });
        store[count] = (ta, da, tb, dist);
        count += 1;
    }
    let brackets = &mut store[..count];
    brackets.sort_unstable_by(|x, y| x.3.total_cmp(&y.3));
    let no_root = || GrindError::NoRoot {
        what: "worm cone angle equalising K_ZV1 on both flanks",
        field: "cone_range_rad",
        min: lo,
        max: hi,
        at_min: samples[0].1,
        at_max: samples[SCAN_STEPS].1,
    };
    if brackets.is_empty() {
        return Err(no_root());
    }
    let found = brackets
        .iter()
        .find_map(|&(a, fa, b, _)| bisect_root(&delta, a, fa, b));
    let Some((a, b)) = found else {
        return Err(no_root());
    };
    let cone = 0.5 * (a + b);
    let (kl, kr, rl, rr) = flank_ratios(spec, cone)?;
    Ok(Equalised {
        cone1_rad: cone,
        k_zv1: 0.5 * (kl + kr),
        k_left: kl,
        k_right: kr,
        rho1_left_rad: rl,
        rho1_right_rad: rr,
    })
}
