//! The worm for a wanted gear modification, iterated on the envelope simulation.
//!
//! The line-class transfer ([`crate::diagonal::worm_modification_for_gear`]) is first order:
//! the ground flank misses the wish by the envelope's second-order terms (1.44 % of a lead
//! crowning, 0.38 µm of a 0.2 µm/mm² twist on the reference gear, issue 13 item 4). This
//! module closes the loop: grind with the envelope, fit the remaining deviation wish − ground
//! in the wish's line class, map that correction to the worm with the same first-order
//! inverse and add it, until the remaining deviation is below the tolerance.

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::contact::WormGearPair;
use crate::diagonal::{worm_modification_for_gear, LineMap};
use crate::envelope::{EnvelopeMode, FlankGrid, GroundFlank};
use crate::error::{GrindError, Result};
use crate::kinematics::FeedCoupling;
use crate::modification::{FlankModification, LineModification, Poly};
use crate::simulate::Grinder;

/// Stopping rule and limits of the iteration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IterationOptions {
    /// Largest number of envelope simulations (the first-order worm is iteration 1).
    pub max_iterations: usize,
    /// Stop when max |ground − wish| ≤ this fraction of max |wish| …
    pub rel_tol: f64,
    /// … or ≤ this absolute value in mm (transverse).
    pub abs_tol_mm: f64,
}

impl Default for IterationOptions {
    /// 0.5 % of the wish or 0.01 µm, at most 8 simulations.
    fn default() -> Self {
        Self {
            max_iterations: 8,
            rel_tol: 0.005,
            abs_tol_mm: 1e-5,
        }
    }
}

/// One simulation of the iteration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SolveIteration {
    /// 1 = the first-order worm.
    pub iteration: usize,
    /// max |ground − wish| over the grid in mm (transverse).
    pub max_abs_deviation_mm: f64,
}

/// Result of [`solve_iterated`].
#[derive(Debug, Clone, PartialEq)]
pub struct IteratedSolve {
    /// Line map and diagonal ratio (unchanged by the iteration).
    pub line_map: LineMap,
    /// The worm modification of the last simulation.
    pub worm: LineModification,
    /// The first-order worm modification (iteration 1).
    pub first_order_worm: LineModification,
    /// The flank ground by [`Self::worm`].
    pub ground: GroundFlank,
    /// Every simulation with its remaining deviation.
    pub iterations: Vec<SolveIteration>,
    /// max |wish| over the grid in mm.
    pub wish_max_abs_mm: f64,
    /// Remaining max |ground − wish| in mm.
    pub remaining_mm: f64,
    /// The stopping rule was met.
    pub converged: bool,
}

/// Degrees of the correction basis in X: F_C, F_L, F_Q (at least these, more if the wish
/// has more coefficients).
const BASIS_DEGREES: (usize, usize, usize) = (4, 3, 2);

/// Worm modification and diagonal ratio that grind `wanted`, iterated on the envelope.
///
/// # Formula
/// M_1 = T⁻¹(W) (first-order transfer); for k ≥ 1: G_k = envelope(M_k),
/// E_k = LSQ fit of (W − G_k) in the line class of W (direction ρ_F2, reference w_0, F_C of
/// degree ≥ 4, F_L ≥ 3, F_Q ≥ 2 in X; SVD, rank-deficient columns dropped),
/// M_{k+1} = M_k + T⁻¹(E_k), until max|W − G_k| ≤ max(rel_tol·max|W|, abs_tol).
/// # Source
/// T⁻¹: docs/grinding.md "Derivation: line-class transfer" [RECONSTRUCTED]; the fixed-point
/// iteration on the envelope is
/// ours (docs/grinding.md, "Iterated solve").
#[allow(clippy::too_many_arguments)]
pub fn solve_iterated(
    pair: &WormGearPair,
    wanted: &LineModification,
    rho1_rad: f64,
    z_v01_mm: f64,
    grid: FlankGrid,
    worm_radii_mm: (f64, f64),
    opts: &IterationOptions,
) -> Result<IteratedSolve> {
    let (lm, first) = worm_modification_for_gear(pair, wanted, rho1_rad, z_v01_mm)?;
    let cpl = FeedCoupling::linear(lm.k_zv1, z_v01_mm)?;
    let wish: Vec<f64> = (0..grid.n_w)
        .flat_map(|i| (0..grid.n_z).map(move |j| (i, j)))
        .map(|(i, j)| wanted.f_ft_mm(grid.w_mm(i), grid.z_mm(j)))
        .collect();
    let wish_max = wish.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let tol = (opts.rel_tol * wish_max).max(opts.abs_tol_mm);
    let mut worm = first.clone();
    let mut iterations = Vec::new();
    let mut best: Option<(LineModification, GroundFlank, f64)> = None;
    for it in 1..=opts.max_iterations.max(1) {
        let g = Grinder::new(pair, &cpl, &worm, EnvelopeMode::RotationAndFeed)
            .with_worm_radii(worm_radii_mm.0, worm_radii_mm.1)?;
        let mut ground = GroundFlank::new(grid);
        g.grind_flank(&mut ground)?;
        let err: Vec<f64> = wish
            .iter()
            .zip(&ground.points)
            .map(|(w, p)| w - p.f_ft_mm)
            .collect();
        let dev = err.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        iterations.push(SolveIteration {
            iteration: it,
            max_abs_deviation_mm: dev,
        });
        let improved = best.as_ref().is_none_or(|b| dev < b.2);
        if improved {
            best = Some((worm.clone(), ground, dev));
        }
        if dev <= tol || !improved || it == opts.max_iterations.max(1) {
            break;
        }
        let corr = fit_line_class(wanted, &grid, &err)?;
        let (_, dworm) = worm_modification_for_gear(pair, &corr, rho1_rad, z_v01_mm)?;
        worm = LineModification::new(
            worm.rho_rad,
            worm.w0_mm,
            worm.c.plus(&dworm.c),
            worm.l.plus(&dworm.l),
            worm.q.plus(&dworm.q),
        )?;
    }
    let (worm, ground, remaining) = best.ok_or(GrindError::BadData {
        field: "iterations",
        got: 0,
        expected: "at least one simulation",
    })?;
    Ok(IteratedSolve {
        line_map: lm,
        worm,
        first_order_worm: first,
        ground,
        iterations,
        wish_max_abs_mm: wish_max,
        remaining_mm: remaining,
        converged: remaining <= tol,
    })
}

