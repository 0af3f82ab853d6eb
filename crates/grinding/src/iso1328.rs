//! ISO 1328-1:2013 profile and helix evaluation of a flank deviation map; the tolerances of a
//! class come from `gearcomp_geometry::iso1328` (re-exported here).
//!
//! The standard works in µm; values enter this module in mm (the crate's unit) and are
//! converted to µm once, in [`DeviationMap::trace_um`].

use serde::{Deserialize, Serialize};

use crate::error::{check_range, GrindError, Result};

use crate::envelope::FlankGrid;
pub use gearcomp_geometry::iso1328::{
    helix_evaluation_range, profile_evaluation_range, round_tolerance_um, tolerances, Tolerances,
};

/// Deviation of a flank from its design over a (w, z) grid (transverse, mm, > 0 = material).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeviationMap {
    /// The grid.
    pub grid: FlankGrid,
    /// f_Ft deviation per grid point (index i_w·n_z + j_z) in mm.
    pub f_mm: Vec<f64>,
}

/// Evaluation of one trace (profile or helix) over its evaluation range.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TraceEvaluation {
    /// Evaluation range (start, end) in mm of roll distance (profile) or width (helix).
    pub range_mm: (f64, f64),
    /// Total deviation F (F_α or F_β) in µm.
    pub total_um: f64,
    /// Form deviation f_f (f_fα or f_fβ) in µm.
    pub form_um: f64,
    /// Slope deviation f_H (f_Hα or f_Hβ) in µm, signed.
    pub slope_um: f64,
}

/// Evaluates a trace (x in mm, f in µm) over `range_mm`.
///
/// # Formula
/// Mean line = least-squares line of f over the evaluation range;
/// F = max f − min f (design trace = zero deviation);
/// f_f = max r − min r with r = f − mean line;
/// f_H = mean line(end) − mean line(start), signed (> 0: more material at the range end, i.e.
/// towards the tip for a profile, towards +z for a helix).
/// # Source
/// ISO 1328-1:2013, definitions of total, form and slope deviation of profile and helix
/// (clause 3.3) [STANDARD]; sign convention of f_H fixed here (docs/grinding.md).
pub fn evaluate_trace(x_mm: &[f64], f_um: &[f64], range_mm: (f64, f64)) -> Result<TraceEvaluation> {
    if x_mm.len() != f_um.len() {
        return Err(GrindError::BadData {
            field: "trace",
            got: f_um.len(),
            expected: "as many deviations as abscissae",
        });
    }
    let pts = || {
        x_mm.iter()
            .zip(f_um)
            .filter(|(x, _)| **x >= range_mm.0 - 1e-12 && **x <= range_mm.1 + 1e-12)
    };
    let n = pts().count();
    if n < 3 || !pts().all(|(x, f)| x.is_finite() && f.is_finite()) {
        return Err(GrindError::BadData {
            field: "trace points inside the evaluation range",
            got: n,
            expected: "at least 3 finite points",
        });
    }
    let nf = n as f64;
    let mx = pts().map(|(x, _)| x).sum::<f64>() / nf;
    let mf = pts().map(|(_, f)| f).sum::<f64>() / nf;
    // two-pass centred sums: the 2-unknown least-squares line without normal-equation loss
    let sxx = pts().map(|(x, _)| (x - mx).powi(2)).sum::<f64>();
    let sxf = pts().map(|(x, f)| (x - mx) * (f - mf)).sum::<f64>();
    if sxx.is_nan() || sxx <= 0.0 {
        return Err(GrindError::BadData {
            field: "trace abscissae",
            got: n,
            expected: "distinct positions",
        });
    }
    let slope = sxf / sxx;
    let line = |x: f64| mf + slope * (x - mx);
    let (mut fmin, mut fmax, mut rmin, mut rmax) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, f) in pts() {
        fmin = fmin.min(*f);
        fmax = fmax.max(*f);
        let r = f - line(*x);
        rmin = rmin.min(r);
        rmax = rmax.max(r);
    }
    Ok(TraceEvaluation {
        range_mm,
        total_um: fmax - fmin,
        form_um: rmax - rmin,
        slope_um: line(range_mm.1) - line(range_mm.0),
    })
}

