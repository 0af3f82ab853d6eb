//! The life of a worm (claims 1 and 2): for each dressing diameter the axis corrections, machine
//! axes, predicted profile deviation, profile stretching and the collision/undercut checks.

use crate::dresser::Dresser;
use crate::envelope::DressingSetup;
use crate::error::{DressError, Result};
use crate::kinematics::{AxesBsp2, AxisCorrection};
use crate::solve::{solve_three_point, NewtonOptions, ThreePoint};
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
    /// Largest |f_nFS − target| over the active profile (µm).
    pub deviation_max_um: f64,
    /// Range of f_nFS − target over the active profile (µm), uniform offset removed.
    pub deviation_range_um: f64,
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
/// seed 004, claims 1–2, E147–E150 [SEED]; algorithm digest §4.A.15 [RECONSTRUCTED];
/// checks O343–O361 [SEED]
pub fn plan(design: &Worm, dresser: &Dresser, spec: &PlanSpec) -> Result<Vec<PlanRow>> {
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
    let design_setup = DressingSetup::new(*design, dresser.clone());
    let (w_nf0, w_na0) = design_setup.active_profile(spec.flank)?;
    let k0 = AxisCorrection::default();
    let r_a_tip = design_setup.association(spec.flank, w_na0, &k0)?;
    let r_a_root = design_setup.association(spec.flank, w_nf0, &k0)?;
    let mut rows = Vec::with_capacity(spec.diameters_mm.len());
    let mut prev = k0;
    for &d_s in &spec.diameters_mm {
        let worm = design.worn(d_s)?;
        let setup = DressingSetup::new(worm, dresser.clone());
        let (w_nf, w_na) = setup.active_profile(spec.flank)?;
        let at = |q: f64| w_nf + q * (w_na - w_nf);
        let wt = [at(0.05), at(0.5), at(0.95)];
        let (dk, iterations) = match spec.correction {
            Correction::None => (k0, 0),
            Correction::ThreePoint => {
                let p = ThreePoint {
                    flank: spec.flank,
                    w_mm: wt,
                    f_mm: [0.0, -spec.crowning_mm, 0.0],
                    w_assoc_mm: w_na,
                    r_a_mm: r_a_tip,
                };
                let sol = solve_three_point(&setup, &p, prev, &NewtonOptions::default())
                    .or_else(|_| solve_three_point(&setup, &p, k0, &NewtonOptions::default()))?;
                (sol.dk, sol.iterations)
            }
        };
        prev = dk;
        let ws: Vec<f64> = (0..=20).map(|i| at(i as f64 / 20.0)).collect();
        let f = setup.profile(spec.flank, &ws, &dk)?;
        let profile: Vec<(f64, f64)> = ws
            .iter()
            .zip(f.iter())
            .map(|(&w, &fv)| (w, 1e3 * (fv - target(&wt, spec.crowning_mm, w))))
            .collect();
        let dev_max = profile.iter().fold(0.0f64, |m, p| m.max(p.1.abs()));
        let (lo, hi) = profile
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.1), b.max(p.1))
            });
        let w1 = setup.roll_dressed_by(spec.flank, r_a_root, &dk, w_nf)?;
        let w2 = setup.roll_dressed_by(spec.flank, r_a_tip, &dk, w_na)?;
        let stretch = (w2 - w1) / (w_na0 - w_nf0) - 1.0;
        let opposite_cut_mm = setup.opposite_flank_cut(spec.flank, &dk)?;
        let jacket_depth_mm = setup.jacket_depth(&dk);
        let n = setup.nominal;
        let axes = setup.machine_axes(&dk)?;
        rows.push(PlanRow {
            d_s_mm: d_s,
            d0_mm: n.d_mm,
            active_mm: (w_nf, w_na),
            dk,
            iterations,
            axes,
            deviation_max_um: dev_max,
            deviation_range_um: hi - lo,
            stretch,
            opposite_cut_mm,
            jacket_depth_mm,
            penetration: opposite_cut_mm > spec.budget_mm,
            undercut: jacket_depth_mm > spec.budget_mm,
            profile,
        });
    }
    Ok(rows)
}
