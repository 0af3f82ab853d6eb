//! Topological (width-dependent) dressing: corrections ΔK(ν_zS) that vary with the worm's axial
//! position, the topological 4-point (15)–(17) and 3-point (22) solves at a contact-line
//! position, the dressing program over the worm width, and the dressed worm topology
//! f_nFS(w, b) as an interpolated grid (what generating grinding reads).

use crate::envelope::{DressingSetup, PointDressing};
use crate::error::{DressError, Result};
use crate::kinematics::AxisCorrection;
use crate::simulation::{SimResult, SimSpec};
use crate::solve::{newton, NewtonOptions};
use crate::worm::Flank;

// The schedules moved to `schedule` (read by `simulation`, which `topology` uses);
// re-exported so `topology::CorrectionSchedule` etc. keep working.
pub use crate::schedule::{CorrectionSchedule, PolynomialSchedule, TabulatedSchedule};
use serde::{Deserialize, Serialize};

/// A quantity given as a polynomial in the worm width position b (mm): Σ_k c_k b^k.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WidthPoly {
    /// Coefficients c_0, c_1, … (value at b = 0 first).
    pub coeffs: Vec<f64>,
}

impl WidthPoly {
    /// The same value at every width position.
    pub fn constant(v: f64) -> Self {
        Self { coeffs: vec![v] }
    }
    /// v(b) = v0 + slope·b.
    pub fn linear(v0: f64, slope_per_mm: f64) -> Self {
        Self {
            coeffs: vec![v0, slope_per_mm],
        }
    }
    /// Value at width position b (Horner).
    pub fn at(&self, b_mm: f64) -> f64 {
        self.coeffs.iter().rev().fold(0.0, |acc, c| acc * b_mm + c)
    }
    fn is_constant(&self) -> bool {
        self.coeffs.iter().skip(1).all(|c| *c == 0.0)
    }
}

/// Envelope point of roll distance w under constant ΔK and the width position where the
/// contact line crosses that roll distance at ν_zS = 0.
///
/// # Formula
/// b_BwFS(w; 0, ΔK) = b_ref(w) + p·t*(w) (t* the envelope time of the axial-section ray)
/// # Source
/// JP6903407B2, eq. (8) [SEED]
pub fn contact_point(
    setup: &DressingSetup,
    flank: Flank,
    w_mm: f64,
    dk: &AxisCorrection,
) -> Result<(PointDressing, f64)> {
    let d = setup.dress_point(flank, w_mm, dk)?;
    Ok((
        d,
        setup.worm.b_axial_section(flank, w_mm) + setup.worm.p_mm * d.t_rad,
    ))
}

/// Where the contact line at axial position ν_zS crosses the curve w(b) on the worm: the b
/// with b = b_BwFS(w(b); 0, ΔK) − ν_zS, and the envelope point there.
///
/// The contact line translates by −ν_zS along b under constant ΔK (screw motion). A constant
/// curve needs one evaluation; otherwise a secant iteration on h(b) = b − b_BwFS(w(b)) + ν
/// (it converges when the curve crosses the contact line, |db/dw · dw/db| ≠ 1).
fn crossing(
    setup: &DressingSetup,
    flank: Flank,
    curve: &WidthPoly,
    nu_zs_mm: f64,
    dk: &AxisCorrection,
    b_start_mm: f64,
) -> Result<(f64, PointDressing)> {
    if curve.is_constant() {
        let (d, bc) = contact_point(setup, flank, curve.at(0.0), dk)?;
        return Ok((bc - nu_zs_mm, d));
    }
    let h = |b: f64| -> Result<(f64, PointDressing)> {
        let (d, bc) = contact_point(setup, flank, curve.at(b), dk)?;
        Ok((b - bc + nu_zs_mm, d))
    };
    let (mut b0, mut b1) = (b_start_mm, b_start_mm + 1.0);
    let (mut h0, _) = h(b0)?;
    for _ in 0..40 {
        let (h1, d1) = h(b1)?;
        if h1.abs() < 1e-11 {
            return Ok((b1, d1));
        }
        let den = h1 - h0;
        if den == 0.0 || !den.is_finite() {
            break;
        }
        let next = b1 - h1 * (b1 - b0) / den;
        (b0, h0, b1) = (b1, h1, next);
    }
    Err(DressError::NoConvergence {
        what: "contact line crossing of a width-dependent curve w(b)",
        detail: format!("last b = {b1} mm, ν_zS = {nu_zs_mm} mm"),
    })
}

