//! Solvers for the axis corrections ΔK: 3-point with radius association, 4-point (minimum
//! norm), weighted least-squares curve fitting; damped Newton with natural-monotonicity test.

use crate::envelope::DressingSetup;
use crate::error::{DressError, Result};
use crate::kinematics::AxisCorrection;
use crate::worm::Flank;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// Options of the damped Newton / Gauss–Newton iteration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NewtonOptions {
    /// Largest number of iterations.
    pub max_iter: usize,
    /// Stop when max |F| is below this (mm).
    pub tol_mm: f64,
    /// When the iteration stalls (no damped step passes the monotonicity test, or the
    /// iteration limit is reached), a max |F| below this (mm) is still a root: at ΔK of
    /// millimetres or degrees the evaluation noise floor is ≈ 1e-7 mm (docs/dressing.md "Derivation: Newton damping and scaling"), far below
    /// any profile deviation a gear maker measures. Larger residuals are "not producible".
    #[serde(default = "default_stall_tol_mm")]
    pub stall_tol_mm: f64,
    /// Central-difference step in scaled unknowns (mm of normal effect).
    pub fd_step_mm: f64,
    /// Tikhonov parameter relative to the largest singular value of the equilibrated Jacobian.
    pub mu_rel: f64,
    /// Smallest damping factor before the solver declares "no root".
    pub lambda_min: f64,
    /// Box |ΔK| ≤ (rad, rad, mm, mm) outside which no root is searched; the two lengths are
    /// for m_n ≤ 3 mm and are multiplied by m_n / 3 mm above.
    pub box_limits: [f64; 4],
}

fn default_stall_tol_mm() -> f64 {
    1e-6
}

impl Default for NewtonOptions {
    fn default() -> Self {
        Self {
            max_iter: 40,
            tol_mm: 1e-9,
            stall_tol_mm: default_stall_tol_mm(),
            fd_step_mm: 2e-5,
            mu_rel: 1e-7,
            lambda_min: 1e-6,
            box_limits: [2.0, 0.2, 3.0, 30.0],
        }
    }
}

/// A converged solve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Solution {
    /// The axis corrections found.
    pub dk: AxisCorrection,
    /// Newton iterations used.
    pub iterations: usize,
    /// Residuals at the solution (mm; the association residual in mm of radius).
    pub residual_mm: Vec<f64>,
    /// Condition number of the column-equilibrated Jacobian at the last iteration.
    pub cond: f64,
}

/// Scale of each unknown in mm of normal effect: (r_b cos β_b, d_A/2, 1, 1).
///
/// # Source
/// docs/dressing.md "Derivation: minimum-norm 4-point solve", docs/dressing.md "Derivation: Newton damping and scaling" (unknowns in mm of normal effect) [RECONSTRUCTED]
pub fn unknown_scale(setup: &DressingSetup) -> [f64; 4] {
    [
        setup.worm.r_b_mm * setup.worm.beta_b_rad.cos(),
        setup.dresser.spec.d_a_mm / 2.0,
        1.0,
        1.0,
    ]
}

