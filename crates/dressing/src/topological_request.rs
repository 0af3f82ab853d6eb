//! A topological `[solve.topological]` request as the operator states it (the `gearcomp dress`
//! TOML keys, in mm and µm): validated, solved as a 3- or 4-point program over the worm width
//! (docs/dressing.md "Derivation: topological programs"), every position checked against the
//! clearance budget, and the dressed worm f_nFS(w, b) tabulated by the quasi-static model.
//!
//! Every error names the TOML keys the user wrote.

use crate::envelope::DressingSetup;
use crate::error::{DressError, Result};
use crate::kinematics::AxisCorrection;
use crate::request::{check_key, Checks, Method, SolveInput};
use crate::solve::{tip_association_radius_mm, NewtonOptions, CROWNING_FRACTIONS};
use crate::topology::{
    solve_topological_four_point, solve_topological_three_point, topological_program,
    TopoFourPoint, TopoProgram, TopoThreePoint, WidthPoly, WormTopology,
};
use crate::worm::{Flank, Worm};
use serde::{Deserialize, Serialize};

/// Most positions a program may have (each is a Newton solve).
pub const TOPO_MAX_POSITIONS: usize = 200;

/// `[solve.topological]`: the solve repeated at contact-line positions over the worm width.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TopologicalInput {
    /// `positions`: number of contact-line positions (≥ 2).
    pub positions: usize,
    /// `b_range_mm`: width range [b_start, b_end] (mm) swept by the reference point (mid
    /// profile).
    pub b_range_mm: [f64; 2],
    /// `crowning_slope_um_per_mm`, 3-point: crowning slope over b (µm/mm); c(b) =
    /// crowning_um + slope·b.
    pub crowning_slope_um_per_mm: Option<f64>,
    /// `crowning_table`, 3-point: crowning as a table [[b mm, c µm], …], linear between, held
    /// beyond the ends.
    pub crowning_table: Option<Vec<[f64; 2]>>,
}

/// Crowning c(b) of a topological 3-point program (µm): constant, linear or a table.
#[derive(Debug, Clone, PartialEq)]
pub enum CrowningOverWidth {
    /// c(b) = c0 + slope·b.
    Linear {
        /// c at b = 0 (µm).
        c0_um: f64,
        /// dc/db (µm/mm).
        slope_um_per_mm: f64,
    },
    /// [[b mm, c µm], …], b strictly increasing.
    Table(Vec<[f64; 2]>),
}

impl CrowningOverWidth {
    /// c(b) and dc/db at b (µm, µm/mm); the table is linear per segment, held beyond its ends.
    pub fn at(&self, b_mm: f64) -> (f64, f64) {
        match self {
            Self::Linear {
                c0_um,
                slope_um_per_mm,
            } => (c0_um + slope_um_per_mm * b_mm, *slope_um_per_mm),
            Self::Table(t) => {
                let n = t.len();
                if b_mm <= t[0][0] {
                    return (t[0][1], 0.0);
                }
                if b_mm >= t[n - 1][0] {
                    return (t[n - 1][1], 0.0);
                }
                let i = t.partition_point(|r| r[0] <= b_mm).clamp(1, n - 1) - 1;
                let slope = (t[i + 1][1] - t[i][1]) / (t[i + 1][0] - t[i][0]);
                (t[i][1] + slope * (b_mm - t[i][0]), slope)
            }
        }
    }
    /// The crowning near b as a polynomial in b (mm): the tangent line there.
    pub fn local_poly_mm(&self, b_mm: f64) -> WidthPoly {
        let (c, s) = self.at(b_mm);
        WidthPoly::linear(1e-3 * (c - s * b_mm), 1e-3 * s)
    }
}

/// A solved topological request.
#[derive(Debug, Clone)]
pub struct TopologicalOutcome {
    /// The flank dressed.
    pub flank: Flank,
    /// The solutions per position and ΔK(ν_zS) through them.
    pub program: TopoProgram,
    /// The budget check of each solution, in the order of `program.solutions`.
    pub checks: Vec<Checks>,
    /// Roll distances of the target curves (mm), constant over the width.
    pub target_w_mm: Vec<f64>,
    /// The crowning over the width (3-point), `None` for 4-point.
    pub crowning: Option<CrowningOverWidth>,
    /// Quasi-static worm topology: roll distances (rows, mm).
    pub map_w_mm: Vec<f64>,
    /// Width positions (columns, mm).
    pub map_b_mm: Vec<f64>,
    /// f_nFS(w, b) (mm), row-major [i_w][i_b].
    pub map_f_mm: Vec<f64>,
}

