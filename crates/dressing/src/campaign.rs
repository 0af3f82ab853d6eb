//! The life of a worm (claims 1 and 2): for each dressing diameter the axis corrections, machine
//! axes, predicted profile deviation, profile stretching and the collision/undercut checks.

use crate::dresser::Dresser;
use crate::envelope::DressingSetup;
use crate::error::{DressError, Result};
use crate::kinematics::{AxesBsp2, AxisCorrection};
use crate::solve::{solve_three_point, NewtonOptions, ThreePoint, CROWNING_FRACTIONS};
use crate::worm::{Flank, Worm};
use serde::{Deserialize, Serialize};

/// How each dressing is corrected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Correction {
    /// Only the centre distance follows the diameter (ΔK = 0): the prior-art dressing.
    None,
    /// 3-point method with radius association at the tip circle.
    ThreePoint,
}

/// What to plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanSpec {
    /// Flank dressed (single-flank method).
    pub flank: Flank,
    /// Worm reference diameters after each dressing (mm), first = new worm.
    pub diameters_mm: Vec<f64>,
    /// Correction mode.
    pub correction: Correction,
    /// Desired profile crowning on the worm c (mm, > 0 removes material mid-profile).
    pub crowning_mm: f64,
    /// Clearance budget A for opposite-flank cut and jacket depth (mm).
    pub budget_mm: f64,
}

/// One dressing of the plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanRow {
    /// Worm reference diameter d_S (mm).
    pub d_s_mm: f64,
    /// Uncorrected centre distance d_0 for this diameter (mm).
    pub d0_mm: f64,
    /// Active profile [w_Nf, w_Na] (mm).
    pub active_mm: (f64, f64),
    /// Axis corrections ΔK.
    pub dk: AxisCorrection,
    /// Newton iterations (0 without correction).
    pub iterations: usize,
    /// Machine axes of machine (5) at φ_S = 0.
    pub axes: AxesBsp2,
    /// Largest |f_nFS − target| over the evaluation range [`Self::deviation_eval_mm`] (µm).
    pub deviation_max_um: f64,
    /// Range of f_nFS − target over the evaluation range (µm), uniform offset removed.
    pub deviation_range_um: f64,
    /// Evaluation range of the deviation: the roll distances of the outer targets, 5 % and
    /// 95 % of the active profile (mm). Outside it the target parabola is extrapolated, and
    /// the foot (0 %) is the fillet/flank junction of the dresser, reported separately.
    pub deviation_eval_mm: (f64, f64),
    /// f_nFS − target at the foot of the active profile, w_Nf (0 %, the fillet/flank junction
    /// dressed uncorrected) (µm).
    pub deviation_foot_um: f64,
    /// f_nFS − target at the tip circle, w_Na (100 %) (µm).
    pub deviation_tip_um: f64,
    /// Relative profile stretching P_FS (1 = 100 %).
    pub stretch: f64,
    /// Cut into the opposite flank (mm, > 0 = below nominal).
    pub opposite_cut_mm: f64,
    /// Depth of the jacket below the root circle (mm, < 0 = root not reached).
    pub jacket_depth_mm: f64,
    /// Opposite flank cut beyond the budget.
    pub penetration: bool,
    /// Jacket deeper than the budget (undercut of the thread at later diameters).
    pub undercut: bool,
    /// Profile (w mm, f − target µm) at 21 points of the active profile.
    pub profile: Vec<(f64, f64)>,
    /// Normal profile angle of the worm at d_S/2 for this dressing (rad): the unchanged
    /// helicoid's, or the zero-stretch angle when it was searched.
    pub alpha_n_rad: f64,
    /// Normal profile angle the unchanged helicoid has at d_S/2 (rad).
    pub alpha_keep_rad: f64,
    /// Lead p_z of the worm for this dressing (mm); it changes with the profile angle.
    pub lead_mm: f64,
}