/// Least-squares fit of grid values in the line class of `like` (its ρ and w_0).
fn fit_line_class(
    like: &LineModification,
    grid: &FlankGrid,
    values: &[f64],
) -> Result<LineModification> {
    let nc = (BASIS_DEGREES.0 + 1).max(like.c.0.len()).min(16);
    let nl = (BASIS_DEGREES.1 + 1).max(like.l.0.len()).min(16);
    let nq = (BASIS_DEGREES.2 + 1).max(like.q.0.len()).min(16);
    let ncol = nc + nl + nq;
    let n = grid.len();
    // X and w − w0 centred and scaled for conditioning; the polynomial is re-expanded after
    let xs: Vec<(f64, f64)> = (0..grid.n_w)
        .flat_map(|i| (0..grid.n_z).map(move |j| (i, j)))
        .map(|(i, j)| {
            (
                like.x_of(grid.w_mm(i), grid.z_mm(j)),
                grid.w_mm(i) - like.w0_mm,
            )
        })
        .collect();
    let (xmin, xmax) = xs.iter().fold((f64::MAX, f64::MIN), |(a, b), (x, _)| {
        (a.min(*x), b.max(*x))
    });
    let (xc, xs_) = (0.5 * (xmin + xmax), (0.5 * (xmax - xmin)).max(1e-9));
    let mut a = DMatrix::zeros(n, ncol);
    for (r, &(x, dw)) in xs.iter().enumerate() {
        let t = (x - xc) / xs_;
        for k in 0..nc {
            a[(r, k)] = t.powi(k as i32);
        }
        for k in 0..nl {
            a[(r, nc + k)] = dw * t.powi(k as i32);
        }
        for k in 0..nq {
            a[(r, nc + nl + k)] = dw * dw * t.powi(k as i32);
        }
    }
    let scale: Vec<f64> = a.column_iter().map(|c| c.amax().max(1e-300)).collect();
    for (j, mut c) in a.column_iter_mut().enumerate() {
        c /= scale[j];
    }
    let b = DVector::from_column_slice(values);
    let bad = || GrindError::BadData {
        field: "remaining deviation (line-class fit)",
        got: n,
        expected: "a grid spread along w and z",
    };
    let svd = gearcomp_linalg::Svd::new(&a).map_err(|_| bad())?;
    let smax = svd.singular_values.get(0).copied().unwrap_or(0.0);
    let sol = svd.solve(&b, 1e-10 * smax);
    // coefficients in t = (X − xc)/xs back to powers of X
    let poly = |off: usize, len: usize| {
        let p_t = Poly((0..len).map(|k| sol[off + k] / scale[off + k]).collect());
        p_t.compose_affine(1.0 / xs_, -xc / xs_)
    };
    LineModification::new(
        like.rho_rad,
        like.w0_mm,
        poly(0, nc),
        poly(nc, nl),
        poly(nc + nl, nq),
    )
}