/// Profile and helix evaluation of a flank against a class.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FlankEvaluation {
    /// Width position of the evaluated profile (mid face) in mm.
    pub profile_z_mm: f64,
    /// Roll distance of the evaluated helix (middle of L_α) in mm.
    pub helix_w_mm: f64,
    /// Profile evaluation (F_α, f_fα, f_Hα).
    pub profile: TraceEvaluation,
    /// Helix evaluation (F_β, f_fβ, f_Hβ).
    pub helix: TraceEvaluation,
    /// Tolerances of the class; `None` for a gear outside ISO 1328-1:2013's scope
    /// ([`OUT_OF_SCOPE`]).
    pub tolerances: Option<Tolerances>,
    /// Every value within its tolerance; `None` without tolerances.
    pub within_tolerance: Option<bool>,
}

/// A trace evaluated at a position: width z of a profile trace, roll distance w of a helix
/// trace (mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PlacedTrace {
    /// Position of the trace in mm.
    pub at_mm: f64,
    /// Its evaluation.
    pub trace: TraceEvaluation,
}

/// The largest values over several traces: F and f_f the maxima, f_H the signed value of
/// largest magnitude.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WorstTrace {
    /// Largest total deviation in µm.
    pub total_um: f64,
    /// Largest form deviation in µm.
    pub form_um: f64,
    /// Slope deviation of largest magnitude in µm (signed).
    pub slope_um: f64,
}

impl WorstTrace {
    fn of(traces: &[PlacedTrace]) -> Self {
        let mut w = WorstTrace {
            total_um: 0.0,
            form_um: 0.0,
            slope_um: 0.0,
        };
        for t in traces {
            w.total_um = w.total_um.max(t.trace.total_um);
            w.form_um = w.form_um.max(t.trace.form_um);
            if t.trace.slope_um.abs() > w.slope_um.abs() {
                w.slope_um = t.trace.slope_um;
            }
        }
        w
    }
}

/// Statement on the pitch deviations, which a one-flank simulation cannot give.
pub const PITCH_NOT_EVALUATED: &str =
    "f_pt and F_p not evaluated: the simulation grinds one tooth flank with ideal indexing \
     (every tooth identical), so pitch deviations would be 0 by construction; they come from \
     machine indexing errors, which are not modelled";

/// ISO 1328-1 evaluation over several profile and helix traces, as measuring practice takes
/// them, with the class the flank achieves.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MultiTraceEvaluation {
    /// Profile traces at the start, middle and end of L_β (and evenly between for more).
    pub profiles: Vec<PlacedTrace>,
    /// Helix traces at the start, middle and end of L_α (and evenly between for more).
    pub helices: Vec<PlacedTrace>,
    /// Largest profile values (F_α, f_fα, f_Hα).
    pub profile_worst: WorstTrace,
    /// Largest helix values (F_β, f_fβ, f_Hβ).
    pub helix_worst: WorstTrace,
    /// Tolerances of the requested class; `None` for a gear outside ISO 1328-1:2013's scope
    /// ([`OUT_OF_SCOPE`]).
    pub tolerances: Option<Tolerances>,
    /// Every trace within the requested class; `None` without tolerances.
    pub within_tolerance: Option<bool>,
    /// The best class (1 … 11) whose profile and helix tolerances every trace meets, None if
    /// not even class 11 or without tolerances.
    pub class_achieved: Option<u8>,
    /// Pitch deviations: not evaluated (see [`PITCH_NOT_EVALUATED`]).
    pub pitch: &'static str,
}