/// Solves F(ΔK) = 0 (or min ‖F‖ when F has more components than 4) from `start`.
///
/// Unknowns in mm of normal effect, column-equilibrated central-difference Jacobian,
/// Tikhonov-filtered step Δx = −Σ σ_i/(σ_i² + μ²)(u_iᵀF) v_i with μ = μ_rel σ_max (minimum-norm
/// answer for the rank-deficient 4-point problem), and Deuflhard's natural-monotonicity test:
/// accept λ when ‖Δx̄(λ)‖ ≤ (1 − λ/4)‖Δx‖, else λ ← min(λ/2, ‖Δx‖λ²/(2‖Δx̄ − (1 − λ)Δx‖)).
///
/// # Source
/// JP6903407B2, four-point method, eqs. (11), (12), Newton on F_FS4 [SEED]; damping, scaling and
/// filtering docs/dressing.md "Derivation: minimum-norm 4-point solve", docs/dressing.md "Derivation: Newton damping and scaling" [RECONSTRUCTED] after Deuflhard, Newton Methods for Nonlinear Problems (2004), NLEQ1
pub fn newton<F>(
    setup: &DressingSetup,
    residual: F,
    start: AxisCorrection,
    opts: &NewtonOptions,
) -> Result<Solution>
where
    F: Fn(&AxisCorrection) -> Result<Vec<f64>>,
{
    let scale = unknown_scale(setup);
    let to_dk = |x: &DVector<f64>| {
        AxisCorrection::from_array([
            x[0] / scale[0],
            x[1] / scale[1],
            x[2] / scale[2],
            x[3] / scale[3],
        ])
    };
    // The box's lengths (Δd, Δν_yA) are set for module ≤ 3 mm and grow with m_n above it, so
    // a worm scaled by k keeps its k-scaled root inside (the angles are scale-free).
    let len_k = (setup.worm.m_n_mm / 3.0).max(1.0);
    let limits = [
        opts.box_limits[0],
        opts.box_limits[1],
        opts.box_limits[2] * len_k,
        opts.box_limits[3] * len_k,
    ];
    let in_box = |x: &DVector<f64>| {
        let a = to_dk(x).to_array();
        a.iter().zip(limits.iter()).all(|(v, l)| v.abs() <= *l)
    };
    let s0 = start.to_array();
    let mut x = DVector::from_iterator(4, (0..4).map(|i| s0[i] * scale[i]));
    let eval = |x: &DVector<f64>| -> Result<DVector<f64>> {
        let v = residual(&to_dk(x))?;
        if v.iter().any(|r| !r.is_finite()) {
            return Err(DressError::NoConvergence {
                what: "residual",
                detail: "non-finite value".into(),
            });
        }
        Ok(DVector::from_vec(v))
    };
    let max_abs = |v: &DVector<f64>| v.iter().fold(0.0f64, |m, r| m.max(r.abs()));
    let mut f = eval(&x)?;
    // (‖Δx‖, λ, Δx̄) of the last accepted step, for the damping predictor.
    let mut prev: Option<(f64, f64, DVector<f64>)> = None;
    // Central-difference Jacobian at x, column-equilibrated: (J·diag(1/c), c).
    let equilibrated_jacobian = |x: &DVector<f64>, m: usize| -> Result<(DMatrix<f64>, [f64; 4])> {
        let mut jac = DMatrix::zeros(m, 4);
        for j in 0..4 {
            let mut xp = x.clone();
            let mut xm = x.clone();
            xp[j] += opts.fd_step_mm;
            xm[j] -= opts.fd_step_mm;
            let col = (eval(&xp)? - eval(&xm)?) / (2.0 * opts.fd_step_mm);
            jac.set_column(j, &col);
        }
        let mut cscale = [1.0; 4];
        for (j, c) in cscale.iter_mut().enumerate() {
            let n = jac.column(j).norm();
            *c = if n > 0.0 { n } else { 1.0 };
        }
        for (j, c) in cscale.iter().enumerate() {
            jac.column_mut(j).scale_mut(1.0 / c);
        }
        Ok((jac, cscale))
    };
    let mut cond = f64::NAN;
    for it in 0..opts.max_iter {
        if max_abs(&f) < opts.tol_mm {
            if it == 0 {
                // Converged at the start (e.g. an unmodified profile, ΔK = 0): no step was
                // taken, so the condition is that of the Jacobian here (it was NaN, printed
                // "cond NaN" and `"condition": null`).
                let (je, _) = equilibrated_jacobian(&x, f.len())?;
                let sig = gearcomp_linalg::singular_values(&je).map_err(|e| {
                    DressError::NoConvergence {
                        what: "SVD of the Jacobian",
                        detail: e.to_string(),
                    }
                })?;
                let smax = sig.iter().fold(0.0f64, |a, &b| a.max(b));
                let smin = sig.iter().fold(f64::INFINITY, |a, &b| a.min(b));
                cond = smax / smin;
            }
            return Ok(Solution {
                dk: to_dk(&x),
                iterations: it,
                residual_mm: f.iter().copied().collect(),
                cond,
            });
        }
        let (je, cscale) = equilibrated_jacobian(&x, f.len())?;
        let svd = gearcomp_linalg::Svd::new(&je).map_err(|e| DressError::NoConvergence {
            what: "SVD of the Jacobian",
            detail: e.to_string(),
        })?;
        let (u, vt) = (&svd.u, &svd.v_t);
        let sig = &svd.singular_values;
        let smax = sig.iter().fold(0.0f64, |a, &b| a.max(b));
        let smin = sig.iter().fold(f64::INFINITY, |a, &b| a.min(b));
        cond = smax / smin;
        let mu = opts.mu_rel * smax;
        let solve = |rhs: &DVector<f64>| -> DVector<f64> {
            let c = u.transpose() * rhs;
            let mut y = DVector::zeros(4);
            for k in 0..sig.len() {
                let fk = sig[k] / (sig[k] * sig[k] + mu * mu);
                y += vt.row(k).transpose() * (fk * c[k]);
            }
            for (j, cj) in cscale.iter().enumerate() {
                y[j] /= cj;
            }
            -y
        };
        let dx = solve(&f);
        let ndx = dx.norm();
        if ndx < 1e-14 {
            return Ok(Solution {
                dk: to_dk(&x),
                iterations: it,
                residual_mm: f.iter().copied().collect(),
                cond,
            });
        }
        // NLEQ1 predictor: μ = ‖Δx_{k−1}‖‖Δx̄_k‖ / (‖Δx̄_k − Δx_k‖‖Δx_k‖) · λ_{k−1}.
        let mut lambda: f64 = match &prev {
            Some((ndx_prev, lam_prev, dxbar_prev)) => {
                let den = (dxbar_prev - &dx).norm() * ndx;
                if den > 0.0 {
                    (ndx_prev * dxbar_prev.norm() / den * lam_prev)
                        .min(1.0)
                        .max(opts.lambda_min * 10.0)
                } else {
                    1.0
                }
            }
            None => 1.0,
        };
        loop {
            let xt = &x + &dx * lambda;
            let trial = if in_box(&xt) { eval(&xt).ok() } else { None };
            let Some(ft) = trial else {
                lambda *= 0.5;
                if lambda < opts.lambda_min {
                    return Err(no_root(it, &f, "every damped step leaves the search box"));
                }
                continue;
            };
            let dxbar = solve(&ft);
            let nbar = dxbar.norm();
            if nbar <= (1.0 - lambda / 4.0) * ndx {
                prev = Some((ndx, lambda, dxbar));
                x = xt;
                f = ft;
                break;
            }
            let den = (&dxbar - &dx * (1.0 - lambda)).norm();
            let lam_new = if den > 0.0 {
                (lambda * 0.5).min(ndx * lambda * lambda / (2.0 * den))
            } else {
                lambda * 0.5
            };
            if lam_new < opts.lambda_min {
                if max_abs(&f) < opts.stall_tol_mm {
                    return Ok(Solution {
                        dk: to_dk(&x),
                        iterations: it,
                        residual_mm: f.iter().copied().collect(),
                        cond,
                    });
                }
                return Err(no_root(
                    it,
                    &f,
                    "natural-monotonicity test fails for every λ",
                ));
            }
            lambda = lam_new;
        }
    }
    if max_abs(&f) < opts.tol_mm.max(opts.stall_tol_mm) {
        return Ok(Solution {
            dk: to_dk(&x),
            iterations: opts.max_iter,
            residual_mm: f.iter().copied().collect(),
            cond,
        });
    }
    Err(no_root(opts.max_iter, &f, "iteration limit reached"))
}