/// Options of [`plan_with_options`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PlanOptions {
    /// Per dressing, choose the worm profile angle (normal base pitch kept, eq. (20)) that makes
    /// the relative profile stretching zero (claim 2).
    pub zero_stretch: bool,
    /// Half-width of the profile-angle search around the unchanged helicoid's angle (rad).
    pub alpha_search_rad: f64,
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            zero_stretch: false,
            alpha_search_rad: 10f64.to_radians(),
        }
    }
}

/// What the stretching of a dressing is measured against: the new worm, dressed uncorrected.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StretchReference {
    /// Active profile [w_Nf,0, w_Na,0] of the new worm (mm).
    pub active0_mm: (f64, f64),
    /// Dresser radii r_A1, r_A2 that dress w_Nf,0 and w_Na,0 uncorrected (mm).
    pub r_a_mm: (f64, f64),
    /// cos β_b of the new worm.
    pub cos_beta_b0: f64,
}

impl StretchReference {
    /// The reference of `design` (new worm) dressed uncorrected by `dresser` on `flank`.
    pub fn new(design: &Worm, dresser: &Dresser, flank: Flank) -> Result<Self> {
        let s = DressingSetup::new(*design, dresser.clone());
        let (w_nf0, w_na0) = s.active_profile(flank)?;
        let k0 = AxisCorrection::default();
        Ok(Self {
            active0_mm: (w_nf0, w_na0),
            r_a_mm: (
                s.association(flank, w_nf0, &k0)?,
                s.association(flank, w_na0, &k0)?,
            ),
            cos_beta_b0: design.beta_b_rad.cos(),
        })
    }
}

/// Relative profile stretching P_FS of a dressing (1 = 100 %), on distances along the line of
/// action.
///
/// Worm and gear roll distances in contact move together along the line of action,
/// dw_S / cos β_bS = dw_V / cos β_bV, so measuring the worm's feature spacing as w / cos β_b makes
/// P_FS equal to the gear's P_FV also when the worm's profile angle (and β_b) is changed; with the
/// helicoid unchanged it is the plain roll-distance ratio of eq. (21).
///
/// # Formula
/// P_FS = [(w(r_A2; ΔK) − w(r_A1; ΔK)) / cos β_b] / [(w_Na,0 − w_Nf,0) / cos β_b0] − 1
/// # Source
/// JP6903407B2, eq. (21) (drawing lost), Fig. 13; form of docs/dressing.md "Derivation: three-point system and relative profile stretching" [RECONSTRUCTED];
/// line-of-action scaling [RECONSTRUCTED]
pub fn profile_stretch(
    setup: &DressingSetup,
    flank: Flank,
    reference: &StretchReference,
    dk: &AxisCorrection,
    active_mm: (f64, f64),
) -> Result<f64> {
    let w1 = setup.roll_dressed_by(flank, reference.r_a_mm.0, dk, active_mm.0)?;
    let w2 = setup.roll_dressed_by(flank, reference.r_a_mm.1, dk, active_mm.1)?;
    let (a0, b0) = reference.active0_mm;
    Ok(((w2 - w1) / setup.worm.beta_b_rad.cos()) / ((b0 - a0) / reference.cos_beta_b0) - 1.0)
}

/// One dressing solved: the worm used, its active profile, targets, ΔK and iterations.
struct Dressed {
    setup: DressingSetup,
    active: (f64, f64),
    targets: [f64; 3],
    dk: AxisCorrection,
    iterations: usize,
}

/// Solves one dressing of `worm` (already worn, possibly re-profiled).
fn dress_once(
    worm: Worm,
    dresser: &Dresser,
    spec: &PlanSpec,
    reference: &StretchReference,
    start: AxisCorrection,
) -> Result<Dressed> {
    let setup = DressingSetup::new(worm, dresser.clone());
    let (w_nf, w_na) = setup.active_profile(spec.flank)?;
    let at = |q: f64| w_nf + q * (w_na - w_nf);
    let targets = CROWNING_FRACTIONS.map(at);
    let k0 = AxisCorrection::default();
    let (dk, iterations) = match spec.correction {
        Correction::None => (k0, 0),
        Correction::ThreePoint => {
            let p = ThreePoint::from_crowning(
                &setup,
                spec.flank,
                spec.crowning_mm,
                reference.r_a_mm.1,
            )?;
            let sol = solve_three_point(&setup, &p, start, &NewtonOptions::default())
                .or_else(|_| solve_three_point(&setup, &p, k0, &NewtonOptions::default()))?;
            (sol.dk, sol.iterations)
        }
    };
    Ok(Dressed {
        setup,
        active: (w_nf, w_na),
        targets,
        dk,
        iterations,
    })
}