/// What the evaluation says of a gear outside the standard's scope: the deviations are
/// evaluated, the tolerances are not (ISO 1328-1:2013 gives its formulas for these ranges only).
pub const OUT_OF_SCOPE: &str =
    "no ISO 1328-1 tolerances: the gear is outside ISO 1328-1:2013's scope (5 ≤ d ≤ 15 000 mm, \
     0.5 ≤ m_n ≤ 70 mm, 4 ≤ b ≤ 1200 mm); deviations only";

/// Tolerances of class A (1 … 11) for reference diameter d, normal module m_n and facewidth b,
/// `None` if the gear is outside the standard's scope (a valid gear still ground and evaluated:
/// a module-0.4 or a 3 mm wide gear was refused "ISO 1328-1 tolerances: normal module m_n =
/// 0.363 mm is outside the allowed range 0.5 … 70 mm").
///
/// # Errors
/// A class outside 1 … 11, or a d, m_n or b that is not a positive finite number.
pub fn tolerances_in_scope(
    d_mm: f64,
    m_n_mm: f64,
    b_mm: f64,
    class: u8,
) -> Result<Option<Tolerances>> {
    match tolerances(d_mm, m_n_mm, b_mm, class) {
        Ok(t) => Ok(Some(t)),
        Err(_)
            if (1..=11).contains(&class)
                && [d_mm, m_n_mm, b_mm]
                    .iter()
                    .all(|v| v.is_finite() && *v > 0.0) =>
        {
            Ok(None)
        }
        Err(e) => Err(e.into()),
    }
}

fn within(t: &Tolerances, p: &WorstTrace, h: &WorstTrace) -> bool {
    p.total_um <= t.total_alpha_t_um
        && p.form_um <= t.f_f_alpha_t_um
        && p.slope_um.abs() <= t.f_h_alpha_t_um
        && h.total_um <= t.total_beta_t_um
        && h.form_um <= t.f_f_beta_t_um
        && h.slope_um.abs() <= t.f_h_beta_t_um
}

impl DeviationMap {
    /// Checks size and values.
    pub fn new(grid: FlankGrid, f_mm: Vec<f64>) -> Result<Self> {
        // the grid's fields are public: re-validate before indexing with them
        let grid = FlankGrid::new(grid.w_range_mm, grid.z_range_mm, grid.n_w, grid.n_z)?;
        if f_mm.len() != grid.len() {
            return Err(GrindError::BadData {
                field: "deviation map",
                got: f_mm.len(),
                expected: "one value per grid point",
            });
        }
        for &v in &f_mm {
            check_range("deviation f_mm", v, -1e3, 1e3, "finite")?;
        }
        Ok(Self { grid, f_mm })
    }

    /// Value at (w, z), bilinear between grid points (clamped to the grid).
    pub fn value_mm(&self, w_mm: f64, z_mm: f64) -> f64 {
        let g = &self.grid;
        let loc = |v: f64, r: (f64, f64), n: usize| {
            let t = ((v - r.0) / (r.1 - r.0) * (n - 1) as f64).clamp(0.0, (n - 1) as f64);
            let i = (t.floor() as usize).min(n - 2);
            (i, t - i as f64)
        };
        let (i, a) = loc(w_mm, g.w_range_mm, g.n_w);
        let (j, b) = loc(z_mm, g.z_range_mm, g.n_z);
        let f = |i: usize, j: usize| self.f_mm[i * g.n_z + j];
        (1.0 - a) * ((1.0 - b) * f(i, j) + b * f(i, j + 1))
            + a * ((1.0 - b) * f(i + 1, j) + b * f(i + 1, j + 1))
    }