fn no_root(iterations: usize, f: &DVector<f64>, reason: &str) -> DressError {
    DressError::NoRoot {
        iterations,
        residual_um: 1e3 * f.iter().fold(0.0f64, |m, r| m.max(r.abs())),
        reason: reason.into(),
    }
}

/// The 3-point problem: f at three roll distances plus "dresser radius r_A dresses w_assoc".
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ThreePoint {
    /// Flank to dress.
    pub flank: Flank,
    /// Roll distances w_FS1..3 (mm).
    pub w_mm: [f64; 3],
    /// Targets f_FS1..3 (mm, > 0 = material left).
    pub f_mm: [f64; 3],
    /// Worm roll distance that the chosen dresser radius must dress (mm).
    pub w_assoc_mm: f64,
    /// Dresser radius r_FA (mm).
    pub r_a_mm: f64,
}

/// Where the profile-crowning rule places its three targets, as fractions of the active
/// profile w_Nf … w_Na (5 %, 50 %, 95 %).
pub const CROWNING_FRACTIONS: [f64; 3] = [0.05, 0.5, 0.95];

impl ThreePoint {
    /// The targets of a profile crowning c: (fraction of the active profile, f) =
    /// (0.05, 0), (0.5, −c), (0.95, 0), f in the unit of `crowning` (the one crowning → 3-point
    /// rule of `gearcomp dress`, `gearcomp grind --dress` and the worm-life plan).
    pub fn crowning_targets(crowning: f64) -> [[f64; 2]; 3] {
        let [q1, q2, q3] = CROWNING_FRACTIONS;
        [[q1, 0.0], [q2, -crowning], [q3, 0.0]]
    }