/// P_FS of the worn worm of diameter `d_s_mm` re-profiled to `alpha_n_rad` (normal base pitch
/// kept) and dressed by the old dresser with the plan's correction; returns (P_FS, ΔK).
///
/// # Source
/// JP6903407B2, claim 2, Fig. 19(b) [SEED]; docs/dressing.md "Derivation: worm life and zero-stretch angle" [RECONSTRUCTED]
pub fn stretch_at_profile_angle(
    design: &Worm,
    dresser: &Dresser,
    spec: &PlanSpec,
    reference: &StretchReference,
    d_s_mm: f64,
    alpha_n_rad: f64,
    start: AxisCorrection,
) -> Result<(f64, AxisCorrection)> {
    let worm = design.worn(d_s_mm)?.with_profile_angle(alpha_n_rad)?;
    let d = dress_once(worm, dresser, spec, reference, start)?;
    let p = profile_stretch(&d.setup, spec.flank, reference, &d.dk, d.active)?;
    Ok((p, d.dk))
}

/// The profile angle α_n (at d_S/2, normal base pitch kept) at which P_FS = 0 for the worn worm
/// of diameter `d_s_mm`.
///
/// P_FS(α) is smooth and steep (a few tenths of a per cent per 0.1°), and only a narrow band of
/// angles is producible by the old dresser at all, so the search starts at the unchanged
/// helicoid's angle with a 0.01° secant step, halves any step whose 3-point solve has no root,
/// and switches to Illinois false position once the root is bracketed; it stops at
/// |P_FS| < 1e-9. ΔK is continued from evaluation to evaluation.
///
/// # Source
/// JP6903407B2, claim 2, Fig. 19(b)/(c) ("path 0") [SEED]; 1-D root find
/// docs/dressing.md "Derivation: worm life and zero-stretch angle" [RECONSTRUCTED]
pub fn zero_stretch_profile_angle(
    design: &Worm,
    dresser: &Dresser,
    spec: &PlanSpec,
    reference: &StretchReference,
    d_s_mm: f64,
    search_rad: f64,
    start: AxisCorrection,
) -> Result<(f64, AxisCorrection)> {
    DressError::check("alpha_search_rad", search_rad, 1e-4, 20f64.to_radians())?;
    let keep = design.worn(d_s_mm)?.profile_angle_at(d_s_mm / 2.0);
    let eval = |a: f64, k: AxisCorrection| {
        stretch_at_profile_angle(design, dresser, spec, reference, d_s_mm, a, k).map_err(|e| {
            match e {
                // The trial angle left the re-profiling range: say so in degrees.
                DressError::OutOfRange {
                    field: "alpha_n_rad",
                    value,
                    min,
                    max,
                } => DressError::NotProducible {
                    key: "[plan] zero_stretch".into(),
                    detail: format!(
                        "the search reached the profile angle {:.3} degrees, outside {:.0} ..= \
                         {:.0} degrees",
                        value.to_degrees(),
                        min.to_degrees(),
                        max.to_degrees()
                    ),
                },
                e => e,
            }
        })
    };
    let no_root = |detail: &str| DressError::NotProducible {
        key: "[plan] zero_stretch".into(),
        detail: format!(
            "no profile angle within ±{:.2}° of {:.4}° makes the profile stretching zero at \
             d_S = {d_s_mm} mm ({detail})",
            search_rad.to_degrees(),
            keep.to_degrees()
        ),
    };
    let (p_keep, k_keep) = eval(keep, start)?;
    if p_keep.abs() < 1e-9 {
        return Ok((keep, k_keep));
    }
    // (α, P) of the last two evaluations; bracket once the sign changes.
    let (mut a0, mut p0) = (keep, p_keep);
    let mut k = k_keep;
    let mut step = 0.01f64.to_radians();
    let (mut a1, mut p1) = loop {
        match eval(keep + step, k) {
            Ok((p, kn)) => {
                k = kn;
                break (keep + step, p);
            }
            Err(_) if step > 1e-7 => step *= 0.5,
            Err(e) => return Err(e),
        }
    };
    let mut bracket: Option<((f64, f64), (f64, f64))> = None;
    let mut side = 0i8;
    for _ in 0..80 {
        if p1.abs() < 1e-9 {
            return Ok((a1, k));
        }
        if bracket.is_none() && p1.signum() != p0.signum() {
            bracket = Some(((a0, p0), (a1, p1)));
        }
        let next = match bracket {
            Some(((lo, plo), (hi, phi))) => (lo * phi - hi * plo) / (phi - plo),
            None => {
                let den = p1 - p0;
                if den == 0.0 {
                    return Err(no_root("the stretching does not change with the angle"));
                }
                let raw = a1 - p1 * (a1 - a0) / den;
                // Expand at most fourfold per step towards the secant root.
                let lim = 4.0 * (a1 - a0).abs();
                a1 + (raw - a1).clamp(-lim, lim)
            }
        };
        if (next - keep).abs() > search_rad {
            return Err(no_root("the root lies beyond the search range"));
        }
        let mut trial = next;
        let (p, kn) = loop {
            match eval(trial, k) {
                Ok(v) => break v,
                Err(_) if (trial - a1).abs() > 1e-9 => trial = 0.5 * (trial + a1),
                Err(e) => return Err(e),
            }
        };
        k = kn;
        match bracket {
            Some(((lo, plo), (hi, phi))) => {
                if (hi - lo).abs() < 1e-12 {
                    return Ok((trial, k));
                }
                if p.signum() == phi.signum() {
                    let plo = if side == 1 { 0.5 * plo } else { plo };
                    bracket = Some(((lo, plo), (trial, p)));
                    side = 1;
                } else {
                    let phi = if side == -1 { 0.5 * phi } else { phi };
                    bracket = Some(((trial, p), (hi, phi)));
                    side = -1;
                }
                (a0, p0, a1, p1) = (a1, p1, trial, p);
            }
            None => (a0, p0, a1, p1) = (a1, p1, trial, p),
        }
    }
    Err(DressError::NoConvergence {
        what: "zero-stretch profile angle",
        detail: format!(
            "last profile angle {:.4} degrees, stretching {:.3e} %",
            a1.to_degrees(),
            100.0 * p1
        ),
    })
}