/// The quasi-static dressing of worm point (w, b) under ΔK(ν_zS).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct QuasiStatic {
    /// f_nFS(w, b) (mm).
    pub f_mm: f64,
    /// Dresser radius that dresses the point (mm).
    pub r_a_mm: f64,
    /// Axial position ν_zS at which the contact line passes the point (mm).
    pub nu_zs_mm: f64,
    /// ΔK(ν_zS) there.
    pub dk: AxisCorrection,
}

/// f_nFS(w, b) of a topologically dressed worm by the quasi-static model: the point receives the
/// profile that the constant correction ΔK(ν*) gives, ν* being the axial position at which the
/// contact line passes the point.
///
/// Exact to first order in dΔK/dν_zS: writing the vector end as S(t, ΔK(p t)), its minimum over t
/// differs from min_t S(t, ΔK(ν*)) by −(∂S/∂ΔK·dΔK/dt)²/(2 S_tt) (second order), S_tt =
/// g_tt/|g_s| being the curvature of the entry depth over time at the envelope.
///
/// # Formula
/// ν* = b_BwFS(w; 0, ΔK(ν*)) − b (fixed point, secant), f = f_nFS(w; ΔK(ν*))
/// # Source
/// JP6903407B2, eqs. (15)–(17), Fig. 2 [SEED]; quasi-static model docs/dressing.md "Derivation: topological programs" [RECONSTRUCTED]
pub fn quasi_static_point<S: CorrectionSchedule + ?Sized>(
    setup: &DressingSetup,
    flank: Flank,
    w_mm: f64,
    b_mm: f64,
    schedule: &S,
) -> Result<QuasiStatic> {
    let g = |nu: f64| -> Result<(f64, PointDressing, AxisCorrection)> {
        let dk = schedule.at(nu);
        let (d, bc) = contact_point(setup, flank, w_mm, &dk)?;
        Ok((bc - b_mm - nu, d, dk))
    };
    // Under a constant ΔK the fixed point is reached in one step: start there.
    let (mut n0, mut r0) = (0.0, g(0.0)?.0);
    let mut n1 = r0;
    for _ in 0..60 {
        let (r1, d, dk) = g(n1)?;
        if r1.abs() < 1e-10 {
            return Ok(QuasiStatic {
                f_mm: d.f_mm,
                r_a_mm: d.r_a_mm,
                nu_zs_mm: n1,
                dk,
            });
        }
        let den = r1 - r0;
        if den == 0.0 || !den.is_finite() {
            break;
        }
        let next = n1 - r1 * (n1 - n0) / den;
        (n0, r0, n1) = (n1, r1, next);
    }
    Err(DressError::NoConvergence {
        what: "axial position of the contact line through a worm point",
        detail: format!("w = {w_mm} mm, b = {b_mm} mm"),
    })
}

/// The topological 4-point problem (15)–(17): f_i(b) hit on four curves w_i(b), the contact line
/// passing through (w_0, b_0).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TopoFourPoint {
    /// Flank to dress.
    pub flank: Flank,
    /// Curves w_FSi(b) on which the modification is prescribed (mm).
    pub w_mm: [WidthPoly; 4],
    /// Targets f_FSi(b) (mm, > 0 = material left).
    pub f_mm: [WidthPoly; 4],
    /// Roll distance w_0 of the reference point of the contact line (mm).
    pub w0_mm: f64,
}

/// The topological 3-point problem with width-dependent radius association (22).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TopoThreePoint {
    /// Flank to dress.
    pub flank: Flank,
    /// Curves w_FSi(b) (mm).
    pub w_mm: [WidthPoly; 3],
    /// Targets f_FSi(b) (mm).
    pub f_mm: [WidthPoly; 3],
    /// Worm roll distance that the dresser radius r_A(b) must dress, w(r_FS(b)) (mm).
    pub w_assoc_mm: WidthPoly,
    /// Dresser radius r_FA(b) (mm).
    pub r_a_mm: WidthPoly,
    /// Roll distance w_0 of the reference point of the contact line (mm).
    pub w0_mm: f64,
}