    /// The 3-point problem for `targets` (fraction of the active profile of `setup`'s worm, f
    /// in µm), f scaled by `scale`; the radius association is "`r_a_mm` dresses the tip end
    /// w_Na of the active profile".
    pub fn from_fractions(
        setup: &DressingSetup,
        flank: Flank,
        targets_um: &[[f64; 2]; 3],
        scale: f64,
        r_a_mm: f64,
    ) -> Result<ThreePoint> {
        let (w_nf, w_na) = setup.active_profile(flank)?;
        let at = |q: f64| w_nf + q * (w_na - w_nf);
        let f = |i: usize| scale * targets_um[i][1] * 1e-3;
        Ok(ThreePoint {
            flank,
            w_mm: [
                at(targets_um[0][0]),
                at(targets_um[1][0]),
                at(targets_um[2][0]),
            ],
            f_mm: [f(0), f(1), f(2)],
            w_assoc_mm: w_na,
            r_a_mm,
        })
    }

    /// The 3-point problem of a profile crowning `crowning_mm` (targets
    /// [`ThreePoint::crowning_targets`]) on `setup`'s worm; `r_a_mm` dresses the tip end w_Na.
    pub fn from_crowning(
        setup: &DressingSetup,
        flank: Flank,
        crowning_mm: f64,
        r_a_mm: f64,
    ) -> Result<ThreePoint> {
        let (w_nf, w_na) = setup.active_profile(flank)?;
        let at = |q: f64| w_nf + q * (w_na - w_nf);
        let t = Self::crowning_targets(crowning_mm);
        Ok(ThreePoint {
            flank,
            w_mm: [at(t[0][0]), at(t[1][0]), at(t[2][0])],
            f_mm: [t[0][1], t[1][1], t[2][1]],
            w_assoc_mm: w_na,
            r_a_mm,
        })
    }
}

/// The dresser radius that dresses the tip circle of the new worm `design` (uncorrected): the
/// radius association of the 3-point solves, so that a worn worm keeps its tip dressed by the
/// same dresser radius.
pub fn tip_association_radius_mm(
    design: &crate::worm::Worm,
    dresser: &crate::dresser::Dresser,
    flank: Flank,
) -> Result<f64> {
    let new = DressingSetup::new(*design, dresser.clone());
    new.association(
        flank,
        new.active_profile(flank)?.1,
        &AxisCorrection::default(),
    )
}

/// Residual F_F3(ΔK) of the 3-point method.
///
/// # Formula
/// F_F3(ΔK) = (f_nFS(w_i; ΔK) − f_i (i = 1..3), r_FA(w_assoc; ΔK) − r_FA*)
/// # Source
/// JP6903407B2, three-point method, eq. (18) (drawing lost), Fig. 12; form of docs/dressing.md "Derivation: three-point system and relative profile stretching" [RECONSTRUCTED]
pub fn three_point_residual(
    setup: &DressingSetup,
    p: &ThreePoint,
    dk: &AxisCorrection,
) -> Result<Vec<f64>> {
    let mut out = Vec::with_capacity(4);
    for i in 0..3 {
        out.push(setup.dress_point(p.flank, p.w_mm[i], dk)?.f_mm - p.f_mm[i]);
    }
    out.push(setup.dress_point(p.flank, p.w_assoc_mm, dk)?.r_a_mm - p.r_a_mm);
    Ok(out)
}

/// Solves the 3-point problem from `start` (usually ΔK = 0 or the previous dressing's ΔK).
pub fn solve_three_point(
    setup: &DressingSetup,
    p: &ThreePoint,
    start: AxisCorrection,
    opts: &NewtonOptions,
) -> Result<Solution> {
    newton(setup, |dk| three_point_residual(setup, p, dk), start, opts)
}