/// Target profile through (w_1, 0), (w_2, −c), (w_3, 0): parabola in w.
fn target(ws: &[f64; 3], c_mm: f64, w: f64) -> f64 {
    let (a, m, b) = (ws[0], ws[1], ws[2]);
    // Lagrange basis for the middle node only (the outer targets are 0).
    -c_mm * (w - a) * (w - b) / ((m - a) * (m - b))
}

/// Plans every dressing of a worm's life with the dresser designed for the new worm.
///
/// # Source
/// JP6903407B2, claims 1–2, Fig. 19 [SEED]; algorithm docs/dressing.md "Derivation: worm life and zero-stretch angle" [RECONSTRUCTED];
/// checks: JP6903407B2, section on the maximum producible profile modification and the choice of dresser and worm [SEED]
pub fn plan(design: &Worm, dresser: &Dresser, spec: &PlanSpec) -> Result<Vec<PlanRow>> {
    plan_with_options(design, dresser, spec, &PlanOptions::default())
}

/// [`plan`] with options: with `zero_stretch` every dressing uses the profile angle of
/// [`zero_stretch_profile_angle`] (claim 2), otherwise the unchanged helicoid (claim 1).
///
/// # Source
/// JP6903407B2, claims 1–2, Fig. 19 [SEED]; algorithm docs/dressing.md "Derivation: worm life and zero-stretch angle" [RECONSTRUCTED];
/// checks: JP6903407B2, section on the maximum producible profile modification and the choice of dresser and worm [SEED]
pub fn plan_with_options(
    design: &Worm,
    dresser: &Dresser,
    spec: &PlanSpec,
    options: &PlanOptions,
) -> Result<Vec<PlanRow>> {
    if spec.diameters_mm.is_empty() {
        return Err(DressError::OutOfRange {
            field: "diameters_mm (count)",
            value: 0.0,
            min: 1.0,
            max: 1000.0,
        });
    }
    DressError::check("crowning_mm", spec.crowning_mm, -0.05, 0.05)?;
    DressError::check("budget_mm", spec.budget_mm, 0.0, 5.0)?;
    let reference = StretchReference::new(design, dresser, spec.flank)?;
    let mut rows = Vec::with_capacity(spec.diameters_mm.len());
    let mut prev = AxisCorrection::default();
    for &d_s in &spec.diameters_mm {
        // Which dressing failed, in the terms of `[plan]`.
        let at_d = |e: DressError| DressError::NotProducible {
            key: "[plan] diameters_mm".into(),
            detail: format!("the dressing at d_S = {d_s} mm: {e}"),
        };
        let worn = design.worn(d_s).map_err(at_d)?;
        let alpha_keep = worn.profile_angle_at(d_s / 2.0);
        let worm = if options.zero_stretch {
            let (a, k) = zero_stretch_profile_angle(
                design,
                dresser,
                spec,
                &reference,
                d_s,
                options.alpha_search_rad,
                prev,
            )
            .map_err(at_d)?;
            prev = k;
            worn.with_profile_angle(a)?
        } else {
            worn
        };
        let d = dress_once(worm, dresser, spec, &reference, prev).map_err(at_d)?;
        let (setup, (w_nf, w_na), wt, dk) = (&d.setup, d.active, d.targets, d.dk);
        prev = dk;
        let at = |q: f64| w_nf + q * (w_na - w_nf);
        let ws: Vec<f64> = (0..=20).map(|i| at(i as f64 / 20.0)).collect();
        let f = setup.profile(spec.flank, &ws, &dk).map_err(at_d)?;
        let profile: Vec<(f64, f64)> = ws
            .iter()
            .zip(f.iter())
            .map(|(&w, &fv)| (w, 1e3 * (fv - target(&wt, spec.crowning_mm, w))))
            .collect();
        // Evaluation range 5 % ..= 95 % (indices 1 ..= 19); foot and tip reported apart.
        let eval = &profile[1..20];
        let dev_max = eval.iter().fold(0.0f64, |m, p| m.max(p.1.abs()));
        let (lo, hi) = eval
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.1), b.max(p.1))
            });
        let (deviation_foot_um, deviation_tip_um) = (profile[0].1, profile[20].1);
        let stretch =
            profile_stretch(setup, spec.flank, &reference, &dk, (w_nf, w_na)).map_err(at_d)?;
        let opposite_cut_mm = setup.opposite_flank_cut(spec.flank, &dk).map_err(at_d)?;
        let jacket_depth_mm = setup.jacket_depth(&dk);
        let n = setup.nominal;
        let axes = setup.machine_axes(&dk)?;
        rows.push(PlanRow {
            d_s_mm: d_s,
            d0_mm: n.d_mm,
            active_mm: (w_nf, w_na),
            dk,
            iterations: d.iterations,
            axes,
            deviation_max_um: dev_max,
            deviation_range_um: hi - lo,
            deviation_eval_mm: (at(0.05), at(0.95)),
            deviation_foot_um,
            deviation_tip_um,
            stretch,
            opposite_cut_mm,
            jacket_depth_mm,
            penetration: opposite_cut_mm > spec.budget_mm,
            undercut: jacket_depth_mm > spec.budget_mm,
            profile,
            alpha_n_rad: setup.worm.profile_angle_at(d_s / 2.0),
            alpha_keep_rad: alpha_keep,
            lead_mm: 2.0 * std::f64::consts::PI * setup.worm.p_mm,
        });
    }
    Ok(rows)
}