fn refuse<T>(message: String) -> Result<T> {
    Err(DressError::Request(message))
}

fn crowning_over_width(solve: &SolveInput, topo: &TopologicalInput) -> Result<CrowningOverWidth> {
    match (&topo.crowning_table, topo.crowning_slope_um_per_mm) {
        (Some(_), Some(_)) => refuse(
            "[solve.topological] give either crowning_table or crowning_slope_um_per_mm, not both"
                .into(),
        ),
        (Some(t), None) => {
            if t.len() < 2 {
                return refuse(format!(
                    "[solve.topological] crowning_table has {} rows, allowed range 2 ..= 1000",
                    t.len()
                ));
            }
            for (i, r) in t.iter().enumerate() {
                if !r[0].is_finite() || r[0].abs() > 1e4 || !r[1].is_finite() || r[1].abs() > 50.0 {
                    return refuse(format!("[solve.topological] crowning_table row {i} = {r:?}: b must be within ±10000 mm and c within ±50 µm"));
                }
                if i > 0 && r[0] <= t[i - 1][0] {
                    return refuse(format!("[solve.topological] crowning_table row {i}: b = {} mm must exceed the previous row's {} mm", r[0], t[i - 1][0]));
                }
            }
            Ok(CrowningOverWidth::Table(t.clone()))
        }
        (None, slope) => {
            let c0 = solve.crowning_um.unwrap_or(0.0);
            let s = slope.unwrap_or(0.0);
            if !s.is_finite() || s.abs() > 10.0 {
                return refuse(format!("[solve.topological] crowning_slope_um_per_mm = {s} is outside the allowed range -10 ..= 10"));
            }
            Ok(CrowningOverWidth::Linear {
                c0_um: c0,
                slope_um_per_mm: s,
            })
        }
    }
}