    /// A trace in µm: along w at width z (profile) or along z at roll distance w (helix),
    /// sampled at the grid lines inside `range_mm` plus the two range ends.
    fn trace_um(&self, profile: bool, at_mm: f64, range_mm: (f64, f64)) -> (Vec<f64>, Vec<f64>) {
        let g = &self.grid;
        let n = if profile { g.n_w } else { g.n_z };
        let mut xs = vec![range_mm.0];
        for k in 0..n {
            let x = if profile { g.w_mm(k) } else { g.z_mm(k) };
            if x > range_mm.0 + 1e-9 && x < range_mm.1 - 1e-9 {
                xs.push(x);
            }
        }
        // A coarse grid (--grid-w/--grid-z 2 … 4) may leave no grid point inside the range:
        // the trace is then the bilinear map's straight line between the ends, sampled at
        // its middle too (F = |f_H|, f_f = 0), not a refusal of a valid grid.
        if xs.len() == 1 {
            xs.push(0.5 * (range_mm.0 + range_mm.1));
        }
        xs.push(range_mm.1);
        let fs = xs
            .iter()
            .map(|&x| {
                let v = if profile {
                    self.value_mm(x, at_mm)
                } else {
                    self.value_mm(at_mm, x)
                };
                v * 1e3
            })
            .collect();
        (xs, fs)
    }

    /// ISO 1328-1 evaluation with `n_traces` (≥ 3) profile traces over L_β and as many helix
    /// traces over L_α (first, last and evenly between), against class `class` of a gear with
    /// reference diameter `d_mm`, module `m_n_mm` and face width `b_mm`, and the best class
    /// achieved.
    ///
    /// # Source
    /// ISO 1328-1:2013 clause 3.3 (deviations), formulas (5)–(12) (tolerances) [STANDARD];
    /// several traces per flank: measuring practice (e.g. three profiles across the face,
    /// three helices across the profile) [convention fixed here, docs/grinding.md].
    pub fn evaluate_traces(
        &self,
        d_mm: f64,
        m_n_mm: f64,
        b_mm: f64,
        class: u8,
        n_traces: usize,
    ) -> Result<MultiTraceEvaluation> {
        if !(3..=101).contains(&n_traces) {
            return Err(GrindError::BadData {
                field: "ISO 1328 traces per direction",
                got: n_traces,
                expected: "3 ..= 101",
            });
        }
        let tol = tolerances_in_scope(d_mm, m_n_mm, b_mm, class)?;
        let g = self.grid;
        let pr = profile_evaluation_range(g.w_range_mm);
        let hr = helix_evaluation_range(g.z_range_mm, m_n_mm);
        let at = |r: (f64, f64), k: usize| r.0 + (r.1 - r.0) * k as f64 / (n_traces - 1) as f64;
        let mut profiles = Vec::with_capacity(n_traces);
        let mut helices = Vec::with_capacity(n_traces);
        for k in 0..n_traces {
            let z = at(hr, k);
            let (x, f) = self.trace_um(true, z, pr);
            profiles.push(PlacedTrace {
                at_mm: z,
                trace: evaluate_trace(&x, &f, pr)?,
            });
            let w = at(pr, k);
            let (x, f) = self.trace_um(false, w, hr);
            helices.push(PlacedTrace {
                at_mm: w,
                trace: evaluate_trace(&x, &f, hr)?,
            });
        }
        let pw = WorstTrace::of(&profiles);
        let hw = WorstTrace::of(&helices);
        let mut class_achieved = None;
        if tol.is_some() {
            for c in 1..=11u8 {
                if within(&tolerances(d_mm, m_n_mm, b_mm, c)?, &pw, &hw) {
                    class_achieved = Some(c);
                    break;
                }
            }
        }
        Ok(MultiTraceEvaluation {
            profiles,
            helices,
            profile_worst: pw,
            helix_worst: hw,
            within_tolerance: tol.map(|t| within(&t, &pw, &hw)),
            tolerances: tol,
            class_achieved,
            pitch: PITCH_NOT_EVALUATED,
        })
    }