/// A solved contact-line position of a topological dressing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TopoSolution {
    /// Width position b_0 of the reference point (mm).
    pub b0_mm: f64,
    /// Worm axial position ν_zS (mm).
    pub nu_zs_mm: f64,
    /// Axis corrections ΔK.
    pub dk: AxisCorrection,
    /// Width positions b_i where the contact line crosses the curves (4; or 3 + association).
    pub b_mm: Vec<f64>,
    /// All 9 residuals: profile (or association) residuals, crossing residuals b_i −
    /// b_BwFS(w_i(b_i); ν_zS, ΔK), and b_0 − b_BwFS(w_0; ν_zS, ΔK) (mm).
    pub residual_mm: Vec<f64>,
    /// Newton iterations.
    pub iterations: usize,
    /// Condition number of the equilibrated 4×4 Jacobian of the reduced system.
    pub cond: f64,
}

/// One evaluation of a topological system: reduced residuals, crossings, ν_zS, full residuals.
struct TopoEval {
    reduced: Vec<f64>,
    b: Vec<f64>,
    nu: f64,
    full: Vec<f64>,
}

/// The four (reduced) residuals of a topological system at ΔK; the five contact-line equations
/// are solved exactly for (ν_zS, b_1..b_4) inside.
fn topo_eval(
    setup: &DressingSetup,
    flank: Flank,
    w0_mm: f64,
    b0_mm: f64,
    curves: &[(&WidthPoly, Target<'_>)],
    dk: &AxisCorrection,
) -> Result<TopoEval> {
    let (_, bc0) = contact_point(setup, flank, w0_mm, dk)?;
    let nu = bc0 - b0_mm;
    let mut reduced = Vec::with_capacity(curves.len());
    let mut b = Vec::with_capacity(curves.len());
    let mut cross = Vec::with_capacity(curves.len());
    for (curve, target) in curves {
        let (bi, d) = crossing(setup, flank, curve, nu, dk, b0_mm)?;
        reduced.push(match target {
            Target::Profile(f) => d.f_mm - f.at(bi),
            Target::Radius(r) => d.r_a_mm - r.at(bi),
        });
        let (_, bci) = contact_point(setup, flank, curve.at(bi), dk)?;
        cross.push(bi - (bci - nu));
        b.push(bi);
    }
    let (_, bc0_check) = contact_point(setup, flank, w0_mm, dk)?;
    let mut full = reduced.clone();
    full.extend(cross);
    full.push(b0_mm - (bc0_check - nu));
    Ok(TopoEval {
        reduced,
        b,
        nu,
        full,
    })
}

/// What a curve must satisfy.
#[derive(Clone, Copy)]
enum Target<'a> {
    /// f_nFS(w(b), b) = f(b).
    Profile(&'a WidthPoly),
    /// r_FA(w(b)) = r(b) (radius association (22)).
    Radius(&'a WidthPoly),
}

fn topo_solve(
    setup: &DressingSetup,
    flank: Flank,
    w0_mm: f64,
    b0_mm: f64,
    curves: &[(&WidthPoly, Target<'_>)],
    start: AxisCorrection,
    opts: &NewtonOptions,
) -> Result<TopoSolution> {
    DressError::check("b0_mm", b0_mm, -1e4, 1e4)?;
    let sol = newton(
        setup,
        |dk| topo_eval(setup, flank, w0_mm, b0_mm, curves, dk).map(|e| e.reduced),
        start,
        opts,
    )?;
    let e = topo_eval(setup, flank, w0_mm, b0_mm, curves, &sol.dk)?;
    Ok(TopoSolution {
        b0_mm,
        nu_zs_mm: e.nu,
        dk: sol.dk,
        b_mm: e.b,
        residual_mm: e.full,
        iterations: sol.iterations,
        cond: sol.cond,
    })
}

/// Solves the topological 4-point system at the contact-line position through (w_0, b_0).
///
/// The 9 unknowns (ΔK, ν_zS, b_1..b_4) are reduced to ΔK exactly: under constant ΔK the
/// contact line translates by −ν_zS, so ν_zS = b_BwFS(w_0; 0, ΔK) − b_0 and each b_i solves
/// b_i = b_BwFS(w_i(b_i); 0, ΔK) − ν_zS; the remaining four equations go to the damped Newton of
/// [`newton`] (minimum-norm, since the single-flank 4-point problem is rank-deficient).
///
/// # Formula
/// e_i = f_nFS(w_i(b_i); ΔK) − f_i(b_i), e_{4+i} = b_i − b_BwFS(w_i(b_i); ν_zS, ΔK),
/// e_9 = b_0 − b_BwFS(w_0; ν_zS, ΔK), i = 1..4
/// # Source
/// JP6903407B2, eqs. (15)–(17), Fig. 2 [SEED]; 9-component system docs/dressing.md "Derivation: topological programs"
/// [RECONSTRUCTED]; docs/dressing.md "Derivation: minimum-norm 4-point solve" [RECONSTRUCTED]
pub fn solve_topological_four_point(
    setup: &DressingSetup,
    p: &TopoFourPoint,
    b0_mm: f64,
    start: AxisCorrection,
    opts: &NewtonOptions,
) -> Result<TopoSolution> {
    let curves: Vec<(&WidthPoly, Target<'_>)> = p
        .w_mm
        .iter()
        .zip(p.f_mm.iter())
        .map(|(w, f)| (w, Target::Profile(f)))
        .collect();
    topo_solve(setup, p.flank, p.w0_mm, b0_mm, &curves, start, opts)
}

/// Solves the topological 3-point system with the width-dependent radius association (22) at
/// the contact-line position through (w_0, b_0); the reduction is that of
/// [`solve_topological_four_point`].
///
/// # Formula
/// e_i = f_nFS(w_i(b_i); ΔK) − f_i(b_i) (i = 1..3), e_4 = r_FA(w_a(b_a); ΔK) − r_A(b_a), plus
/// the crossing equations of b_1..b_3, b_a and of b_0
/// # Source
/// JP6903407B2, eq. (22), Fig. 3 [SEED]; docs/dressing.md "Derivation: topological programs" [RECONSTRUCTED]
pub fn solve_topological_three_point(
    setup: &DressingSetup,
    p: &TopoThreePoint,
    b0_mm: f64,
    start: AxisCorrection,
    opts: &NewtonOptions,
) -> Result<TopoSolution> {
    let mut curves: Vec<(&WidthPoly, Target<'_>)> = p
        .w_mm
        .iter()
        .zip(p.f_mm.iter())
        .map(|(w, f)| (w, Target::Profile(f)))
        .collect();
    curves.push((&p.w_assoc_mm, Target::Radius(&p.r_a_mm)));
    topo_solve(setup, p.flank, p.w0_mm, b0_mm, &curves, start, opts)
}

/// A dressing program over the worm width: the solved positions and ΔK(ν_zS) through them.
#[derive(Debug, Clone)]
pub struct TopoProgram {
    /// One solution per contact-line position, in the order solved.
    pub solutions: Vec<TopoSolution>,
    /// ΔK(ν_zS) interpolated through the solutions.
    pub schedule: TabulatedSchedule,
}

/// Sweeps the contact-line reference point over `b0s_mm` with continuation (each solve starts
/// from the previous ΔK) and tabulates ΔK(ν_zS).
///
/// # Source
/// docs/dressing.md "Derivation: topological programs" (dressing program) [RECONSTRUCTED]; JP6903407B2, eqs. (15)–(17) [SEED]
pub fn topological_program<F>(
    b0s_mm: &[f64],
    start: AxisCorrection,
    solve: F,
) -> Result<TopoProgram>
where
    F: Fn(f64, AxisCorrection) -> Result<TopoSolution>,
{
    let mut solutions = Vec::with_capacity(b0s_mm.len());
    let mut prev = start;
    for &b0 in b0s_mm {
        let s = solve(b0, prev)?;
        prev = s.dk;
        solutions.push(s);
    }
    let nodes: Vec<(f64, AxisCorrection)> = solutions.iter().map(|s| (s.nu_zs_mm, s.dk)).collect();
    Ok(TopoProgram {
        schedule: TabulatedSchedule::new(&nodes)?,
        solutions,
    })
}

/// A dressed worm flank as a grid f_nFS(w, b) with bilinear interpolation: what a topologically
/// dressed worm hands to generating grinding.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WormTopology {
    /// Flank.
    pub flank: Flank,
    /// Roll distances of the rows, strictly increasing (mm).
    pub w_mm: Vec<f64>,
    /// Width positions of the columns, strictly increasing (mm).
    pub b_mm: Vec<f64>,
    /// f_nFS per grid point, row-major [i_w · n_b + i_b] (mm, > 0 = material left).
    pub f_mm: Vec<f64>,
}

fn increasing(field: &'static str, v: &[f64]) -> Result<()> {
    if v.len() < 2 {
        return Err(DressError::OutOfRange {
            field,
            value: v.len() as f64,
            min: 2.0,
            max: f64::INFINITY,
        });
    }
    if v.iter().any(|x| !x.is_finite()) || v.windows(2).any(|p| p[1] <= p[0]) {
        return Err(DressError::Geometry(format!(
            "{field} must be finite and strictly increasing"
        )));
    }
    Ok(())
}

impl WormTopology {
    /// Grid from explicit values (row-major, n_w × n_b).
    pub fn new(flank: Flank, w_mm: Vec<f64>, b_mm: Vec<f64>, f_mm: Vec<f64>) -> Result<Self> {
        increasing("w_mm", &w_mm)?;
        increasing("b_mm", &b_mm)?;
        if f_mm.len() != w_mm.len() * b_mm.len() {
            return Err(DressError::OutOfRange {
                field: "f_mm (count)",
                value: f_mm.len() as f64,
                min: (w_mm.len() * b_mm.len()) as f64,
                max: (w_mm.len() * b_mm.len()) as f64,
            });
        }
        Ok(Self {
            flank,
            w_mm,
            b_mm,
            f_mm,
        })
    }

    /// The worm left by a full simulation (grid of `spec`, final vector ends).
    pub fn from_simulation(spec: &SimSpec, result: &SimResult) -> Result<Self> {
        let f: Vec<f64> = result.f_mm.iter().flatten().copied().collect();
        Self::new(spec.flank, spec.w_mm.clone(), spec.b_mm.clone(), f)
    }

    /// The worm by the quasi-static model ([`quasi_static_point`]) on a grid: fast, exact to
    /// first order in dΔK/dν_zS.
    pub fn quasi_static<S: CorrectionSchedule + ?Sized>(
        setup: &DressingSetup,
        flank: Flank,
        w_mm: Vec<f64>,
        b_mm: Vec<f64>,
        schedule: &S,
    ) -> Result<Self> {
        increasing("w_mm", &w_mm)?;
        increasing("b_mm", &b_mm)?;
        let mut f = Vec::with_capacity(w_mm.len() * b_mm.len());
        for &w in &w_mm {
            for &b in &b_mm {
                f.push(quasi_static_point(setup, flank, w, b, schedule)?.f_mm);
            }
        }
        Self::new(flank, w_mm, b_mm, f)
    }

    /// f_nFS(w, b) by bilinear interpolation (mm); outside the grid an error names the axis.
    ///
    /// # Formula
    /// f = (1−u)(1−v) f_00 + u(1−v) f_10 + (1−u) v f_01 + u v f_11 in the cell containing (w, b)
    pub fn f_at(&self, w_mm: f64, b_mm: f64) -> Result<f64> {
        let (i, u) = cell("w_mm", &self.w_mm, w_mm)?;
        let (j, v) = cell("b_mm", &self.b_mm, b_mm)?;
        let nb = self.b_mm.len();
        let f = |a: usize, b: usize| self.f_mm[a * nb + b];
        Ok((1.0 - u) * (1.0 - v) * f(i, j)
            + u * (1.0 - v) * f(i + 1, j)
            + (1.0 - u) * v * f(i, j + 1)
            + u * v * f(i + 1, j + 1))
    }
}

/// Cell index and local coordinate of x in the strictly increasing knots xs.
fn cell(field: &'static str, xs: &[f64], x: f64) -> Result<(usize, f64)> {
    let n = xs.len();
    DressError::check(field, x, xs[0], xs[n - 1])?;
    let i = xs.partition_point(|v| *v <= x).clamp(1, n - 1) - 1;
    Ok((i, (x - xs[i]) / (xs[i + 1] - xs[i])))
}