/// Solves `[solve]` with `[solve.topological]` on `setup` (the worm at `[solve] diameter_mm`,
/// `design` the new worm): the 3-point program (targets (0, −c(b), 0) at
/// [`CROWNING_FRACTIONS`] of the active profile, the tip radius association of the new worm)
/// or the 4-point program (constant targets `[solve] points`), each position checked against
/// `[solve] budget_mm`, and the dressed worm over the swept width.
/// `contact_point_given`: whether `[solve] contact_point` was written (it excludes a program).
pub fn solve_topological_request(
    solve: &SolveInput,
    topo: &TopologicalInput,
    contact_point_given: bool,
    design: &Worm,
    setup: &DressingSetup,
) -> Result<TopologicalOutcome> {
    if !(2..=TOPO_MAX_POSITIONS).contains(&topo.positions) {
        return refuse(format!(
            "[solve.topological] positions = {} is outside the allowed range 2 ..= {TOPO_MAX_POSITIONS}",
            topo.positions
        ));
    }
    let [b_lo, b_hi] = topo.b_range_mm;
    if !b_lo.is_finite()
        || !b_hi.is_finite()
        || b_lo.abs() > 1e4
        || b_hi.abs() > 1e4
        || b_hi <= b_lo
    {
        return refuse(format!(
            "[solve.topological] b_range_mm = [{b_lo}, {b_hi}]: need -10000 <= start < end <= 10000 (mm)"
        ));
    }
    check_key("[solve] budget_mm", solve.budget_mm, 0.0, 5.0, "mm")?;
    if contact_point_given {
        return refuse("[solve] contact_point and [solve.topological] exclude each other: the program sets the contact line positions".into());
    }
    let fl = solve.flank;
    let (w_nf, w_na) = setup.active_profile(fl)?;
    let at = |q: f64| w_nf + q * (w_na - w_nf);
    let w0 = at(0.5);
    let n = topo.positions;
    let b0s: Vec<f64> = (0..n)
        .map(|i| b_lo + (b_hi - b_lo) * i as f64 / (n - 1) as f64)
        .collect();
    let k0 = AxisCorrection::default();
    let opts = NewtonOptions::default();
    let program_error = |e: DressError| {
        e.during("not producible ([solve.topological]): the program over b_range_mm")
    };
    let (program, target_w, crowning) = match solve.method {
        Method::ThreePoint => {
            if solve.points.is_some() {
                return refuse("[solve.topological] three-point takes its targets from crowning_um / crowning_slope_um_per_mm / crowning_table, not from points".into());
            }
            let cw = crowning_over_width(solve, topo)?;
            for &b in &b0s {
                let cb = cw.at(b).0;
                if cb.abs() > 50.0 {
                    return refuse(format!("[solve.topological] crowning at b = {b} mm is {cb} um, outside the allowed range -50 ..= 50"));
                }
            }
            // The dresser radius that dresses the tip circle of the new worm keeps doing so.
            let r_tip = tip_association_radius_mm(design, &setup.dresser, fl)?;
            let ws = CROWNING_FRACTIONS.map(at);
            let prog = topological_program(&b0s, k0, |b0, start| {
                let cb = cw.local_poly_mm(b0);
                let neg: Vec<f64> = cb.coeffs.iter().map(|v| -v).collect();
                let p = TopoThreePoint {
                    flank: fl,
                    w_mm: [
                        WidthPoly::constant(ws[0]),
                        WidthPoly::constant(ws[1]),
                        WidthPoly::constant(ws[2]),
                    ],
                    f_mm: [
                        WidthPoly::constant(0.0),
                        WidthPoly { coeffs: neg },
                        WidthPoly::constant(0.0),
                    ],
                    w_assoc_mm: WidthPoly::constant(w_na),
                    r_a_mm: WidthPoly::constant(r_tip),
                    w0_mm: w0,
                };
                solve_topological_three_point(setup, &p, b0, start, &opts)
            })
            .map_err(program_error)?;
            (prog, ws.to_vec(), Some(cw))
        }
        Method::FourPoint => {
            if topo.crowning_table.is_some() || topo.crowning_slope_um_per_mm.is_some() {
                return refuse("[solve.topological] four-point takes constant targets from [solve] points; crowning_table / crowning_slope_um_per_mm are for three-point".into());
            }
            let Some(points) = &solve.points else {
                return refuse("[solve] four-point needs `points` (4 of them)".into());
            };
            if points.len() != 4 {
                return refuse(format!(
                    "[solve] four-point needs 4 points, got {}",
                    points.len()
                ));
            }
            for p in points {
                if !(0.0..=1.0).contains(&p[0]) || !p[1].is_finite() || p[1].abs() > 1000.0 {
                    return refuse(format!(
                        "[solve] point {:?}: fraction must be in 0..=1 and f within ±1000 µm",
                        p
                    ));
                }
            }
            let ws: Vec<f64> = points.iter().map(|p| at(p[0])).collect();
            let prog = topological_program(&b0s, k0, |b0, start| {
                let p = TopoFourPoint {
                    flank: fl,
                    w_mm: [0, 1, 2, 3].map(|i| WidthPoly::constant(ws[i])),
                    f_mm: [0, 1, 2, 3].map(|i| WidthPoly::constant(points[i][1] * 1e-3)),
                    w0_mm: w0,
                };
                solve_topological_four_point(setup, &p, b0, start, &opts)
            })
            .map_err(program_error)?;
            (prog, ws, None)
        }
    };
    let mut checks = Vec::with_capacity(n);
    for s in &program.solutions {
        // The penetration check of `dress plan`, per position.
        let ck = Checks::of(setup, fl, &s.dk, solve.budget_mm)?;
        if !ck.ok() && !solve.accept_penetration {
            return Err(DressError::NotProducible {
                key: "[solve.topological]".into(),
                detail: format!(
                    "at b0 = {:.3} mm the dresser cuts {:.1} µm into the opposite flank and its jacket reaches {:.1} µm below the worm root circle; [solve] budget_mm = {} mm ({:.0} µm) is exceeded. Reduce the crowning or its slope, or set [solve] accept_penetration = true to output the program anyway (flagged)",
                    s.b0_mm,
                    1e3 * ck.opposite_cut_mm,
                    1e3 * ck.jacket_depth_mm,
                    solve.budget_mm,
                    1e3 * solve.budget_mm
                ),
            });
        }
        checks.push(ck);
    }
    // The dressed worm by the quasi-static model over the swept width.
    let map_w: Vec<f64> = (0..=10).map(|i| at(f64::from(i) / 10.0)).collect();
    let nb = (2 * n - 1).clamp(3, 41);
    let map_b: Vec<f64> = (0..nb)
        .map(|j| b_lo + (b_hi - b_lo) * j as f64 / (nb - 1) as f64)
        .collect();
    let topology =
        WormTopology::quasi_static(setup, fl, map_w.clone(), map_b.clone(), &program.schedule)?;
    Ok(TopologicalOutcome {
        flank: fl,
        program,
        checks,
        target_w_mm: target_w,
        crowning,
        map_w_mm: map_w,
        map_b_mm: map_b,
        map_f_mm: topology.f_mm,
    })
}