    /// ISO 1328-1 evaluation: profile at mid face width, helix at the middle of L_α; the grid's
    /// w range is taken as the active profile and its z range as the face width.
    /// `tol` is `None` for a gear outside the standard's scope ([`tolerances_in_scope`]).
    pub fn evaluate(&self, tol: Option<Tolerances>, m_n_mm: f64) -> Result<FlankEvaluation> {
        let g = self.grid;
        let pr = profile_evaluation_range(g.w_range_mm);
        let hr = helix_evaluation_range(g.z_range_mm, m_n_mm);
        let z_mid = 0.5 * (g.z_range_mm.0 + g.z_range_mm.1);
        let w_mid = 0.5 * (pr.0 + pr.1);
        let (x, f) = self.trace_um(true, z_mid, pr);
        let profile = evaluate_trace(&x, &f, pr)?;
        let (x, f) = self.trace_um(false, w_mid, hr);
        let helix = evaluate_trace(&x, &f, hr)?;
        let within = tol.map(|tol| {
            profile.total_um <= tol.total_alpha_t_um
                && profile.form_um <= tol.f_f_alpha_t_um
                && profile.slope_um.abs() <= tol.f_h_alpha_t_um
                && helix.total_um <= tol.total_beta_t_um
                && helix.form_um <= tol.f_f_beta_t_um
                && helix.slope_um.abs() <= tol.f_h_beta_t_um
        });
        Ok(FlankEvaluation {
            profile_z_mm: z_mid,
            helix_w_mm: w_mid,
            profile,
            helix,
            tolerances: tol,
            within_tolerance: within,
        })
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use approx::assert_relative_eq;

    /// ISO 1328-1:2013 tolerance example (clause 5 formulas): class 6, d = 80 mm, m_n = 2 mm, b = 20 mm.
    /// Hand-computed trace: f = 0.2x + 0.05(x − 5)² µm at x = 0, 1, …, 10 mm.
    /// Mean line slope 0.2 (the parabola is symmetric) ⇒ f_H = 2.0 µm; mean of (x−5)² = 10 ⇒
    /// residual 0.05((x−5)² − 10) ∈ [−0.5, 0.75] ⇒ f_f = 1.25 µm; f(0) = 1.25, f(10) = 3.25,
    /// min at x = 3: 0.8 ⇒ F = 2.45 µm.
    /// A coarse grid (2 or 3 points per direction, none inside an evaluation range) is
    /// evaluated, not refused: on the bilinear map of a plane f = a·w + c·z the profile and
    /// helix traces are its lines, so f_H = a·L_α and c·L_β, F = |f_H|, f_f = 0, as on a
    /// fine grid of the same plane.
    #[test]
    fn a_coarse_grid_evaluates_the_plane_it_spans() {
        let (a, c) = (2e-4, -1.5e-4); // mm per mm
        let tol = tolerances(80.0, 2.0, 20.0, 6).ok();
        for (n_w, n_z) in [(2, 2), (2, 31), (25, 2), (3, 3), (25, 31)] {
            let g = FlankGrid::new((8.0, 22.0), (-10.0, 10.0), n_w, n_z).unwrap();
            let f: Vec<f64> = (0..n_w)
                .flat_map(|i| (0..n_z).map(move |j| (i, j)))
                .map(|(i, j)| a * g.w_mm(i) + c * g.z_mm(j))
                .collect();
            let e = DeviationMap::new(g, f).unwrap().evaluate(tol, 2.0).unwrap();
            let pr = profile_evaluation_range((8.0, 22.0));
            let hr = helix_evaluation_range((-10.0, 10.0), 2.0);
            assert_relative_eq!(e.profile.slope_um, a * (pr.1 - pr.0) * 1e3, epsilon = 1e-9);
            assert_relative_eq!(e.profile.total_um, e.profile.slope_um.abs(), epsilon = 1e-9);
            assert!(e.profile.form_um.abs() < 1e-9, "{n_w}×{n_z}: {e:?}");
            assert_relative_eq!(e.helix.slope_um, c * (hr.1 - hr.0) * 1e3, epsilon = 1e-9);
            assert_relative_eq!(e.helix.total_um, e.helix.slope_um.abs(), epsilon = 1e-9);
            assert!(e.helix.form_um.abs() < 1e-9, "{n_w}×{n_z}: {e:?}");
        }
    }

    #[test]
    fn hand_computed_trace() {
        let x: Vec<f64> = (0..=10).map(f64::from).collect();
        let f: Vec<f64> = x
            .iter()
            .map(|x| 0.2 * x + 0.05 * (x - 5.0).powi(2))
            .collect();
        let e = evaluate_trace(&x, &f, (0.0, 10.0)).unwrap();
        assert_relative_eq!(e.slope_um, 2.0, epsilon = 1e-12);
        assert_relative_eq!(e.form_um, 1.25, epsilon = 1e-12);
        assert_relative_eq!(e.total_um, 2.45, epsilon = 1e-12);
        assert!(evaluate_trace(&x, &f[..3], (0.0, 10.0)).is_err());
        assert!(evaluate_trace(&x, &f, (20.0, 30.0)).is_err());
    }

    /// Hand-computed flank: f = k·(w − 11) + c·z² on w ∈ [11, 23], z ∈ [−10, 10], m_n = 2.
    /// L_α = [11, 22.4] (95 %), L_β = [−9, 9] (min(5 % of 20, 2) = 1 mm per end).
    /// Profile at z = 0: linear ⇒ f_fα = 0, f_Hα = F_α = k·11.4. Helix at w = 16.7: parabola
    /// c·z² on [−9, 9] ⇒ f_Hβ = 0, F_β = 81c, f_fβ = 81c (residual range of a symmetric
    /// parabola = c·9² when the ends and the centre are samples).
    #[test]
    fn hand_computed_flank() {
        let grid = FlankGrid::new((11.0, 23.0), (-10.0, 10.0), 13, 21).unwrap();
        let (k, c) = (0.5e-3, 0.1e-3);
        let mut f = Vec::new();
        for i in 0..grid.n_w {
            for j in 0..grid.n_z {
                f.push(k * (grid.w_mm(i) - 11.0) + c * grid.z_mm(j).powi(2));
            }
        }
        let map = DeviationMap::new(grid, f).unwrap();
        let tol = tolerances(80.0, 2.0, 20.0, 6).unwrap();
        let e = map.evaluate(Some(tol), 2.0).unwrap();
        assert_eq!(e.profile.range_mm, (11.0, 22.4));
        assert_relative_eq!(e.helix.range_mm.0, -9.0, epsilon = 1e-12);
        assert_relative_eq!(e.profile.slope_um, 0.5 * 11.4, epsilon = 1e-9);
        assert_relative_eq!(e.profile.total_um, 0.5 * 11.4, epsilon = 1e-9);
        assert!(e.profile.form_um < 1e-9);
        assert!(e.helix.slope_um.abs() < 1e-9);
        assert_relative_eq!(e.helix.total_um, 8.1, epsilon = 1e-9);
        assert_relative_eq!(e.helix.form_um, 8.1, epsilon = 1e-9);
        // 5.7 ≤ 7.0, 5.7 ≤ 11, 8.1 ≤ 9.5, 8.1 ≤ 13 ⇒ class 6 passes; class 5 (f_fβT 6.5) fails
        assert_eq!(e.within_tolerance, Some(true));
        let e5 = map
            .evaluate(tolerances(80.0, 2.0, 20.0, 5).ok(), 2.0)
            .unwrap();
        assert_eq!(e5.within_tolerance, Some(false));
    }

    /// A twist f = k·(w − 16.7)·z (k = 1e-4 mm/mm²) on w ∈ [11, 23], z ∈ [−10, 10], m_n = 2:
    /// the single mid-face profile and mid-profile helix see nothing (f = 0 on both), three
    /// traces each see it. By hand: profiles at z = −9, 0, 9 (L_β ends and middle) have slope
    /// k·z·11.4 µm·10³ ⇒ f_Hα = ±10.26 µm, F_α = 10.26, f_fα = 0; helices at w = 11, 16.7,
    /// 22.4 have slope k·(w − 16.7)·18 ⇒ ±10.26 µm likewise. The class achieved is the smallest
    /// class whose f_Hα, F_α, f_Hβ, F_β limits exceed 10.26 µm.
    #[test]
    fn three_traces_see_a_twist() {
        let grid = FlankGrid::new((11.0, 23.0), (-10.0, 10.0), 13, 21).unwrap();
        let k = 1e-4;
        let mut f = Vec::new();
        for i in 0..grid.n_w {
            for j in 0..grid.n_z {
                f.push(k * (grid.w_mm(i) - 16.7) * grid.z_mm(j));
            }
        }
        let map = DeviationMap::new(grid, f).unwrap();
        let one = map
            .evaluate(tolerances(80.0, 2.0, 20.0, 6).ok(), 2.0)
            .unwrap();
        assert!(one.profile.total_um < 1e-9 && one.helix.total_um < 1e-9);
        let e = map.evaluate_traces(80.0, 2.0, 20.0, 6, 3).unwrap();
        let pos: Vec<f64> = e.profiles.iter().map(|t| t.at_mm).collect();
        assert_eq!(pos.len(), 3);
        assert_relative_eq!(pos[0], -9.0, epsilon = 1e-12);
        assert_relative_eq!(pos[2], 9.0, epsilon = 1e-12);
        assert_relative_eq!(e.helices[2].at_mm, 22.4, epsilon = 1e-12);
        assert_relative_eq!(e.profiles[0].trace.slope_um, -10.26, epsilon = 1e-9);
        assert_relative_eq!(e.profiles[2].trace.slope_um, 10.26, epsilon = 1e-9);
        assert!(e.profiles[1].trace.total_um < 1e-9);
        assert_relative_eq!(e.profile_worst.total_um, 10.26, epsilon = 1e-9);
        assert!(e.profile_worst.form_um < 1e-9);
        assert_relative_eq!(e.helices[0].trace.slope_um, -10.26, epsilon = 1e-9);
        assert_relative_eq!(e.helix_worst.total_um, 10.26, epsilon = 1e-9);
        let expect = (1..=11u8).find(|&c| {
            let t = tolerances(80.0, 2.0, 20.0, c).unwrap();
            t.f_h_alpha_t_um >= 10.26
                && t.total_alpha_t_um >= 10.26
                && t.f_h_beta_t_um >= 10.26
                && t.total_beta_t_um >= 10.26
        });
        assert_eq!(e.class_achieved, expect);
        assert!(expect.unwrap() > 6 && e.within_tolerance == Some(false));
        assert!(e.pitch.contains("not evaluated"));
        assert!(map.evaluate_traces(80.0, 2.0, 20.0, 6, 2).is_err());
    }

    /// Outside the standard's scope: no tolerances (deviations only), inside: the class's
    /// tolerances; a bad class or a non-finite size stays an error.
    #[test]
    fn tolerances_in_scope_separates_scope_from_bad_input() {
        assert_eq!(
            tolerances_in_scope(80.0, 2.0, 20.0, 6).unwrap(),
            Some(tolerances(80.0, 2.0, 20.0, 6).unwrap())
        );
        for (d, m, b) in [
            (80.0, 0.4, 20.0),
            (80.0, 2.0, 3.0),
            (16_000.0, 20.0, 200.0),
            (4.0, 0.5, 4.0),
        ] {
            assert_eq!(
                tolerances_in_scope(d, m, b, 6).unwrap(),
                None,
                "{d} {m} {b}"
            );
        }
        for (d, m, b, c) in [
            (80.0, 2.0, 20.0, 0),
            (80.0, 2.0, 20.0, 12),
            (f64::NAN, 2.0, 20.0, 6),
            (80.0, -2.0, 20.0, 6),
            (80.0, 2.0, f64::INFINITY, 6),
        ] {
            assert!(tolerances_in_scope(d, m, b, c).is_err(), "{d} {m} {b} {c}");
        }
    }
}