/// The 4-point problem: f hit exactly at four roll distances.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FourPoint {
    /// Flank to dress.
    pub flank: Flank,
    /// Roll distances w_FS1..4 (mm).
    pub w_mm: [f64; 4],
    /// Targets f_FS1..4 (mm).
    pub f_mm: [f64; 4],
}

/// Solves F_FS4(ΔK) = (f_nFS(w_i; ΔK) − f_i)_{i=1..4} = 0; the Tikhonov-filtered step returns
/// the minimum-norm correction because the single-flank 4-point Jacobian is rank-deficient
/// (docs/dressing.md "Derivation: minimum-norm 4-point solve").
///
/// # Source
/// JP6903407B2, eqs. (11), (12) [SEED]; minimum norm docs/dressing.md "Derivation: minimum-norm 4-point solve" [RECONSTRUCTED]
pub fn solve_four_point(
    setup: &DressingSetup,
    p: &FourPoint,
    start: AxisCorrection,
    opts: &NewtonOptions,
) -> Result<Solution> {
    newton(
        setup,
        |dk| {
            p.w_mm
                .iter()
                .zip(p.f_mm.iter())
                .map(|(&w, &f)| setup.dress_point(p.flank, w, dk).map(|d| d.f_mm - f))
                .collect()
        },
        start,
        opts,
    )
}

/// Weighted least-squares fit of the profile at m ≥ 4 roll distances (curve-fitting variant).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CurveFit {
    /// Flank to dress.
    pub flank: Flank,
    /// Roll distances (mm).
    pub w_mm: Vec<f64>,
    /// Targets (mm).
    pub f_mm: Vec<f64>,
    /// Weights (larger = tighter tolerance).
    pub weights: Vec<f64>,
}

/// Minimises Σ ω_j (f_nFS(w_j; ΔK) − f_j)² by Gauss–Newton with the same damping.
///
/// # Source
/// JP6903407B2, curve-fitting variant (weights) [SEED]; Gauss–Newton docs/dressing.md "Derivation: three-point system and relative profile stretching" [RECONSTRUCTED]
pub fn solve_curve_fit(
    setup: &DressingSetup,
    p: &CurveFit,
    start: AxisCorrection,
    opts: &NewtonOptions,
) -> Result<Solution> {
    if p.w_mm.len() < 4 || p.f_mm.len() != p.w_mm.len() || p.weights.len() != p.w_mm.len() {
        return Err(DressError::OutOfRange {
            field: "curve_fit.points",
            value: p.w_mm.len() as f64,
            min: 4.0,
            max: f64::INFINITY,
        });
    }
    for &wt in &p.weights {
        DressError::check("curve_fit.weight", wt, 0.0, 1e12)?;
    }
    newton(
        setup,
        |dk| {
            p.w_mm
                .iter()
                .zip(p.f_mm.iter().zip(p.weights.iter()))
                .map(|(&w, (&f, &wt))| {
                    setup
                        .dress_point(p.flank, w, dk)
                        .map(|d| wt.sqrt() * (d.f_mm - f))
                })
                .collect()
        },
        start,
        opts,
    )
}

/// Worm axial position ν_zS that puts the contact line through the worm point (w_0, b_0), the
/// fifth unknown of ^F_F4 / ^F_F3.
///
/// With ΔK constant the dressing motion is a screw, so the contact line only translates with
/// ν_zS: b_BwFS(w; ν_zS, ΔK) = b_BwFS(w; 0, ΔK) − ν_zS. The 5-component Jacobian is therefore
/// block-triangular and ν_zS follows in closed form after the 4-component solve.
///
/// # Formula
/// ν_zS = b_BwFS(w_0; 0, ΔK) − b_0
/// # Source
/// JP6903407B2, eqs. (13), (14) [SEED]; decoupling docs/dressing.md "Derivation: screw reduction" [RECONSTRUCTED]
pub fn axial_position_for_contact_point(
    setup: &DressingSetup,
    flank: Flank,
    w0_mm: f64,
    b0_mm: f64,
    dk: &AxisCorrection,
) -> Result<f64> {
    let d = setup.dress_point(flank, w0_mm, dk)?;
    let b_c = setup.worm.b_axial_section(flank, w0_mm) + setup.worm.p_mm * d.t_rad;
    Ok(b_c - b0_mm)
}
