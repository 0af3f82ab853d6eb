//! Stacked generalisation of the model families (issue 12; Breiman, "Stacked regressions",
//! Machine Learning 24 (1996) 49–64): the families' out-of-fold predictions on the
//! validation blocks are combined with weights w ≥ 0, Σ w = 1 (a convex combination, so the
//! combined prediction never leaves the range the families span) chosen by least squares.
//! Each family is linear in its filtered features, so the combination is again one linear
//! model: Σ w_k·(b0_k + Σ b_kj·x_kj), written as the union of the families' terms.
//!
//! **Sensor cap.** Only supports (sets of families with w > 0) whose families together read
//! at most `cap` sensors are admissible. The minimum over the admissible supports is exact:
//! the constrained optimum lies on a face of the simplex where the equality-constrained
//! least-squares solution on that face is non-negative, and every face of an admissible
//! support is admissible (fewer families, fewer sensors). The families are few (≤ 9), so
//! every support is tried (2^M small problems on the (M + 1)² R factor of [P y]).
//!
//! **Validation of the stack.** The weights used on fold f's block are fitted on the other
//! folds' out-of-fold predictions only (cross-validation of the level-1 fit, as Breiman
//! does), so the stack's validation figure is held out like the families'. Every family's
//! prediction on a block comes from its model trained on that fold's training rows only
//! (rolling origin: the blocks before; leave-one-run-out: the other runs).

use nalgebra::{DMatrix, DVector};

/// Largest number of families combined by enumeration of the supports.
pub const MAX_MEMBERS: usize = 14;

/// Convex weights (w ≥ 0, Σ w = 1) minimising Σ_i (y_i − Σ_k w_k·p_k,i)² over `rows`,
/// among supports whose `groups` (the sensors each family reads) together hold at most
/// `cap` items. Returns the weights (0 outside the support) and the residual sum of
/// squares; `None` when no single family is admissible, when there are no rows, or when
/// there are more than [`MAX_MEMBERS`] families. Ties keep the smaller support, then the
/// earlier family.
pub fn convex_weights(
    preds: &[Vec<f64>],
    y: &[f64],
    rows: &[usize],
    groups: &[Vec<usize>],
    cap: usize,
) -> Option<(Vec<f64>, f64)> {
    let m = preds.len();
    if m == 0 || m > MAX_MEMBERS || rows.is_empty() || groups.len() != m {
        return None;
    }
    // R factor of [P y] over the rows: every residual below is a combination of these
    // columns, and ‖Q·R·v‖ = ‖R·v‖.
    let a = DMatrix::from_fn(rows.len(), m + 1, |i, k| {
        if k < m {
            preds[k][rows[i]]
        } else {
            y[rows[i]]
        }
    });
    if a.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let r = if rows.len() > m { a.qr().r() } else { a };
    let mut best: Option<(Vec<f64>, f64, usize)> = None;
    let mut subsets: Vec<u32> = (1..(1u32 << m)).collect();
    subsets.sort_by_key(|s| (s.count_ones(), *s));
    for s in subsets {
        let support: Vec<usize> = (0..m).filter(|k| s & (1 << k) != 0).collect();
        let mut sensors: Vec<usize> = support.iter().flat_map(|&k| groups[k].clone()).collect();
        sensors.sort_unstable();
        sensors.dedup();
        if sensors.len() > cap {
            continue;
        }
        let Some((w, sse)) = simplex_face(&r, m, &support) else {
            continue;
        };
        if best.as_ref().is_none_or(|b| sse < b.1) {
            let mut full = vec![0.0; m];
            for (&k, &v) in support.iter().zip(&w) {
                full[k] = v;
            }
            best = Some((full, sse, support.len()));
        }
    }
    best.map(|(w, sse, _)| (w, sse))
}

/// Least squares on one face of the simplex: weights of `support` summing to 1 (the last
/// is 1 − the others), from the R factor `r` of [P y] (`m` prediction columns). `None` when
/// a weight is negative or the face is degenerate (two families predicting alike).
fn simplex_face(r: &DMatrix<f64>, m: usize, support: &[usize]) -> Option<(Vec<f64>, f64)> {
    let last = *support.last()?;
    let rl = r.column(last).into_owned();
    let b: DVector<f64> = r.column(m) - &rl;
    let q = support.len() - 1;
    if q == 0 {
        return Some((vec![1.0], b.norm_squared()));
    }
    let a = DMatrix::from_fn(r.nrows(), q, |i, j| r[(i, support[j])] - rl[i]);
    let scale = a.column_iter().map(|c| c.norm()).fold(0.0_f64, f64::max);
    if r.nrows() < q || scale.is_nan() || scale <= 0.0 {
        return None;
    }
    let qr = a.clone().qr();
    let rr = qr.r();
    if (0..q).any(|j| rr[(j, j)].abs() <= 1e-10 * scale) {
        return None;
    }
    let qtb = qr.q().transpose() * &b;
    let v = rr.solve_upper_triangular(&qtb.rows(0, q).into_owned())?;
    let wl = 1.0 - v.sum();
    if v.iter().any(|&x| x < 0.0) || wl < 0.0 {
        return None;
    }
    let res = &b - &a * &v;
    let mut w: Vec<f64> = v.iter().copied().collect();
    w.push(wl);
    Some((w, res.norm_squared()))
}

/// The stack's held-out SSE per fold: the weights used on fold f's rows are fitted on the
/// rows of the other folds ([`convex_weights`]); `fold_of_row[i]` is the fold whose block
/// row `i` of `preds`/`y` belongs to. `None` when some fold has no admissible weights.
pub fn held_out_sse(
    preds: &[Vec<f64>],
    y: &[f64],
    fold_of_row: &[usize],
    folds: usize,
    groups: &[Vec<usize>],
    cap: usize,
) -> Option<Vec<f64>> {
    (0..folds)
        .map(|f| {
            let fit: Vec<usize> = (0..y.len()).filter(|&i| fold_of_row[i] != f).collect();
            let (w, _) = convex_weights(preds, y, &fit, groups, cap)?;
            Some(
                (0..y.len())
                    .filter(|&i| fold_of_row[i] == f)
                    .map(|i| {
                        let p: f64 = w.iter().zip(preds).map(|(w, p)| w * p[i]).sum();
                        (y[i] - p).powi(2)
                    })
                    .sum(),
            )
        })
        .collect()
}
